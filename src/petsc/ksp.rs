//! Linear solvers ([`Ksp`]): a factorisation by MUMPS unless the options say otherwise,
//! solves with their backward errors, MUMPS's Schur complement and selected entries of the
//! inverse, and blocks of the inverse by multiple-right-hand-side solves.

use std::ffi::CStr;
use std::ptr;

use super::comm::Comm;
use super::error::{call, cstr, PetscError, Result, ERR_MISSING_FACTOR, ERR_UNKNOWN_TYPE};
use super::is::Is;
use super::mat::Matrix;
use super::mumps;
use super::options::{clear_option, option_default, option_present, option_string, set_option};
use super::vec::{Gather, Vector, PETSC_DETERMINE};
use super::{ffi, Int};

/// The target block of right-hand sides of [`Ksp::mumps_inverse_block`] (MUMPS's ICNTL(27)).
/// MUMPS's solve workspace on the first rank grows with it: `paper` n = 512 on 8 ranks, the
/// group's first rank held 97 MiB of it with all 513 columns in one block, 49 with 256, and
/// that was its peak (docs/scaling.md, "Memory per rank"). Each block is one traversal of the
/// pruned tree, whose cost on several ranks hardly depends on its width ([`inverse_block`]).
const INVERSE_BLOCK: usize = 256;

/// The block of ICNTL(27) for `columns` columns of K⁻¹: as many blocks as INVERSE_BLOCK goes
/// into `columns`, rounded to the nearest (one at least), of equal width, so that no traversal
/// of the pruned tree is spent on a few leftover columns (513 columns: two blocks of 257, not
/// 256, 256 and 1; a block is at most 1.5 × INVERSE_BLOCK wide). `paper` n = 512 on 8 ranks
/// per body (16 cores): 17, 9, 3 and 1 blocks took 18.4, 8.6, 4.1 and 2.5 s, about 0.8 s per
/// block more (docs/results.md, "On 16 cores").
fn inverse_block(columns: usize) -> Int {
    let blocks = ((columns + INVERSE_BLOCK / 2) / INVERSE_BLOCK).max(1);
    columns.div_ceil(blocks).max(1) as Int
}

/// The solver options whose value PETSc may not know, each with the error code that says so
/// and the words of PETSc's message before the value ("Unable to find requested KSP type foo").
const TYPE_OPTIONS: [(i32, &str, &str); 3] = [
    (ERR_UNKNOWN_TYPE, "ksp_type", "KSP type "),
    (ERR_UNKNOWN_TYPE, "pc_type", "PC type "),
    (
        ERR_MISSING_FACTOR,
        "pc_factor_mat_solver_type",
        "solver type ",
    ),
];

/// The option of the solver of options prefix `prefix` whose value `e` says PETSc does not know
/// (`-body1_ksp_type`), and that value; `None` for any other error.
pub fn unknown_type_option(prefix: &str, e: &PetscError) -> Option<(String, String)> {
    TYPE_OPTIONS.iter().find_map(|&(code, name, words)| {
        let option = format!("-{prefix}{name}");
        let value = option_string(&option).ok().flatten()?;
        let said = e.code == code && e.message.contains(&format!("{words}{value}"));
        said.then_some((option, value))
    })
}

/// What a solve did.
#[derive(Clone, Copy, Debug)]
pub struct SolveInfo {
    pub iterations: i64,
    pub reason: i32,
    /// The normwise backward error of the solution, ‖b − A x‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞): about
    /// 1e−16 for a stable factorisation whatever the condition of A, at most the relative
    /// residual for an iterative solve ([`Ksp::backward_error`]).
    pub backward_error: f64,
}

/// A KSP with its operator; configured by defaults (a direct Cholesky factorisation by MUMPS)
/// that the options database (`-<prefix>ksp_type`, `-<prefix>pc_type`, …) overrides.
pub struct Ksp {
    ksp: ffi::KSP,
    _mat: Matrix,
    schur: Option<Vec<f64>>,
    prefix: String,
    /// ‖A‖∞, once computed.
    a_norm: std::cell::Cell<Option<f64>>,
    /// Seconds spent computing backward errors.
    check_seconds: std::cell::Cell<f64>,
    /// Bytes of PETSc's copy of the operator for MUMPS freed on this rank once factored
    /// ([`mumps::release_triples`]).
    freed_copy: usize,
    /// The MUMPS factorisations that fell short of workspace before this one, each with the
    /// relaxation ICNTL(14) it was made again with ([`Ksp::new`]).
    relaxed: Vec<(mumps::Failure, Int)>,
}

