//! The signals that ask a run to stop: SIGTERM (a batch system's time limit, or
//! `kill`), SIGINT (Ctrl-C) and SIGUSR1 (which `mpirun` forwards to every rank, where it ends
//! the job on SIGTERM itself). `PetscInitialize` installs PETSc's own handler for SIGTERM,
//! which aborts; [`catch_stop_requests`] replaces it (and is therefore called after PETSc's
//! initialisation).
//!
//! What a signal does depends on the phase of the run ([`StopPhase`], set by the run with
//! [`enter`]):
//! - in the NNDD loop and on the way out (post-processing, output: [`StopPhase::Deferred`]),
//!   the handler only sets a flag, which the NNDD loop reads at the end of each iteration
//!   (the run then writes its results and a restart point, exit 4), and the output reads
//!   once the files are complete;
//! - in a phase with nothing worth keeping (the setup, the reference solve, the monolithic
//!   solve, the final estimate), the handler itself ends the process at once: it writes one
//!   line `nndd: stopped by SIGTERM during the setup; no results written` (with `write(2)`)
//!   and `_exit`s with [`EXIT_STOPPED`]. Rank 0 writes the line, the other ranks end
//!   silently: where every rank got the signal (Slurm, `kill` of every rank) the line is
//!   printed once; where one other rank got it, mpirun answers its exit by sending SIGTERM to
//!   the others, and rank 0 prints the line then.
//!
//! A second signal ends the process at once in every phase (exit status 128 + the signal).
//!
//! The other signals a run sets the disposition of: SIGPIPE, whose default a closed pipe on
//! the output ends the process with ([`default_broken_pipe`]), and SIGXFSZ, ignored so that a
//! write past the file-size limit fails instead ([`ignore_file_size_limit`]).

use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU8, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);
static PHASE: AtomicU8 = AtomicU8::new(StopPhase::Setup as u8);
static RANK: AtomicI32 = AtomicI32::new(0);

/// The exit status of a run that a signal ended in a phase with nothing to keep.
pub const EXIT_STOPPED: i32 = 5;

/// The signals [`catch_stop_requests`] handles.
pub const STOP_SIGNALS: [(libc::c_int, &str); 3] = [
    (libc::SIGTERM, "SIGTERM"),
    (libc::SIGINT, "SIGINT"),
    (libc::SIGUSR1, "SIGUSR1"),
];

/// The phases of a run as a stop signal sees them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum StopPhase {
    /// The signal sets a flag, read at the end of each NNDD iteration and after the output.
    Deferred = 0,
    /// Options, meshes, assembly, factorisation, interface operators: end at once.
    Setup = 1,
    /// The reference solution of (26) on the refined mesh: end at once.
    Reference = 2,
    /// The monolithic solve: end at once.
    Monolithic = 3,
    /// The estimate of the reported iterate after the NNDD loop: end at once.
    FinalEstimate = 4,
    /// The estimate of the monolithic solution: end at once.
    MonolithicEstimate = 5,
}

impl StopPhase {
    const ALL: [StopPhase; 6] = [
        StopPhase::Deferred,
        StopPhase::Setup,
        StopPhase::Reference,
        StopPhase::Monolithic,
        StopPhase::FinalEstimate,
        StopPhase::MonolithicEstimate,
    ];

    /// The line's words for the phase (after "during "), and what was kept.
    pub fn words(self) -> (&'static str, &'static str) {
        match self {
            StopPhase::Deferred => ("the solve", ""),
            StopPhase::Setup => ("the setup", "; no results written"),
            StopPhase::Reference => ("the reference solve", "; no results written"),
            StopPhase::Monolithic => ("the monolithic solve", "; no results written"),
            StopPhase::FinalEstimate => (
                "the final estimate",
                "; no results written (restart points of -nndd_checkpoint_every remain)",
            ),
            StopPhase::MonolithicEstimate => (
                "the estimate of the monolithic solution",
                "; no results written",
            ),
        }
    }
}

/// Record this process's MPI rank (rank 0 writes the line of a stop at once).
pub fn set_rank(rank: i32) {
    RANK.store(rank, Ordering::SeqCst);
}

