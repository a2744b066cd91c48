//! The condensed Tresca (and, by a fixed point, Coulomb) frictional contact problem on m node
//! pairs
//!
//! ```text
//!     minimise ½ zᵀ P z + qᵀ z + Σ_k g_k |z_{m+k}|   subject to z_k ≥ 0 (k < m),
//! ```
//!
//! z = [z_n; z_t] ∈ R²ᵐ (normal part, then tangential part), P dense SPD, g ≥ 0 the nodal
//! friction thresholds, y = P z + q the nodal contact forces. Its KKT conditions, per node k:
//!
//! ```text
//!     normal:      z_n ≥ 0,  y_n ≥ 0,  z_n y_n = 0;
//!     tangential:  |y_t| ≤ g,  and z_t = 0 (stick) or y_t = −g sign(z_t) (slip).
//! ```
//!
//! The solution is unique (P is positive definite). [`solve_active_set`] is the primal–dual
//! active-set method with stick/slip sets (Hüeber, Stadler & Wohlmuth 2008; a semismooth
//! Newton method on the complementarity functions y_n − max(0, y_n − c z_n) = 0 and
//! y_t − P_g(y_t − c z_t) = 0, P_g the projection onto [−g, g]): each step solves the problem
//! exactly on guessed sets, and certifies the point when it satisfies the KKT conditions to
//! round-off. [`solve_clarabel`] is Clarabel on the scaled conic form, polished by the
//! active-set method from the sets of its point; [`solve_tresca`] is the first with the second
//! as fallback, and [`solve_coulomb`] the fixed point g = μ y_n over Tresca problems.

use std::collections::HashSet;

use clarabel::algebra::CscMatrix;

use crate::qp::dense::SymMatrix;
use crate::qp::solution::{inf_norm, QpMethod, POLISH_EPS};
use crate::qp::solver::{run_clarabel, scaled_upper, QpError, QpSettings};

/// Active-set steps tried when polishing Clarabel's point from its sets.
const MAX_POLISH_STEPS: usize = 5;

/// The set update's c, relative to mean diag P: small, so that a slip of the wrong sign
/// (σ z_t < 0) goes to stick rather than to the opposite slip. With c = mean diag P the method
/// cycled from the cold start on half of the designed test problems; with c/mean diag P
/// between 1e-8 and 0.3 on none. (The normal sets do not depend on c, see [`step`].)
const UPDATE_C: f64 = 1e-2;

/// The tangential state of a node: stuck (z_t = 0) or slipping forward (z_t > 0, y_t = −g)
/// or backward (z_t < 0, y_t = g).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Slip {
    Stick,
    Forward,
    Backward,
}

impl Slip {
    /// The slip direction σ: +1 forward, −1 backward, 0 stuck.
    pub fn sign(self) -> f64 {
        match self {
            Slip::Stick => 0.0,
            Slip::Forward => 1.0,
            Slip::Backward => -1.0,
        }
    }
}

/// The guessed (or found) sets of the m nodes: in contact (z_n = 0 imposed) or not (y_n = 0),
/// and the tangential state.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FrictionSets {
    pub contact: Vec<bool>,
    pub slip: Vec<Slip>,
}

impl FrictionSets {
    /// The sets as flags: in contact (m), then sticking (m) — what the NNDD shares and
    /// restarts from.
    pub fn flags(&self) -> Vec<bool> {
        let mut v = self.contact.clone();
        v.extend(self.slip.iter().map(|s| *s == Slip::Stick));
        v
    }

    /// The sets of [`FrictionSets::flags`] (a slip's direction is found again by the method).
    pub fn from_flags(flags: &[bool]) -> Self {
        let m = flags.len() / 2;
        FrictionSets {
            contact: flags[..m].to_vec(),
            slip: flags[m..]
                .iter()
                .map(|&s| if s { Slip::Stick } else { Slip::Forward })
                .collect(),
        }
    }

    /// The sets of the point z = 0, y = q (the cold start when no earlier sets are known):
    /// contact where q_n > 0, stick where |q_t| ≤ g, else slip against q_t.
    pub fn cold_start(q: &[f64], g: &[f64]) -> Self {
        FrictionSets::from_point(&vec![0.0; q.len()], q, g, 1.0)
    }

    /// The sets of a point (z, y) by the complementarity functions, c > 0 making z and y
    /// comparable: contact iff y_n − c z_n > 0; with ξ = −y_t + c z_t, stick iff |ξ| ≤ g,
    /// else slip with σ = sign ξ.
    pub fn from_point(z: &[f64], y: &[f64], g: &[f64], c: f64) -> Self {
        let m = g.len();
        let contact = (0..m).map(|k| y[k] - c * z[k] > 0.0).collect();
        let slip = (0..m)
            .map(|k| {
                let xi = -y[m + k] + c * z[m + k];
                if xi.abs() <= g[k] {
                    Slip::Stick
                } else if xi > 0.0 {
                    Slip::Forward
                } else {
                    Slip::Backward
                }
            })
            .collect();
        FrictionSets { contact, slip }
    }
}

