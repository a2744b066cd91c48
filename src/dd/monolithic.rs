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
//!
//! A body held only by contact ([`Support::Contact`]) has no D^α: its Neumann system is
//! singular. Its energy as a function of its normal Γc trace v is ½vᵀS^αv + c^αᵀv with the
//! Schur complement S^α (singular: the free rigid motion costs nothing) and c^α its Γc reaction
//! at v = 0, both from its Dirichlet system ([`condensed_by_dirichlet`]); a body held by its
//! conditions has S^α, and c^α = −S^α v^α*. With the gaps z = v² − v¹ + g₀ ≥ 0 and v¹ free,
//! minimising over v¹ (M = S¹ + S², SPD) leaves the QP
//!   minimise ½ zᵀH z + (h − H g₀)ᵀz  subject to  z ≥ 0,
//! H = S² − S²M⁻¹S², h = c² − S²M⁻¹(c¹ + c²), whose multiplier is the contact force
//! μ = T² = S²v² + c² ≥ 0 and v¹ = −M⁻¹(c¹ + c² + S²(z − g₀)) ([`held_by_contact`]).

use crate::dd::body::{Body, BodyError};
use crate::dd::displacement::Displacement;
use crate::dd::friction::{Friction, Solved};
use crate::parallel::layout::Layout;
use crate::problem::Support;
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
    pub u: [Displacement; 2],
    /// Contact forces μ on the Γc pairs (known on every rank).
    pub forces: Vec<f64>,
    pub active: Vec<bool>,
    pub qp_iterations: u32,
    pub kkt_residual: f64,
    /// With friction: the nodal bounds g_k of the tangential forces (m; empty without).
    pub bounds: Vec<f64>,
}

/// The gap QP's answer: z, its multiplier y, the flags (in contact, then with friction
/// sticking), iterations and KKT residual.
struct GapAnswer {
    z: Vec<f64>,
    y: Vec<f64>,
    flags: Vec<bool>,
    iterations: u32,
    kkt: f64,
    bounds: Vec<f64>,
}

/// Solve min ½ zᵀH z + qᵀz (+ Σ g_k |z_t,k| with friction) subject to z_n ≥ 0, the QP of the
/// gaps z (2m rows with friction: the normal gaps, then the tangential relative displacements
/// u²_t − u¹_t), by Clarabel polished (frictionless) or the frictional active-set method with
/// Clarabel as its fallback (Tresca, and Coulomb's fixed point g = μ y_n).
fn gap_qp(
    h: &SymMatrix,
    q: &[f64],
    friction: Option<&Friction>,
    qp: &QpSettings,
) -> Result<GapAnswer, QpError> {
    let Some(f) = friction else {
        let sol = solve_nonneg_qp(h, q, qp)?;
        return Ok(GapAnswer {
            flags: sol.active,
            z: sol.x,
            y: sol.y,
            iterations: sol.iterations,
            kkt: sol.kkt_residual,
            bounds: Vec::new(),
        });
    };
    let Solved { sol, bounds, .. } = f.solve(h, q, None, &[], MAX_STEPS, qp)?;
    Ok(GapAnswer {
        flags: sol.sets.flags(),
        bounds,
        z: sol.z,
        y: sol.y,
        iterations: sol.iterations,
        kkt: sol.kkt_residual,
    })
}

/// The active-set steps of the monolithic frictional QP before Clarabel.
const MAX_STEPS: usize = 100;