/// The factorisations a solver makes again where MUMPS's workspace falls short, each with
/// the relaxation ICNTL(14) raised from r to 2 r + 50 per cent (20 → 90 → 230).
const RELAXATION_RETRIES: usize = 2;

impl Ksp {
    /// The operator the solver was made for.
    pub fn operator(&self) -> &Matrix {
        &self._mat
    }

    /// Create the solver for `mat` with options prefix `prefix` (e.g. `body1_`). When
    /// `schur_rows` is given and the factorisation is MUMPS, its Schur complement on those rows
    /// is computed during the factorisation ([`Ksp::schur_complement`]).
    /// Where MUMPS's workspace falls short (INFOG(1) = −8, −9) and the user did not set
    /// `-<prefix>mat_mumps_icntl_14`, the factorisation is made again with a larger relaxation
    /// ([`RELAXATION_RETRIES`] times at most; [`Ksp::relaxed`] says which); any other failure
    /// is the error naming INFOG(1), INFOG(2) and what to change. A raised relaxation is
    /// removed from the options database once the solver is made (or has failed): the next
    /// factorisation with this prefix (the run's after the reference's, the Dirichlet system
    /// after the Neumann one) starts from MUMPS's default and may be made again in turn.
    pub fn new(comm: Comm, mat: Matrix, prefix: &str, schur_rows: Option<&[Int]>) -> Result<Ksp> {
        let option = format!("-{prefix}mat_mumps_icntl_14");
        let set_by_user = option_present(&option);
        let mut relaxed = Vec::new();
        let made = loop {
            match Ksp::attempt(comm, mat.share()?, prefix, schur_rows) {
                Ok(Ok(mut solver)) => {
                    solver.relaxed = std::mem::take(&mut relaxed);
                    break Ok(solver);
                }
                Ok(Err(f)) if f.workspace_short() && !set_by_user => {
                    if relaxed.len() == RELAXATION_RETRIES {
                        break Err(f.error(prefix));
                    }
                    let more = 2 * f.relaxation.max(0) + 50;
                    set_option(&option, &more.to_string())?;
                    relaxed.push((f, more));
                }
                Ok(Err(f)) => break Err(f.error(prefix)),
                Err(e) => break Err(e),
            }
        };
        if !set_by_user && option_present(&option) {
            clear_option(&option)?;
        }
        made
    }

    /// The MUMPS factorisations that fell short of workspace before this solver's, each with
    /// the relaxation ICNTL(14) it was made again with (empty: the first one did).
    pub fn relaxed(&self) -> &[(mumps::Failure, Int)] {
        &self.relaxed
    }

