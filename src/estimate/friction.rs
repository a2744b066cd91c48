//! The friction term of the constitutive relation error (docs/method.md §9), on a straight Γc
//! with tangent τ = (n_y, −n_x).
//!
//! With friction the interface law is −t̂ ∈ ∂φ(ŵ), φ(w) = I(w_n ≤ 0) + ∫ g|w_t| (Tresca), and
//! the contact term of (17) is its Fenchel gap, 2∫ (t̂_n ŵ_n + g|ŵ_t| + t̂_t ŵ_t) dS ≥ 0 for
//! any ŵ_n ≤ 0 and any traction with t̂_n ≤ 0, |t̂_t| ≤ g: the normal part is the
//! frictionless term, the friction part is what this module adds, segment by segment (t̂ the
//! traction on body 1, ŵ = û¹ − û²). The admissible tangential density is the target's
//! clipped to [−g, g] at the nodes (P1 on each segment, with g constant (Tresca) or
//! μ|t̂_n| (linear there, t̂_n of one sign) the bound holds between the nodes too). Coulomb's
//! bound g = μ|t̂_n| makes this the CRE of the Tresca problem with that threshold: a bound
//! of the Coulomb error is not guaranteed (its law has no potential), docs/method.md §9.

use crate::dd::friction::{FrictionLaw, Tangential};

/// The tangential data of an iterate's estimates, at the m Γc nodes (every rank).
#[derive(Clone, Debug, Default)]
pub struct FrictionData {
    /// The tangent τ of the straight Γc.
    pub tau: [f64; 2],
    /// η^glo: the admissible tangential density t̂_t on body 1, its bound g, and the jump
    /// ŵ_t = û¹_t − û²_t of the iterate.
    pub glo_t: Vec<f64>,
    pub glo_bound: Vec<f64>,
    pub glo_w: Vec<f64>,
    /// η^FE (body 2 behind λ_p): t̂_t,p (body 1's convention), its bound, and λ_t.
    pub fe_t: Vec<f64>,
    pub fe_bound: Vec<f64>,
    pub lambda_t: Vec<f64>,
    /// T¹_t: body 1's tangential reaction (nodal forces), its η^FE data.
    pub reaction1: Vec<f64>,
    /// The discrete η^NNDD: nodal tangential forces μ̂_t on body 2 and their bounds.
    pub mu_t: Vec<f64>,
    pub mu_bound: Vec<f64>,
}

/// The density bound of the law for the admissible normal density `tn` (≤ 0): g, or μ|t̂_n|.
pub fn density_bound(law: FrictionLaw, tn: &[f64]) -> Vec<f64> {
    match law {
        FrictionLaw::Tresca { threshold } => vec![threshold; tn.len()],
        FrictionLaw::Coulomb { coefficient } => tn.iter().map(|t| coefficient * t.abs()).collect(),
        FrictionLaw::Frictionless => vec![0.0; tn.len()],
    }
}

/// `t` clipped to [−g, g] node by node.
pub fn clip(t: &[f64], g: &[f64]) -> Vec<f64> {
    t.iter().zip(g).map(|(t, g)| t.clamp(-g, *g)).collect()
}

/// The nodal discrete η^NNDD's tangential forces on body 2: ½(T²_t − T¹_t) clipped to the
/// nodal bounds (Tresca g s_k with the pairs' shares `shares`, Coulomb μ μ̂_n with the normal
/// forces `mu_n`).
pub fn nodal_forces(
    law: FrictionLaw,
    t: &Tangential,
    shares: &[f64],
    mu_n: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let bound: Vec<f64> = match law {
        FrictionLaw::Tresca { threshold } => shares.iter().map(|s| threshold * s).collect(),
        FrictionLaw::Coulomb { coefficient } => mu_n.iter().map(|m| coefficient * m).collect(),
        FrictionLaw::Frictionless => vec![0.0; mu_n.len()],
    };
    let target: Vec<f64> = t.forces[1]
        .iter()
        .zip(&t.forces[0])
        .map(|(a, b)| 0.5 * (a - b))
        .collect();
    (clip(&target, &bound), bound)
}

/// 2∫ (g|w| + t w) ds over a segment of length `len`, with g, t, w linear (their values at
/// the two ends): exact, the segment split where w changes sign. ≥ 0 when |t| ≤ g.
pub fn segment_term(len: f64, g: [f64; 2], t: [f64; 2], w: [f64; 2]) -> f64 {
    // ∫₀¹ a(s) b(s) ds of two linear functions, times the length.
    let product = |l: f64, a: [f64; 2], b: [f64; 2]| {
        l / 6.0 * (2.0 * a[0] * b[0] + a[0] * b[1] + a[1] * b[0] + 2.0 * a[1] * b[1])
    };
    let tw = product(len, t, w);
    let gw = if w[0] * w[1] >= 0.0 {
        let sign = if w[0] + w[1] >= 0.0 { 1.0 } else { -1.0 };
        sign * product(len, g, w)
    } else {
        // w = 0 at s* = w₀/(w₀ − w₁): |w| on each part.
        let s = w[0] / (w[0] - w[1]);
        let gs = g[0] + s * (g[1] - g[0]);
        let left = product(s * len, [g[0], gs], [w[0], 0.0]).abs();
        let right = product((1.0 - s) * len, [gs, g[1]], [0.0, w[1]]).abs();
        left + right
    };
    2.0 * (gw + tw)
}

/// 2 Σ_k (g_k|w_k| + t_k w_k) of nodal forces t (on body 1), bounds g and jumps w, node k's
/// weight `weights[k]` (a node's share between its two segments' elements).
pub fn nodal_term(g: f64, t: f64, w: f64) -> f64 {
    2.0 * (g * w.abs() + t * w)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The segment term against a fine midpoint rule, and ≥ 0 for |t| ≤ g.
    #[test]
    fn the_segment_term_is_exact_and_nonnegative() {
        let cases = [
            ([2.0, 3.0], [-1.0, 2.5], [0.4, -0.7]),
            ([1.0, 1.0], [1.0, -1.0], [0.3, 0.2]),
            ([0.5, 2.0], [0.2, -2.0], [-0.1, -0.5]),
        ];
        for (g, t, w) in cases {
            let len = 0.7;
            let n = 200_000;
            let mut quad = 0.0;
            for i in 0..n {
                let s = (i as f64 + 0.5) / n as f64;
                let at = |v: [f64; 2]| v[0] + s * (v[1] - v[0]);
                quad += 2.0 * (at(g) * at(w).abs() + at(t) * at(w)) * len / n as f64;
            }
            let exact = segment_term(len, g, t, w);
            assert!((exact - quad).abs() < 1e-9, "{exact} vs {quad}");
            assert!(exact >= 0.0, "{exact}");
        }
    }

    #[test]
    fn clipping_keeps_the_density_within_its_bound() {
        assert_eq!(
            clip(&[3.0, -3.0, 0.5], &[1.0, 2.0, 1.0]),
            vec![1.0, -2.0, 0.5]
        );
        assert_eq!(
            density_bound(FrictionLaw::Coulomb { coefficient: 0.5 }, &[-4.0, 0.0]),
            vec![2.0, 0.0]
        );
    }
}
