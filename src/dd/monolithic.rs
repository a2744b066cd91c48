//! The discrete global contact problem solved at once: both bodies, u²_n − u¹_n ≥ −g₀ at every
//! Γc node pair (g₀ the initial gap). The check of the NNDD, and the reference problem of
//! η^NNDD.
//!
//! Condensed exactly on Γc with the contact force μ ≥ 0 (body 2 receives +μ, body 1 −μ):
//! u^α = u^α₀ ± K^α⁻¹Bᵀμ, so the gap is g(μ) = (v²* − v¹*) + (D¹ + D²) μ with the bodies'
//! Delassus operators D^α = B K^α⁻¹ Bᵀ = (S^α)⁻¹ (with the initial gap, g(μ) = g₀ +
//! (v²* − v¹*) + (D¹ + D²) μ). The problem is the QP
//!   minimise ½ μᵀ(D¹ + D²)μ + μᵀ(g₀ + v²* − v¹*)  subject to μ ≥ 0
//! (KKT: g ≥ 0, μ ≥ 0, μᵀg = 0), solved by Clarabel on world rank 0 and polished.

use crate::dd::body::{Body, BodyError};
use crate::parallel::layout::Layout;
use crate::qp::dense::SymMatrix;
use crate::qp::{solve_nonneg_qp, QpError, QpSettings};

#[derive(Debug, thiserror::Error)]
pub enum MonolithicError {
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error("monolithic QP: {0}")]
    Qp(#[from] QpError),
}

pub struct MonolithicResult {
    /// u^α on the ranks owning body α (empty elsewhere).
    pub u: [Vec<f64>; 2],
    /// Contact forces μ on the Γc pairs (known on every rank).
    pub forces: Vec<f64>,
    pub active: Vec<bool>,
    pub qp_iterations: u32,
    pub kkt_residual: f64,
}

pub fn solve(
    layout: &Layout,
    bodies: [Option<&Body>; 2],
    qp: &QpSettings,
) -> Result<MonolithicResult, MonolithicError> {
    // Each body: u₀ (own data, free Γc), v* = B u₀, D = S⁻¹; shared with rank 0.
    let mut free = [Vec::new(), Vec::new()];
    let mut v_star = [Vec::new(), Vec::new()];
    // g₀ is part of the geometry every rank holds.
    let gap = bodies
        .iter()
        .flatten()
        .next()
        .map(|b| b.problem.gap.clone())
        .unwrap_or_default();
    let mut delassus = [Vec::new(), Vec::new()];
    for (k, body) in bodies.iter().enumerate() {
        if let Some(b) = body {
            let u0 = b.neumann_solve(&vec![0.0; b.gc.len()], true)?;
            v_star[k] = b.normal_trace(&u0);
            free[k] = u0;
            // D^α is on the body's first rank, which shares it below.
            if let Some(c) = b.condensed() {
                delassus[k] = c.delassus.data().to_vec();
            }
        }
        layout.share_vec(k + 1, &mut v_star[k]);
        layout.share_vec(k + 1, &mut delassus[k]);
    }
    let m = v_star[0].len();
    let mut mu = vec![0.0; m];
    let mut act = vec![0.0; m];
    let mut stats = [0.0; 2];
    if layout.is_root() {
        let d: Vec<f64> = delassus[0]
            .iter()
            .zip(&delassus[1])
            .map(|(a, b)| a + b)
            .collect();
        let d = SymMatrix::from_rows(m, d);
        let q: Vec<f64> = (0..m)
            .map(|i| gap[i] + v_star[1][i] - v_star[0][i])
            .collect();
        let sol = solve_nonneg_qp(&d, &q, qp)?;
        mu = sol.x;
        // The QP's bound μ_i ≥ 0 is active where the pair is *open*: contact is the complement.
        act = sol.active.iter().map(|&open| !open as u8 as f64).collect();
        stats = [sol.iterations as f64, sol.kkt_residual];
    }
    // Rank 0 is body 1's root: broadcast from there.
    layout.share(1, &mut mu);
    layout.share(1, &mut act);
    layout.share(1, &mut stats);
    let mut u = [Vec::new(), Vec::new()];
    for (k, body) in bodies.iter().enumerate() {
        if let Some(b) = body {
            let sign = if k == 0 { -1.0 } else { 1.0 };
            let load: Vec<f64> = mu.iter().map(|x| sign * x).collect();
            let w = b.neumann_solve(&load, false)?;
            u[k] = free[k].iter().zip(&w).map(|(a, b)| a + b).collect();
        }
    }
    Ok(MonolithicResult {
        u,
        forces: mu,
        active: act.iter().map(|&a| a > 0.5).collect(),
        qp_iterations: stats[0] as u32,
        kkt_residual: stats[1],
    })
}
