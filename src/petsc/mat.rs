//! Sparse (AIJ) matrices: preallocation, assembly, Dirichlet elimination, the near null
//! space.

use std::ptr;

use super::comm::Comm;
use super::error::{call, cstr, PetscError, Result, ERR_PLIB};
use super::vec::{Vector, PETSC_DETERMINE};
use super::{ffi, Int};

/// A PETSc AIJ matrix (SeqAIJ or MPIAIJ depending on the communicator size).
pub struct Matrix(pub(super) ffi::Mat);

impl Matrix {
    /// ‖A‖∞, the largest absolute row sum (collective).
    pub fn norm_inf(&self) -> Result<f64> {
        let mut n = 0.0;
        call!(MatNorm(self.0, ffi::NORM_INFINITY, &mut n))?;
        Ok(n)
    }

    /// An AIJ matrix (block size 2) with `local_rows` rows on this rank, to be filled by
    /// [`Matrix::add_values`]: `d_nnz[i]` / `o_nnz[i]` are the nonzeros of local row i in the
    /// diagonal block (columns owned here) and off it (the exact counts: a missing one is an error).
    pub fn preallocated(
        comm: Comm,
        local_rows: usize,
        d_nnz: &[Int],
        o_nnz: &[Int],
    ) -> Result<Matrix> {
        assert!(d_nnz.len() == local_rows && o_nnz.len() == local_rows);
        let mut m: ffi::Mat = ptr::null_mut();
        call!(MatCreate(comm.0, &mut m))?;
        let mat = Matrix(m);
        let n = local_rows as Int;
        call!(MatSetSizes(mat.0, n, n, PETSC_DETERMINE, PETSC_DETERMINE))?;
        call!(MatSetBlockSize(mat.0, 2))?;
        let aij = cstr("aij");
        call!(MatSetType(mat.0, aij.as_ptr()))?;
        call!(MatSeqAIJSetPreallocation(mat.0, 0, d_nnz.as_ptr()))?;
        call!(MatMPIAIJSetPreallocation(
            mat.0,
            0,
            d_nnz.as_ptr(),
            0,
            o_nnz.as_ptr()
        ))?;
        Ok(mat)
    }

    /// Add the dense block `vals` (row-major, rows × cols) at global `rows`, `cols`; rows of
    /// other ranks are sent to their owners by [`Matrix::assemble`].
    pub fn add_values(&mut self, rows: &[Int], cols: &[Int], vals: &[f64]) -> Result<()> {
        assert_eq!(rows.len() * cols.len(), vals.len());
        call!(MatSetValues(
            self.0,
            rows.len() as Int,
            rows.as_ptr(),
            cols.len() as Int,
            cols.as_ptr(),
            vals.as_ptr(),
            ffi::ADD_VALUES
        ))
    }

    /// Final assembly (collective), then mark the stiffness symmetric positive definite.
    pub fn assemble(&mut self) -> Result<()> {
        call!(MatAssemblyBegin(self.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(self.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatSetOption(self.0, ffi::MAT_SYMMETRIC, ffi::PETSC_TRUE))?;
        call!(MatSetOption(self.0, ffi::MAT_SPD, ffi::PETSC_TRUE))
    }

    /// The nonzeros stored, summed over the ranks, after checking that the preallocation was
    /// exact (no entry allocated during assembly, none allocated and left unused; collective).
    pub fn exact_nonzeros(&self) -> Result<f64> {
        let mut info = ffi::MatInfo::default();
        call!(MatGetInfo(self.0, ffi::MAT_GLOBAL_SUM, &mut info))?;
        if info.mallocs > 0.0 || info.nz_allocated != info.nz_used {
            return Err(PetscError {
                code: ERR_PLIB,
                call: "MatGetInfo",
                message: format!(
                    "the preallocation was not exact: {} nonzeros used, {} allocated, {} allocations during assembly",
                    info.nz_used, info.nz_allocated, info.mallocs
                ),
            });
        }
        Ok(info.nz_used)
    }

    /// Final assembly (collective) of a matrix that is not SPD (a coupling block).
    pub fn assemble_general(&mut self) -> Result<()> {
        call!(MatAssemblyBegin(self.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(self.0, ffi::MAT_FINAL_ASSEMBLY))
    }

    /// Attach a near null space (for GAMG) spanned by `modes`: this rank's parts (in the
    /// matrix's row order) of orthonormal vectors.
    pub fn set_near_null_space(&mut self, comm: Comm, modes: &[Vec<f64>]) -> Result<()> {
        let vecs = modes
            .iter()
            .map(|m| {
                let mut v = Vector::new(comm, m.len())?;
                call!(VecSetBlockSize(v.0, 2))?;
                v.copy_from(m)?;
                Ok(v)
            })
            .collect::<Result<Vec<Vector>>>()?;
        let raw: Vec<ffi::Vec> = vecs.iter().map(|v| v.0).collect();
        let mut ns: ffi::MatNullSpace = ptr::null_mut();
        call!(MatNullSpaceCreate(
            comm.0,
            ffi::PETSC_FALSE,
            raw.len() as Int,
            raw.as_ptr(),
            &mut ns
        ))?;
        let set = call!(MatSetNearNullSpace(self.0, ns));
        unsafe { ffi::MatNullSpaceDestroy(&mut ns) };
        set
    }

    /// A second handle of this matrix (PETSc's reference count raised; each handle's drop
    /// lowers it): what a solver holds while its maker keeps the matrix to try again.
    pub fn share(&self) -> Result<Matrix> {
        call!(PetscObjectReference(self.0 as ffi::PetscObject))?;
        Ok(Matrix(self.0))
    }

    pub fn duplicate(&self) -> Result<Matrix> {
        let mut m: ffi::Mat = ptr::null_mut();
        call!(MatDuplicate(self.0, ffi::MAT_COPY_VALUES, &mut m))?;
        Ok(Matrix(m))
    }

    /// Zero the given global rows and columns, putting `diag` on the diagonal: symmetric
    /// elimination of Dirichlet conditions (the right-hand side is lifted by the caller).
    pub fn zero_rows_columns(&mut self, rows: &[Int], diag: f64) -> Result<()> {
        call!(MatZeroRowsColumns(
            self.0,
            rows.len() as Int,
            rows.as_ptr(),
            diag,
            ptr::null_mut(),
            ptr::null_mut()
        ))?;
        // The elimination keeps the matrix SPD; tell the factorisation again.
        call!(MatSetOption(self.0, ffi::MAT_SPD, ffi::PETSC_TRUE))
    }

    /// y = A x.
    pub fn mult(&self, x: &Vector, y: &mut Vector) -> Result<()> {
        call!(MatMult(self.0, x.0, y.0))
    }

    /// y = y + A x.
    pub fn mult_add(&self, x: &Vector, y: &mut Vector) -> Result<()> {
        call!(MatMultAdd(self.0, x.0, y.0, y.0))
    }
}

impl Drop for Matrix {
    fn drop(&mut self) {
        unsafe { ffi::MatDestroy(&mut self.0) };
    }
}