/// Enter `phase`; returns the phase left (to restore with [`enter`]). Entering a phase that
/// ends at once after a signal already arrived ends the process here, as the handler would.
pub fn enter(phase: StopPhase) -> StopPhase {
    let before = PHASE.swap(phase as u8, Ordering::SeqCst);
    if phase != StopPhase::Deferred && REQUESTED.load(Ordering::SeqCst) {
        let sig = RECEIVED.load(Ordering::SeqCst);
        stop_now(sig, phase as u8);
    }
    StopPhase::ALL[before as usize]
}

/// The signal that set the flag.
static RECEIVED: AtomicI32 = AtomicI32::new(libc::SIGTERM);

/// Write the line and `_exit` (async-signal-safe: no allocation, no lock).
fn stop_now(sig: libc::c_int, phase: u8) -> ! {
    if RANK.load(Ordering::SeqCst) != 0 {
        // SAFETY: _exit is async-signal-safe.
        unsafe { libc::_exit(EXIT_STOPPED) }
    }
    let name = name_of(sig);
    let (during, kept) = StopPhase::ALL
        .get(phase as usize)
        .copied()
        .unwrap_or(StopPhase::Setup)
        .words();
    let mut line = [0u8; 256];
    let mut len = 0;
    for part in ["nndd: stopped by ", name, " during ", during, kept, "\n"] {
        for &b in part.as_bytes() {
            if len < line.len() {
                line[len] = b;
                len += 1;
            }
        }
    }
    // SAFETY: write(2) and _exit(2) are async-signal-safe; `line` holds `len` bytes.
    unsafe {
        libc::write(2, line.as_ptr().cast(), len);
        libc::_exit(EXIT_STOPPED)
    }
}

extern "C" fn on_stop_signal(sig: libc::c_int) {
    if REQUESTED.load(Ordering::SeqCst) {
        // SAFETY: _exit is async-signal-safe.
        unsafe { libc::_exit(128 + sig) }
    }
    RECEIVED.store(sig, Ordering::SeqCst);
    REQUESTED.store(true, Ordering::SeqCst);
    let phase = PHASE.load(Ordering::SeqCst);
    if phase != StopPhase::Deferred as u8 {
        stop_now(sig, phase);
    }
}

/// Catch [`STOP_SIGNALS`] (replacing PETSc's handler).
pub fn catch_stop_requests() -> std::io::Result<()> {
    for (sig, _) in STOP_SIGNALS {
        // SAFETY: a zeroed sigaction with an async-signal-safe handler (atomics, write
        // and _exit) and an emptied mask is a valid argument.
        let rc = unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_stop_signal as extern "C" fn(libc::c_int) as usize;
            action.sa_flags = libc::SA_RESTART;
            libc::sigemptyset(&mut action.sa_mask);
            libc::sigaction(sig, &action, std::ptr::null_mut())
        };
        if rc != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(())
}

/// A closed pipe on the output (`nndd -help | head`) ends the process quietly, as it ends
/// `cat` or `grep` (killed by SIGPIPE, status 141), instead of PETSc's handler, which
/// `PetscInitialize` installs for it, aborting the job with a page of messages (and instead of
/// Rust's default, which ignores the signal and then fails on the write). Called right after
/// `PetscInitialize`.
pub fn default_broken_pipe() -> std::io::Result<()> {
    // SAFETY: restoring a signal's default disposition.
    if unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) } == libc::SIG_ERR {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// Ignore SIGXFSZ, which the kernel sends to a process that writes past the file-size limit
/// (`ulimit -f`) and which would kill it at once (status 153), leaving the other ranks of the
/// job waiting and a temporary file behind. Ignored, the write fails with `EFBIG` instead, and
/// the output's error handling reports it (one line naming the file, every rank ends).
/// Called first thing in `main`, before MPI or HDF5 write anything.
pub fn ignore_file_size_limit() -> std::io::Result<()> {
    // SAFETY: setting a signal's disposition to ignored.
    if unsafe { libc::signal(libc::SIGXFSZ, libc::SIG_IGN) } == libc::SIG_ERR {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// The name of the stop signal that arrived (SIGTERM if none did).
pub fn received_name() -> &'static str {
    name_of(RECEIVED.load(Ordering::SeqCst))
}

/// The name of one of [`STOP_SIGNALS`] (async-signal-safe: no allocation).
fn name_of(sig: libc::c_int) -> &'static str {
    STOP_SIGNALS
        .iter()
        .find(|(s, _)| *s == sig)
        .map_or("a signal", |(_, n)| n)
}

/// Whether a stop signal arrived on this rank.
pub fn stop_requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}