    /// One try of [`Ksp::new`]: `Ok(Err)` where MUMPS's factorisation failed.
    fn attempt(
        comm: Comm,
        mat: Matrix,
        prefix: &str,
        schur_rows: Option<&[Int]>,
    ) -> Result<std::result::Result<Ksp, mumps::Failure>> {
        let mut ksp: ffi::KSP = ptr::null_mut();
        call!(KSPCreate(comm.0, &mut ksp))?;
        let mut solver = Ksp {
            ksp,
            _mat: mat,
            schur: None,
            prefix: prefix.to_string(),
            a_norm: std::cell::Cell::new(None),
            check_seconds: std::cell::Cell::new(0.0),
            freed_copy: 0,
            relaxed: Vec::new(),
        };
        call!(KSPSetOperators(solver.ksp, solver._mat.0, solver._mat.0))?;
        let p = cstr(prefix);
        call!(KSPSetOptionsPrefix(solver.ksp, p.as_ptr()))?;
        let preonly = cstr("preonly");
        call!(KSPSetType(solver.ksp, preonly.as_ptr()))?;
        let mut pc: ffi::PC = ptr::null_mut();
        call!(KSPGetPC(solver.ksp, &mut pc))?;
        let chol = cstr("cholesky");
        call!(PCSetType(pc, chol.as_ptr()))?;
        let mumps = cstr("mumps");
        call!(PCFactorSetMatSolverType(pc, mumps.as_ptr()))?;
        // `-<prefix>pc_type lu` (or `cholesky`) alone makes a new PC, which forgets the
        // package set above (and may create its factor before it could be set again): MUMPS
        // stays the default unless `-<prefix>pc_factor_mat_solver_type` names another.
        let pc_option = option_string(&format!("-{prefix}pc_type"))?;
        if matches!(pc_option.as_deref(), Some("lu" | "cholesky")) {
            option_default(&format!("-{prefix}pc_factor_mat_solver_type"), "mumps")?;
        }
        call!(KSPSetFromOptions(solver.ksp))?;
        let mut factor: ffi::Mat = ptr::null_mut();
        let mut schur_is = None;
        let mumps_factor = solver.uses_mumps_factor(pc)?;
        if let (Some(rows), true) = (schur_rows, mumps_factor) {
            call!(PCFactorSetUpMatSolverType(pc))?;
            call!(PCFactorGetMatrix(pc, &mut factor))?;
            let is = Is::new(comm, rows)?;
            call!(MatFactorSetSchurIS(factor, is.0))?;
            schur_is = Some((is, rows.len()));
        }
        call!(KSPSetUp(solver.ksp))?;
        if mumps_factor {
            call!(PCFactorGetMatrix(pc, &mut factor))?;
            if let Err(f) = mumps::verdict(factor)? {
                return Ok(Err(f));
            }
        }
        if let Some((_is, m)) = schur_is {
            let mut s: ffi::Mat = ptr::null_mut();
            let mut status = ffi::MAT_FACTOR_SCHUR_UNFACTORED;
            call!(MatFactorCreateSchurComplement(factor, &mut s, &mut status))?;
            let s = Matrix(s);
            let mut a: *const f64 = ptr::null();
            call!(MatDenseGetArrayRead(s.0, &mut a))?;
            // SAFETY: a sequential dense m x m matrix, column-major.
            let dense = unsafe { std::slice::from_raw_parts(a, m * m) }.to_vec();
            call!(MatDenseRestoreArrayRead(s.0, &mut a))?;
            solver.schur = Some(dense);
        }
        if mumps_factor {
            solver.freed_copy = mumps::release_triples(factor)?;
        }
        Ok(Ok(solver))
    }

    /// The PC's type name.
    fn pc_type(pc: ffi::PC) -> Result<String> {
        let mut t: ffi::PCType = ptr::null();
        call!(PCGetType(pc, &mut t))?;
        if t.is_null() {
            return Ok(String::new());
        }
        // SAFETY: PETSc's type names are static, NUL-terminated strings.
        Ok(unsafe { CStr::from_ptr(t) }.to_string_lossy().into_owned())
    }

    /// Whether the PC is a factorisation (`cholesky` or `lu`).
    fn is_factorisation(&self, pc: ffi::PC) -> Result<bool> {
        Ok(matches!(Self::pc_type(pc)?.as_str(), "cholesky" | "lu"))
    }

    /// The factorisation's package (`mumps`, `petsc`, `superlu_dist`…), when one is set.
    fn solver_package(&self, pc: ffi::PC) -> Result<Option<String>> {
        let mut t: ffi::MatSolverType = ptr::null();
        call!(PCFactorGetMatSolverType(pc, &mut t))?;
        if t.is_null() {
            return Ok(None);
        }
        // SAFETY: as in `pc_type`.
        Ok(Some(
            unsafe { CStr::from_ptr(t) }.to_string_lossy().into_owned(),
        ))
    }

    fn uses_mumps_factor(&self, pc: ffi::PC) -> Result<bool> {
        Ok(self.is_factorisation(pc)? && self.solver_package(pc)?.as_deref() == Some("mumps"))
    }

    /// The KSP's and the PC's type names (`preonly`, `cholesky`…), for messages.
    pub fn types(&self) -> Result<(String, String)> {
        let mut t: ffi::KSPType = ptr::null();
        call!(KSPGetType(self.ksp, &mut t))?;
        // SAFETY: as in `pc_type`.
        let ksp = unsafe { CStr::from_ptr(t) }.to_string_lossy().into_owned();
        let mut pc: ffi::PC = ptr::null_mut();
        call!(KSPGetPC(self.ksp, &mut pc))?;
        Ok((ksp, Self::pc_type(pc)?))
    }