/// Solution of the Tresca problem, in the original units.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionSolution {
    /// [z_n; z_t]; when certified, z_n = 0 exactly on contact and z_t = 0 exactly on stick.
    pub z: Vec<f64>,
    /// y = P z + q; when certified, y_n = 0 exactly off contact and y_t = −g σ exactly on slip.
    pub y: Vec<f64>,
    /// The sets the certified point was solved on (for Clarabel's unpolished point, those of
    /// [`FrictionSets::from_point`]).
    pub sets: FrictionSets,
    /// Active-set steps, or Clarabel's iterations (`method`).
    pub iterations: u32,
    /// Relative KKT violation, see [`friction_kkt_residual`].
    pub kkt_residual: f64,
    pub method: QpMethod,
    /// Whether the point is certified by an exact solve on its sets.
    pub polished: bool,
}

/// Relative KKT violation of a candidate (z, y) of the Tresca problem, with Z = ‖z‖∞ and
/// Y = max(‖y‖∞, ‖q‖∞):
///
/// ```text
///   max over nodes of  −z_n / Z,  −y_n / Y,  |z_n y_n| / (Z Y),        normal
///                      (|y_t| − g) / Y,                                 friction bound
///                      |z_t| |y_t + g sign z_t| / (Z Y),                slip (z_t ≠ 0)
///   and ‖y − (P z + q)‖∞ / max(‖q‖∞, ‖P z‖∞)                            stationarity
/// ```
///
/// Each term is dimensionless; the slip term is weighted by |z_t| like the normal
/// complementarity, so that it is continuous in z (an interior point's z_t of 1e-12 on a stuck
/// node is not a full violation). A zero denominator counts as the smallest positive number.
/// A certified solution has a residual at round-off (≤ 1e-12).
pub fn friction_kkt_residual(p: &SymMatrix, q: &[f64], g: &[f64], z: &[f64], y: &[f64]) -> f64 {
    let mut pz = vec![0.0; q.len()];
    p.matvec(z, &mut pz);
    kkt_with(&pz, q, g, z, y)
}

/// [`friction_kkt_residual`] with the product `pz` = P z already made.
fn kkt_with(pz: &[f64], q: &[f64], g: &[f64], z: &[f64], y: &[f64]) -> f64 {
    let m = g.len();
    let tiny = f64::MIN_POSITIVE;
    let zs = inf_norm(z).max(tiny);
    let ys = inf_norm(y).max(inf_norm(q)).max(tiny);
    let mut r: f64 = 0.0;
    for k in 0..m {
        let (zn, yn, zt, yt) = (z[k] / zs, y[k] / ys, z[m + k] / zs, y[m + k] / ys);
        r = r.max(-zn).max(-yn).max((zn * yn).abs());
        r = r.max(yt.abs() - g[k] / ys);
        if zt != 0.0 {
            r = r.max(zt.abs() * (yt + g[k] / ys * zt.signum()).abs());
        }
    }
    let stat = (0..q.len())
        .map(|i| (y[i] - (pz[i] + q[i])).abs())
        .fold(0.0f64, f64::max)
        / inf_norm(q).max(inf_norm(pz)).max(tiny);
    r.max(stat)
}

/// The outcome of one step: the certified point (z, y, P z), or the sets of the next step.
enum Step {
    Certified {
        z: Vec<f64>,
        y: Vec<f64>,
        pz: Vec<f64>,
    },
    Next(FrictionSets),
}

/// z with z_n = 0 on contact, z_t = 0 on stick, y_n = 0 off contact and y_t = −g σ on slip:
/// P_FF z_F = −q_F + r_F on the free indices F; `None` when the Cholesky factorisation fails.
fn solve_on_sets(p: &SymMatrix, q: &[f64], g: &[f64], sets: &FrictionSets) -> Option<Vec<f64>> {
    let m = g.len();
    let free: Vec<usize> = (0..m)
        .filter(|&k| !sets.contact[k])
        .chain(
            (0..m)
                .filter(|&k| sets.slip[k] != Slip::Stick)
                .map(|k| m + k),
        )
        .collect();
    let mut z = vec![0.0; 2 * m];
    if free.is_empty() {
        return Some(z);
    }
    let mut zf: Vec<f64> = free
        .iter()
        .map(|&i| match i.checked_sub(m) {
            Some(k) => -q[i] - g[k] * sets.slip[k].sign(),
            None => -q[i],
        })
        .collect();
    let mut sub = p.submatrix(&free);
    sub.symmetrize();
    sub.cholesky().ok()?.solve_in_place(&mut zf);
    for (&i, v) in free.iter().zip(&zf) {
        z[i] = *v;
    }
    Some(z)
}

