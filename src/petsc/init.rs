//! PETSc's life in the process: [`Petsc`] initialises it (`PetscInitialize`, with the
//! returning error handler) and finalises it when dropped.

use std::ffi::CString;
use std::os::raw::{c_char, c_int};
use std::ptr;

use super::comm::{comm_from_rsmpi, Comm};
use super::error::{call, cstr, PetscError, Result};
use super::{ffi, signals};

/// An initialised PETSc. Create it once per process after MPI; dropping it finalises PETSc.
pub struct Petsc {
    _argv: Vec<CString>,
}

/// A failure to restore SIGPIPE's default disposition.
fn pipe_error(e: std::io::Error) -> PetscError {
    PetscError {
        code: 0,
        call: "signal(SIGPIPE, SIG_DFL)",
        message: e.to_string(),
    }
}

impl Petsc {
    /// `PetscInitialize` with the process arguments; `help` is printed by `-help`.
    pub fn initialize(args: &[String], help: &str) -> Result<Petsc> {
        let argv_owned: Vec<CString> = args.iter().map(|a| cstr(a)).collect();
        // PETSc keeps argv: leak the pointer array for the life of the process.
        let mut ptrs: Vec<*mut c_char> = argv_owned
            .iter()
            .map(|a| a.as_ptr() as *mut c_char)
            .collect();
        ptrs.push(ptr::null_mut());
        let ptrs = Box::leak(ptrs.into_boxed_slice());
        let mut argc: c_int = args.len() as c_int;
        let mut argv: *mut *mut c_char = ptrs.as_mut_ptr();
        let help = Box::leak(cstr(help).into_boxed_c_str());
        // `-help` prints inside PetscInitialize, after PETSc has trapped SIGPIPE: a listing
        // piped into `head` would end in its handler. The listing does nothing else, so it
        // runs without PETSc's signal handlers (the options database takes values before
        // PetscInitialize).
        if args.iter().any(|a| a == "-help") {
            let flag = cstr("-no_signal_handler");
            call!(PetscOptionsSetValue(
                ptr::null_mut(),
                flag.as_ptr(),
                ptr::null()
            ))?;
            signals::default_broken_pipe().map_err(pipe_error)?;
        }
        call!(PetscInitialize(
            &mut argc,
            &mut argv,
            ptr::null(),
            help.as_ptr()
        ))?;
        // Errors come back as codes; we print them as one line ourselves.
        call!(PetscPushErrorHandler(
            Some(ffi::PetscReturnErrorHandler),
            ptr::null_mut()
        ))?;
        let petsc = Petsc { _argv: argv_owned };
        signals::default_broken_pipe().map_err(pipe_error)?;
        Ok(petsc)
    }

    /// `MPI_COMM_SELF` (a macro in C, so taken from rsmpi).
    pub fn comm_self() -> Comm {
        use mpi::traits::AsRaw;
        comm_from_rsmpi(mpi::topology::SimpleCommunicator::self_comm().as_raw())
    }

    /// `PETSC_COMM_WORLD`.
    pub fn comm_world() -> Comm {
        // SAFETY: a global set by PetscInitialize.
        Comm(unsafe { ffi::PETSC_COMM_WORLD })
    }

    /// The floating-point operations PETSc logged on this process so far (what `-log_view`
    /// sums over the ranks).
    pub fn logged_flops() -> f64 {
        let mut flops = 0.0;
        // SAFETY: PetscGetFlops only reads PETSc's counter.
        if unsafe { ffi::PetscGetFlops(&mut flops) } != 0 {
            return 0.0;
        }
        flops
    }

    /// Ask PETSc to track the peak resident memory (`-memory_view` style).
    pub fn track_memory() -> Result<()> {
        call!(PetscMemorySetGetMaximumUsage())
    }

    /// Peak resident set size of this process in bytes: the kernel's high-water mark
    /// (getrusage's ru_maxrss). PETSc's `PetscMemoryGetMaximumUsage` only samples the resident
    /// size when PETSc objects are destroyed, so it missed transient peaks between them (the
    /// estimate's: at n = 512 it reported 977 MiB where the high-water mark was 1304 MiB).
    pub fn peak_memory() -> f64 {
        // SAFETY: getrusage fills the zeroed struct it is given.
        let mut r: libc::rusage = unsafe { std::mem::zeroed() };
        if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut r) } != 0 {
            return 0.0;
        }
        r.ru_maxrss as f64 * 1024.0 // kilobytes on Linux
    }

    /// Give the heap's free pages back to the system (glibc's `malloc_trim`) when at least
    /// `min_bytes` are free in it. Arrays under glibc's mmap threshold (which grows to 32 MiB
    /// as large blocks are freed) live in the heap and stay resident after they are freed, so
    /// without this a phase's freed arrays still count when the next phase allocates others.
    /// Below the threshold the pages are kept: faulting them in again costs more than they
    /// weigh.
    pub fn release_free_memory(min_bytes: usize) {
        // SAFETY: mallinfo2 only reads the allocator's statistics, and malloc_trim only
        // returns unused pages of its own heaps.
        unsafe {
            if libc::mallinfo2().fordblks >= min_bytes {
                libc::malloc_trim(0);
            }
        }
    }
}

impl Drop for Petsc {
    fn drop(&mut self) {
        // SAFETY: every PETSc object is dropped before `Petsc` by construction of `main`.
        unsafe { ffi::PetscFinalize() };
    }
}
