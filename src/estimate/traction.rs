//! The contact interface Γc as a 1D P1 space (its mass matrix M_Γ, densities and nodal
//! forces), and the admissible contact traction of docs/method.md §3.2: the P1 density t̂ ≤ 0
//! closest in L²(Γc) to a target with the target's resultant, small QPs solved exactly by
//! Clarabel.

use crate::problem::interface_mass;
use crate::qp::dense::SymMatrix;
use crate::qp::{solve_nonneg_qp, QpError, QpSettings};

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

    /// The admissible contact traction (docs/method.md §3.2) of the nodal forces G = `target`:
    /// a P1 density t̂ ≤ 0 at every node (hence on every edge) that carries the same resultant
    /// Σ(M_Γt̂)_k = ΣG_k where G is compressive overall (ΣG < 0).
    /// - Where the consistent density g = M_Γ⁻¹G is ≤ 0 at every node, t̂ = g: it carries G
    ///   exactly.
    /// - Otherwise the L² projection of g onto t̂ ≤ 0 with the resultant kept:
    ///   ‖t̂ − g‖²_M = t̂ᵀMt̂ − 2t̂ᵀG + const, so with x = −t̂ ≥ 0 it is
    ///   min ½ xᵀM_Γx + xᵀG subject to mᵀx = −ΣG (m = M_Γ1, the lumped masses: mᵀx is x's
    ///   resultant). For the multiplier ν of the resultant the problem is the bound-constrained
    ///   QP with G − νm (Clarabel, polished to its exact active set), whose resultant grows
    ///   with ν: ν is found by regula falsi ([`resultant_multiplier`]). Clipping alone
    ///   adds the clipped tensile lobes' force: nodal forces that alternate from node to node
    ///   (curves meshed on their own) have a consistent density that alternates three times
    ///   as much, and the pin in its hole meshed 2:3 got 1.5 times its contact force.
    pub fn admissible_traction(
        &self,
        target: &[f64],
        qp: &QpSettings,
    ) -> Result<Vec<f64>, QpError> {
        let g = self.density(target);
        if g.iter().all(|&v| v <= 0.0) {
            return Ok(g);
        }
        let mass = self.mass();
        let lumped = self.lumped();
        let project = |nu: f64| -> Result<Vec<f64>, QpError> {
            let q: Vec<f64> = target
                .iter()
                .zip(&lumped)
                .map(|(f, m)| f - nu * m)
                .collect();
            Ok(solve_nonneg_qp(&mass, &q, qp)?.x)
        };
        let x = project(0.0)?;
        let want = -target.iter().sum::<f64>();
        if want <= 0.0 {
            return Ok(x.iter().map(|v| -v).collect()); // no net compression to keep
        }
        let nu = resultant_multiplier(&project, &lumped, want, &x)?;
        let x = if nu == 0.0 { x } else { project(nu)? };
        Ok(x.iter().map(|v| -v).collect())
    }

    /// The lumped mass of each node, M_Γ1 (half its segments' lengths): a node's share of Γc.
    pub fn lumped(&self) -> Vec<f64> {
        self.forces(&vec![1.0; self.len()])
    }
}

/// The multiplier ν at which the projection `project(ν)` has the resultant mᵀx = `want`
/// (`x0` = project(0)). mᵀx(ν) is continuous, nondecreasing and piecewise linear in ν
/// (linear while the active set stays), 0 as ν → −∞ and unbounded as ν → ∞: a bracket by
/// doubling, then regula falsi (Illinois), exact once both ends share an active set.
fn resultant_multiplier(
    project: &dyn Fn(f64) -> Result<Vec<f64>, QpError>,
    lumped: &[f64],
    want: f64,
    x0: &[f64],
) -> Result<f64, QpError> {
    let resultant = |x: &[f64]| x.iter().zip(lumped).map(|(a, m)| a * m).sum::<f64>();
    let tol = 1e-13 * want;
    let f0 = resultant(x0) - want;
    if f0.abs() <= tol {
        return Ok(0.0);
    }
    // ν has the units of a density: start the bracket at the largest |M_Γ⁻¹G|-like size.
    let total_mass: f64 = lumped.iter().sum();
    let mut step = want / total_mass;
    let (mut a, mut fa) = (0.0, f0);
    let (mut b, mut fb) = (a, fa);
    // (2^200 times the mean density brackets any finite data: the QP refuses a
    // non-finite one)
    for _ in 0..200 {
        b = if f0 > 0.0 { -step } else { step };
        fb = resultant(&project(b)?) - want;
        if fb.abs() <= tol {
            return Ok(b);
        }
        if fb.signum() != fa.signum() {
            break;
        }
        (a, fa) = (b, fb);
        step *= 2.0;
    }
    if fb.signum() == fa.signum() {
        return Err(QpError::InvalidData(format!(
            "no multiplier gives the contact traction the resultant {want:e}"
        )));
    }
    let mut side = 0;
    for _ in 0..100 {
        let c = (a * fb - b * fa) / (fb - fa);
        let fc = resultant(&project(c)?) - want;
        if fc.abs() <= tol {
            return Ok(c);
        }
        if fc.signum() == fb.signum() {
            (b, fb) = (c, fc);
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        } else {
            (a, fa) = (c, fc);
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        }
    }
    Ok(if fa.abs() < fb.abs() { a } else { b })
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
        // Compressive nodal forces that alternate: a density ≤ 0 with their resultant (to
        // round-off), where clipping their consistent density would add force.
        let forces = vec![-1.0, 0.0, -2.0, 0.0, -1.0];
        let iface = Interface::new(vec![0.25; 4]);
        assert!(iface.density(&forces).iter().any(|&v| v > 0.0));
        let got = iface
            .admissible_traction(&forces, &QpSettings::default())
            .unwrap();
        assert!(got.iter().all(|&v| v <= 0.0), "{got:?}");
        let (sum, want): (f64, f64) = (iface.forces(&got).iter().sum(), forces.iter().sum());
        assert!((sum - want).abs() < 1e-12, "resultant {sum} vs {want}");
        let clipped = solve_nonneg_qp(&iface.mass(), &forces, &QpSettings::default()).unwrap();
        let more: f64 = iface.forces(&clipped.x).iter().sum();
        assert!(
            more + want > 0.1,
            "clipping alone adds force: {more} vs {}",
            -want
        );
        let iface = Interface::new(vec![0.5, 0.5]);
        // A positive (tensile) target gives 0.
        let got = iface
            .admissible_traction(&[1.0, 1.0, 1.0], &QpSettings::default())
            .unwrap();
        assert!(got.iter().all(|&v| v == 0.0), "{got:?}");
    }
}
