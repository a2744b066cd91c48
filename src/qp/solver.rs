//! The condensed contact problem: a small dense convex QP with nonnegativity
//! constraints, solved by Clarabel and then polished to machine precision.
//!
//! # The problem
//! Each Neumann–Neumann contact iteration condenses the contact conditions on
//! the interface (m unknowns, up to about a thousand) into
//!
//! ```text
//!     minimise ½ xᵀ P x + qᵀ x   subject to x ≥ 0,
//! ```
//!
//! with `P` dense symmetric positive definite (a Schur complement of the
//! elasticity stiffness, or its inverse) and `q` arbitrary. Its KKT
//! conditions form the linear complementarity problem
//!
//! ```text
//!     y = P x + q,   x ≥ 0,   y ≥ 0,   xᵀ y = 0,
//! ```
//!
//! which has a unique solution because `P` is positive definite. `y` is the
//! multiplier of `x ≥ 0`.
//!
//! # Why scaling
//! With steel (E ≈ 2e11 Pa) and displacements of about 1e-4 m, the entries
//! of a stiffness Schur complement are about 1e11 and `q` about 1e6; for the
//! compliance (inverse) form they are about 1e-11 and 1e-5. Clarabel's
//! tolerances are absolute/relative mixes tuned for data of order one, and
//! its regularisation (≈1e-8) would swamp a `P` of size 1e-11. We therefore
//! solve the equivalent problem
//!
//! ```text
//!     P̂ = P / d,  q̂ = q / (d s),  x = s x̂,   d = mean diag(P),  s = ‖q‖∞ / d,
//! ```
//!
//! whose data are of order one (`mean diag P̂ = 1`, `‖q̂‖∞ = 1`); then
//! `ŷ = P̂ x̂ + q̂ = y / (d s)`.
//!
//! # Why polishing
//! An interior-point method stops at a point strictly inside the cone, with
//! complementarity and feasibility only satisfied to its tolerance (≈1e-10
//! relative at best). The a posteriori error bounds of the contact algorithm
//! need the condensed problem solved to round-off. Once Clarabel has
//! identified the active set `A = { i : x̂ᵢ < ŷᵢ }`, the exact solution solves
//! the linear system `P_FF x_F = −q_F`, `x_A = 0` on the free set `F`; we
//! solve it by dense Cholesky and check that it is feasible (`x_F ≥ 0`,
//! `y_A ≥ 0` up to round-off). If it is not (a wrongly identified index),
//! the violating indices are moved to the other set and the linear solve is
//! repeated a few times (the steps of [`crate::qp::active_set`]); if that still
//! fails, Clarabel's point is returned with `polished = false`.

use crate::qp::active_set;
use crate::qp::dense::{DenseError, SymMatrix};
use crate::qp::solution::inf_norm;
pub use crate::qp::solution::{kkt_residual, QpMethod, QpSolution};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};

/// Number of linear solves tried while polishing (the first uses Clarabel's
/// active set, the others move violating indices between the sets).
const MAX_POLISH_ROUNDS: usize = 4;

/// Settings of [`solve_nonneg_qp`].
#[derive(Debug, Clone, PartialEq)]
pub struct QpSettings {
    /// Clarabel's `tol_gap_abs`, `tol_gap_rel` and `tol_feas` (on the scaled
    /// problem). Default 1e-10.
    pub tol: f64,
    /// Clarabel's iteration limit. Default 200.
    pub max_iter: u32,
    /// Polish Clarabel's point by an exact solve on its active set.
    /// Default true.
    pub polish: bool,
    /// Let Clarabel print its iteration log. Default false.
    pub verbose: bool,
}

impl Default for QpSettings {
    fn default() -> Self {
        QpSettings {
            tol: 1e-10,
            max_iter: 200,
            polish: true,
            verbose: false,
        }
    }
}

