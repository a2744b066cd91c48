//! How a body's interface operators S^α, D^α are formed (`-nndd_schur`, [`SchurChoice`]),
//! whether a body wants them ([`SchurMode`]), where they came from ([`SchurSource`]), and the
//! solver choices they depend on (a MUMPS or SuperLU_DIST factorisation).

use crate::petsc::readers::SettingsError;
use crate::petsc::{self, OptionsBlock};

/// Whether a body needs its interface operators S^α, D^α.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SchurMode {
    None,
    /// Only when the factorisation gives them (MUMPS, on any rank count).
    IfFactored,
    /// Always: from MUMPS, else from m back-solves.
    Always,
}

/// How the interface operators are formed (`-nndd_schur`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SchurChoice {
    /// MUMPS's Schur complement on one rank, MUMPS's entries of K⁻¹ on several, back-solves
    /// without a MUMPS factorisation.
    Auto,
    MumpsSchur,
    MumpsInverse,
    Solves,
}

impl SchurChoice {
    pub fn name(self) -> &'static str {
        match self {
            SchurChoice::Auto => "auto",
            SchurChoice::MumpsSchur => "mumps_schur",
            SchurChoice::MumpsInverse => "mumps_inverse",
            SchurChoice::Solves => "solves",
        }
    }

    /// Read and register `-nndd_schur`.
    pub fn from_options(o: &mut OptionsBlock) -> Result<SchurChoice, SettingsError> {
        o.choice(
            "-nndd_schur",
            "Interface operators S, D of each body: auto (MUMPS's Schur complement on one rank, MUMPS's entries of the inverse on several, back-solves without MUMPS), mumps_schur, mumps_inverse, solves",
            &[
                SchurChoice::Auto,
                SchurChoice::MumpsSchur,
                SchurChoice::MumpsInverse,
                SchurChoice::Solves,
            ]
            .map(|c| (c.name(), c)),
        )
    }

    /// `mumps_schur` needs each body on one rank and factored by MUMPS, and `mumps_inverse` a
    /// MUMPS factorisation; `group_sizes`: the ranks of each body (bad input, found alike on
    /// every rank).
    pub fn check(self, group_sizes: [usize; 2]) -> Result<(), SettingsError> {
        for alpha in [1, 2] {
            let why = match self {
                SchurChoice::MumpsSchur | SchurChoice::MumpsInverse if !uses_mumps(alpha)? => {
                    format!("body {alpha} is not factored by MUMPS (-body{alpha}_pc_factor_mat_solver_type mumps with -body{alpha}_pc_type cholesky or lu and -body{alpha}_ksp_type preonly); use auto or solves")
                }
                SchurChoice::MumpsSchur if group_sizes[alpha - 1] > 1 => format!(
                    "body {alpha} is on {} ranks, and PETSc 3.18 forms MUMPS's Schur complement on one only; use auto or mumps_inverse",
                    group_sizes[alpha - 1]
                ),
                _ => continue,
            };
            return Err(SettingsError::named(
                &format!("-nndd_schur {}", self.name()),
                why,
            ));
        }
        Ok(())
    }
}

/// Whether body α's solver is a MUMPS factorisation (`-body<α>_ksp_type preonly`,
/// `-body<α>_pc_type cholesky` or `lu`, `-body<α>_pc_factor_mat_solver_type mumps`: the
/// defaults).
pub fn uses_mumps(alpha: usize) -> Result<bool, petsc::PetscError> {
    let get = |what: &str, default: &str| -> Result<String, petsc::PetscError> {
        Ok(petsc::option_string(&format!("-body{alpha}_{what}"))?
            .unwrap_or_else(|| default.to_string()))
    };
    Ok(get("ksp_type", "preonly")? == "preonly"
        && matches!(get("pc_type", "cholesky")?.as_str(), "cholesky" | "lu")
        && get("pc_factor_mat_solver_type", "mumps")? == "mumps")
}

/// Whether body α's factorisation is SuperLU_DIST (`-body<α>_pc_factor_mat_solver_type`).
/// PETSc 3.18 keeps one SuperLU_DIST process grid per communicator and frees it twice when two
/// factorisations shared it, so a body that uses it gets no second factorisation.
pub fn uses_superlu_dist(alpha: usize) -> Result<bool, petsc::PetscError> {
    let name = format!("-body{alpha}_pc_factor_mat_solver_type");
    Ok(petsc::option_string(&name)?.as_deref() == Some("superlu_dist"))
}

/// Where a body's interface operators came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SchurSource {
    /// MUMPS's Schur complement, formed during the factorisation (one rank: PETSc 3.18's
    /// MUMPS interface refuses it on several): S^α, then D^α = (S^α)⁻¹.
    MumpsSchur,
    /// MUMPS's selected entries of K⁻¹ on the Γc normal dofs (ICNTL(30), sparse right-hand
    /// sides on the pruned elimination tree of the one factorisation, any rank count): D^α,
    /// then S^α = (D^α)⁻¹.
    MumpsInverse,
    /// m back-solves K X = Bᵀ (any KSP; `KSPMatSolve` in batches): D^α, then S^α.
    Solves,
}

impl SchurSource {
    pub fn name(self) -> &'static str {
        match self {
            SchurSource::MumpsSchur => "mumps_schur",
            SchurSource::MumpsInverse => "mumps_inverse",
            SchurSource::Solves => "solves",
        }
    }
}
