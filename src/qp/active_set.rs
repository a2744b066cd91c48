//! The primal–dual active-set method for the contact QP
//!
//! ```text
//!     minimise ½ xᵀ P x + qᵀ x   subject to x ≥ 0,      y = P x + q
//! ```
//!
//! (Hintermüller, Ito & Kunisch 2002, a semismooth Newton method on min(x, y/c) = 0; the
//! method of deal.II's step-41). Each step solves the problem exactly on a guessed active set
//! A (x_A = 0, y_F = 0 on the free set F):
//!
//! ```text
//!     P_FF x_F = −q_F,         y = P x + q,
//! ```
//!
//! and moves every index that violates the KKT conditions to the other set (x_i < 0 on F
//! joins A, y_i < 0 on A joins F). When no index violates them, the point is the unique
//! solution (P is positive definite): the method *certifies* its answer, to round-off. From
//! the previous NNDD iteration's contact set it usually certifies in one or two steps.
//!
//! Each step costs one dense Cholesky factorisation of the smaller of the two systems: P_FF
//! (|F|³/6 multiply-adds), or, when the inverse D = P⁻¹ is at hand (the contact step has it:
//! the body's Delassus operator, made once per run) and the active set is the smaller, the
//! dual form on A:
//!
//! ```text
//!     x = D (y − q),  y_F = 0,  x_A = 0   ⇒   D_AA y_A = (D q)_A,   x = D_{:,A} y_A − D q,
//! ```
//!
//! (|A|³/6), plus two products with P or D (m²). An [`ActiveSet`] solver keeps its last
//! factorisation: a step on the set of the previous QP's answer (the NNDD's contact step once
//! its contact set has settled) reuses it, and costs two products and two triangular solves.
//! The method may cycle on matrices that are not M-matrices; a set met before, or `max_steps`
//! steps without a certificate, end it without an answer, and the caller falls back to
//! Clarabel ([`crate::qp::solve_nonneg_qp`]).

use std::collections::HashSet;

use crate::qp::dense::{Cholesky, SymMatrix};
use crate::qp::solution::{inf_norm, kkt_residual_with, QpMethod, QpSolution, POLISH_EPS};

/// The QP's operator P, and its inverse when the caller has it.
#[derive(Clone, Copy)]
pub struct Operator<'a> {
    pub p: &'a SymMatrix,
    /// D = P⁻¹ (symmetric), which makes a step on a small active set cheap.
    pub inverse: Option<&'a SymMatrix>,
}

/// The factorisation of one step: of P_FF (`dual` false) or D_AA (`dual` true) on `set`.
struct Factor {
    set: Vec<bool>,
    dual: bool,
    chol: Cholesky,
}

/// The primal–dual active-set method, keeping the factorisation of its last step for the next
/// QP with the same operator (reset it with [`ActiveSet::forget`] when the operator changes).
#[derive(Default)]
pub struct ActiveSet {
    last: Option<Factor>,
}

/// The outcome of one step on the set `active`: the point (x, y = P x + q, and P x) when it
/// satisfies the KKT conditions to round-off, else the set of the next step.
enum Step {
    Certified {
        x: Vec<f64>,
        y: Vec<f64>,
        px: Vec<f64>,
    },
    Next(Vec<bool>),
    /// A Cholesky factorisation failed (P not positive definite to round-off).
    Failed,
}

impl ActiveSet {
    /// Drop the kept factorisation.
    pub fn forget(&mut self) {
        self.last = None;
    }

    /// The Cholesky factor of `a[idx, idx]` on `set` (`dual`: of D_AA, else of P_FF), the
    /// kept one when it is of the same set and side.
    fn factor(
        &mut self,
        a: &SymMatrix,
        idx: &[usize],
        set: &[bool],
        dual: bool,
    ) -> Option<&Cholesky> {
        let kept = self
            .last
            .as_ref()
            .is_some_and(|f| f.dual == dual && f.set == set);
        if !kept {
            self.last = None;
            let mut sub = a.submatrix(idx);
            sub.symmetrize();
            let chol = sub.cholesky().ok()?;
            self.last = Some(Factor {
                set: set.to_vec(),
                dual,
                chol,
            });
        }
        self.last.as_ref().map(|f| &f.chol)
    }

