//! Layer `petsc`: the one home of PETSc: the unsafe FFI (`ffi`, the bindings `build.rs`
//! generates) and safe RAII wrappers around it, one file per kind of PETSc object:
//!
//! - `error.rs`: [`PetscError`], and the `call!` macro every wrapper calls PETSc through;
//! - `init.rs`: [`Petsc`], PETSc's initialisation and finalisation;
//! - `comm.rs`: the MPI communicators handed to PETSc ([`Comm`]);
//! - `options.rs`: the options database, and the registered options `-help` lists
//!   ([`OptionsBlock`]);
//! - `is.rs`, `vec.rs`, `mat.rs`, `ksp.rs`: index sets, vectors ([`Vector`], [`Gather`]),
//!   matrices ([`Matrix`]), linear solvers ([`Ksp`]);
//! - `mumps.rs`: the verdict of a MUMPS factorisation (a failure in one line);
//! - [`log`]: the `-log_view` stages of a run.
//!
//! Every `PetscErrorCode` becomes a [`PetscError`] carrying PETSc's own message; PETSc's
//! traceback printer is replaced by a returning error handler, so an error reaches the user
//! as one line. Nothing outside this module calls PETSc's FFI; what the run asks of the
//! operating system (signals, memory) is the layer `os`.
//!
//! May use: `os`.

mod comm;
mod error;
mod ffi;
mod init;
mod is;
mod ksp;
pub mod log;
mod mat;
mod mumps;
mod options;
pub mod readers;
mod vec;

pub use comm::{comm_from_rsmpi, Comm};
pub use error::{PetscError, Result};
/// PETSc's `PetscInt` (32-bit in Debian's build).
pub use ffi::PetscInt as Int;
pub use init::Petsc;
pub use ksp::{unknown_type_option, Ksp, SolveInfo};
pub use log::{LogStage, StageGuard};
pub use mat::Matrix;
pub use mumps::Failure as MumpsFailure;
pub use options::{
    names_in, option_default, option_names, option_present, option_string, options_text,
    unused_options, OptionsBlock,
};
pub use vec::{Gather, Vector};
