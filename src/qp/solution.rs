//! What a QP solve gives: the point, its multipliers and contact set ([`QpSolution`]), the
//! method that found it ([`QpMethod`]), and its relative KKT violation ([`kkt_residual`]),
//! shared by Clarabel's driver ([`super::solver`]) and the active-set method
//! ([`super::active_set`]).

use super::dense::SymMatrix;

/// Relative tolerance for accepting a polished point: `x_F ≥ −ε‖x‖∞` and
/// `y_A ≥ −ε·max(‖y‖∞, ‖q‖∞)`.
pub(crate) const POLISH_EPS: f64 = 1e-12;

/// Solution of `min ½xᵀPx + qᵀx, x ≥ 0`, in the original (unscaled) units.
#[derive(Debug, Clone, PartialEq)]
pub struct QpSolution {
    /// Primal solution, `x ≥ 0` (exactly, when polished).
    pub x: Vec<f64>,
    /// Multiplier `y = P x + q ≥ 0`. When polished, `y_F = 0` exactly and
    /// `y_A ≥ 0` exactly; otherwise it is the computed `P x + q`.
    pub y: Vec<f64>,
    /// Active set: `active[i]` iff `xᵢ = 0` is imposed (for the polished
    /// point, the set `A` it was solved with; otherwise `x̂ᵢ < ŷᵢ`).
    /// For `q = 0` every index is reported active.
    pub active: Vec<bool>,
    /// Clarabel's iteration count (0 if Clarabel was not called).
    pub iterations: u32,
    /// Whether the polished point was accepted.
    pub polished: bool,
    /// Relative KKT violation of (`x`, `y`), see [`kkt_residual`].
    pub kkt_residual: f64,
    /// The method whose point this is.
    pub method: QpMethod,
}

/// Which method produced a [`QpSolution`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QpMethod {
    /// The primal–dual active-set method ([`crate::qp::active_set`]), certified by the KKT
    /// conditions (`iterations` counts its steps).
    ActiveSet,
    /// Clarabel's interior-point method (`iterations` counts its iterations), polished.
    Clarabel,
}

impl QpMethod {
    pub fn name(self) -> &'static str {
        match self {
            QpMethod::ActiveSet => "active_set",
            QpMethod::Clarabel => "clarabel",
        }
    }
}

/// Relative KKT violation of a candidate solution (`x`, `y`) of
/// `min ½xᵀPx + qᵀx, x ≥ 0`:
///
/// ```text
///   max( ‖min(x,0)‖∞ / ‖x‖∞,                      primal infeasibility
///        ‖min(y,0)‖∞ / max(‖y‖∞, ‖q‖∞),            dual infeasibility
///        |xᵀy| / (‖x‖₂ ‖y‖₂),                      complementarity (cosine)
///        ‖y − (Px + q)‖∞ / max(‖q‖∞, ‖Px‖∞) )     stationarity
/// ```
///
/// Each term is dimensionless (invariant under scaling of `P`, `q` and `x`),
/// a zero denominator counts as the smallest positive number (so that e.g.
/// `x = 0` gives 0 for the first term). The stationarity term is measured
/// against `max(‖q‖∞, ‖Px‖∞)` rather than `‖q‖∞` alone because computing
/// `Px + q` in floating point has an error of order `ε‖Px‖`. A polished
/// solution of a well-posed problem has a residual of a few 1e-16 to 1e-14.
pub fn kkt_residual(p: &SymMatrix, q: &[f64], x: &[f64], y: &[f64]) -> f64 {
    let mut px = vec![0.0; q.len()];
    p.matvec(x, &mut px);
    kkt_residual_with(&px, q, x, y)
}

/// [`kkt_residual`] with the product `px` = P x already made.
pub(crate) fn kkt_residual_with(px: &[f64], q: &[f64], x: &[f64], y: &[f64]) -> f64 {
    let m = q.len();
    let tiny = f64::MIN_POSITIVE;
    let xinf = inf_norm(x);
    let yinf = inf_norm(y);
    let qinf = inf_norm(q);
    let neg = |v: &[f64]| v.iter().fold(0.0f64, |a, &b| a.max(-b));
    let r_x = neg(x) / xinf.max(tiny);
    let r_y = neg(y) / yinf.max(qinf).max(tiny);
    let xty: f64 = x.iter().zip(y).map(|(a, b)| a * b).sum();
    let r_c = xty.abs() / (norm2(x) * norm2(y)).max(tiny);
    let r_s = (0..m)
        .map(|i| (y[i] - (px[i] + q[i])).abs())
        .fold(0.0f64, f64::max)
        / qinf.max(inf_norm(px)).max(tiny);
    r_x.max(r_y).max(r_c).max(r_s)
}

pub(crate) fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, &b| a.max(b.abs()))
}

fn norm2(v: &[f64]) -> f64 {
    // Scale to avoid overflow/underflow of the squares (entries may be ~1e-16
    // or ~1e11).
    let s = inf_norm(v);
    if s == 0.0 {
        return 0.0;
    }
    s * v.iter().map(|a| (a / s) * (a / s)).sum::<f64>().sqrt()
}
