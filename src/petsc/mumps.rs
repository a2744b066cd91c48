//! The verdict of a MUMPS factorisation. PETSc records a failed MUMPS factorisation in the
//! factor (INFOG(1) < 0) and goes on; the first solve or the entries of K⁻¹ then
//! fail with MUMPS's "INFOG(1)=-3" (called in the wrong state), which says nothing of the
//! cause. [`verdict`] reads INFOG(1) and INFOG(2) at once and says in one line what failed
//! and which option to change.
//!
//! MUMPS relaxes its factorisation's workspace estimate by ICNTL(14) per cent, 20–35 % by its
//! default on several ranks (5 % on one), and most of a rank's peak is that workspace
//! (docs/scaling.md, "Memory per rank"). nndd keeps MUMPS's default: with 5 % on a group of
//! several ranks, `paper` n = 1024 on 8 ranks ended in MUMPS 5.5 with a Fortran runtime error
//! (dfac_process_blocfacto_LDLT.F, line 983) instead of INFOG(1) = −9. Where the default
//! falls short (INFOG(1) = −8 or −9: small bodies on many ranks), the solver factors again
//! with a larger relaxation ([`Failure::workspace_short`], `Ksp::new`), unless the user set
//! it.
//!
//! [`inverse_entries`] asks MUMPS itself for selected entries of A⁻¹ (ICNTL(30)) with the
//! factorisation PETSc made: MUMPS takes the wanted entries as a sparse right-hand side with
//! one column per row of A (it refuses fewer, INFOG(1) = −47), and PETSc's
//! MatMumpsGetInverseTranspose would take them as a matrix with as many rows on the first
//! rank, its per-row arrays about 28 bytes per row (docs/scaling.md, "Memory per rank");
//! given to MUMPS directly the pattern costs its column pointers alone, 4 bytes per row.
//!
//! [`release_triples`] frees the copy of the matrix PETSc made for MUMPS (its triples
//! i, j, a_ij, 16 bytes per entry of the upper triangle for a Cholesky factorisation: about
//! 70 % of what the matrix itself takes) once MUMPS has factored it (docs/scaling.md, "Memory
//! per rank").

use std::ptr;

use super::error::{call, PetscError, Result, ERR_LIB};
use super::{ffi, Int};

/// A failed MUMPS factorisation: INFOG(1), INFOG(2) and the relaxation ICNTL(14) (per cent
/// of the analysis's workspace estimate) it ran with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Failure {
    pub status: Int,
    pub detail: Int,
    pub relaxation: Int,
}

impl Failure {
    /// Whether its workspace was too small (INFOG(1) = −8, −9): a larger relaxation may let
    /// the factorisation through.
    pub fn workspace_short(&self) -> bool {
        matches!(self.status, -8 | -9)
    }

    /// The error of this failure of the solver with options prefix `prefix`.
    pub(super) fn error(&self, prefix: &str) -> PetscError {
        failure(prefix, self.status, self.detail, self.relaxation)
    }
}

/// `Ok(Ok)` where MUMPS's factorisation `factor` succeeded, `Ok(Err)` with what failed where it
/// did not (INFOG is the same on every rank of its group, so every rank returns the same).
pub(super) fn verdict(factor: ffi::Mat) -> Result<std::result::Result<(), Failure>> {
    let (mut status, mut detail, mut relaxation): (Int, Int, Int) = (0, 0, 0);
    call!(MatMumpsGetInfog(factor, 1, &mut status))?;
    if status >= 0 {
        return Ok(Ok(()));
    }
    call!(MatMumpsGetInfog(factor, 2, &mut detail))?;
    call!(MatMumpsGetIcntl(factor, 14, &mut relaxation))?;
    Ok(Err(Failure {
        status,
        detail,
        relaxation,
    }))
}

