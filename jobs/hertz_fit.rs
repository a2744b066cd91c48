//! Hertz's solution for a cylinder on a half-space, plane strain, and the measures of a
//! computed contact pressure against it (shared by `jobs/hertz.rs` and `tests/hertz.rs`).
//!
//! 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂, half-width a = √(4PR/(πE*)), peak p₀ = 2P/(πa),
//! p(x) = p₀ √(1 − x²/a²), with P the total normal force per unit length (the computed one).
#![allow(dead_code)]

/// The computed contact against Hertz's.
#[derive(Clone, Debug)]
pub struct HertzFit {
    /// Total normal force per unit length (N/m), the sum of the nodal contact forces.
    pub force: f64,
    pub a: f64,
    pub p0: f64,
    /// Computed half-width: half the extent of the contact set, each end half-way to the
    /// first open node.
    pub a_h: f64,
    /// Computed peak pressure (the largest lumped nodal pressure).
    pub p0_h: f64,
    /// ‖p_h − p‖ / ‖p‖ in L² over the paired interface (trapezoidal rule on the nodes).
    pub l2: f64,
}

impl HertzFit {
    pub fn a_err(&self) -> f64 {
        (self.a_h - self.a).abs() / self.a
    }

    pub fn p0_err(&self) -> f64 {
        (self.p0_h - self.p0).abs() / self.p0
    }

    /// Hertz's pressure at x.
    pub fn pressure(&self, x: f64) -> f64 {
        let r = x / self.a;
        if r.abs() < 1.0 {
            self.p0 * (1.0 - r * r).sqrt()
        } else {
            0.0
        }
    }
}

/// Compare the nodal contact data (x of the interface nodes, sorted; nodal forces N/m;
/// lumped pressures Pa; active flags) with Hertz for radius `r` and materials (E, ν) of the
/// two bodies.
pub fn fit(
    x: &[f64],
    force: &[f64],
    pressure: &[f64],
    active: &[bool],
    r: f64,
    materials: [(f64, f64); 2],
) -> HertzFit {
    let inv: f64 = materials.iter().map(|(e, nu)| (1.0 - nu * nu) / e).sum();
    let e_star = 1.0 / inv;
    let p: f64 = force.iter().sum();
    let a = (4.0 * p * r / (std::f64::consts::PI * e_star)).sqrt();
    let p0 = 2.0 * p / (std::f64::consts::PI * a);
    let first = active.iter().position(|&s| s).unwrap_or(0);
    let last = active.iter().rposition(|&s| s).unwrap_or(0);
    let left = if first > 0 {
        0.5 * (x[first - 1] + x[first])
    } else {
        x[first]
    };
    let right = if last + 1 < x.len() {
        0.5 * (x[last] + x[last + 1])
    } else {
        x[last]
    };
    let p0_h = pressure.iter().fold(0.0f64, |m, &v| m.max(v));
    let mut fit = HertzFit {
        force: p,
        a,
        p0,
        a_h: 0.5 * (right - left),
        p0_h,
        l2: 0.0,
    };
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..x.len() {
        let lo = if i > 0 { 0.5 * (x[i] - x[i - 1]) } else { 0.0 };
        let hi = if i + 1 < x.len() {
            0.5 * (x[i + 1] - x[i])
        } else {
            0.0
        };
        let exact = fit.pressure(x[i]);
        num += (lo + hi) * (pressure[i] - exact).powi(2);
        den += (lo + hi) * exact * exact;
    }
    fit.l2 = (num / den).sqrt();
    fit
}