/// y = P z + q, and P z.
fn forces(p: &SymMatrix, q: &[f64], z: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut pz = vec![0.0; q.len()];
    p.matvec(z, &mut pz);
    let y = pz.iter().zip(q).map(|(a, b)| a + b).collect();
    (y, pz)
}

/// One step on `sets`: the exact point, and the KKT verdict on it (the tolerance of
/// [`POLISH_EPS`], relative to ‖z‖∞ and max(‖y‖∞, ‖q‖∞)); `None` when a factorisation fails.
fn step(p: &SymMatrix, q: &[f64], g: &[f64], c: f64, sets: &FrictionSets) -> Option<Step> {
    let m = g.len();
    let mut z = solve_on_sets(p, q, g, sets)?;
    let (y, _) = forces(p, q, &z);
    let ztol = POLISH_EPS * inf_norm(&z);
    let ytol = POLISH_EPS * inf_norm(&y).max(inf_norm(q));
    let holds = (0..m).all(|k| {
        let normal = if sets.contact[k] {
            y[k] >= -ytol
        } else {
            z[k] >= -ztol
        };
        let sigma = sets.slip[k].sign();
        let tangential = if sigma == 0.0 {
            y[m + k].abs() <= g[k] + ytol
        } else {
            sigma * z[m + k] >= -ztol
        };
        normal && tangential
    });
    if !holds {
        // The update from the imposed values (y_n = 0 off contact, y_t = −g σ on slip; z is
        // already 0 on the other indices), so that only c|z_t| against g depends on c.
        let mut y = y;
        for k in 0..m {
            if !sets.contact[k] {
                y[k] = 0.0;
            }
            if sets.slip[k] != Slip::Stick {
                y[m + k] = -g[k] * sets.slip[k].sign();
            }
        }
        return Some(Step::Next(FrictionSets::from_point(&z, &y, g, c)));
    }
    // Clamp round-off of the wrong sign, then y = P z + q with the clamped z, made exact on
    // the free indices and feasible on the others.
    for k in 0..m {
        if !sets.contact[k] {
            z[k] = z[k].max(0.0);
        }
        if sets.slip[k].sign() * z[m + k] < 0.0 {
            z[m + k] = 0.0;
        }
    }
    let (mut y, pz) = forces(p, q, &z);
    for k in 0..m {
        y[k] = if sets.contact[k] { y[k].max(0.0) } else { 0.0 };
        y[m + k] = match sets.slip[k] {
            Slip::Stick => y[m + k].clamp(-g[k], g[k]),
            s => -g[k] * s.sign(),
        };
    }
    Some(Step::Certified { z, y, pz })
}

/// Run the active-set method from the sets `start` for at most `max_steps` steps. Returns the
/// certified solution (`iterations` = the steps taken, `method` = [`QpMethod::ActiveSet`]), or
/// `None` when it did not certify one: mismatched dimensions, a factorisation failed, a set
/// came back (a cycle), or the steps ran out. The sets are updated by
/// [`FrictionSets::from_point`] with c = [`UPDATE_C`] · mean diag P.
pub fn solve_active_set(
    p: &SymMatrix,
    q: &[f64],
    g: &[f64],
    start: &FrictionSets,
    max_steps: usize,
) -> Option<FrictionSolution> {
    let m = g.len();
    if p.n() != 2 * m || q.len() != 2 * m || start.contact.len() != m || start.slip.len() != m {
        return None;
    }
    let c = UPDATE_C * p.diag_mean();
    let mut seen: HashSet<FrictionSets> = HashSet::new();
    let mut sets = start.clone();
    for k in 1..=max_steps {
        if !seen.insert(sets.clone()) {
            return None; // a cycle
        }
        match step(p, q, g, c, &sets)? {
            Step::Certified { z, y, pz } => {
                let kkt_residual = kkt_with(&pz, q, g, &z, &y);
                return Some(FrictionSolution {
                    z,
                    y,
                    sets,
                    iterations: k as u32,
                    kkt_residual,
                    method: QpMethod::ActiveSet,
                    polished: true,
                });
            }
            Step::Next(next) => sets = next,
        }
    }
    None
}