/// The error of a failed MUMPS factorisation: INFOG(1) `status`, INFOG(2) `detail`, under the
/// relaxation ICNTL(14) = `relaxation`.
fn failure(prefix: &str, status: Int, detail: Int, relaxation: Int) -> PetscError {
    let why = match status {
        -8 | -9 => format!(
            "its workspace, the analysis's estimate + {relaxation} %, was too small; raise -{prefix}mat_mumps_icntl_14 (a percentage >= 0; MUMPS's default is 20 to 35 on several ranks)"
        ),
        -10 => "the matrix is numerically singular".to_string(),
        -13 => "an allocation failed: not enough memory on a rank (run on more ranks or nodes)"
            .to_string(),
        _ => "see INFOG(1) in MUMPS's users' guide".to_string(),
    };
    PetscError {
        code: ERR_LIB,
        call: "MatCholeskyFactorNumeric",
        message: format!(
            "-{prefix}pc_factor_mat_solver_type mumps: the factorisation failed (INFOG(1) = {status}, INFOG(2) = {detail}): {why}"
        ),
    }
}

/// MUMPS's instance of the factor `f`: PETSc's `Mat_MUMPS` (src/mat/impls/aij/mpi/mumps/mumps.c,
/// not in a header) begins with MUMPS's `DMUMPS_STRUC_C`. `None` unless what it holds is what
/// PETSc reports of the same factor (its size, ICNTL(1..=35) and INFOG(1..=3)).
fn instance(f: ffi::Mat) -> Result<Option<*mut ffi::DMUMPS_STRUC_C>> {
    // SAFETY: `f` is a live factor matrix, whose `data` PETSc's MUMPS interface set.
    let id = unsafe { (*f).data } as *mut ffi::DMUMPS_STRUC_C;
    if id.is_null() {
        return Ok(None);
    }
    let (mut rows, mut cols) = (0 as Int, 0 as Int);
    call!(MatGetSize(f, &mut rows, &mut cols))?;
    // SAFETY: a Mat_MUMPS is larger than the structure it begins with; read only.
    let (n, icntl, infog) = unsafe { ((*id).n, (*id).icntl, (*id).infog) };
    if n != rows {
        return Ok(None);
    }
    for k in 1..=35 {
        let mut v: Int = 0;
        call!(MatMumpsGetIcntl(f, k, &mut v))?;
        if icntl[k as usize - 1] != v {
            return Ok(None);
        }
    }
    for k in 1..=3 {
        let mut v: Int = 0;
        call!(MatMumpsGetInfog(f, k, &mut v))?;
        if infog[k as usize - 1] != v {
            return Ok(None);
        }
    }
    Ok(Some(id))
}

/// The entries (A⁻¹)[i, j] for i, j in `rows` (distinct, increasing) of the factored A in
/// `f`, `block` right-hand sides at a time (ICNTL(27)), by MUMPS directly: column-major on the
/// first rank (`root`), empty on the others. Collective over the factor's communicator.
/// MUMPS's controls and right-hand side are as before on return. An error naming
/// `-nndd_schur solves` where `f`'s instance is not MUMPS's as expected ([`instance`]; every
/// rank of the group sees the same layout).
pub(super) fn inverse_entries(
    f: ffi::Mat,
    root: bool,
    rows: &[Int],
    block: Int,
    prefix: &str,
) -> Result<Vec<f64>> {
    let Some(id) = instance(f)? else {
        return Err(PetscError {
            code: ERR_LIB,
            call: "dmumps_c",
            message: format!(
                "-{prefix}pc_factor_mat_solver_type mumps: this PETSc's MUMPS factor is not laid out as PETSc 3.18's, so its entries of K⁻¹ cannot be asked of MUMPS; use -nndd_schur solves"
            ),
        });
    };
    let d = rows.len();
    // SAFETY: `instance` checked the layout; MUMPS's size is the factor's.
    let n = unsafe { (*id).n } as usize;
    // Column j of the right-hand side (1-based pointers): the rows of column j's wanted
    // entries, for the columns in `rows`, empty elsewhere.
    let (mut pointers, mut indices, mut values) = (Vec::new(), Vec::new(), Vec::new());
    if root {
        pointers = vec![0 as Int; n + 1];
        for &j in rows {
            pointers[j as usize + 1] = d as Int;
        }
        pointers[0] = 1;
        for j in 0..n {
            pointers[j + 1] += pointers[j];
        }
        indices = (0..d).flat_map(|_| rows.iter().map(|&i| i + 1)).collect();
        values = vec![0.0; d * d];
    }
    // (the right-hand side is the host's alone: none on the other ranks)
    let on_root = |v: &mut [Int]| match root {
        true => v.as_mut_ptr(),
        false => ptr::null_mut(),
    };
    let solve = SolveFields {
        job: 3,
        nrhs: n as Int,
        lrhs: n as Int,
        rhs: ptr::null_mut(),
        nz_rhs: if root { (d * d) as Int } else { 0 },
        irhs_ptr: on_root(&mut pointers),
        irhs_sparse: on_root(&mut indices),
        rhs_sparse: match root {
            true => values.as_mut_ptr(),
            false => ptr::null_mut(),
        },
        // ICNTL(20): a sparse right-hand side; (21): the solution centralised on the host;
        // (27): the block; (30): entries of A⁻¹
        icntl: [1, 0, block, 1],
    };
    // SAFETY: `id` is MUMPS's instance, alive with `f`; the arrays outlive the call (MUMPS
    // keeps no pointer to them: the fields are put back before this returns), and their
    // lengths are NRHS + 1 and NZ_RHS as MUMPS reads them.
    let status = unsafe {
        let s = &mut *id;
        let saved = SolveFields::of(s);
        solve.put(s);
        ffi::dmumps_c(id);
        saved.put(s);
        (s.infog[0], s.info[1])
    };
    if status.0 < 0 {
        return Err(PetscError {
            code: ERR_LIB,
            call: "dmumps_c",
            message: format!(
                "MUMPS's entries of the inverse (ICNTL(30)) failed: INFOG(1) = {}, INFO(2) = {}",
                status.0, status.1
            ),
        });
    }
    Ok(values)
}