pub fn solve(
    layout: &Layout,
    bodies: [Option<&Body>; 2],
    qp: &QpSettings,
    friction: Option<&Friction>,
) -> Result<MonolithicResult, MonolithicError> {
    // Whether each body is held only by contact, from its root to every rank.
    let mut held = [0.0; 2];
    for (k, body) in bodies.iter().enumerate() {
        if let Some(b) = body {
            held[k] = f64::from(u8::from(b.problem.support == Support::Contact));
        }
        layout.share(k + 1, &mut held[k..k + 1]);
    }
    if held.iter().any(|&h| h > 0.5) {
        return held_by_contact(layout, bodies, qp, friction);
    }
    // Each body: u₀ (own data, free Γc), v* = B u₀, D = S⁻¹; shared with rank 0.
    let mut v_star = [Vec::new(), Vec::new()];
    // g₀ is part of the geometry every rank holds.
    let gap = interface_gaps(bodies, friction.is_some());
    let mut delassus = [Vec::new(), Vec::new()];
    for (k, body) in bodies.iter().enumerate() {
        if let Some(b) = body {
            // (u₀ held as the body keeps its fields: Γc's among the nodes)
            let u0 = b.neumann_field(&vec![0.0; b.pairs()], true)?;
            v_star[k] = b.trace(&u0);
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
    let mut bounds = vec![0.0; m - friction.map_or(m, |_| m / 2)];
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
        if friction.is_some() {
            // The primal form in the gaps z = z* + Dμ, z* = g₀ + v²* − v¹*: H = D⁻¹,
            // q = −H z*, and the multiplier y = H(z − z*) is μ.
            let h = d.inverse_spd().map_err(QpError::from)?;
            let mut hq = vec![0.0; m];
            h.matvec(&q, &mut hq);
            hq.iter_mut().for_each(|x| *x = -*x);
            let a = gap_qp(&h, &hq, friction, qp)?;
            mu = a.y;
            act = a.flags.iter().map(|&f| f as u8 as f64).collect();
            stats = [a.iterations as f64, a.kkt];
            bounds = a.bounds;
        } else {
            let sol = solve_nonneg_qp(&d, &q, qp)?;
            mu = sol.x;
            // The QP's bound μ_i ≥ 0 is active where the pair is *open*: contact is the
            // complement.
            act = sol.active.iter().map(|&open| !open as u8 as f64).collect();
            stats = [sol.iterations as f64, sol.kkt_residual];
        }
    }
    // Rank 0 is body 1's root: broadcast from there.
    layout.share(1, &mut mu);
    layout.share(1, &mut act);
    layout.share(1, &mut stats);
    layout.share(1, &mut bounds);
    let mut u: [Displacement; 2] = Default::default();
    for (k, body) in bodies.iter().enumerate() {
        if let Some(b) = body {
            let sign = if k == 0 { -1.0 } else { 1.0 };
            let load: Vec<f64> = mu.iter().map(|x| sign * x).collect();
            // u₀ plus the response to the contact forces, in one solve with both loads
            u[k] = b.neumann_field(&load, true)?;
        }
    }
    Ok(MonolithicResult {
        u,
        forces: mu,
        active: act.iter().map(|&a| a > 0.5).collect(),
        qp_iterations: stats[0] as u32,
        kkt_residual: stats[1],
        bounds,
    })
}

/// The initial gaps g₀ of the interface rows (0 on the tangential rows of a frictional
/// interface), on every rank (part of the geometry every rank holds).
fn interface_gaps(bodies: [Option<&Body>; 2], frictional: bool) -> Vec<f64> {
    let mut gap = bodies
        .iter()
        .flatten()
        .next()
        .map(|b| b.problem.gap.clone())
        .unwrap_or_default();
    if frictional {
        gap.resize(2 * gap.len(), 0.0);
    }
    gap
}

/// Body α's Γc energy ½vᵀSv + cᵀv as (S row-major, c), shared with every rank: S, c from its
/// Dirichlet system (c the reaction at v = 0, S's columns the reactions to unit v less c: m
/// solves) for a body held only by contact, else S from its interface operators and
/// c = −S v* (v* the normal trace of its solution with Γc free).
fn condensed_by_dirichlet(
    layout: &Layout,
    body: Option<&Body>,
    alpha: usize,
    m: usize,
) -> Result<(Vec<f64>, Vec<f64>), BodyError> {
    let (mut s, mut c) = (Vec::new(), Vec::new());
    if let Some(b) = body {
        if b.problem.support == Support::Contact {
            let c0 = b.dirichlet_reaction(&vec![0.0; m])?;
            s = vec![0.0; m * m];
            let mut e = vec![0.0; m];
            for j in 0..m {
                e[j] = 1.0;
                let t = b.dirichlet_reaction(&e)?;
                e[j] = 0.0;
                for i in 0..m {
                    // Symmetric: column j is row j.
                    s[j * m + i] = t[i] - c0[i];
                }
            }
            c = c0;
        } else {
            let u0 = b.neumann_field(&vec![0.0; m], true)?;
            let v_star = b.trace(&u0);
            if let Some(cond) = b.condensed() {
                s = cond.schur.data().to_vec();
                c = vec![0.0; m];
                cond.schur.matvec(&v_star, &mut c);
                c.iter_mut().for_each(|x| *x = -*x);
            }
        }
    }
    layout.share_vec(alpha, &mut s);
    layout.share_vec(alpha, &mut c);
    Ok((s, c))
}

fn matvec(a: &[f64], x: &[f64]) -> Vec<f64> {
    let m = x.len();
    (0..m)
        .map(|i| (0..m).map(|j| a[i * m + j] * x[j]).sum())
        .collect()
}

/// The monolithic solve with a body held only by contact (module docs): both bodies' Γc
/// energies, the QP in the gaps on world rank 0, then each body's field (a Dirichlet solve at
/// its trace for the body held by contact, u₀ plus a back-solve with its Γc forces for the
/// other).
fn held_by_contact(
    layout: &Layout,
    bodies: [Option<&Body>; 2],
    qp: &QpSettings,
    friction: Option<&Friction>,
) -> Result<MonolithicResult, MonolithicError> {
    let mut gap = interface_gaps(bodies, friction.is_some());
    layout.share_vec(1, &mut gap);
    let m = gap.len();
    let pairs = m - friction.map_or(0, |_| m / 2);
    let (s1, c1) = condensed_by_dirichlet(layout, bodies[0], 1, m)?;
    let (s2, c2) = condensed_by_dirichlet(layout, bodies[1], 2, m)?;
    // v¹, v², μ, contact set, QP statistics: found on rank 0, shared.
    let mut out = vec![0.0; 4 * m + 2 + (m - pairs)];
    if layout.is_root() {
        let sum: Vec<f64> = s1.iter().zip(&s2).map(|(a, b)| a + b).collect();
        let m_inv = SymMatrix::from_rows(m, sum)
            .inverse_spd()
            .map_err(QpError::from)?;
        // S²M⁻¹ (row-major), H = S² − S²M⁻¹S², h = c² − S²M⁻¹(c¹ + c²).
        let mut s2_minv = vec![0.0; m * m];
        for i in 0..m {
            for j in 0..m {
                s2_minv[i * m + j] = (0..m).map(|k| s2[i * m + k] * m_inv.get(k, j)).sum();
            }
        }
        let mut h_mat = SymMatrix::new(m);
        for i in 0..m {
            for j in 0..m {
                let x: f64 = (0..m).map(|k| s2_minv[i * m + k] * s2[k * m + j]).sum();
                h_mat.set(i, j, s2[i * m + j] - x);
            }
        }
        h_mat.symmetrize();
        let c12: Vec<f64> = c1.iter().zip(&c2).map(|(a, b)| a + b).collect();
        let hg = {
            let mut y = vec![0.0; m];
            h_mat.matvec(&gap, &mut y);
            y
        };
        let q: Vec<f64> = matvec(&s2_minv, &c12)
            .iter()
            .enumerate()
            .map(|(i, x)| c2[i] - x - hg[i])
            .collect();
        let sol = gap_qp(&h_mat, &q, friction, qp)?;
        let w: Vec<f64> = sol.z.iter().zip(&gap).map(|(z, g)| z - g).collect();
        let rhs: Vec<f64> = matvec(&s2, &w)
            .iter()
            .zip(&c12)
            .map(|(a, b)| a + b)
            .collect();
        let mut v1 = vec![0.0; m];
        m_inv.matvec(&rhs, &mut v1);
        v1.iter_mut().for_each(|x| *x = -*x);
        for i in 0..m {
            out[i] = v1[i];
            out[m + i] = v1[i] + w[i];
            out[2 * m + i] = sol.y[i];
            // The bound z_i ≥ 0 is active where the pair is in contact.
            out[3 * m + i] = f64::from(u8::from(sol.flags[i]));
        }
        out[4 * m] = sol.iterations as f64;
        out[4 * m + 1] = sol.kkt;
        out[4 * m + 2..].copy_from_slice(&sol.bounds);
    }
    layout.share(1, &mut out);
    let mut u: [Displacement; 2] = Default::default();
    for (k, body) in bodies.iter().enumerate() {
        let Some(b) = body else { continue };
        let trace = &out[k * m..(k + 1) * m];
        u[k] = if b.problem.support == Support::Contact {
            b.dirichlet_solve(trace)?.0
        } else {
            let sign = if k == 0 { -1.0 } else { 1.0 };
            let load: Vec<f64> = out[2 * m..3 * m].iter().map(|x| sign * x).collect();
            b.neumann_field(&load, true)?
        };
    }
    Ok(MonolithicResult {
        u,
        forces: out[2 * m..3 * m].to_vec(),
        active: out[3 * m..4 * m].iter().map(|&a| a > 0.5).collect(),
        qp_iterations: out[4 * m] as u32,
        kkt_residual: out[4 * m + 1],
        bounds: out[4 * m + 2..].to_vec(),
    })
}
