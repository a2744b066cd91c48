//! Errors from PETSc, and how every wrapper calls it: [`call!`] turns each
//! `PetscErrorCode` into a [`PetscError`] carrying PETSc's own message (PETSc's traceback
//! printer is replaced by a returning error handler in [`Petsc::initialize`], so an error
//! reaches the user as one line), and [`cstr`] makes the C strings the calls take.
//!
//! [`Petsc::initialize`]: super::Petsc::initialize

use std::ffi::{CStr, CString};
use std::os::raw::c_char;
use std::ptr;

use super::ffi;

/// A PETSc call that failed.
#[derive(Debug, thiserror::Error)]
#[error("PETSc error {code} in {call}: {message}")]
pub struct PetscError {
    pub code: i32,
    pub call: &'static str,
    pub message: String,
}

pub type Result<T> = std::result::Result<T, PetscError>;

/// `PETSC_ERR_ARG_UNKNOWN_TYPE` (petscerror.h): a type name nothing registered
/// (`-body1_ksp_type foo`).
pub const ERR_UNKNOWN_TYPE: i32 = 86;
/// `PETSC_ERR_MISSING_FACTOR` (petscerror.h): no package factors this matrix so
/// (`-body1_pc_factor_mat_solver_type foo`).
pub const ERR_MISSING_FACTOR: i32 = 92;
/// `PETSC_ERR_PLIB` (petscerror.h): PETSc was used wrongly (an inexact preallocation).
pub const ERR_PLIB: i32 = 77;
/// `PETSC_ERR_LIB` (petscerror.h): an error in a library PETSc called (a MUMPS factorisation).
pub const ERR_LIB: i32 = 76;

impl PetscError {
    /// The same error, reported as a bad value of option `name`.
    pub(super) fn for_option(mut self, name: &str) -> PetscError {
        self.message = format!("{name}: {}", self.message);
        self
    }
}

/// `Ok` for a zero code, else the error PETSc describes for it.
pub(super) fn check(code: ffi::PetscErrorCode, call: &'static str) -> Result<()> {
    if code == 0 {
        return Ok(());
    }
    let mut text: *const c_char = ptr::null();
    let mut specific: *mut c_char = ptr::null_mut();
    // SAFETY: PetscErrorMessage only writes the two pointers to static strings.
    unsafe { ffi::PetscErrorMessage(code, &mut text, &mut specific) };
    let pick = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: PETSc returns NUL-terminated static buffers.
            unsafe { CStr::from_ptr(p) }
                .to_string_lossy()
                .trim()
                .to_string()
        }
    };
    let mut message = pick(specific);
    if message.is_empty() {
        message = pick(text);
    }
    Err(PetscError {
        code,
        call,
        message: message.replace('\n', " "),
    })
}

/// Call the FFI function `f` and check its error code: `call!(VecNorm(v, t, &mut n))?`.
macro_rules! call {
    ($f:ident ( $($arg:expr),* $(,)? )) => {
        $crate::petsc::error::check(
            unsafe { $crate::petsc::ffi::$f($($arg),*) },
            stringify!($f),
        )
    };
}
pub(super) use call;

/// A Rust string as the C string PETSc takes.
pub(super) fn cstr(s: &str) -> CString {
    CString::new(s).expect("option strings never contain NUL")
}
