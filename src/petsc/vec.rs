//! Vectors, and [`Gather`], which copies chosen entries of a distributed vector to every
//! rank.

use std::ptr;

use super::comm::Comm;
use super::error::{call, Result};
use super::init::Petsc;
use super::is::Is;
use super::{ffi, Int};

/// `PETSC_DETERMINE`: a global size PETSc sums from the local ones.
pub(super) const PETSC_DETERMINE: Int = -1;

/// A PETSc vector (sequential or distributed over `comm`).
pub struct Vector(pub(super) ffi::Vec);

impl Vector {
    /// A vector with `local` entries on this rank, on communicator `comm`.
    pub fn new(comm: Comm, local: usize) -> Result<Vector> {
        let mut v: ffi::Vec = ptr::null_mut();
        call!(VecCreateMPI(comm.0, local as Int, PETSC_DETERMINE, &mut v))?;
        Ok(Vector(v))
    }

    pub fn duplicate(&self) -> Result<Vector> {
        let mut v: ffi::Vec = ptr::null_mut();
        call!(VecDuplicate(self.0, &mut v))?;
        Ok(Vector(v))
    }

    pub fn local_len(&self) -> Result<usize> {
        let mut n: Int = 0;
        call!(VecGetLocalSize(self.0, &mut n))?;
        Ok(n as usize)
    }

    /// Copy the local part out.
    pub fn to_vec(&self) -> Result<Vec<f64>> {
        let n = self.local_len()?;
        let mut a: *const f64 = ptr::null();
        call!(VecGetArrayRead(self.0, &mut a))?;
        // SAFETY: PETSc gives `n` readable entries until the restore below.
        let out = unsafe { std::slice::from_raw_parts(a, n) }.to_vec();
        call!(VecRestoreArrayRead(self.0, &mut a))?;
        Ok(out)
    }

    /// The largest absolute entry over every rank (collective).
    pub fn norm_inf(&self) -> Result<f64> {
        let mut n = 0.0;
        call!(VecNorm(self.0, ffi::NORM_INFINITY, &mut n))?;
        Ok(n)
    }

    /// Overwrite the local part.
    pub fn copy_from(&mut self, values: &[f64]) -> Result<()> {
        let n = self.local_len()?;
        assert_eq!(n, values.len(), "vector length mismatch");
        let mut a: *mut f64 = ptr::null_mut();
        call!(VecGetArray(self.0, &mut a))?;
        // SAFETY: PETSc gives `n` writable entries until the restore below.
        unsafe { std::slice::from_raw_parts_mut(a, n) }.copy_from_slice(values);
        call!(VecRestoreArray(self.0, &mut a))
    }
}

/// Copies chosen global entries of a distributed vector to every rank (a `VecScatter` onto
/// a sequential vector): the whole vector, or a few rows such as the Γc dofs.
pub struct Gather {
    scatter: ffi::VecScatter,
    out: Vector,
    _is: Is,
}

impl Gather {
    /// Gather the global `rows` of vectors laid out like `like` (every rank asks for the same
    /// rows, in this order).
    pub fn new(like: &Vector, rows: &[Int]) -> Result<Gather> {
        let self_comm = Petsc::comm_self();
        let is = Is::new(self_comm, rows)?;
        let mut v: ffi::Vec = ptr::null_mut();
        call!(VecCreateSeq(self_comm.0, rows.len() as Int, &mut v))?;
        let out = Vector(v);
        let mut scatter: ffi::VecScatter = ptr::null_mut();
        call!(VecScatterCreate(
            like.0,
            is.0,
            out.0,
            ptr::null_mut(),
            &mut scatter
        ))?;
        Ok(Gather {
            scatter,
            out,
            _is: is,
        })
    }

    /// The gathered entries of `x` (collective over `x`'s communicator).
    pub fn gather(&mut self, x: &Vector) -> Result<Vec<f64>> {
        self.gather_raw(x.0)
    }

    pub(super) fn gather_raw(&mut self, x: ffi::Vec) -> Result<Vec<f64>> {
        call!(VecScatterBegin(
            self.scatter,
            x,
            self.out.0,
            ffi::INSERT_VALUES,
            ffi::SCATTER_FORWARD
        ))?;
        call!(VecScatterEnd(
            self.scatter,
            x,
            self.out.0,
            ffi::INSERT_VALUES,
            ffi::SCATTER_FORWARD
        ))?;
        self.out.to_vec()
    }
}

impl Drop for Gather {
    fn drop(&mut self) {
        unsafe { ffi::VecScatterDestroy(&mut self.scatter) };
    }
}

impl Drop for Vector {
    fn drop(&mut self) {
        unsafe { ffi::VecDestroy(&mut self.0) };
    }
}
