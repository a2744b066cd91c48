//! `-nndd_theta auto`: the NNDD update λ ← λ + θ d (d = (w¹ − w²)·n) accelerated by a
//! multi-secant model of the interface map (Anderson acceleration, in the form of IQN-ILS:
//! Degroote, Bathe & Vierendeels 2009; Walker & Ni 2011), restarted at every change of the
//! contact set (docs/method.md §2, "Relaxation").
//!
//! (The analysis below is of the paper's update, both Neumann steps with ∓½R; θ auto's default
//! update is the Dirichlet body's Neumann step alone, whose operator I + D^D PŜ^CPᵀ has its
//! spectrum in [1, 1 + ‖D^D Ŝ^C‖]: [`crate::dd::neumann::NeumannBodies`].)
//!
//! Why not one scalar θ. While the contact set stays the same, d is affine in λ,
//! d(λ) = b − Aλ with A = ½(S¹⁻¹ + S²⁻¹)(S¹ + P Ŝ² Pᵀ) (Ŝ²: body 2's Schur complement on the
//! contact set; body 2 exerts no force at the free Γc nodes). S²⁻¹P Ŝ² Pᵀ is a projector, so for
//! S¹ = c S² the spectrum of A is two points: (1 + c)²/(2c) on the contact set and (1 + c)/2 on
//! the free nodes. Their ratio is 1/c when body 1 is the softer body (c < 1): at E¹/E² = 0.01
//! the eigenvalues are 51 and 0.505. A fixed θ must stay below 2/51 and then removes the
//! free-node component by only 1 − 0.505 θ per iteration (hundreds of iterations), and a scalar
//! Aitken θ, which follows whichever component dominates d, asks for θ ≈ 2 once the contact-set
//! component has converged, which multiplies that component by |1 − 2·51| ≈ 100. With the
//! Dirichlet step on body 2 (c → 1/c, Ŝ¹ on the contact set) they are (1 + c)²/(2c) and
//! (1 + c)/(2c), a ratio 1 + c: the Dirichlet step on the stiffer body
//! (`-nndd_dirichlet_body auto`) keeps the ratio below 2, which matters most where the contact
//! set changes often and each change restarts the history (docs/method.md §2).
//!
//! The secant model fits every direction it has seen: with the differences Δλ_j, Δd_j = −AΔλ_j
//! of the iterates since the contact set last changed, γ minimises ‖d_p − ΔD γ‖, the point
//! λ_p − ΔΛ γ has the predicted update r = d_p − ΔD γ, and the new iterate is
//! λ_{p+1} = λ_p − ΔΛ γ + θ r. On an affine map this is GMRES (Walker & Ni 2011): a two-point
//! spectrum is solved in a few iterations, whatever θ. θ only scales the new direction (and is
//! the whole step after a restart); it is kept safe for the stiffest direction known,
//! θ = min(1, 1/max(μ₀, ρ_max)): ρ_max is the largest ‖Δd_j‖/‖Δλ_j‖ (≤ ‖A‖) seen in the run,
//! and μ₀ = (1 + c)²/(2c) the largest eigenvalue of A for S¹ = c S², with c = ‖w²‖/‖w¹‖ from the
//! first iteration's two Neumann corrections (w^α = ∓½ S^α⁻¹ R, so the ratio is c when the
//! Schur complements are proportional). μ₀ makes the first step safe without a guess: a fixed
//! probe θ = 1e−3 overshoots by (1 − 1e−3 μ) = −4 at E¹/E² = 1e−4 and separates the bodies.
//!
//! Safeguards. (1) The differences are used only within one contact set: across a change the
//! map changed, so the history restarts and the step is the plain θ d. (2) The model is exact
//! only up to the first change of the contact set along the step, and beyond it the map can be
//! very different: with body 1 a thousand times softer, a gap closed by 6e−7 too much at one
//! node let the stiff body 2 pivot on it and lift off 15 nodes (n = 32). So the secant correction
//! stops where the model predicts the first sign change of the contact step's conditions (T² ≥ 0
//! on the contact set, gap ≥ 0 off it; both affine in λ within the set, so their differences
//! are columns of the model too), a ratio test as in active-set methods ([`step_fraction`]); the
//! plain part θ r of the step, safe in every set, carries the node over. Without this the runs
//! at E¹/E² = 0.001 (n = 8), 1e−4 and 1e−5 (n = 16) chatter between contact sets and stagnate;
//! stepping even halfway from the first predicted change to the next failed at n = 32. (3) Columns
//! nearly dependent on newer ones are dropped for good (QR filtering), so the least-squares
//! problem stays well conditioned when the Krylov space is exhausted; at most `memory` columns
//! are kept.

