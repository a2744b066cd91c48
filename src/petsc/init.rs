//! PETSc's life in the process: [`Petsc`] initialises it (`PetscInitialize`, with the
//! returning error handler) and finalises it when dropped; between the two it gives PETSc's
//! communicators, the flops PETSc logged and PETSc's memory tracking.

use std::ffi::CString;
use std::os::raw::{c_char, c_int};
use std::ptr;

use super::comm::{comm_from_rsmpi, Comm};
use super::error::{call, cstr, PetscError, Result};
use super::ffi;
use crate::os::signals;

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
        // PETSc leaves MPI_COMM_WORLD returning MPI's errors as codes, which rsmpi does not
        // read: an MPI error in nndd's own collectives (on communicators made from the world
        // from here on) would pass unnoticed on one rank while the others wait for it. MPI's
        // default again: such an error ends the job.
        // SAFETY: MPI is initialised; both handles are MPI's constants.
        unsafe {
            mpi::ffi::MPI_Comm_set_errhandler(
                mpi::ffi::RSMPI_COMM_WORLD,
                mpi::ffi::RSMPI_ERRORS_ARE_FATAL,
            );
        }
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
}

impl Drop for Petsc {
    fn drop(&mut self) {
        // SAFETY: every PETSc object is dropped before `Petsc` by construction of `main`.
        unsafe { ffi::PetscFinalize() };
    }
}
