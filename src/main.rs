//! `nndd`: see `nndd -help` and README.md.
//!
//! How a run ends (README "Exit codes"): every failure ends every rank, with one
//! line naming the cause. Failures that all ranks meet at the same point (bad input, an
//! unwritable output, a failure at the end of a setup phase) are agreed on and reported once,
//! and the ranks exit together; a failure of one rank in the middle of the solve, where the
//! others wait in a collective, is reported by that rank, which then aborts the job; so is an
//! internal error (a panic) on any rank.
//! A result file that failed once created is left open (HDF5 would close it inside
//! `MPI_Finalize`, flushing into the failed file again): after the agreed line, the ranks end
//! without finalising. A stop signal outside the NNDD loop ends the process in its handler
//! (exit 5, `src/os/signals.rs`); SIGXFSZ is ignored, so that a write past the file-size
//! limit fails with an error instead of killing the rank.

use nndd::app::{self, preflight, AppError, Outcome};
use nndd::parallel::fault::{self, Agreement, Phase};
use nndd::petsc::Petsc;

use mpi::traits::Communicator;

fn main() {
    std::panic::set_hook(Box::new(internal_error));
    if let Err(e) = nndd::os::signals::ignore_file_size_limit() {
        nndd::io::monitor::say(format_args!("nndd: error: cannot ignore SIGXFSZ: {e}"));
        std::process::exit(1);
    }
    let Some(universe) = mpi::initialize() else {
        nndd::io::monitor::say(format_args!("nndd: error: MPI could not be initialised"));
        std::process::exit(1);
    };
    let world = universe.world();
    let rank = world.rank();
    nndd::os::signals::set_rank(rank);
    let agreement = Agreement::new(&world);
    let args: Vec<String> = std::env::args().collect();
    // PETSc reads the options files on rank 0 only and broadcasts them: every rank checks
    // them first, so that a missing one ends every rank instead of leaving them waiting.
    let files = preflight::options_files(&args);
    if failed_somewhere(&agreement, rank, files.err()) {
        drop(agreement);
        drop(universe);
        std::process::exit(1);
    }
    // `-nndd_fault RANK:init` must be on the command line (PETSc reads the options files).
    fault::arm(fault_on_command_line(&args), rank);
    let petsc = Petsc::initialize(&args, app::HELP)
        .map_err(|e| e.to_string())
        .and_then(|p| match fault::check(Phase::Init) {
            Ok(()) => Ok(p),
            Err(e) => {
                std::mem::forget(p); // not finalised: see below
                Err(e.to_string())
            }
        });
    if failed_somewhere(&agreement, rank, petsc.as_ref().err().cloned()) {
        // PETSc did not start on every rank: PetscFinalize would wait for them.
        std::mem::forget(petsc);
        drop(agreement);
        drop(universe);
        std::process::exit(1);
    }
    let petsc = petsc.expect("agreed");
    // From here a stop signal ends the setup at once (src/os/signals.rs), instead of
    // PETSc's handler; `app::run` reports a failure to install it.
    let _ = nndd::os::signals::catch_stop_requests();
    let code = match app::run(world, &agreement) {
        Ok(Outcome::Solved) | Ok(Outcome::Help) => 0,
        Ok(Outcome::NotConverged) | Ok(Outcome::Unreached) => 3,
        Ok(Outcome::Interrupted) => 4,
        Err(e) => report(&e, rank, &agreement),
    };
    if nndd::io::output::file_left_open() {
        // A result file failed part-way and is still open in HDF5, which would close it
        // (and flush into it again) inside MPI_Finalize: end here (every rank agreed on the
        // failure and arrives here), without finalising, once every rank is here (so after
        // the line of the failure is printed).
        agreement.gather_within_deadline();
        end_at_once(code);
    }
    drop(petsc); // PetscFinalize before MPI_Finalize
    drop(agreement);
    drop(universe);
    std::process::exit(code);
}

/// The panic hook: one line naming the internal error, its place and the rank (and the
/// backtrace where `RUST_BACKTRACE` asks for it); then, where
/// other ranks run, the end of the whole job (they may wait in a collective for this one, and
/// unwinding would wait for them in MPI_Finalize).
fn internal_error(info: &std::panic::PanicHookInfo) {
    let payload = info.payload();
    let what = (payload.downcast_ref::<&str>().copied())
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("a panic");
    let at = info
        .location()
        .map_or(String::new(), |l| format!(" at {}:{}", l.file(), l.line()));
    let running = mpi::environment::is_initialized() && !mpi::environment::is_finalized();
    let world = mpi::topology::SimpleCommunicator::world;
    let rank = match running {
        true => format!(" (rank {})", world().rank()),
        false => String::new(),
    };
    let what = what.replace('\n', " ");
    nndd::io::monitor::say(format_args!("nndd: internal error{rank}: {what}{at}"));
    // (with RUST_BACKTRACE=1, where the panic came from: what a bug report needs)
    let trace = std::backtrace::Backtrace::capture();
    if trace.status() == std::backtrace::BacktraceStatus::Captured {
        eprintln!("{trace}");
    }
    if running && world().size() > 1 {
        world().abort(101)
    }
}

/// End the process now with `code`, after our own output, running no exit handler
/// (neither HDF5's nor MPI's finalisation).
fn end_at_once(code: i32) -> ! {
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
    let _ = std::io::stderr().flush();
    // SAFETY: _exit ends the process; nothing of it is used afterwards.
    unsafe { libc::_exit(code) }
}

/// Before the run: whether any rank failed (`failure` is this rank's reason); the lowest
/// failed rank prints its reason. Collective.
fn failed_somewhere(agreement: &Agreement, rank: i32, failure: Option<String>) -> bool {
    let code = failure.as_ref().map(|_| 1);
    match agreement.first_failure(code, || app::abort_with(failure.as_deref())) {
        Some((first, _)) => {
            if first == rank as usize {
                nndd::io::monitor::say(format_args!(
                    "nndd: error: {}",
                    failure.unwrap_or_default()
                ));
            }
            true
        }
        None => false,
    }
}

/// `-nndd_fault RANK:PHASE[:panic]` from the command line (the options files are read by
/// PETSc, and `-nndd_fault` there arms the later phases through the settings).
fn fault_on_command_line(args: &[String]) -> Option<fault::Fault> {
    let at = args.iter().position(|a| a == "-nndd_fault")?;
    fault::Fault::parse(args.get(at + 1)?)
}

/// Report `e` once and give the exit code (see the module documentation).
fn report(e: &AppError, rank: i32, agreement: &Agreement) -> i32 {
    if !e.is_collective() {
        // A failure on this rank only: the others may wait in a collective; end the job.
        if mpi::topology::SimpleCommunicator::world().size() == 1 {
            nndd::io::monitor::say(format_args!("nndd: error: {e}"));
            return 2;
        }
        app::abort_with(Some(&e.to_string()));
    }
    // Every rank meets this error here: the lowest rank holding a message prints it, and all
    // exit with its code.
    let has_message = !matches!(e, AppError::ReportedElsewhere { .. });
    let message = e.to_string();
    let first = agreement.first_failure(has_message.then_some(e.exit_code() as u8), || {
        app::abort_with(has_message.then_some(message.as_str()))
    });
    match first {
        Some((r, code)) => {
            if r == rank as usize {
                nndd::io::monitor::say(format_args!("nndd: error: {e}"));
            }
            code as i32
        }
        None => e.exit_code(),
    }
}
