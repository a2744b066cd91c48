//! Step 2 of an iteration: the two Neumann problems (paper (15)–(16), docs/method.md §2 step 4),
//! homogeneous Dirichlet data on Γ_D^α and the interface loads ∓½R_p on the Γc normal dofs.

use crate::dd::body::{Body, BodyError};

/// Step 4 on body α: the normal trace of w^α, K^α w^α = ±½ R_p on Γc (homogeneous data).
pub fn neumann_step(body: &Body, residual: &[f64]) -> Result<Vec<f64>, BodyError> {
    // Body 1 receives −½R, body 2 +½R (docs/method.md §2 step 4).
    let sign = if body.alpha() == 1 { -0.5 } else { 0.5 };
    let load: Vec<f64> = residual.iter().map(|r| sign * r).collect();
    body.neumann_trace(&load, false)
}
