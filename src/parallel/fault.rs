//! Faults: how ranks agree that a phase failed, and the test-only injection of a
//! failure on one rank (`-nndd_fault RANK:PHASE`, or `RANK:PHASE:panic` for an internal error).
//!
//! Every collective of a run is reached by all ranks in the same order, so a rank that fails
//! between two collectives must either make the others learn it at the next agreement (the
//! input and setup phases, the checkpoints and the output: [`Agreement`]), or end the job
//! (`MPI_Abort`, which `main` calls for a failure of one rank in the middle of the solve).

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator, CommunicatorCollectives};

/// The phases of a run, in order (where `-nndd_fault` can inject a failure).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// PETSc's initialisation.
    Init,
    /// Reading the `-nndd_` options.
    Options,
    /// Reading the meshes and building the problem.
    Mesh,
    /// Assembling a body's stiffness.
    Assembly,
    /// Factorising a body's systems.
    Factorisation,
    /// A body's Neumann solve in the NNDD loop (a KSP that fails on one body).
    Ksp,
    /// The contact step's QP.
    Qp,
    /// An error estimate.
    Estimate,
    /// Writing a checkpoint.
    Checkpoint,
    /// Writing the results.
    Output,
}

impl Phase {
    pub const ALL: [Phase; 10] = [
        Phase::Init,
        Phase::Options,
        Phase::Mesh,
        Phase::Assembly,
        Phase::Factorisation,
        Phase::Ksp,
        Phase::Qp,
        Phase::Estimate,
        Phase::Checkpoint,
        Phase::Output,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Phase::Init => "init",
            Phase::Options => "options",
            Phase::Mesh => "mesh",
            Phase::Assembly => "assembly",
            Phase::Factorisation => "factorisation",
            Phase::Ksp => "ksp",
            Phase::Qp => "qp",
            Phase::Estimate => "estimate",
            Phase::Checkpoint => "checkpoint",
            Phase::Output => "output",
        }
    }

    /// The accepted values of `-nndd_fault`, for its messages.
    pub const ACCEPTED: &'static str = "RANK:PHASE or RANK:PHASE:panic with PHASE one of init, options, mesh, assembly, factorisation, ksp, qp, estimate, checkpoint, output";
}

/// What `-nndd_fault` injects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// An error of the phase, reported as the phase reports its own.
    Error,
    /// A panic: an internal error of nndd.
    Panic,
}

/// `-nndd_fault RANK:PHASE[:panic]`: a failure of one rank at one phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fault {
    pub rank: i32,
    pub phase: Phase,
    pub kind: FaultKind,
}

impl Fault {
    /// Parse `RANK:PHASE` or `RANK:PHASE:panic`.
    pub fn parse(spec: &str) -> Option<Fault> {
        let mut parts = spec.split(':').map(str::trim);
        let rank = parts.next()?.parse::<i32>().ok().filter(|r| *r >= 0)?;
        let name = parts.next()?;
        let phase = Phase::ALL.into_iter().find(|p| p.name() == name)?;
        let kind = match parts.next() {
            None => FaultKind::Error,
            Some("panic") => FaultKind::Panic,
            Some(_) => return None,
        };
        parts
            .next()
            .is_none()
            .then_some(Fault { rank, phase, kind })
    }
}

/// The failure `-nndd_fault` injects.
#[derive(Debug, thiserror::Error)]
#[error("injected fault in phase '{phase}' on rank {rank} (-nndd_fault)")]
pub struct InjectedFault {
    pub phase: &'static str,
    pub rank: i32,
}

/// The armed fault: the fault if `-nndd_fault` names this rank.
static ARMED: OnceLock<Option<Fault>> = OnceLock::new();
static RANK: OnceLock<i32> = OnceLock::new();

/// Arm `-nndd_fault` on this rank (`my_rank`); later calls are ignored.
pub fn arm(fault: Option<Fault>, my_rank: i32) {
    let _ = RANK.set(my_rank);
    let _ = ARMED.set(fault.filter(|f| f.rank == my_rank));
}

/// `Err` on the rank where `-nndd_fault` injects a failure at `phase` (a panic there with
/// `:panic`), `Ok` everywhere else.
pub fn check(phase: Phase) -> Result<(), InjectedFault> {
    match ARMED.get() {
        Some(Some(f)) if f.phase == phase => {
            let rank = RANK.get().copied().unwrap_or(0);
            if f.kind == FaultKind::Panic {
                panic!(
                    "injected panic in phase '{}' on rank {rank} (-nndd_fault)",
                    phase.name()
                );
            }
            Err(InjectedFault {
                phase: phase.name(),
                rank,
            })
        }
        _ => Ok(()),
    }
}