use std::collections::VecDeque;

/// Relative size below which a difference column is taken as dependent on the newer ones.
const FILTER: f64 = 1e-10;

/// θ of a step before anything is known of the interface map (the probe of
/// [`SecantUpdate::new`]). The first step normally takes θ = 1/μ₀ from the first Neumann
/// corrections instead ([`SecantUpdate::estimate_spectrum`]); this value is used only when
/// they are zero.
pub const AUTO_THETA_PROBE: f64 = 1e-3;

/// One secant column: the differences of two iterates in the same contact set.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
struct Column {
    /// Δλ.
    dl: Vec<f64>,
    /// Δd = −A Δλ.
    dd: Vec<f64>,
    /// Δ of the sign conditions (T² on the contact set, the gap off it).
    ds: Vec<f64>,
}

/// An iterate as the update remembers it.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
struct Point {
    lambda: Vec<f64>,
    d: Vec<f64>,
    active: Vec<bool>,
    signs: Vec<f64>,
}

/// The state of the secant update across the NNDD iterations (kept in a checkpoint).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SecantUpdate {
    probe: f64,
    memory: usize,
    /// The iterate of step p − 1.
    previous: Option<Point>,
    /// The columns, newest first, all in the contact set of `previous`.
    columns: VecDeque<Column>,
    /// The largest ‖Δd‖/‖Δλ‖ seen (0: none yet).
    rho_max: f64,
    /// μ₀ from the first Neumann corrections (0: not known).
    mu0: f64,
}

