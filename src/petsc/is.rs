//! Index sets (`IS`): the rows a scatter gathers or a Schur complement keeps.

use std::ptr;

use super::comm::Comm;
use super::error::{call, Result};
use super::{ffi, Int};

/// A general index set, destroyed when dropped.
pub(super) struct Is(pub(super) ffi::IS);

impl Is {
    pub(super) fn new(comm: Comm, idx: &[Int]) -> Result<Is> {
        let mut is: ffi::IS = ptr::null_mut();
        call!(ISCreateGeneral(
            comm.0,
            idx.len() as Int,
            idx.as_ptr(),
            ffi::PETSC_COPY_VALUES,
            &mut is
        ))?;
        Ok(Is(is))
    }
}

impl Drop for Is {
    fn drop(&mut self) {
        unsafe { ffi::ISDestroy(&mut self.0) };
    }
}