/// How long a rank that failed waits for the others at an [`Agreement`] before it ends the
/// job: they may be waiting in a collective that its failure left them in.
pub const DEADLINE: Duration = Duration::from_secs(5);

/// The agreements on failure: at the end of each input and setup phase, and on the way out,
/// every rank says whether it failed, on a communicator of their own (so that they never meet
/// another collective). A rank that did not fail waits as long as the others need (a
/// factorisation may take minutes on one body and seconds on the other); a rank that failed
/// waits at most [`DEADLINE`], then ends the job (`MPI_Abort`), because a rank that has not
/// arrived by then is stuck in a collective with the failed one and never will.
pub struct Agreement {
    comm: SimpleCommunicator,
}

impl Agreement {
    /// On a duplicate of `world` (collective).
    pub fn new(world: &SimpleCommunicator) -> Agreement {
        Agreement {
            comm: world.duplicate(),
        }
    }

    /// Wait until every rank arrives here, at most [`DEADLINE`] (collective; used before
    /// ranks end without `MPI_Finalize`, so that none ends before the line of the failure is
    /// printed).
    pub fn gather_within_deadline(&self) {
        if self.comm.size() == 1 {
            return;
        }
        let t0 = Instant::now();
        let mut req = self.comm.immediate_barrier();
        loop {
            match req.test() {
                Ok(_) => return,
                Err(r) => req = r,
            }
            if t0.elapsed() > DEADLINE {
                // Left pending: the process ends right after.
                std::mem::forget(req);
                return;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// The lowest failed rank and its code (None: none failed); `code` is this rank's failure
    /// (a small code, the exit code). Every rank calls it at the same point; `on_timeout`
    /// (which must end the job) is called on a failed rank whose partners do not arrive
    /// within [`DEADLINE`].
    pub fn first_failure(
        &self,
        code: Option<u8>,
        on_timeout: impl FnOnce() -> std::convert::Infallible,
    ) -> Option<(usize, u8)> {
        first_failure(&self.comm, code, on_timeout)
    }
}

/// [`Agreement::first_failure`] without codes, on `comm`: a non-blocking reduction, which a rank that failed
/// waits for at most [`DEADLINE`]. Every rank of `comm` calls it at the same point.
pub fn first_failed<C: Communicator>(
    comm: &C,
    failed: bool,
    on_timeout: impl FnOnce() -> std::convert::Infallible,
) -> Option<usize> {
    first_failure(comm, failed.then_some(0), on_timeout).map(|(rank, _)| rank)
}

/// The reduction behind [`Agreement`]: the minimum of 256 · rank + code over the failed ranks
/// (256 · size where none failed).
fn first_failure<C: Communicator>(
    comm: &C,
    code: Option<u8>,
    on_timeout: impl FnOnce() -> std::convert::Infallible,
) -> Option<(usize, u8)> {
    let size = comm.size();
    let failed = code.is_some();
    let mine: i64 = match code {
        Some(c) => 256 * comm.rank() as i64 + c as i64,
        None => 256 * size as i64,
    };
    if size == 1 {
        return code.map(|c| (0, c));
    }
    let mut first = 256 * size as i64;
    let t0 = Instant::now();
    mpi::request::scope(|scope| {
        let mut req =
            comm.immediate_all_reduce_into(scope, &mine, &mut first, SystemOperation::min());
        if !failed {
            crate::parallel::wait::politely(req);
            return;
        }
        loop {
            match req.test() {
                Ok(_) => return,
                Err(r) => req = r,
            }
            if t0.elapsed() > DEADLINE {
                match on_timeout() {}
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    });
    (first < 256 * size as i64).then_some(((first / 256) as usize, (first % 256) as u8))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_specs_parse_and_refuse() {
        let fault = |rank, phase, kind| Some(Fault { rank, phase, kind });
        assert_eq!(
            Fault::parse("1:ksp"),
            fault(1, Phase::Ksp, FaultKind::Error)
        );
        assert_eq!(
            Fault::parse("0:output"),
            fault(0, Phase::Output, FaultKind::Error)
        );
        assert_eq!(
            Fault::parse("2:qp:panic"),
            fault(2, Phase::Qp, FaultKind::Panic)
        );
        for p in Phase::ALL {
            let spec = format!("3:{}", p.name());
            assert_eq!(Fault::parse(&spec), fault(3, p, FaultKind::Error));
        }
        for bad in [
            "",
            "1",
            "ksp",
            "-1:ksp",
            "1:kps",
            "x:qp",
            "1:",
            "1:qp:",
            "1:qp:abort",
            "1:qp:panic:x",
        ] {
            assert_eq!(Fault::parse(bad), None, "{bad}");
        }
    }
}
