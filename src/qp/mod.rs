//! Layer `qp`: the contact quadratic programme and the dense algebra it needs.
//! min ½xᵀPx + qᵀx subject to x ≥ 0 by two methods: [`active_set`], the primal–dual
//! active-set method (the contact step, warm-started from the previous contact set), and
//! [`solver`], Clarabel polished to round-off on its contact set (the fallback of the contact
//! step, the monolithic check, the admissible contact traction of the estimates); [`solution`]:
//! what either gives and its KKT check; [`dense`]: dense SPD matrices (Schur complements on
//! Γc) and their Cholesky factorisation; [`friction`]: the Tresca frictional problem (normal
//! z_n ≥ 0 and a friction term g|z_t|) by an active-set method with stick/slip sets and by
//! Clarabel, and Coulomb friction by a fixed point over Tresca problems.
//!
//! May use: `fem`, `petsc`, `os` (today it uses nothing of the crate).

pub mod active_set;
pub mod dense;
pub mod friction;
pub mod solution;
pub mod solver;

pub use solution::{kkt_residual, QpMethod, QpSolution};
pub use solver::{solve_nonneg_qp, QpError, QpSettings};