    /// x with x_A = 0 and y_F = 0: the exact minimiser on the face of the active set.
    fn solve_on_set(
        &mut self,
        op: Operator,
        q: &[f64],
        dq: Option<&[f64]>,
        active: &[bool],
    ) -> Option<Vec<f64>> {
        let m = q.len();
        let free: Vec<usize> = (0..m).filter(|&i| !active[i]).collect();
        let on: Vec<usize> = (0..m).filter(|&i| active[i]).collect();
        let mut x = vec![0.0; m];
        if free.is_empty() {
            return Some(x);
        }
        if let (Some(d), Some(dq), true) = (op.inverse, dq, on.len() < free.len()) {
            // Dual form on A: D_AA y_A = (D q)_A, x = D_{:,A} y_A − D q.
            let mut y_a: Vec<f64> = on.iter().map(|&i| dq[i]).collect();
            if !on.is_empty() {
                self.factor(d, &on, active, true)?.solve_in_place(&mut y_a);
            }
            for &i in &free {
                let row = &d.data()[i * m..(i + 1) * m];
                let s: f64 = on.iter().zip(&y_a).map(|(&j, y)| row[j] * y).sum();
                x[i] = s - dq[i];
            }
            return Some(x);
        }
        let mut xf: Vec<f64> = free.iter().map(|&i| -q[i]).collect();
        self.factor(op.p, &free, active, false)?
            .solve_in_place(&mut xf);
        for (&i, v) in free.iter().zip(&xf) {
            x[i] = *v;
        }
        Some(x)
    }

    /// One step: the exact point on `active`, and the KKT verdict on it (the tolerance of
    /// [`POLISH_EPS`], relative to ‖x‖∞ and max(‖y‖∞, ‖q‖∞)).
    fn step(&mut self, op: Operator, q: &[f64], dq: Option<&[f64]>, active: &[bool]) -> Step {
        let m = q.len();
        let Some(mut x) = self.solve_on_set(op, q, dq, active) else {
            return Step::Failed;
        };
        let xtol = POLISH_EPS * inf_norm(&x);
        let bad_x: Vec<usize> = (0..m).filter(|&i| !active[i] && x[i] < -xtol).collect();
        // Clamp round-off negatives, then y = P x + q with the clamped x.
        x.iter_mut().for_each(|v| *v = v.max(0.0));
        let mut px = vec![0.0; m];
        op.p.matvec(&x, &mut px);
        let mut y: Vec<f64> = px.iter().zip(q).map(|(a, b)| a + b).collect();
        let ytol = POLISH_EPS * inf_norm(&y).max(inf_norm(q));
        let bad_y: Vec<usize> = (0..m).filter(|&i| active[i] && y[i] < -ytol).collect();
        if bad_x.is_empty() && bad_y.is_empty() {
            for i in 0..m {
                y[i] = if active[i] { y[i].max(0.0) } else { 0.0 };
            }
            return Step::Certified { x, y, px };
        }
        let mut next = active.to_vec();
        for i in bad_x {
            next[i] = true;
        }
        for i in bad_y {
            next[i] = false;
        }
        Step::Next(next)
    }