/// Check the dimensions (P 2m × 2m, q 2m, g m) and that the data are finite with g ≥ 0.
fn check_data(p: &SymMatrix, q: &[f64], g: &[f64]) -> Result<(), QpError> {
    if q.len() != p.n() {
        return Err(QpError::DimensionMismatch {
            matrix: p.n(),
            vector: q.len(),
        });
    }
    if q.len() != 2 * g.len() {
        return Err(QpError::InvalidData(format!(
            "q has length {} but g has length {} (expected half)",
            q.len(),
            g.len()
        )));
    }
    if q.iter().chain(g).chain(p.data()).any(|v| !v.is_finite()) {
        return Err(QpError::InvalidData("non-finite entry in P, q or g".into()));
    }
    if g.iter().any(|&v| v < 0.0) {
        return Err(QpError::InvalidData("negative friction threshold".into()));
    }
    Ok(())
}

/// Solve the Tresca problem by Clarabel on the scaled problem P̂ = P/d, q̂ = q/‖q‖∞,
/// ĝ = g/‖q‖∞ (d = mean diag P; z = ẑ ‖q‖∞/d, as in [`crate::qp::solver`]), then polish: the
/// active-set method from the sets of Clarabel's point ([`FrictionSets::from_point`] with
/// c = d, i.e. ŷ − ẑ in the scaled units) for a few steps. When that does not certify,
/// Clarabel's point is returned with `polished` false.
///
/// # Errors
/// [`QpError::DimensionMismatch`] / [`QpError::InvalidData`] for bad data (see
/// [`check_data`]), [`QpError::NotConverged`] or [`QpError::Setup`] from Clarabel.
pub fn solve_clarabel(
    p: &SymMatrix,
    q: &[f64],
    g: &[f64],
    settings: &QpSettings,
) -> Result<FrictionSolution, QpError> {
    check_data(p, q, g)?;
    let m = g.len();
    let qmax = inf_norm(q);
    if qmax == 0.0 {
        // z = 0, y = 0 is the (unique) solution: the objective is ≥ 0.
        return Ok(FrictionSolution {
            z: vec![0.0; 2 * m],
            y: vec![0.0; 2 * m],
            sets: FrictionSets::cold_start(q, g),
            iterations: 0,
            kkt_residual: 0.0,
            method: QpMethod::Clarabel,
            polished: true,
        });
    }
    let d = p.diag_mean();
    if !(d > 0.0 && d.is_finite()) {
        return Err(QpError::InvalidData(format!(
            "mean diagonal of P is {d:e}, expected > 0"
        )));
    }
    let (zh, iterations) = clarabel_tresca(p, q, g, d, qmax, settings)?;
    let z: Vec<f64> = zh[..2 * m].iter().map(|v| v * qmax / d).collect();
    let (y, pz) = forces(p, q, &z);
    let sets = FrictionSets::from_point(&z, &y, g, d);
    if settings.polish {
        if let Some(polished) = solve_active_set(p, q, g, &sets, MAX_POLISH_STEPS) {
            return Ok(FrictionSolution {
                iterations,
                method: QpMethod::Clarabel,
                ..polished
            });
        }
    }
    let kkt_residual = kkt_with(&pz, q, g, &z, &y);
    Ok(FrictionSolution {
        z,
        y,
        sets,
        iterations,
        kkt_residual,
        method: QpMethod::Clarabel,
        polished: false,
    })
}