    /// The KSP's relative tolerance (`-<prefix>ksp_rtol`).
    pub fn rtol(&self) -> Result<f64> {
        let (mut rtol, mut abstol, mut dtol, mut maxits) = (0.0, 0.0, 0.0, 0 as Int);
        call!(KSPGetTolerances(
            self.ksp,
            &mut rtol,
            &mut abstol,
            &mut dtol,
            &mut maxits
        ))?;
        Ok(rtol)
    }

    /// ‖A‖∞ (computed once).
    fn a_norm(&self) -> Result<f64> {
        if let Some(n) = self.a_norm.get() {
            return Ok(n);
        }
        let mut n = 0.0;
        call!(MatNorm(self._mat.0, ffi::NORM_INFINITY, &mut n))?;
        self.a_norm.set(Some(n));
        Ok(n)
    }

    /// The normwise backward error of x as a solution of A x = b,
    /// ‖b − A x‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞) (Rigal & Gaches; Higham, *Accuracy and Stability of
    /// Numerical Algorithms*, Thm. 7.1): the smallest relative change of A and b of which x is
    /// the exact solution. A stable factorisation gives about the machine epsilon whatever the
    /// condition of A; a preconditioner applied once (`preonly` with a non-direct PC) gives
    /// orders of magnitude more. Collective; NaN when x is not finite.
    pub fn backward_error(&self, b: &Vector, x: &Vector) -> Result<f64> {
        let t = std::time::Instant::now();
        let r = b.duplicate()?;
        call!(MatMult(self._mat.0, x.0, r.0))?;
        call!(VecAXPY(r.0, -1.0, b.0))?;
        let (rn, xn, bn) = (r.norm_inf()?, x.norm_inf()?, b.norm_inf()?);
        let e = ratio(rn, self.a_norm()? * xn + bn);
        self.add_check_time(t);
        Ok(e)
    }

    fn add_check_time(&self, since: std::time::Instant) {
        self.check_seconds
            .set(self.check_seconds.get() + since.elapsed().as_secs_f64());
    }

    /// Bytes of PETSc's copy of the operator for MUMPS (its triples) freed on this rank once
    /// MUMPS factored it; 0 where they are kept or the solver is no MUMPS factorisation.
    pub fn freed_copy_bytes(&self) -> usize {
        self.freed_copy
    }

    /// Seconds this solver spent computing the backward errors of its solves.
    pub fn check_seconds(&self) -> f64 {
        self.check_seconds.get()
    }

    /// The worst backward error of the columns of X as solutions of A X = B (dense
    /// matrices with A's row layout). Collective.
    fn backward_error_columns(&self, b: &Matrix, x: &Matrix, columns: usize) -> Result<f64> {
        let t = std::time::Instant::now();
        let mut r: ffi::Mat = ptr::null_mut();
        call!(MatMatMult(
            self._mat.0,
            x.0,
            ffi::MAT_INITIAL_MATRIX,
            -2.0, // PETSC_DEFAULT
            &mut r
        ))?;
        let r = Matrix(r);
        call!(MatAXPY(r.0, -1.0, b.0, ffi::SAME_NONZERO_PATTERN))?;
        let norms = |m: &Matrix| -> Result<Vec<f64>> {
            let mut n = vec![0.0; columns];
            call!(MatGetColumnNorms(m.0, ffi::NORM_INFINITY, n.as_mut_ptr()))?;
            Ok(n)
        };
        let (rn, xn, bn) = (norms(&r)?, norms(x)?, norms(b)?);
        let a = self.a_norm()?;
        let e = (0..columns)
            .map(|c| ratio(rn[c], a * xn[c] + bn[c]))
            .fold(0.0, worst);
        self.add_check_time(t);
        Ok(e)
    }

    /// The dense Schur complement computed during factorisation (column-major, symmetric part
    /// completed), if MUMPS computed one.
    pub fn schur_complement(&self) -> Option<&[f64]> {
        self.schur.as_deref()
    }

