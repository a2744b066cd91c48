//! Layer `qp`: the contact quadratic programme and the dense algebra it needs.
//! [`solver`]: min ½xᵀPx + qᵀx subject to x ≥ 0, solved by Clarabel and polished to
//! round-off on its contact set (the contact step, the monolithic check, the admissible
//! contact traction of the estimates); [`dense`]: dense SPD matrices (Schur complements on Γc)
//! and their Cholesky factorisation.
//!
//! May use: `fem`, `petsc` (today it uses nothing of the crate).

pub mod dense;
pub mod solver;

pub use solver::{
    kkt_residual, solve_nonneg_qp, solve_with_active_set, QpError, QpSettings, QpSolution,
};
