//! The signals that ask a run to stop: SIGTERM (a batch system's time limit, or
//! `kill`), SIGINT (Ctrl-C) and SIGUSR1 (which `mpirun` forwards to every rank, where it ends
//! the job on SIGTERM itself). `PetscInitialize` installs PETSc's own handler for SIGTERM,
//! which aborts; [`catch_stop_requests`] replaces it (and is therefore called after PETSc's
//! initialisation, here beside the rest of the foreign calls). The handler only sets a flag,
//! which the NNDD loop reads at the end of each iteration; a second signal ends the process
//! at once (exit status 128 + the signal).

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// The signals [`catch_stop_requests`] handles.
pub const STOP_SIGNALS: [(libc::c_int, &str); 3] = [
    (libc::SIGTERM, "SIGTERM"),
    (libc::SIGINT, "SIGINT"),
    (libc::SIGUSR1, "SIGUSR1"),
];

extern "C" fn on_stop_signal(sig: libc::c_int) {
    if REQUESTED.swap(true, Ordering::SeqCst) {
        // SAFETY: _exit is async-signal-safe.
        unsafe { libc::_exit(128 + sig) }
    }
}

/// Catch [`STOP_SIGNALS`] (replacing PETSc's handler).
pub fn catch_stop_requests() -> std::io::Result<()> {
    for (sig, _) in STOP_SIGNALS {
        // SAFETY: a zeroed sigaction with an async-signal-safe handler (one atomic swap, or
        // _exit) and an emptied mask is a valid argument.
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

/// Whether a stop signal arrived on this rank.
pub fn stop_requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}
