//! The `-log_view` stages of a run ([`LogStage`], and the run's [`Stages`]), and wall-clock
//! timings per phase for the JSON summary.

use std::time::{Duration, Instant};

use super::error::{call, cstr, Result};
use super::ffi;

/// A `-log_view` stage.
#[derive(Clone, Copy, Debug)]
pub struct LogStage(ffi::PetscLogStage);

impl LogStage {
    pub fn register(name: &str) -> Result<LogStage> {
        let n = cstr(name);
        let mut s: ffi::PetscLogStage = 0;
        call!(PetscLogStageRegister(n.as_ptr(), &mut s))?;
        Ok(LogStage(s))
    }

    /// Push the stage; it is popped when the guard drops.
    pub fn enter(self) -> StageGuard {
        let ok = call!(PetscLogStagePush(self.0)).is_ok();
        StageGuard(ok)
    }
}

pub struct StageGuard(bool);

impl Drop for StageGuard {
    fn drop(&mut self) {
        if self.0 {
            unsafe { ffi::PetscLogStagePop() };
        }
    }
}

/// The stages `-log_view` reports, in the order of the algorithm.
pub struct Stages {
    pub assembly: LogStage,
    pub factorisation: LogStage,
    /// The condensed steps' setup: each body's S^α and D^α, and the free solutions u^α₀.
    pub interface: LogStage,
    pub dirichlet_step: LogStage,
    pub contact_step: LogStage,
    pub neumann_step: LogStage,
    /// The fields of the reported and the estimated iterates (a back-solve per body).
    pub fields: LogStage,
    pub monolithic: LogStage,
    pub estimation: LogStage,
    /// The parts of the estimation, nested in it (their time is theirs, not Estimation's).
    pub estimation_parts: [LogStage; 6],
    pub reference: LogStage,
    pub output: LogStage,
}

/// The names of the estimation's parts, in the order of `Stages::estimation_parts` and of
/// `estimate::Part`.
pub const ESTIMATION_PARTS: [&str; 6] = [
    "Estimation/traction QP",
    "Estimation/re-solves",
    "Estimation/recovery",
    "Estimation/element sums",
    "Estimation/e_ref",
    "Estimation/reduction",
];

impl Stages {
    pub fn register() -> Result<Stages> {
        let stages = Stages {
            assembly: LogStage::register("Assembly")?,
            factorisation: LogStage::register("Factorisation")?,
            interface: LogStage::register("Interface operators")?,
            dirichlet_step: LogStage::register("Dirichlet step")?,
            contact_step: LogStage::register("Contact step")?,
            neumann_step: LogStage::register("Neumann step")?,
            fields: LogStage::register("Fields")?,
            monolithic: LogStage::register("Monolithic QP")?,
            estimation: LogStage::register("Estimation")?,
            estimation_parts: {
                let mut parts = [LogStage::register(ESTIMATION_PARTS[0])?; 6];
                for (p, name) in parts.iter_mut().zip(ESTIMATION_PARTS).skip(1) {
                    *p = LogStage::register(name)?;
                }
                parts
            },
            reference: LogStage::register("Reference solve")?,
            output: LogStage::register("Output")?,
        };
        // Enter every stage once on every rank: -log_view names a stage only where it ran, and
        // with one body per rank the contact step never runs on rank 0.
        for s in [
            stages.assembly,
            stages.factorisation,
            stages.interface,
            stages.dirichlet_step,
            stages.contact_step,
            stages.neumann_step,
            stages.fields,
            stages.monolithic,
            stages.estimation,
            stages.reference,
            stages.output,
        ]
        .iter()
        .chain(&stages.estimation_parts)
        {
            drop(s.enter());
        }
        Ok(stages)
    }
}

impl Stages {
    /// These stages with every one of them the reference solve's: the reference's setup,
    /// steps and fields are booked in its own stage, not in the run's (`-log_view` then matches
    /// the summary's timings).
    pub fn all_in_reference(&self) -> Stages {
        let r = self.reference;
        Stages {
            assembly: r,
            factorisation: r,
            interface: r,
            dirichlet_step: r,
            contact_step: r,
            neumann_step: r,
            fields: r,
            monolithic: r,
            estimation: r,
            estimation_parts: [r; 6],
            reference: r,
            output: r,
        }
    }
}

/// Accumulated wall time of one phase.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timer(Duration);

impl Timer {
    /// Run `f`, adding its wall time.
    pub fn time<T>(&mut self, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let r = f();
        self.0 += t.elapsed();
        r
    }

    pub fn seconds(&self) -> f64 {
        self.0.as_secs_f64()
    }
}