/// Errors of [`solve_nonneg_qp`].
#[derive(Debug, thiserror::Error)]
pub enum QpError {
    /// Clarabel stopped with a status other than `Solved`/`AlmostSolved`.
    #[error("clarabel did not converge: status {status} after {iterations} iterations")]
    NotConverged {
        /// Clarabel's status, as text (e.g. `MaxIterations`).
        status: String,
        /// Iterations performed.
        iterations: u32,
    },
    /// Clarabel refused the settings or the problem data.
    #[error("clarabel setup failed: {0}")]
    Setup(String),
    /// `q` does not have the dimension of `P`.
    #[error("dimension mismatch: P is {matrix}x{matrix} but q has length {vector}")]
    DimensionMismatch {
        /// Dimension of `P`.
        matrix: usize,
        /// Length of `q`.
        vector: usize,
    },
    /// Data that cannot come from an SPD problem (non-finite entries,
    /// non-positive mean diagonal).
    #[error("invalid QP data: {0}")]
    InvalidData(String),
    /// A dense factorisation failed. Not produced by the polish, which falls
    /// back to Clarabel's point instead; lets callers that also use
    /// [`crate::qp::dense`] propagate both kinds of error with `?`.
    #[error(transparent)]
    Dense(#[from] DenseError),
}

/// Solve `min ½ xᵀ P x + qᵀ x` subject to `x ≥ 0` (see the module docs).
///
/// `P` must be symmetric positive definite (a small asymmetry from
/// round-off is tolerated: Clarabel sees `½(P + Pᵀ)`, the polish solves with
/// the symmetrised principal submatrix, and `y` is computed with `P` as
/// given). Polishing failures, including a Cholesky failure of `P_FF`, are
/// not errors: Clarabel's point is then returned with `polished = false`.
///
/// # Errors
/// [`QpError::DimensionMismatch`] if `q.len() != P.n()`,
/// [`QpError::InvalidData`] for non-finite data or `mean diag P ≤ 0`,
/// [`QpError::NotConverged`] if Clarabel's final status is neither `Solved`
/// nor `AlmostSolved`, [`QpError::Setup`] if Clarabel rejects the problem.
pub fn solve_nonneg_qp(
    p: &SymMatrix,
    q: &[f64],
    settings: &QpSettings,
) -> Result<QpSolution, QpError> {
    let m = p.n();
    if q.len() != m {
        return Err(QpError::DimensionMismatch {
            matrix: m,
            vector: q.len(),
        });
    }
    if q.iter().chain(p.data()).any(|v| !v.is_finite()) {
        return Err(QpError::InvalidData("non-finite entry in P or q".into()));
    }
    let qmax = inf_norm(q);
    if qmax == 0.0 {
        // x = 0, y = 0 is the (unique) solution.
        return Ok(QpSolution {
            x: vec![0.0; m],
            y: vec![0.0; m],
            active: vec![true; m],
            iterations: 0,
            polished: true,
            kkt_residual: 0.0,
            method: QpMethod::Clarabel,
        });
    }
    let d = p.diag_mean();
    if !(d > 0.0 && d.is_finite()) {
        return Err(QpError::InvalidData(format!(
            "mean diagonal of P is {d:e}, expected > 0"
        )));
    }
    let s = qmax / d;

    // Interior-point solve of the scaled problem.
    let (xh, iterations) = clarabel_solve(p, q, d, qmax, settings)?;

    // Back to physical units; y = P x + q = d s ŷ.
    let x: Vec<f64> = xh.iter().map(|v| s * v).collect();
    let mut y = vec![0.0; m];
    p.matvec(&x, &mut y);
    y.iter_mut().zip(q).for_each(|(yi, qi)| *yi += qi);
    // x̂ᵢ < ŷᵢ with x̂ = x / s and ŷ = y / (d s).
    let active: Vec<bool> = x
        .iter()
        .zip(&y)
        .map(|(xi, yi)| xi / s < yi / (d * s))
        .collect();

    if settings.polish {
        let op = active_set::Operator { p, inverse: None };
        if let Some(polished) = active_set::solve_from(op, q, &active, MAX_POLISH_ROUNDS) {
            return Ok(QpSolution {
                iterations,
                method: QpMethod::Clarabel,
                ..polished
            });
        }
    }
    let kkt = kkt_residual(p, q, &x, &y);
    Ok(QpSolution {
        x,
        y,
        active,
        iterations,
        polished: false,
        kkt_residual: kkt,
        method: QpMethod::Clarabel,
    })
}

/// Run Clarabel on the scaled problem `P̂ = P/d`, `q̂ = q/qmax` (note
/// `d s = qmax`), with the constraint written as `−x + s = 0, s ∈ ℝ₊ᵐ`.
/// Returns `x̂` and the iteration count.
fn clarabel_solve(
    p: &SymMatrix,
    q: &[f64],
    d: f64,
    qmax: f64,
    settings: &QpSettings,
) -> Result<(Vec<f64>, u32), QpError> {
    let m = p.n();
    let ph = scaled_upper(p, d, m);
    let qh: Vec<f64> = q.iter().map(|v| v / qmax).collect();
    let a = CscMatrix::new(m, m, (0..=m).collect(), (0..m).collect(), vec![-1.0; m]);
    run_clarabel(&ph, &qh, &a, settings)
}

/// The upper triangle of ½(P + Pᵀ)/d in CSC, of size `n` ≥ P's (the columns beyond P's
/// empty); explicit zeros off the diagonal are dropped, the diagonal is always stored.
pub(crate) fn scaled_upper(p: &SymMatrix, d: f64, n: usize) -> CscMatrix<f64> {
    let m = p.n();
    let mut colptr = Vec::with_capacity(n + 1);
    let mut rowval = Vec::with_capacity(m * (m + 1) / 2);
    let mut nzval = Vec::with_capacity(m * (m + 1) / 2);
    colptr.push(0);
    for j in 0..n {
        for i in (0..=j).filter(|_| j < m) {
            let v = 0.5 * (p.get(i, j) + p.get(j, i)) / d;
            if v != 0.0 || i == j {
                rowval.push(i);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    CscMatrix::new(n, n, colptr, rowval, nzval)
}

/// Clarabel on min ½xᵀP̂x + q̂ᵀx subject to A x + s = 0, s ≥ 0 (a nonnegative cone on every
/// row of A), with `settings`' tolerances: x̂ and the iteration count.
pub(crate) fn run_clarabel(
    ph: &CscMatrix<f64>,
    qh: &[f64],
    a: &CscMatrix<f64>,
    settings: &QpSettings,
) -> Result<(Vec<f64>, u32), QpError> {
    let rows = a.m;
    let b = vec![0.0; rows];
    let cones = [NonnegativeConeT(rows)];
    let cl_settings = DefaultSettingsBuilder::default()
        .verbose(settings.verbose)
        .tol_gap_abs(settings.tol)
        .tol_gap_rel(settings.tol)
        .tol_feas(settings.tol)
        .max_iter(settings.max_iter)
        .build()
        .map_err(|e| QpError::Setup(e.to_string()))?;
    let mut solver = DefaultSolver::new(ph, qh, a, &b, &cones, cl_settings)
        .map_err(|e| QpError::Setup(e.to_string()))?;
    solver.solve();
    let sol = &solver.solution;
    match sol.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => Ok((sol.x.clone(), sol.iterations)),
        status => Err(QpError::NotConverged {
            status: status.to_string(),
            iterations: sol.iterations,
        }),
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
pub(crate) mod tests {
    use super::*;

    use crate::testutil::Lcg;

    /// `Bᵀ B + shift I` with B uniform in [-1,1]ⁿˣⁿ.
    fn random_spd(n: usize, shift: f64, rng: &mut Lcg) -> SymMatrix {
        let b: Vec<f64> = (0..n * n).map(|_| rng.next()).collect();
        let mut a = SymMatrix::new(n);
        for i in 0..n {
            for j in 0..n {
                let mut s = if i == j { shift } else { 0.0 };
                for k in 0..n {
                    s += b[k * n + i] * b[k * n + j];
                }
                a.set(i, j, s);
            }
        }
        a
    }

    fn scaled(a: &SymMatrix, c: f64) -> SymMatrix {
        SymMatrix::from_rows(a.n(), a.data().iter().map(|v| v * c).collect())
    }

    /// Brute force over all 2ⁿ active sets: returns (x, y) of the set whose
    /// exact solution is the least infeasible, and that infeasibility.
    fn brute_force(p: &SymMatrix, q: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
        let n = q.len();
        let qinf = inf_norm(q);
        let mut best = (vec![], vec![], f64::INFINITY);
        for mask in 0u32..(1 << n) {
            let free: Vec<usize> = (0..n).filter(|i| mask & (1 << i) == 0).collect();
            let mut x = vec![0.0; n];
            if !free.is_empty() {
                let chol = p.submatrix(&free).cholesky().unwrap();
                let mut xf: Vec<f64> = free.iter().map(|&i| -q[i]).collect();
                chol.solve_in_place(&mut xf);
                for (&i, v) in free.iter().zip(&xf) {
                    x[i] = *v;
                }
            }
            let mut y = vec![0.0; n];
            p.matvec(&x, &mut y);
            let mut viol: f64 = 0.0;
            for i in 0..n {
                y[i] += q[i];
                if mask & (1 << i) == 0 {
                    viol = viol.max(-x[i] / inf_norm(&x).max(f64::MIN_POSITIVE));
                    y[i] = 0.0;
                } else {
                    viol = viol.max(-y[i] / qinf);
                }
            }
            if viol < best.2 {
                best = (x, y, viol);
            }
        }
        best
    }

    fn rel_err(a: &[f64], b: &[f64], scale: f64) -> f64 {
        a.iter()
            .zip(b)
            .map(|(u, v)| (u - v).abs())
            .fold(0.0, f64::max)
            / scale
    }

    fn solve(p: &SymMatrix, q: &[f64]) -> QpSolution {
        solve_nonneg_qp(p, q, &QpSettings::default()).unwrap()
    }

    #[test]
    fn hand_2x2_one_active() {
        // Unconstrained minimiser (1, -1) is infeasible; with x₂ = 0:
        // 2x₁ = 1, y₂ = x₁ + 1 = 1.5.
        let p = SymMatrix::from_rows(2, vec![2.0, 1.0, 1.0, 2.0]);
        let sol = solve(&p, &[-1.0, 1.0]);
        assert!(sol.polished);
        assert_eq!(sol.active, vec![false, true]);
        assert!(
            (sol.x[0] - 0.5).abs() < 1e-15 && sol.x[1] == 0.0,
            "{:?}",
            sol.x
        );
        assert!(
            sol.y[0] == 0.0 && (sol.y[1] - 1.5).abs() < 1e-15,
            "{:?}",
            sol.y
        );
        assert!(sol.kkt_residual < 1e-15, "{}", sol.kkt_residual);
        assert!(sol.iterations > 0);
    }

    #[test]
    fn hand_3x3_all_free() {
        // x* = (1, 2, 3) > 0, q = -P x*.
        let p = SymMatrix::from_rows(3, vec![4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0]);
        let sol = solve(&p, &[-6.0, -10.0, -8.0]);
        assert!(sol.polished);
        assert_eq!(sol.active, vec![false; 3]);
        for (k, v) in sol.x.iter().enumerate() {
            assert!((v - (k + 1) as f64).abs() < 1e-14, "x = {:?}", sol.x);
        }
        assert_eq!(sol.y, vec![0.0; 3]);
        assert!(sol.kkt_residual < 1e-15);
    }

    #[test]
    fn hand_3x3_all_active() {
        let p = SymMatrix::from_rows(3, vec![4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0]);
        let q = [1.0, 2.0, 3.0];
        let sol = solve(&p, &q);
        assert!(sol.polished);
        assert_eq!(sol.active, vec![true; 3]);
        assert_eq!(sol.x, vec![0.0; 3]);
        assert_eq!(sol.y, q.to_vec());
        assert_eq!(sol.kkt_residual, 0.0);
    }

    #[test]
    fn hand_3x3_mixed() {
        // x* = (1, 0, 2), y* = (0, 5, 0): P x* = (4, 3, 4), q = y* - P x* = (-4, 2, -4).
        let p = SymMatrix::from_rows(3, vec![4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0]);
        let sol = solve(&p, &[-4.0, 2.0, -4.0]);
        assert!(sol.polished);
        assert_eq!(sol.active, vec![false, true, false]);
        assert!(
            rel_err(&sol.x, &[1.0, 0.0, 2.0], 2.0) < 1e-15,
            "{:?}",
            sol.x
        );
        assert!(
            rel_err(&sol.y, &[0.0, 5.0, 0.0], 5.0) < 1e-15,
            "{:?}",
            sol.y
        );
    }

    #[test]
    fn polish_corrects_a_wrong_active_set() {
        // Solution x = (0.5, 0), y = (0, 1.5); start from "all free", whose
        // solve gives x = (1, -1).
        let p = SymMatrix::from_rows(2, vec![2.0, 1.0, 1.0, 2.0]);
        let q = [-1.0, 1.0];
        let op = active_set::Operator {
            p: &p,
            inverse: None,
        };
        assert!(active_set::solve_from(op, &q, &[false, false], 1).is_none());
        let s = active_set::solve_from(op, &q, &[false, false], 2).unwrap();
        assert_eq!(s.active, vec![false, true]);
        assert_eq!((s.x[1], s.y[0]), (0.0, 0.0));
        assert!((s.x[0] - 0.5).abs() < 1e-15 && (s.y[1] - 1.5).abs() < 1e-15);
        // Starting from "all active" (y = q has y₀ = -1 < 0) also recovers.
        let s2 = active_set::solve_from(op, &q, &[true, true], 2).unwrap();
        assert_eq!(s2.active, vec![false, true]);
        assert_eq!(s2.x, s.x);
    }

    #[test]
    fn zero_q_and_dimension_mismatch() {
        let p = SymMatrix::from_rows(2, vec![2.0, 1.0, 1.0, 2.0]);
        let sol = solve(&p, &[0.0, 0.0]);
        assert_eq!(sol.x, vec![0.0, 0.0]);
        assert_eq!(sol.iterations, 0);
        let err = solve_nonneg_qp(&p, &[1.0], &QpSettings::default()).unwrap_err();
        assert!(matches!(
            err,
            QpError::DimensionMismatch {
                matrix: 2,
                vector: 1
            }
        ));
        let err = solve_nonneg_qp(&p, &[1.0, f64::NAN], &QpSettings::default()).unwrap_err();
        assert!(matches!(err, QpError::InvalidData(_)));
    }

    #[test]
    fn max_iterations_is_an_error() {
        let mut rng = Lcg(7);
        let p = random_spd(6, 0.1, &mut rng);
        let q: Vec<f64> = (0..6).map(|_| rng.next()).collect();
        let settings = QpSettings {
            max_iter: 1,
            ..QpSettings::default()
        };
        match solve_nonneg_qp(&p, &q, &settings) {
            Err(QpError::NotConverged { status, .. }) => assert_eq!(status, "MaxIterations"),
            other => panic!("expected MaxIterations, got {other:?}"),
        }
    }

    #[test]
    fn unpolished_point_is_close() {
        let mut rng = Lcg(99);
        let p = random_spd(6, 0.5, &mut rng);
        let q: Vec<f64> = (0..6).map(|_| rng.next()).collect();
        let settings = QpSettings {
            polish: false,
            ..QpSettings::default()
        };
        let sol = solve_nonneg_qp(&p, &q, &settings).unwrap();
        let (xb, _, _) = brute_force(&p, &q);
        assert!(!sol.polished);
        assert!(rel_err(&sol.x, &xb, inf_norm(&xb)) < 1e-6);
        // Interior point: complementarity is only approximate.
        assert!(sol.kkt_residual < 1e-6, "{}", sol.kkt_residual);
    }

    /// Random problems n = 2..8 against brute force, for several scalings of
    /// (P, q). Returns the worst kkt residual.
    fn random_against_brute_force(p_scale: f64, q_scale: f64, seed: u64, count: usize) -> f64 {
        let mut rng = Lcg(seed);
        let mut worst_kkt: f64 = 0.0;
        for n in 2..=8 {
            for trial in 0..count {
                let shift = if trial % 2 == 0 { 0.1 } else { 1.0 };
                let p = scaled(&random_spd(n, shift, &mut rng), p_scale);
                let q: Vec<f64> = (0..n).map(|_| q_scale * rng.next()).collect();
                let (xb, yb, viol) = brute_force(&p, &q);
                assert!(viol < 1e-12, "brute force found no solution ({viol:e})");
                let sol = solve(&p, &q);
                assert!(sol.polished, "n={n} trial={trial}: not polished");
                let ex = rel_err(&sol.x, &xb, inf_norm(&xb).max(f64::MIN_POSITIVE));
                let ey = rel_err(&sol.y, &yb, inf_norm(&q));
                assert!(ex < 1e-10, "n={n} trial={trial}: x rel err {ex:e}");
                assert!(ey < 1e-10, "n={n} trial={trial}: y rel err {ey:e}");
                for i in 0..n {
                    assert_eq!(sol.active[i], yb[i] > 0.0, "n={n} trial={trial} i={i}");
                }
                worst_kkt = worst_kkt.max(sol.kkt_residual);
            }
        }
        worst_kkt
    }

    #[test]
    fn random_small_against_brute_force() {
        let kkt = random_against_brute_force(1.0, 1.0, 2024, 10);
        assert!(kkt < 1e-12, "worst kkt residual {kkt:e}");
    }

    #[test]
    fn badly_scaled_stiffness() {
        // Stiffness-like: P ~ 1e11, q ~ 1e6, x ~ 1e-5.
        let kkt = random_against_brute_force(1e11, 1e6, 77, 4);
        assert!(kkt < 1e-12, "worst kkt residual {kkt:e}");
    }

    #[test]
    fn badly_scaled_compliance() {
        // Compliance-like: P ~ 1e-11, q ~ 1e-5, x ~ 1e6.
        let kkt = random_against_brute_force(1e-11, 1e-5, 78, 4);
        assert!(kkt < 1e-12, "worst kkt residual {kkt:e}");
    }

    #[test]
    fn badly_scaled_mixed() {
        // Extreme mismatch: P ~ 1e11, q ~ 1e-5 (x ~ 1e-16).
        let kkt = random_against_brute_force(1e11, 1e-5, 79, 2);
        assert!(kkt < 1e-12, "worst kkt residual {kkt:e}");
    }

    /// Contact-like dense SPD matrix: E (G + I) with G the inverse of the 1D
    /// Laplacian tridiag(-1, 2, -1), i.e. Gᵢⱼ = min(i,j)(n+1−max(i,j))/(n+1)
    /// (1-based). Condition number about 7e3 for n = 300.
    pub(crate) fn contact_like(n: usize, e: f64) -> SymMatrix {
        let mut p = SymMatrix::new(n);
        let h = (n + 1) as f64;
        for i in 0..n {
            for j in 0..n {
                let (a, b) = ((i.min(j) + 1) as f64, (i.max(j) + 1) as f64);
                let g = a * (h - b) / h;
                p.set(i, j, e * (g + if i == j { 1.0 } else { 0.0 }));
            }
        }
        p
    }

    /// A known strictly complementary solution with about half of the
    /// constraints active (alternating blocks of 10); returns (q, x*, y*).
    pub(crate) fn designed_rhs(p: &SymMatrix, xs: f64, ys: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = p.n();
        let mut x = vec![0.0; n];
        let mut y = vec![0.0; n];
        for i in 0..n {
            if (i / 10) % 2 == 1 {
                y[i] = ys * (1.2 + (0.07 * i as f64).cos());
            } else {
                x[i] = xs * (1.5 + (0.1 * i as f64).sin());
            }
        }
        let mut px = vec![0.0; n];
        p.matvec(&x, &mut px);
        let q = (0..n).map(|i| y[i] - px[i]).collect();
        (q, x, y)
    }

    #[test]
    fn contact_like_n300() {
        let n = 300;
        let stiff = contact_like(n, 2e11);
        let compliance = stiff.inverse_spd().unwrap();
        for (name, p, xs, ys) in [
            ("stiffness (P~1e11-1e13)", &stiff, 1e-4, 1e8),
            ("compliance (P~1e-12)", &compliance, 1e6, 1e-5),
        ] {
            let (q, xstar, ystar) = designed_rhs(p, xs, ys);
            let t = std::time::Instant::now();
            let sol = solve(p, &q);
            let dt = t.elapsed();
            println!(
                "n = {n} {name}: {:.3} s, {} clarabel iterations, polished = {}, kkt = {:.2e}",
                dt.as_secs_f64(),
                sol.iterations,
                sol.polished,
                sol.kkt_residual
            );
            assert!(sol.polished, "{name}: not polished");
            assert!(
                sol.kkt_residual < 1e-12,
                "{name}: kkt {:e}",
                sol.kkt_residual
            );
            let nact = sol.active.iter().filter(|&&a| a).count();
            assert_eq!(nact, 150, "{name}");
            for i in 0..n {
                assert_eq!(sol.active[i], ystar[i] > 0.0, "{name}: index {i}");
            }
            let ex = rel_err(&sol.x, &xstar, inf_norm(&xstar));
            let ey = rel_err(&sol.y, &ystar, inf_norm(&ystar));
            assert!(ex < 1e-10 && ey < 1e-10, "{name}: errors {ex:e} {ey:e}");
        }
    }
}