/// PETSc 3.18's `Mat_MUMPS` up to the triples it gives MUMPS (src/mat/impls/aij/mpi/mumps/
/// mumps.c: after MUMPS's structure, `MatStructure matstruc; PetscMPIInt myid, petsc_size;
/// PetscMUMPSInt *irn, *jcn; PetscScalar *val, *val_alloc; PetscInt64 nnz;`).
#[repr(C)]
struct Triples {
    id: ffi::DMUMPS_STRUC_C,
    matstruc: ffi::MatStructure,
    myid: ffi::PetscMPIInt,
    petsc_size: ffi::PetscMPIInt,
    irn: *mut std::os::raw::c_int,
    jcn: *mut std::os::raw::c_int,
    val: *mut f64,
    val_alloc: *mut f64,
    nnz: i64,
}

/// Free the copy of the matrix that PETSc made for MUMPS, its triples (i, j, a_ij) of this
/// rank's entries (of the upper triangle for a Cholesky factorisation), once MUMPS has
/// factored it: 16 bytes per entry, held through the run for a refactorisation nndd never
/// makes (a body's matrices are not changed once factored: the
/// [`super::Ksp`] owns its operator). MUMPS reads them again only for iterative refinement
/// (ICNTL(10)) and error analysis (ICNTL(11)), so they are kept where either is asked for,
/// and where the factor is not laid out as PETSc 3.18's: its pointers must be the ones
/// MUMPS holds. Returns the bytes freed on this rank. PETSc frees the same pointers the
/// same way (`PetscFree2(irn, jcn)`, `PetscFree(val_alloc)`) when the factor is destroyed,
/// where they are then null.
pub(super) fn release_triples(f: ffi::Mat) -> Result<usize> {
    let Some(id) = instance(f)? else {
        return Ok(0);
    };
    let t = id as *mut Triples;
    // SAFETY: `instance` checked that `f`'s data is MUMPS's instance at the start of PETSc's
    // Mat_MUMPS, which goes on with these fields; read only until they are found to hold
    // exactly the triples MUMPS was given.
    let (held, t) = unsafe {
        let t = &mut *t;
        let s = &t.id;
        let distributed = s.icntl[17] == 3;
        let given = match distributed {
            true => (s.irn_loc, s.jcn_loc, s.a_loc, s.nnz_loc),
            false => (s.irn, s.jcn, s.a, s.nnz),
        };
        let held = (distributed || t.petsc_size == 1)
            && (0..t.petsc_size).contains(&t.myid)
            && given == (t.irn, t.jcn, t.val, t.nnz)
            && !t.irn.is_null()
            && (t.val_alloc.is_null() || t.val_alloc == t.val)
            && s.icntl[9] == 0
            && s.icntl[10] == 0;
        (held, t)
    };
    if !held {
        return Ok(0);
    }
    let copied = !t.val_alloc.is_null();
    let index = std::mem::size_of::<std::os::raw::c_int>();
    let bytes = t.nnz as usize * (2 * index + if copied { 8 } else { 0 });
    let (line, func, file) = (
        line!() as i32,
        c"release_triples".as_ptr(),
        c"mumps.rs".as_ptr(),
    );
    // The pointers are PETSc's allocations (PetscMalloc2 for irn and jcn, PetscMalloc1 for
    // val_alloc), freed here as PETSc frees them and nulled with MUMPS's copies of them, so
    // that nothing reads them and the factor's destruction frees nothing twice.
    let irn = &mut t.irn as *mut *mut std::os::raw::c_int;
    call!(PetscFreeA(
        2,
        line,
        func,
        file,
        irn.cast(),
        &mut t.jcn as *mut *mut std::os::raw::c_int
    ))?;
    if copied {
        let val = &mut t.val_alloc as *mut *mut f64;
        call!(PetscFreeA(1, line, func, file, val.cast()))?;
    }
    t.val = ptr::null_mut();
    let s = &mut t.id;
    (s.irn_loc, s.jcn_loc, s.a_loc) = (ptr::null_mut(), ptr::null_mut(), ptr::null_mut());
    (s.irn, s.jcn, s.a) = (ptr::null_mut(), ptr::null_mut(), ptr::null_mut());
    Ok(bytes)
}

