//! Where an estimate's time goes: its parts, each a `-log_view` stage and a timer.

use crate::petsc::LogStage;

/// The parts of an estimate, each a `-log_view` stage nested in Estimation
/// (`petsc::log::ESTIMATION_PARTS`) and a timer for the summary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The admissible Γc tractions (Clarabel QPs).
    TractionQp = 0,
    /// The FE-equilibrated Neumann re-solves.
    Resolves,
    /// The equilibrated stresses (EET + Johnson–Mercier, patch relaxation) and their overlap.
    Recovery,
    /// The element contributions of η^glo, η^FE, η^NNDD.
    ElementSums,
    /// e_ref against the reference solution.
    ReferenceError,
    /// Sums and maxima over the ranks.
    Reduction,
}

/// Where the estimates' time goes: per [`Part`], the stage it is logged in and the seconds
/// spent in it on this rank.
pub struct Parts {
    stages: Option<[LogStage; 6]>,
    seconds: std::cell::Cell<[f64; 6]>,
}

impl Parts {
    /// `stages`: the nested `-log_view` stages (`Stages::estimation_parts`), or none.
    pub fn new(stages: Option<[LogStage; 6]>) -> Parts {
        Parts {
            stages,
            seconds: Default::default(),
        }
    }

    /// Run `f` as `part`: inside its stage, its wall time added to the part's.
    pub fn run<T>(&self, part: Part, f: impl FnOnce() -> T) -> T {
        let _stage = self.stages.map(|s| s[part as usize].enter());
        let t = std::time::Instant::now();
        let r = f();
        let mut s = self.seconds.get();
        s[part as usize] += t.elapsed().as_secs_f64();
        self.seconds.set(s);
        r
    }

    /// Seconds per part, in [`Part`]'s order.
    pub fn seconds(&self) -> [f64; 6] {
        self.seconds.get()
    }
}