    /// The factored matrix of the PC when it is a MUMPS factorisation (after setup).
    fn mumps_factor(&self) -> Result<Option<ffi::Mat>> {
        let mut pc: ffi::PC = ptr::null_mut();
        call!(KSPGetPC(self.ksp, &mut pc))?;
        if !self.is_direct()? || !self.uses_mumps_factor(pc)? {
            return Ok(None);
        }
        let mut factor: ffi::Mat = ptr::null_mut();
        call!(PCFactorGetMatrix(pc, &mut factor))?;
        Ok(Some(factor))
    }

    /// Whether the solver is a MUMPS factorisation applied once (`preonly`).
    pub fn has_mumps_factor(&self) -> Result<bool> {
        Ok(self.mumps_factor()?.is_some())
    }

    /// MUMPS's count of the floating-point operations of its factorisation (RINFOG(3), over
    /// every rank of the communicator), when the solver is a MUMPS factorisation.
    pub fn mumps_factorisation_flops(&self) -> Result<Option<f64>> {
        let Some(f) = self.mumps_factor()? else {
            return Ok(None);
        };
        let mut flops = 0.0;
        call!(MatMumpsGetRinfog(f, 3, &mut flops))?;
        Ok(Some(flops))
    }

    /// The block (A⁻¹)[rows, rows] (column-major) from MUMPS's computation of selected
    /// entries of the inverse (ICNTL(30)) with the factorisation already made: sparse
    /// right-hand sides and a pruned elimination tree, on any number of ranks. Collective;
    /// the block arrives on the communicator's first rank (`root`), `None` elsewhere, and
    /// `None` everywhere when the solver is not a MUMPS factorisation.
    pub fn mumps_inverse_block(&self, root: bool, rows: &[Int]) -> Result<Option<Vec<f64>>> {
        let Some(f) = self.mumps_factor()? else {
            return Ok(None);
        };
        let m = rows.len();
        let mut distinct = rows.to_vec();
        distinct.sort_unstable();
        distinct.dedup();
        // Blocks of about INVERSE_BLOCK columns (ICNTL(27), MUMPS's default is 32 at most):
        // the pruned tree is traversed once per block (paper n = 256 on 2 ranks: all in one
        // block 0.24 s against 0.50 s with 32), unless the user chose a block size.
        let block = match option_present(&format!("-{}mat_mumps_icntl_27", self.prefix)) {
            true => {
                let mut b: Int = 0;
                call!(MatMumpsGetIcntl(f, 27, &mut b))?;
                b
            }
            false => inverse_block(distinct.len()),
        };
        let values = super::mumps::inverse_entries(f, root, &distinct, block, &self.prefix)?;
        if !root {
            return Ok(None);
        }
        // (`rows` in their order, from the distinct ones MUMPS computed)
        let at = |r: Int| distinct.binary_search(&r).expect("a row of the block");
        let d = distinct.len();
        let mut out = vec![0.0; m * m];
        for (j, &c) in rows.iter().enumerate() {
            for (i, &r) in rows.iter().enumerate() {
                out[j * m + i] = values[at(c) * d + at(r)];
            }
        }
        Ok(Some(out))
    }

    /// Whether several right-hand sides go to one `KSPMatSolve`: a factorisation applied once
    /// (`preonly`), but not SuperLU_DIST's, whose multiple-right-hand-side solve
    /// (`pdReDistribute_B_to_X` in libsuperlu-dist 8) corrupts the heap on a group of two
    /// ranks (Hertz level 1 on 3 ranks: `free(): corrupted unsorted chunks`, SIGABRT).
    fn solves_blocks(&self) -> Result<bool> {
        let mut pc: ffi::PC = ptr::null_mut();
        call!(KSPGetPC(self.ksp, &mut pc))?;
        Ok(self.is_direct()? && self.solver_package(pc)?.as_deref() != Some("superlu_dist"))
    }

