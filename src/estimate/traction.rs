//! The contact interface Γc as a 1D P1 space (its mass matrix M_Γ, densities and nodal
//! forces), and the admissible contact traction of docs/method.md §3.2: the P1 density t̂ ≤ 0
//! closest in L²(Γc) to a target, a small QP solved exactly by Clarabel.

use crate::problem::interface_mass;
use crate::qp::dense::SymMatrix;
use crate::qp::{solve_nonneg_qp, QpError, QpSettings};

/// Tensile nodal forces up to this fraction of the forces' sum are noise, not tension: a
/// converged iterate's forces at free nodes are 0 to the NNDD's tolerance (4e−9 of the sum on
/// the pin in its hole at tol 1e−8), and clipping them moves the resultant by as little.
const ROUND_OFF: f64 = 1e-6;

/// The contact interface Γc seen as a 1D P1 space on body 1's side (parametrised by its arc
/// length): its mass matrix M_Γ and integrals.
pub struct Interface {
    /// The lengths of the segments [k, k+1].
    pub lengths: Vec<f64>,
    diag: Vec<f64>,
    upper: Vec<f64>,
}

impl Interface {
    /// Γc from the lengths of its segments (body 1's, `BodyProblem::contact_lengths`).
    pub fn new(lengths: Vec<f64>) -> Interface {
        let (diag, upper) = interface_mass(&lengths);
        Interface {
            lengths,
            diag,
            upper,
        }
    }

    pub fn len(&self) -> usize {
        self.diag.len()
    }

    pub fn is_empty(&self) -> bool {
        self.diag.is_empty()
    }

    /// Nodal forces M_Γ t of a P1 density t.
    pub fn forces(&self, t: &[f64]) -> Vec<f64> {
        let m = self.len();
        (0..m)
            .map(|i| {
                let mut f = self.diag[i] * t[i];
                if i > 0 {
                    f += self.upper[i - 1] * t[i - 1];
                }
                if i + 1 < m {
                    f += self.upper[i] * t[i + 1];
                }
                f
            })
            .collect()
    }

    /// The density t = M_Γ⁻¹ T carrying the nodal forces T (tridiagonal solve).
    pub fn density(&self, forces: &[f64]) -> Vec<f64> {
        let m = self.len();
        let mut c = vec![0.0; m];
        let mut d = forces.to_vec();
        let mut b = self.diag.clone();
        for i in 1..m {
            let w = self.upper[i - 1] / b[i - 1];
            b[i] -= w * self.upper[i - 1];
            d[i] -= w * d[i - 1];
        }
        for i in (0..m).rev() {
            let next = if i + 1 < m {
                self.upper[i] * c[i + 1]
            } else {
                0.0
            };
            c[i] = (d[i] - next) / b[i];
        }
        c
    }

    fn mass(&self) -> SymMatrix {
        let m = self.len();
        let mut a = SymMatrix::new(m);
        for i in 0..m {
            a.set(i, i, self.diag[i]);
            if i + 1 < m {
                a.set(i, i + 1, self.upper[i]);
                a.set(i + 1, i, self.upper[i]);
            }
        }
        a
    }

    /// ∫ a b on each segment [k, k+1] (exact for P1 a, b).
    pub fn segment_products(&self, a: &[f64], b: &[f64]) -> Vec<f64> {
        (0..self.len().saturating_sub(1))
            .map(|k| {
                let h = self.lengths[k];
                h / 6.0
                    * (2.0 * a[k] * b[k]
                        + a[k] * b[k + 1]
                        + a[k + 1] * b[k]
                        + 2.0 * a[k + 1] * b[k + 1])
            })
            .collect()
    }

    /// The lumped mass of each node (the row sums of M_Γ: half its segments' lengths).
    fn lumped(&self) -> Vec<f64> {
        let m = self.len();
        (0..m)
            .map(|i| {
                let left = if i > 0 { self.lengths[i - 1] } else { 0.0 };
                let right = if i + 1 < m { self.lengths[i] } else { 0.0 };
                0.5 * (left + right)
            })
            .collect()
    }

