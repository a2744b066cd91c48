//! The verdict of a MUMPS factorisation. PETSc records a failed MUMPS factorisation in the
//! factor (INFOG(1) < 0) and goes on; the first solve or MatMumpsGetInverseTranspose then
//! fails with MUMPS's "INFOG(1)=-3" (called in the wrong state), which says nothing of the
//! cause. [`verdict`] reads INFOG(1) and INFOG(2) at once and says in one line what failed
//! and which option to change.
//!
//! MUMPS relaxes its factorisation's workspace estimate by ICNTL(14) per cent, 20–35 % by its
//! default on several ranks (5 % on one), and most of a rank's peak is that workspace
//! (docs/scaling.md, "Memory per rank"). nndd keeps MUMPS's default: with 5 % on a group of
//! several ranks, `paper` n = 1024 on 8 ranks ended in MUMPS 5.5 with a Fortran runtime error
//! (dfac_process_blocfacto_LDLT.F, line 983) instead of INFOG(1) = −9.

use super::error::{call, PetscError, Result, ERR_LIB};
use super::{ffi, Int};

/// `Ok` where MUMPS's factorisation `factor` succeeded (INFOG is the same on every rank of its
/// group, so every rank returns the same), else the error naming what to change.
pub(super) fn verdict(factor: ffi::Mat, prefix: &str) -> Result<()> {
    let (mut status, mut detail, mut relaxation): (Int, Int, Int) = (0, 0, 0);
    call!(MatMumpsGetInfog(factor, 1, &mut status))?;
    if status >= 0 {
        return Ok(());
    }
    call!(MatMumpsGetInfog(factor, 2, &mut detail))?;
    call!(MatMumpsGetIcntl(factor, 14, &mut relaxation))?;
    Err(failure(prefix, status, detail, relaxation))
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