    /// The block (A⁻¹)[rows, rows] (column-major), from the solves A X = E with the unit
    /// vectors of `rows`, `batch` right-hand sides at a time (`KSPMatSolve`: one multiple-RHS
    /// solve per batch where [`Self::solves_blocks`], one solve per column otherwise). `owned` is this rank's row
    /// range, `local_rows` its length; `gather` gathers exactly `rows`. Returns the block and
    /// the worst converged reason.
    pub fn inverse_block(
        &self,
        comm: Comm,
        owned: std::ops::Range<Int>,
        rows: &[Int],
        gather: &mut Gather,
        batch: usize,
    ) -> Result<(Vec<f64>, i32, f64)> {
        let m = rows.len();
        let local = owned.end - owned.start;
        let mut out = vec![0.0; m * m];
        let mut reason = 1;
        let mut backward = 0.0;
        if !self.solves_blocks()? {
            for (c, &row) in rows.iter().enumerate() {
                let mut unit = vec![0.0; local as usize];
                if owned.contains(&row) {
                    unit[(row - owned.start) as usize] = 1.0;
                }
                let mut b = Vector::new(comm, unit.len())?;
                b.copy_from(&unit)?;
                let mut x = b.duplicate()?;
                let info = self.solve(&b, &mut x)?;
                reason = reason.min(info.reason);
                backward = worst(backward, info.backward_error);
                out[c * m..(c + 1) * m].copy_from_slice(&gather.gather(&x)?);
            }
            return Ok((out, reason, backward));
        }
        for first in (0..m).step_by(batch.max(1)) {
            let nb = batch.max(1).min(m - first);
            let dense = |values: bool| -> Result<Matrix> {
                let mut b: ffi::Mat = ptr::null_mut();
                call!(MatCreateDense(
                    comm.0,
                    local,
                    -1,
                    PETSC_DETERMINE,
                    nb as Int,
                    ptr::null_mut(),
                    &mut b
                ))?;
                let b = Matrix(b);
                if values {
                    for c in 0..nb {
                        let row = rows[first + c];
                        if owned.contains(&row) {
                            let col = c as Int;
                            call!(MatSetValues(
                                b.0,
                                1,
                                &row,
                                1,
                                &col,
                                &1.0,
                                ffi::INSERT_VALUES
                            ))?;
                        }
                    }
                }
                call!(MatAssemblyBegin(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
                call!(MatAssemblyEnd(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
                Ok(b)
            };
            let (e, x) = (dense(true)?, dense(false)?);
            call!(KSPMatSolve(self.ksp, e.0, x.0))?;
            let mut r = ffi::KSP_CONVERGED_ITERATING;
            call!(KSPGetConvergedReason(self.ksp, &mut r))?;
            reason = reason.min(r);
            backward = worst(backward, self.backward_error_columns(&e, &x, nb)?);
            for c in 0..nb {
                let mut v: ffi::Vec = ptr::null_mut();
                call!(MatDenseGetColumnVecRead(x.0, c as Int, &mut v))?;
                let col = gather.gather_raw(v);
                call!(MatDenseRestoreColumnVecRead(x.0, c as Int, &mut v))?;
                out[(first + c) * m..(first + c + 1) * m].copy_from_slice(&col?);
            }
        }
        Ok((out, reason, backward))
    }

    /// Whether the solver is a factorisation applied once (`preonly`).
    pub fn is_direct(&self) -> Result<bool> {
        let mut t: ffi::KSPType = ptr::null();
        call!(KSPGetType(self.ksp, &mut t))?;
        Ok(unsafe { CStr::from_ptr(t) }.to_bytes() == b"preonly")
    }

    /// Solve A X = B for the columns of B. A factorisation (`preonly`) solves them at once
    /// (`KSPMatSolve`: one multiple-right-hand-side solve, which reads the factor once; not
    /// SuperLU_DIST's, [`Self::solves_blocks`]); an iterative solver one by one, so that each
    /// column's convergence is checked. `columns`
    /// are this rank's rows of B's columns, each `local` long; returns this rank's rows of X's
    /// columns and the worst converged reason. Each column is freed once PETSc holds its copy.
    pub fn solve_many(
        &self,
        comm: Comm,
        columns: Vec<Vec<f64>>,
    ) -> Result<(Vec<Vec<f64>>, i32, f64)> {
        if !self.solves_blocks()? {
            let (mut reason, mut backward) = (1, 0.0);
            let mut out = Vec::with_capacity(columns.len());
            for col in columns {
                let mut b = Vector::new(comm, col.len())?;
                b.copy_from(&col)?;
                let mut x = b.duplicate()?;
                let info = self.solve(&b, &mut x)?;
                reason = reason.min(info.reason);
                backward = worst(backward, info.backward_error);
                out.push(x.to_vec()?);
            }
            return Ok((out, reason, backward));
        }
        let nb = columns.len();
        let local = columns.first().map_or(0, |c| c.len());
        let dense = || -> Result<Matrix> {
            let mut m: ffi::Mat = ptr::null_mut();
            call!(MatCreateDense(
                comm.0,
                local as Int,
                -1,
                PETSC_DETERMINE,
                nb as Int,
                ptr::null_mut(),
                &mut m
            ))?;
            Ok(Matrix(m))
        };
        let (b, x) = (dense()?, dense()?);
        let mut a: *mut f64 = ptr::null_mut();
        call!(MatDenseGetArray(b.0, &mut a))?;
        // SAFETY: a dense matrix PETSc allocated with `local` rows and `nb` columns on this
        // rank, column-major with leading dimension `local`, writable until the restore.
        let values = unsafe { std::slice::from_raw_parts_mut(a, local * nb) };
        for (c, col) in columns.into_iter().enumerate() {
            assert_eq!(col.len(), local, "right-hand side length mismatch");
            values[c * local..(c + 1) * local].copy_from_slice(&col);
        }
        call!(MatDenseRestoreArray(b.0, &mut a))?;
        call!(MatAssemblyBegin(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyBegin(x.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(x.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(KSPMatSolve(self.ksp, b.0, x.0))?;
        let mut reason = ffi::KSP_CONVERGED_ITERATING;
        call!(KSPGetConvergedReason(self.ksp, &mut reason))?;
        let backward = self.backward_error_columns(&b, &x, nb)?;
        drop(b);
        let mut r: *const f64 = ptr::null();
        call!(MatDenseGetArrayRead(x.0, &mut r))?;
        // SAFETY: as above, readable until the restore.
        let values = unsafe { std::slice::from_raw_parts(r, local * nb) };
        let out = (0..nb)
            .map(|c| values[c * local..(c + 1) * local].to_vec())
            .collect();
        call!(MatDenseRestoreArrayRead(x.0, &mut r))?;
        Ok((out, reason, backward))
    }

    /// Solve A x = b.
    pub fn solve(&self, b: &Vector, x: &mut Vector) -> Result<SolveInfo> {
        call!(KSPSolve(self.ksp, b.0, x.0))?;
        let mut reason = ffi::KSP_CONVERGED_ITERATING;
        call!(KSPGetConvergedReason(self.ksp, &mut reason))?;
        let mut its: Int = 0;
        call!(KSPGetIterationNumber(self.ksp, &mut its))?;
        Ok(SolveInfo {
            iterations: its as i64,
            reason,
            backward_error: self.backward_error(b, x)?,
        })
    }
}

/// a / b, NaN when either is not finite (a solution that overflowed has no backward error).
fn ratio(a: f64, b: f64) -> f64 {
    if a.is_finite() && b.is_finite() {
        if b > 0.0 {
            a / b
        } else {
            0.0
        }
    } else {
        f64::NAN
    }
}

/// The worse of two backward errors, NaN (not finite) the worst.
fn worst(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

impl Drop for Ksp {
    fn drop(&mut self) {
        unsafe { ffi::KSPDestroy(&mut self.ksp) };
    }
}

#[cfg(test)]
mod tests {
    use super::inverse_block;

    #[test]
    fn inverse_blocks_are_equal_and_leave_no_few_columns_over() {
        // (columns, block): one block up to 1.5 × 256 − 1, then the nearest count of blocks
        let cases = [
            (1, 1),
            (257, 257),
            (383, 383),
            (384, 192),
            (513, 257),
            (1025, 257),
        ];
        for (columns, block) in cases {
            assert_eq!(inverse_block(columns), block, "{columns} columns");
        }
        for columns in 1..5000 {
            let b = inverse_block(columns) as usize;
            let blocks = columns.div_ceil(b);
            // the nearest count of 256-column blocks, one at least
            let nearest = ((columns as f64 / 256.0).round() as usize).max(1);
            assert_eq!(blocks, nearest, "{columns} columns in blocks of {b}");
            // equal widths: the last block is short of the others by fewer columns than there
            // are blocks
            let last = columns - (blocks - 1) * b;
            assert!(
                last <= b && last + blocks > b,
                "{columns}: {b}, last {last}"
            );
        }
    }
}