    /// The admissible contact traction (docs/method.md §3.2) of the nodal forces G = `target`:
    /// a P1 density t̂ ≤ 0 at every node (hence on every edge).
    /// - Where the consistent density g = M_Γ⁻¹G is ≤ 0 at every node, t̂ = g: it carries G
    ///   exactly.
    /// - Where G ≤ 0 at every node (compressive forces, to [`ROUND_OFF`] of their sum) but g
    ///   is not (forces that alternate
    ///   from node to node, as on curves meshed independently: M_Γ⁻¹ amplifies the alternation
    ///   threefold), the lumped density t̂_k = G_k/m_k: ≤ 0, and its resultant Σ(M_Γt̂)_k =
    ///   Σ m_k t̂_k is ΣG exactly (clipping g would add the clipped lobes' force, 1.5 times
    ///   on the pin in its hole meshed 2:3).
    /// - Otherwise (tensile nodal forces, an early NNDD iterate) the L² projection onto
    ///   t̂ ≤ 0: ‖t̂ − g‖²_M = t̂ᵀMt̂ − 2t̂ᵀG + const, so with x = −t̂ ≥ 0 the QP is
    ///   min ½ xᵀM_Γx + xᵀG (Clarabel, polished).
    pub fn admissible_traction(
        &self,
        target: &[f64],
        qp: &QpSettings,
    ) -> Result<Vec<f64>, QpError> {
        let g = self.density(target);
        if g.iter().all(|&v| v <= 0.0) {
            return Ok(g);
        }
        let tensile: f64 = target.iter().map(|&v| v.max(0.0)).sum();
        let total: f64 = target.iter().map(|v| v.abs()).sum();
        if tensile <= ROUND_OFF * total {
            return Ok(target
                .iter()
                .zip(self.lumped())
                .map(|(f, m)| f.min(0.0) / m)
                .collect());
        }
        let sol = solve_nonneg_qp(&self.mass(), target, qp)?;
        Ok(sol.x.iter().map(|v| -v).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interface_mass_and_density_are_inverse() {
        let iface = Interface::new(vec![0.25; 4]);
        let t = vec![-1.0, -2.0, 0.5, -3.0, 0.0];
        let back = iface.density(&iface.forces(&t));
        for (a, b) in t.iter().zip(&back) {
            assert!((a - b).abs() < 1e-14);
        }
        // ∫ 1 = 1 and ∫ x·1 = 1/2 through the segment products.
        let ones = vec![1.0; 5];
        let s: f64 = iface.segment_products(&ones, &ones).iter().sum();
        assert!((s - 1.0).abs() < 1e-15);
        let x = [0.0, 0.25, 0.5, 0.75, 1.0];
        let s: f64 = iface.segment_products(&x, &ones).iter().sum();
        assert!((s - 0.5).abs() < 1e-15);
    }

    #[test]
    fn admissible_traction_is_the_clipped_projection() {
        let iface = Interface::new(vec![0.5, 0.5]);
        // A target density that is already ≤ 0 is returned exactly.
        let t = vec![-3.0, -1.0, -2.0];
        let got = iface
            .admissible_traction(&iface.forces(&t), &QpSettings::default())
            .unwrap();
        for (a, b) in t.iter().zip(&got) {
            assert!((a - b).abs() < 1e-12 * 3.0, "{got:?}");
        }
        // Compressive nodal forces that alternate: the lumped density, with their resultant.
        let forces = vec![-1.0, 0.0, -2.0, 0.0, -1.0];
        let iface = Interface::new(vec![0.25; 4]);
        assert!(iface.density(&forces).iter().any(|&v| v > 0.0));
        let got = iface
            .admissible_traction(&forces, &QpSettings::default())
            .unwrap();
        assert!(got.iter().all(|&v| v <= 0.0), "{got:?}");
        let (sum, want): (f64, f64) = (iface.forces(&got).iter().sum(), forces.iter().sum());
        assert!((sum - want).abs() < 1e-14, "resultant {sum} vs {want}");
        let iface = Interface::new(vec![0.5, 0.5]);
        // A positive (tensile) target gives 0.
        let got = iface
            .admissible_traction(&[1.0, 1.0, 1.0], &QpSettings::default())
            .unwrap();
        assert!(got.iter().all(|&v| v == 0.0), "{got:?}");
    }
}