/// Run Clarabel on the scaled problem in x = [z (2m); s (m)]: minimise ½ zᵀP̂z + q̂ᵀz + ĝᵀs
/// with A x + slack = 0, slack ≥ 0 for the rows −z_n, z_t − s, −z_t − s. Returns x̂ and the
/// iteration count.
fn clarabel_tresca(
    p: &SymMatrix,
    q: &[f64],
    g: &[f64],
    d: f64,
    qmax: f64,
    settings: &QpSettings,
) -> Result<(Vec<f64>, u32), QpError> {
    let m = g.len();
    let (n2, n3) = (2 * m, 3 * m);
    // The s columns of P̂ are empty.
    let ph = scaled_upper(p, d, n3);
    let c: Vec<f64> = q.iter().chain(g).map(|v| v / qmax).collect();
    // Columns of A: z_n,k → row k; z_t,k → rows m+k (+1), 2m+k (−1); s_k → both rows (−1).
    let mut colptr = vec![0];
    let (mut rowval, mut nzval) = (Vec::new(), Vec::new());
    for j in 0..n3 {
        let k = j % m;
        let entries: &[(usize, f64)] = match j / m {
            0 => &[(k, -1.0)],
            1 => &[(m + k, 1.0), (n2 + k, -1.0)],
            _ => &[(m + k, -1.0), (n2 + k, -1.0)],
        };
        for &(i, v) in entries {
            rowval.push(i);
            nzval.push(v);
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(n3, n3, colptr, rowval, nzval);
    run_clarabel(&ph, &c, &a, settings)
}

/// Solve the Tresca problem by the active-set method from `start` (at most `max_steps`
/// steps), falling back to [`solve_clarabel`] when it does not certify.
///
/// # Errors
/// Those of [`solve_clarabel`] (bad data is reported even when the active set would succeed).
pub fn solve_tresca(
    p: &SymMatrix,
    q: &[f64],
    g: &[f64],
    start: &FrictionSets,
    max_steps: usize,
    settings: &QpSettings,
) -> Result<FrictionSolution, QpError> {
    check_data(p, q, g)?;
    match solve_active_set(p, q, g, start, max_steps) {
        Some(sol) => Ok(sol),
        None => solve_clarabel(p, q, g, settings),
    }
}

/// Solve the Coulomb problem (g = μ y_n) by the fixed point over Tresca problems: `g_start`
/// first (empty: g = 0, the tangential part free; the NNDD's contact step passes its previous
/// step's bounds), then g = μ max(y_n, 0) of the last solution, each Tresca
/// problem by [`solve_tresca`] warm-started from the previous sets (the first from `start`),
/// until ‖g_new − g‖∞ ≤ tol · ‖g_new‖∞ (which includes g = 0 twice: no contact). Returns the
/// last Tresca solution (its threshold g is within that tolerance of μ y_n) and the number of
/// Tresca solves. The fixed point converges for small μ (the usual case); when it has not
/// converged after `max_outer` solves, the last solution is returned with the count
/// `max_outer`: a count below `max_outer` means converged, `max_outer` means the test may not
/// have been met (the caller decides).
///
/// # Errors
/// Those of [`solve_tresca`]; [`QpError::InvalidData`] for μ < 0, non-finite μ or
/// `max_outer` = 0.
#[allow(clippy::too_many_arguments)]
pub fn solve_coulomb(
    p: &SymMatrix,
    q: &[f64],
    mu: f64,
    g_start: &[f64],
    start: &FrictionSets,
    max_steps: usize,
    settings: &QpSettings,
    tol: f64,
    max_outer: usize,
) -> Result<(FrictionSolution, usize), QpError> {
    if !(mu >= 0.0 && mu.is_finite()) || max_outer == 0 {
        return Err(QpError::InvalidData(format!(
            "Coulomb: μ = {mu:e}, max_outer = {max_outer}"
        )));
    }
    let m = q.len() / 2;
    let mut g = if g_start.len() == m {
        g_start.to_vec()
    } else {
        vec![0.0; m]
    };
    let mut sets = start.clone();
    let mut outer = 0;
    loop {
        outer += 1;
        let sol = solve_tresca(p, q, &g, &sets, max_steps, settings)?;
        let g_new: Vec<f64> = sol.y[..m].iter().map(|&yn| mu * yn.max(0.0)).collect();
        let change = g_new
            .iter()
            .zip(&g)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f64, f64::max);
        if change <= tol * inf_norm(&g_new).max(f64::MIN_POSITIVE) || outer == max_outer {
            return Ok((sol, outer));
        }
        sets = sol.sets;
        g = g_new;
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::qp::solve_nonneg_qp;
    use crate::qp::solver::tests::contact_like;
    use crate::testutil::Lcg;

    /// [[A, C], [C, B]] with A = contact_like(m, e), B = A/2, C = 0.2 e I: SPD, since A ≥ e I
    /// and B − C A⁻¹ C ≥ 0.46 e I.
    fn block_operator(m: usize, e: f64) -> SymMatrix {
        let a = contact_like(m, e);
        let mut p = SymMatrix::new(2 * m);
        for i in 0..m {
            for j in 0..m {
                p.set(i, j, a.get(i, j));
                p.set(m + i, m + j, 0.5 * a.get(i, j));
            }
            p.set(i, m + i, 0.2 * e);
            p.set(m + i, i, 0.2 * e);
        }
        p
    }

    /// Bᵀ B + shift I with B uniform in [-1,1]ⁿˣⁿ.
    fn random_spd(n: usize, shift: f64, rng: &mut Lcg) -> SymMatrix {
        let b: Vec<f64> = (0..n * n).map(|_| rng.next()).collect();
        let mut p = SymMatrix::new(n);
        for i in 0..n {
            for j in 0..n {
                let s: f64 = (0..n).map(|k| b[k * n + i] * b[k * n + j]).sum();
                p.set(i, j, s + if i == j { shift } else { 0.0 });
            }
        }
        p
    }

    /// A known strictly complementary solution, node k in state (k + offset) % 4: separated and
    /// slipping, in contact and stuck, in contact and slipping, separated and stuck (z of size
    /// zs, y and g of size ys). Returns (q, g, z*, y*, sets*).
    fn designed(
        p: &SymMatrix,
        offset: usize,
        zs: f64,
        ys: f64,
        rng: &mut Lcg,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, FrictionSets) {
        let m = p.n() / 2;
        let (mut z, mut y, mut g) = (vec![0.0; 2 * m], vec![0.0; 2 * m], vec![0.0; m]);
        let mut sets = FrictionSets::cold_start(&y, &g);
        for k in 0..m {
            let state = (k + offset) % 4;
            g[k] = ys * (1.0 + 0.5 * rng.next());
            sets.contact[k] = state == 1 || state == 2;
            if sets.contact[k] {
                y[k] = ys * (1.0 + 0.5 * rng.next());
            } else {
                z[k] = zs * (1.0 + 0.5 * rng.next());
            }
            if state % 2 == 1 {
                y[m + k] = 0.8 * g[k] * rng.next();
                sets.slip[k] = Slip::Stick;
            } else {
                sets.slip[k] = if rng.next() > 0.0 {
                    Slip::Forward
                } else {
                    Slip::Backward
                };
                let sigma = sets.slip[k].sign();
                z[m + k] = sigma * zs * (1.0 + 0.5 * rng.next());
                y[m + k] = -g[k] * sigma;
            }
        }
        let mut pz = vec![0.0; 2 * m];
        p.matvec(&z, &mut pz);
        let q = (0..2 * m).map(|i| y[i] - pz[i]).collect();
        (q, g, z, y, sets)
    }

    fn rel_err(a: &[f64], b: &[f64]) -> f64 {
        let d = a
            .iter()
            .zip(b)
            .map(|(u, v)| (u - v).abs())
            .fold(0.0, f64::max);
        d / inf_norm(b).max(f64::MIN_POSITIVE)
    }

    /// Designed problems m = 1..40, stiffness-like (P ~ 1e11) and random SPD: the active set
    /// from the cold start and polished Clarabel both find the designed point and sets; all
    /// three node states occur.
    #[test]
    fn active_set_agrees_with_clarabel() {
        let mut rng = Lcg(31);
        let (mut worst_as, mut worst_cl, mut worst_diff) = (0.0f64, 0.0f64, 0.0f64);
        let (mut steps, mut failed, mut worst_raw) = (0, 0, 0.0f64);
        for trial in 0..24 {
            let m = 1 + (trial * 7) % 40;
            let (p, zs, ys) = if trial % 2 == 0 {
                (block_operator(m, 2e11), 1e-4, 1e8)
            } else {
                (random_spd(2 * m, 0.5, &mut rng), 1.0, 1.0)
            };
            let (q, g, zstar, ystar, sets) = designed(&p, trial, zs, ys, &mut rng);
            let start = FrictionSets::cold_start(&q, &g);
            let Some(a) = solve_active_set(&p, &q, &g, &start, 100) else {
                failed += 1;
                continue;
            };
            let unpolished = QpSettings {
                polish: false,
                ..QpSettings::default()
            };
            let raw = solve_clarabel(&p, &q, &g, &unpolished).unwrap();
            assert!(!raw.polished && raw.kkt_residual < 1e-6, "trial {trial}");
            worst_raw = worst_raw.max(rel_err(&raw.z, &zstar));
            let c = solve_clarabel(&p, &q, &g, &QpSettings::default()).unwrap();
            assert!(
                c.polished && c.method == QpMethod::Clarabel,
                "trial {trial}"
            );
            assert_eq!(a.sets, sets, "trial {trial}");
            assert_eq!(c.sets, sets, "trial {trial}");
            for s in [&a, &c] {
                assert!(rel_err(&s.z, &zstar) < 1e-10, "trial {trial}");
                assert!(rel_err(&s.y, &ystar) < 1e-10, "trial {trial}");
            }
            worst_diff = worst_diff.max(rel_err(&a.z, &c.z)).max(rel_err(&a.y, &c.y));
            assert!(rel_err(&a.z, &c.z) < 1e-8 && rel_err(&a.y, &c.y) < 1e-8);
            worst_as = worst_as.max(a.kkt_residual);
            worst_cl = worst_cl.max(c.kkt_residual);
            steps = steps.max(a.iterations);
            if m >= 4 {
                let contact = a.sets.contact.iter().filter(|&&b| b).count();
                let stick = a.sets.slip.iter().filter(|&&s| s == Slip::Stick).count();
                assert!(
                    0 < contact && contact < m && 0 < stick && stick < m,
                    "trial {trial}"
                );
            }
        }
        println!(
            "kkt: active set {worst_as:.2e}, clarabel {worst_cl:.2e}; \
             active set vs clarabel {worst_diff:.2e}; unpolished clarabel z {worst_raw:.2e}; \
             most steps {steps}; failed {failed}"
        );
        assert!(worst_as <= 1e-12 && worst_cl <= 1e-12 && worst_raw < 1e-6);
        assert_eq!(
            failed, 0,
            "the active set did not certify from the cold start"
        );
    }

    /// The solution's sets as the start certify in one step, with the same point.
    #[test]
    fn warm_start_certifies_in_one_step() {
        let mut rng = Lcg(5);
        let p = block_operator(40, 2e11);
        let (q, g, _, _, _) = designed(&p, 0, 1e-4, 1e8, &mut rng);
        let cold = solve_active_set(&p, &q, &g, &FrictionSets::cold_start(&q, &g), 100).unwrap();
        assert!(cold.iterations > 1);
        let warm = solve_active_set(&p, &q, &g, &cold.sets, 100).unwrap();
        assert_eq!(warm.iterations, 1);
        assert_eq!((&warm.z, &warm.y), (&cold.z, &cold.y));
        // Too few steps give no answer; solve_tresca then falls back to Clarabel.
        assert!(solve_active_set(&p, &q, &g, &FrictionSets::cold_start(&q, &g), 1).is_none());
        let start = FrictionSets::cold_start(&q, &g);
        let s = solve_tresca(&p, &q, &g, &start, 1, &QpSettings::default()).unwrap();
        assert_eq!((s.method, s.polished), (QpMethod::Clarabel, true));
        assert!(rel_err(&s.z, &cold.z) < 1e-10);
    }

    /// g = 0: the tangential part is free, and the answer is the frictionless problem's on the
    /// Schur complement S = P_nn − P_nt P_tt⁻¹ P_tn of P on the normal block, with
    /// q_S = q_n − P_nt P_tt⁻¹ q_t; made from D = P⁻¹ as S = D_nn⁻¹, q_S = S (D q)_n.
    #[test]
    fn zero_friction_is_the_frictionless_problem() {
        let mut rng = Lcg(11);
        let m = 30;
        let p = block_operator(m, 2e11);
        let q: Vec<f64> = (0..2 * m).map(|_| 1e7 * rng.next()).collect();
        let g = vec![0.0; m];
        let d = p.inverse_spd().unwrap();
        let s = d
            .submatrix(&(0..m).collect::<Vec<_>>())
            .inverse_spd()
            .unwrap();
        let (mut dq, mut qs) = (vec![0.0; 2 * m], vec![0.0; m]);
        d.matvec(&q, &mut dq);
        s.matvec(&dq[..m], &mut qs);
        let normal = solve_nonneg_qp(&s, &qs, &QpSettings::default()).unwrap();
        // y = [y_n; 0], z = D (y − q).
        let y: Vec<f64> = normal.y.iter().copied().chain(vec![0.0; m]).collect();
        let mut z = vec![0.0; 2 * m];
        d.matvec(
            &y.iter().zip(&q).map(|(a, b)| a - b).collect::<Vec<_>>(),
            &mut z,
        );
        assert!(rel_err(&z[..m], &normal.x) < 1e-10);
        let a = solve_active_set(&p, &q, &g, &FrictionSets::cold_start(&q, &g), 100).unwrap();
        let c = solve_clarabel(&p, &q, &g, &QpSettings::default()).unwrap();
        let contact = normal.active.iter().filter(|&&b| b).count();
        assert!(0 < contact && contact < m, "{contact} in contact");
        for s in [&a, &c] {
            assert!(s.polished && s.kkt_residual <= 1e-12, "{}", s.kkt_residual);
            assert!(rel_err(&s.z, &z) < 1e-10 && rel_err(&s.y, &y) < 1e-10);
            assert!(s.y[m..].iter().all(|&v| v == 0.0));
        }
    }

    /// g huge: every node sticks, and the answer is the problem with z_t fixed at 0.
    #[test]
    fn huge_friction_sticks() {
        let mut rng = Lcg(12);
        let m = 25;
        let p = random_spd(2 * m, 0.5, &mut rng);
        let q: Vec<f64> = (0..2 * m).map(|_| rng.next()).collect();
        let g = vec![1e6; m];
        let pnn = p.submatrix(&(0..m).collect::<Vec<_>>());
        let normal = solve_nonneg_qp(&pnn, &q[..m], &QpSettings::default()).unwrap();
        let z: Vec<f64> = normal.x.iter().copied().chain(vec![0.0; m]).collect();
        let mut y = vec![0.0; 2 * m];
        p.matvec(&z, &mut y);
        y.iter_mut().zip(&q).for_each(|(a, b)| *a += b);
        for s in [
            solve_active_set(&p, &q, &g, &FrictionSets::cold_start(&q, &g), 100).unwrap(),
            solve_clarabel(&p, &q, &g, &QpSettings::default()).unwrap(),
        ] {
            assert!(s.sets.slip.iter().all(|&t| t == Slip::Stick));
            assert!(s.z[m..].iter().all(|&v| v == 0.0));
            assert!(rel_err(&s.z, &z) < 1e-10 && rel_err(&s.y, &y) < 1e-10);
            assert!(s.polished && s.kkt_residual <= 1e-12);
        }
    }

    /// One node, P = diag(2, 4), g = 1, by hand: the three states.
    #[test]
    fn hand_one_node() {
        let p = SymMatrix::from_rows(2, vec![2.0, 0.0, 0.0, 4.0]);
        let g = [1.0];
        // q_n = −2: z_n = 1 (separated); q_t = −3: slip, z_t = (3 − 1)/4, y_t = −g.
        // q_n = 2: contact, y_n = 2; q_t = −0.5: stick, y_t = −0.5.
        for (q, z, y, contact, slip) in [
            ([-2.0, -3.0], [1.0, 0.5], [0.0, -1.0], false, Slip::Forward),
            ([2.0, -0.5], [0.0, 0.0], [2.0, -0.5], true, Slip::Stick),
            ([-2.0, 5.0], [1.0, -1.0], [0.0, 1.0], false, Slip::Backward),
        ] {
            let s = solve_active_set(&p, &q, &g, &FrictionSets::cold_start(&q, &g), 10).unwrap();
            assert!(rel_err(&s.z, &z) < 1e-15 && s.y == y, "{:?} {:?}", s.z, s.y);
            assert_eq!((s.sets.contact[0], s.sets.slip[0]), (contact, slip));
            assert!(s.kkt_residual < 1e-15);
            let c = solve_clarabel(&p, &q, &g, &QpSettings::default()).unwrap();
            assert_eq!((c.z, c.y), (s.z, s.y));
        }
    }

    /// Coulomb by the fixed point: |y_t| ≤ μ y_n, with equality where slipping.
    #[test]
    fn coulomb_fixed_point() {
        let mut rng = Lcg(21);
        let m = 30;
        let p = block_operator(m, 2e11);
        let q: Vec<f64> = (0..2 * m)
            .map(|i| 1e7 * (rng.next() + if i < m { 0.3 } else { 0.0 }))
            .collect();
        let (mu, settings) = (0.3, QpSettings::default());
        let start = FrictionSets::cold_start(&q, &[0.0; 30]);
        let (s, outer) = solve_coulomb(&p, &q, mu, &[], &start, 100, &settings, 1e-13, 50).unwrap();
        println!(
            "coulomb: {outer} fixed-point iterations, kkt {:.2e}",
            s.kkt_residual
        );
        assert!(1 < outer && outer < 50, "{outer}");
        assert!(s.polished && s.kkt_residual <= 1e-12);
        let scale = inf_norm(&s.y);
        let (mut stick, mut slip) = (0, 0);
        for k in 0..m {
            let bound = mu * s.y[k];
            assert!(s.y[m + k].abs() <= bound + 1e-10 * scale, "node {k}");
            match s.sets.slip[k] {
                _ if s.y[k] == 0.0 => {}
                Slip::Stick => stick += 1,
                _ => {
                    slip += 1;
                    assert!(
                        (s.y[m + k].abs() - bound).abs() <= 1e-10 * scale,
                        "node {k}"
                    );
                }
            }
        }
        println!("coulomb: {stick} stuck, {slip} slipping of {m}");
        assert!(stick > 0 && slip > 0, "stick {stick}, slip {slip}");
    }

    #[test]
    fn bad_data_is_an_error() {
        let p = SymMatrix::from_rows(2, vec![2.0, 0.0, 0.0, 4.0]);
        let settings = QpSettings::default();
        let r = solve_clarabel(&p, &[1.0], &[1.0], &settings);
        assert!(matches!(r, Err(QpError::DimensionMismatch { .. })));
        let r = solve_clarabel(&p, &[1.0, 1.0], &[-1.0], &settings);
        assert!(matches!(r, Err(QpError::InvalidData(_))));
        let start = FrictionSets::cold_start(&[1.0, 1.0], &[1.0]);
        assert!(solve_active_set(&p, &[1.0, 1.0, 1.0], &[1.0], &start, 10).is_none());
    }
}