/// The fields of MUMPS's instance that [`inverse_entries`] sets for its solve (and puts back).
#[derive(Clone, Copy)]
struct SolveFields {
    job: Int,
    nrhs: Int,
    lrhs: Int,
    rhs: *mut f64,
    nz_rhs: Int,
    irhs_ptr: *mut Int,
    irhs_sparse: *mut Int,
    rhs_sparse: *mut f64,
    /// ICNTL(20), ICNTL(21), ICNTL(27), ICNTL(30).
    icntl: [Int; 4],
}

/// The positions in MUMPS's ICNTL array of [`SolveFields::icntl`].
const SOLVE_ICNTL: [usize; 4] = [19, 20, 26, 29];

impl SolveFields {
    fn of(s: &ffi::DMUMPS_STRUC_C) -> SolveFields {
        SolveFields {
            job: s.job,
            nrhs: s.nrhs,
            lrhs: s.lrhs,
            rhs: s.rhs,
            nz_rhs: s.nz_rhs,
            irhs_ptr: s.irhs_ptr,
            irhs_sparse: s.irhs_sparse,
            rhs_sparse: s.rhs_sparse,
            icntl: SOLVE_ICNTL.map(|i| s.icntl[i]),
        }
    }

    fn put(self, s: &mut ffi::DMUMPS_STRUC_C) {
        s.job = self.job;
        s.nrhs = self.nrhs;
        s.lrhs = self.lrhs;
        s.rhs = self.rhs;
        s.nz_rhs = self.nz_rhs;
        s.irhs_ptr = self.irhs_ptr;
        s.irhs_sparse = self.irhs_sparse;
        s.rhs_sparse = self.rhs_sparse;
        for (k, &i) in SOLVE_ICNTL.iter().enumerate() {
            s.icntl[i] = self.icntl[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_workspace_failure_names_the_option_to_raise() {
        let text = failure("body2_", -9, 1234, 0).to_string();
        assert!(text.contains("-body2_mat_mumps_icntl_14"), "{text}");
        assert!(text.contains("INFOG(1) = -9, INFOG(2) = 1234"), "{text}");
        assert!(text.contains("estimate + 0 %"), "{text}");
        let singular = failure("body1_", -10, 3, 20).to_string();
        assert!(singular.contains("numerically singular"), "{singular}");
        assert!(!singular.contains("icntl_14"), "{singular}");
    }
}