/// One update.
pub struct SecantStep {
    /// λ_{p+1}.
    pub lambda: Vec<f64>,
    /// The relaxation θ of the step's new direction.
    pub theta: f64,
    /// The difference columns used (0: a plain step λ + θ d).
    pub columns: usize,
    /// The fraction of the secant correction taken (1: all; less when the model predicts a
    /// change of the contact set before the full correction).
    pub fraction: f64,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

fn diff(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

impl SecantUpdate {
    /// `probe`: θ of the steps before anything is known of the map (without
    /// [`Self::estimate_spectrum`]); `memory`: the most columns kept.
    pub fn new(probe: f64, memory: usize) -> SecantUpdate {
        SecantUpdate {
            probe,
            memory: memory.max(1),
            previous: None,
            columns: VecDeque::new(),
            rho_max: 0.0,
            mu0: 0.0,
        }
    }

    /// μ₀ = (1 + c)²/(2c), c = ‖w²‖/‖w¹‖, from the Neumann corrections w¹, w² on Γc of the first
    /// iteration (later calls keep the first estimate; zero corrections give none).
    pub fn estimate_spectrum(&mut self, w1: &[f64], w2: &[f64]) {
        let c = norm(w2) / norm(w1);
        if self.mu0 == 0.0 && c > 0.0 && c.is_finite() {
            self.mu0 = (1.0 + c) * (1.0 + c) / (2.0 * c);
        }
    }

    /// λ_{p+1} from λ_p, d_p = d(λ_p), the contact set of step p and its sign conditions
    /// (`signs[i]`: the contact step's multiplier, T²_i or −T¹_i, ≥ 0 on the contact set, the
    /// gap ≥ 0 off it).
    pub fn step(
        &mut self,
        lambda: &[f64],
        d: &[f64],
        active: &[bool],
        signs: &[f64],
    ) -> SecantStep {
        let now = Point {
            lambda: lambda.to_vec(),
            d: d.to_vec(),
            active: active.to_vec(),
            signs: signs.to_vec(),
        };
        match self.previous.take() {
            Some(old) if old.active == active => {
                let c = Column {
                    dl: diff(lambda, &old.lambda),
                    dd: diff(d, &old.d),
                    ds: diff(signs, &old.signs),
                };
                let (nl, nd) = (norm(&c.dl), norm(&c.dd));
                // A difference at round-off says nothing about the map.
                if nl > 1e-12 * norm(lambda) && nd > 0.0 {
                    self.rho_max = self.rho_max.max(nd / nl);
                    self.columns.push_front(c);
                    self.columns.truncate(self.memory);
                }
            }
            Some(old) => {
                // Another contact set: the history restarts, but the difference still bounds
                // the map's stiffness. d(λ) is continuous and affine on each contact set (the
                // contact step's QP solution is Lipschitz in λ), so ‖Δd‖/‖Δλ‖ across a change
                // is at most the largest ‖A‖ of the sets crossed: never an overestimate. Where
                // the set changes at every iteration (a contact zone a segment or two wide on a
                // coarse curve meshed 1:10 against the other) no column is ever kept, and
                // without this θ stayed at 1/μ₀ while the plain steps grew 2.6 times each.
                self.columns.clear();
                let (nl, nd) = (norm(&diff(lambda, &old.lambda)), norm(&diff(d, &old.d)));
                if nl > 1e-12 * norm(lambda) && nd > 0.0 {
                    self.rho_max = self.rho_max.max(nd / nl);
                }
            }
            None => self.columns.clear(),
        }
        self.previous = Some(now);
        let mu = self.rho_max.max(self.mu0);
        let theta = if mu > 0.0 {
            (1.0 / mu).min(1.0)
        } else {
            self.probe
        };
        let gamma = self.least_squares(d);
        let m = d.len();
        // The secant correction −ΔΛγ, its predicted effect on the sign conditions −ΔSγ, and
        // the predicted update r = d − ΔDγ at its end.
        let mut corr = vec![0.0; m];
        let mut dsig = vec![0.0; m];
        let mut r = d.to_vec();
        for (c, g) in self.columns.iter().zip(&gamma) {
            for i in 0..m {
                corr[i] -= g * c.dl[i];
                dsig[i] -= g * c.ds[i];
                r[i] -= g * c.dd[i];
            }
        }
        let fraction = step_fraction(signs, &dsig);
        // At the fraction s of the correction the predicted update is (1 − s) d + s r.
        let next = (0..m)
            .map(|i| {
                lambda[i] + fraction * corr[i] + theta * (fraction * r[i] + (1.0 - fraction) * d[i])
            })
            .collect();
        SecantStep {
            lambda: next,
            theta,
            columns: gamma.len(),
            fraction,
        }
    }

    /// γ minimising ‖d − ΔD γ‖ by modified Gram–Schmidt on the columns, newest first; a column
    /// whose part orthogonal to the newer ones is below FILTER of its norm is dropped from the
    /// history.
    fn least_squares(&mut self, d: &[f64]) -> Vec<f64> {
        let mut q: Vec<Vec<f64>> = Vec::new();
        let mut r: Vec<Vec<f64>> = Vec::new(); // r[k][i], i ≤ k: column k of R
        let mut keep = vec![false; self.columns.len()];
        for (j, col) in self.columns.iter().enumerate() {
            let mut v = col.dd.clone();
            let n0 = norm(&v);
            let mut rk = Vec::with_capacity(q.len() + 1);
            for qi in &q {
                let h = dot(qi, &v);
                for (x, y) in v.iter_mut().zip(qi) {
                    *x -= h * y;
                }
                rk.push(h);
            }
            let nv = norm(&v);
            if nv.is_nan() || nv <= FILTER * n0 {
                continue;
            }
            v.iter_mut().for_each(|x| *x /= nv);
            rk.push(nv);
            q.push(v);
            r.push(rk);
            keep[j] = true;
        }
        let mut j = 0;
        self.columns.retain(|_| {
            j += 1;
            keep[j - 1]
        });
        // R γ = Qᵀ d, back substitution.
        let k = q.len();
        let c: Vec<f64> = q.iter().map(|qi| dot(qi, d)).collect();
        let mut gamma = vec![0.0; k];
        for i in (0..k).rev() {
            let mut s = c[i];
            for (jj, g) in gamma.iter().enumerate().skip(i + 1) {
                s -= r[jj][i] * g;
            }
            gamma[i] = s / r[i][i];
        }
        gamma
    }
}

/// The fraction s ∈ [0, 1] of a secant correction to take, from the sign conditions φ ≥ 0 of the
/// contact step and their predicted change δφ along the correction (φ + s δφ, exact while the
/// contact set stays): the first predicted sign change, where the model ends (1 if none).
pub fn step_fraction(signs: &[f64], change: &[f64]) -> f64 {
    signs
        .iter()
        .zip(change)
        .filter(|(p, dp)| **dp < 0.0 && **p + **dp < 0.0)
        .map(|(p, dp)| (p / -dp).max(0.0))
        .fold(1.0, f64::min)
}

#[cfg(test)]
mod tests {
    use super::{step_fraction, SecantUpdate};

    /// The ratio test: the correction stops at the first predicted sign change.
    #[test]
    fn the_correction_stops_at_the_first_predicted_sign_change() {
        // φ + s δφ: node 1 changes sign at s = 1/4, node 0 only at s = 2, node 2 never.
        assert_eq!(step_fraction(&[2.0, 1.0, 5.0], &[-1.0, -4.0, 3.0]), 0.25);
        assert_eq!(
            step_fraction(&[2.0, 1.0], &[-1.0, 0.5]),
            1.0,
            "no change: all"
        );
        assert_eq!(
            step_fraction(&[0.0, 1.0], &[-1.0, 0.0]),
            0.0,
            "at the kink: none"
        );
    }

    fn apply(a: &[Vec<f64>], x: &[f64]) -> Vec<f64> {
        a.iter()
            .map(|row| row.iter().zip(x).map(|(p, q)| p * q).sum())
            .collect()
    }

    /// The model problem of the module docs: A with the two eigenvalues 51 and 0.505 (E¹/E² =
    /// 0.01), non-symmetric. Every fixed θ needs hundreds of iterations; the secant update
    /// solves it to round-off within a few, from the probe θ.
    #[test]
    fn two_point_spectrum_in_a_few_iterations() {
        let n = 6;
        // A = V diag(μ) V⁻¹ with V = I + upper-triangular coupling.
        let mu = [51.0, 51.0, 51.0, 51.0, 0.505, 0.505];
        let mut v = vec![vec![0.0; n]; n];
        let mut vinv = vec![vec![0.0; n]; n];
        for i in 0..n {
            v[i][i] = 1.0;
            vinv[i][i] = 1.0;
            if i + 1 < n {
                v[i][i + 1] = 0.3;
            }
        }
        // Inverse of the bidiagonal V: entries (−0.3)^(j−i).
        for (i, row) in vinv.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate().skip(i + 1) {
                *x = (-0.3f64).powi((j - i) as i32);
            }
        }
        let mut a = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..n {
                a[i][j] = (0..n).map(|k| v[i][k] * mu[k] * vinv[k][j]).sum();
            }
        }
        let b: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let d_of = |l: &[f64]| -> Vec<f64> {
            let al = apply(&a, l);
            b.iter().zip(&al).map(|(x, y)| x - y).collect()
        };
        let active = vec![true; n];
        let mut s = SecantUpdate::new(1e-3, 50);
        let mut l = vec![0.0; n];
        let mut its = 0;
        loop {
            its += 1;
            let d = d_of(&l);
            let step = s.step(&l, &d, &active, &vec![1.0; n]);
            let change: f64 = step
                .lambda
                .iter()
                .zip(&l)
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>()
                .sqrt();
            let size: f64 = step.lambda.iter().map(|x| x * x).sum::<f64>().sqrt();
            l = step.lambda;
            if change <= 1e-12 * size || its == 100 {
                break;
            }
        }
        assert!(its <= 8, "{its} iterations");
        let d = d_of(&l);
        let res: f64 = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(res < 1e-10, "residual {res}");
    }

    /// A change of the contact set restarts the history: the step is the plain θ d.
    #[test]
    fn a_contact_set_change_restarts_the_history() {
        let mut s = SecantUpdate::new(0.1, 10);
        let a = [true, false];
        let b = [true, true];
        let z = [1.0, 1.0];
        let st = s.step(&[0.0, 0.0], &[1.0, 1.0], &a, &z);
        assert_eq!(st.columns, 0);
        assert_eq!(st.theta, 0.1);
        let st = s.step(&[0.1, 0.1], &[0.5, 0.8], &a, &z);
        assert_eq!(st.columns, 1);
        // ρ = ‖(−0.5, −0.2)‖ / ‖(0.1, 0.1)‖
        let rho = (0.29f64).sqrt() / (0.02f64).sqrt();
        assert!((st.theta - 1.0 / rho).abs() < 1e-15);
        let (l, theta) = (st.lambda.clone(), st.theta);
        let st = s.step(&l, &[0.2, 0.3], &b, &z);
        assert_eq!(st.columns, 0);
        assert_eq!(st.theta, theta, "θ kept across the change");
        assert_eq!(st.lambda, vec![l[0] + theta * 0.2, l[1] + theta * 0.3]);
    }
}