    /// Run the method from the active set `start` for at most `max_steps` steps; `dq` is D q
    /// when the caller knows it (else it is formed when D is given). Returns the certified
    /// solution (`iterations` = the steps taken, `method` = [`QpMethod::ActiveSet`]), or `None`
    /// when it did not certify one: a factorisation failed, a set came back (a cycle), or the
    /// steps ran out.
    pub fn solve(
        &mut self,
        op: Operator,
        q: &[f64],
        dq: Option<&[f64]>,
        start: &[bool],
        max_steps: usize,
    ) -> Option<QpSolution> {
        let m = q.len();
        if start.len() != m || op.p.n() != m || op.inverse.is_some_and(|d| d.n() != m) {
            return None;
        }
        let formed;
        let dq = match (dq, op.inverse) {
            (Some(v), _) => Some(v),
            (None, Some(d)) => {
                let mut v = vec![0.0; m];
                d.matvec(q, &mut v);
                formed = v;
                Some(&formed[..])
            }
            (None, None) => None,
        };
        let mut seen: HashSet<Vec<bool>> = HashSet::new();
        let mut active = start.to_vec();
        for k in 1..=max_steps {
            if !seen.insert(active.clone()) {
                return None; // a cycle
            }
            match self.step(op, q, dq, &active) {
                Step::Certified { x, y, px } => {
                    let kkt_residual = kkt_residual_with(&px, q, &x, &y);
                    return Some(QpSolution {
                        x,
                        y,
                        active,
                        iterations: k as u32,
                        polished: true,
                        kkt_residual,
                        method: QpMethod::ActiveSet,
                    });
                }
                Step::Next(next) => active = next,
                Step::Failed => return None,
            }
        }
        None
    }
}

/// [`ActiveSet::solve`] without a kept factorisation or a known D q.
pub fn solve_from(op: Operator, q: &[f64], start: &[bool], max_steps: usize) -> Option<QpSolution> {
    ActiveSet::default().solve(op, q, None, start, max_steps)
}

/// The active set of the unconstrained minimiser x = −D q where it is negative (the cold start
/// when no earlier contact set is known); x = 0 with y = q (A = {q_i > 0}) without D.
pub fn cold_start(op: Operator, q: &[f64]) -> Vec<bool> {
    match op.inverse {
        Some(d) => {
            let mut x = vec![0.0; q.len()];
            d.matvec(q, &mut x);
            x.iter().map(|&v| -v < 0.0).collect()
        }
        None => q.iter().map(|&v| v > 0.0).collect(),
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::qp::solver::tests::{contact_like, designed_rhs};
    use crate::qp::{solve_nonneg_qp, QpSettings};
    use crate::testutil::Lcg;

    fn solve(p: &SymMatrix, d: Option<&SymMatrix>, q: &[f64], start: &[bool]) -> QpSolution {
        solve_from(Operator { p, inverse: d }, q, start, 50).expect("certified")
    }

    #[test]
    fn hand_2x2_one_active() {
        // P = [[2, 1], [1, 2]], q = (−2, 1): x = (1, 0), y = (0, 2).
        let p = SymMatrix::from_rows(2, vec![2.0, 1.0, 1.0, 2.0]);
        let d = p.inverse_spd().unwrap();
        let q = [-2.0, 1.0];
        for inverse in [None, Some(&d)] {
            for start in [[false, false], [true, true], [true, false], [false, true]] {
                let s = solve(&p, inverse, &q, &start);
                assert!((s.x[0] - 1.0).abs() < 1e-15 && s.x[1] == 0.0, "{:?}", s.x);
                assert!(s.y[0] == 0.0 && (s.y[1] - 2.0).abs() < 1e-15, "{:?}", s.y);
                assert_eq!(s.active, vec![false, true]);
                assert!(s.kkt_residual < 1e-15);
            }
        }
    }

    /// The designed contact-like problems of the Clarabel tests: the same active set and
    /// point as Clarabel's to 1e-10, from cold and warm starts, with and without D.
    #[test]
    fn agrees_with_clarabel_on_contact_like_problems() {
        let n = 300;
        let stiff = contact_like(n, 2e11);
        let d = stiff.inverse_spd().unwrap();
        let (q, xstar, ystar) = designed_rhs(&stiff, 1e-4, 1e8);
        let clarabel = solve_nonneg_qp(&stiff, &q, &QpSettings::default()).unwrap();
        assert_eq!(clarabel.method, QpMethod::Clarabel);
        let op = Operator {
            p: &stiff,
            inverse: Some(&d),
        };
        for (name, start) in [
            ("cold", cold_start(op, &q)),
            ("all active", vec![true; n]),
            ("all free", vec![false; n]),
        ] {
            for inverse in [None, Some(&d)] {
                let s = solve(&stiff, inverse, &q, &start);
                assert_eq!(s.active, clarabel.active, "{name}");
                for i in 0..n {
                    assert!((s.x[i] - xstar[i]).abs() <= 1e-10 * 2.5e-4, "{name} x[{i}]");
                    assert!((s.y[i] - ystar[i]).abs() <= 1e-10 * 2.2e8, "{name} y[{i}]");
                    assert!((s.x[i] - clarabel.x[i]).abs() <= 1e-10 * 2.5e-4);
                }
                assert!(s.kkt_residual < 1e-12, "{name}: {:e}", s.kkt_residual);
                assert!(s.iterations <= 10, "{name}: {} steps", s.iterations);
            }
        }
        // The solution itself as the start certifies in one step.
        let warm = solve(&stiff, Some(&d), &q, &clarabel.active);
        assert_eq!(warm.iterations, 1);
    }

    /// Random SPD problems: whenever the method certifies, its point is Clarabel's.
    #[test]
    fn random_problems_agree_with_clarabel() {
        let mut rng = Lcg(17);
        let mut certified = 0;
        for trial in 0..200 {
            let n = 2 + trial % 15;
            let b: Vec<f64> = (0..n * n).map(|_| rng.next()).collect();
            let mut p = SymMatrix::new(n);
            for i in 0..n {
                for j in 0..n {
                    let s: f64 = (0..n).map(|k| b[k * n + i] * b[k * n + j]).sum();
                    p.set(i, j, s + if i == j { 0.1 } else { 0.0 });
                }
            }
            let q: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let d = p.inverse_spd().unwrap();
            let reference = solve_nonneg_qp(&p, &q, &QpSettings::default()).unwrap();
            let op = Operator {
                p: &p,
                inverse: Some(&d),
            };
            if let Some(s) = solve_from(op, &q, &cold_start(op, &q), 50) {
                certified += 1;
                assert_eq!(s.active, reference.active, "trial {trial}");
                let scale = inf_norm(&reference.x).max(1e-300);
                for i in 0..n {
                    assert!(
                        (s.x[i] - reference.x[i]).abs() <= 1e-9 * scale,
                        "trial {trial}"
                    );
                }
            }
        }
        assert!(certified >= 190, "certified only {certified} of 200");
    }

    /// A solver that keeps its factorisation gives the same answers as a fresh one, and
    /// certifies the next QP on the same set in one step (the NNDD's settled contact step).
    #[test]
    fn the_kept_factorisation_gives_the_same_answers() {
        let n = 300;
        let stiff = contact_like(n, 2e11);
        let d = stiff.inverse_spd().unwrap();
        let op = Operator {
            p: &stiff,
            inverse: Some(&d),
        };
        let (q, _, _) = designed_rhs(&stiff, 1e-4, 1e8);
        let mut kept = ActiveSet::default();
        let first = kept.solve(op, &q, None, &cold_start(op, &q), 50).unwrap();
        // A second QP with the same solution's contact set: q scaled.
        let q2: Vec<f64> = q.iter().map(|v| 1.5 * v).collect();
        let again = kept.solve(op, &q2, None, &first.active, 50).unwrap();
        let fresh = solve_from(op, &q2, &first.active, 50).unwrap();
        assert_eq!(again.iterations, 1);
        assert_eq!(again.active, fresh.active);
        for i in 0..n {
            assert!((again.x[i] - fresh.x[i]).abs() <= 1e-12 * 3.8e-4, "x[{i}]");
            assert!((again.y[i] - fresh.y[i]).abs() <= 1e-12 * 3.3e8, "y[{i}]");
        }
    }

    /// A step budget too small to reach the solution gives no answer (the contact step then
    /// falls back to Clarabel).
    #[test]
    fn too_few_steps_give_no_answer() {
        let n = 300;
        let stiff = contact_like(n, 2e11);
        let (q, _, _) = designed_rhs(&stiff, 1e-4, 1e8);
        let op = Operator {
            p: &stiff,
            inverse: None,
        };
        assert!(solve_from(op, &q, &vec![false; n], 1).is_none());
        assert!(solve_from(op, &q, &vec![false; n], 50).is_some());
    }
}
