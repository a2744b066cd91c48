//! The final check of a reported solution, NNDD or monolithic: its fields, formed by solves
//! with the iterate's Γc forces, must be in the discrete equilibrium of each body with those
//! forces, the two bodies' Γc forces must balance, and body 2's Γc trace must satisfy the
//! contact conditions against body 1's (no penetration, no tension, complementarity). What the iteration computed by condensed
//! algebra (S^α, D^α, the contact QP) is thus checked against the bodies' own systems.

use crate::dd::body::{Body, BodyError};
use crate::dd::iterate::Iterate;
use crate::parallel::layout::Layout;
use crate::problem::BodyProblem;

/// The largest equilibrium residual (a normwise backward error) of the final fields accepted.
pub const EQUILIBRIUM_LIMIT: f64 = 1e-9;
/// The largest penetration, tension and complementarity product of the final fields accepted,
/// relative to the displacements' and the Γc forces' scales.
pub const CONTACT_LIMIT: f64 = 1e-8;

/// The a-posteriori check of a reported iterate (its fields formed by solves, not by the
/// iteration's condensed algebra), before it is called converged or solved.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct SolutionCheck {
    /// Each body's discrete equilibrium with its Γc forces ([`Body::equilibrium_residual`]).
    pub equilibrium: [f64; 2],
    /// The interface force balance ‖T¹ + T²‖ / max(‖T¹‖, ‖T²‖) (each body in equilibrium with
    /// its own forces says nothing of whether the two forces are equal and opposite).
    pub balance: f64,
    /// The largest penetration of body 2 into body 1's Γc trace, max(0, λ − g₀ − u²_n),
    /// over the largest |λ|, |u²_n|, |g₀|.
    pub penetration: f64,
    /// The largest tensile Γc force, max(0, −T²) (−T¹ for T² when body 1 takes the contact
    /// step), over the largest |T²|.
    pub tension: f64,
    /// The largest |T²_k| · gap_k over the largest |T²| times the displacement scale.
    pub complementarity: f64,
    /// With friction: the largest violation of the friction law by the contact forces
    /// ([`crate::dd::friction::Tangential::violation`]), 0 without.
    pub friction: f64,
}

impl SolutionCheck {
    /// The first failed check, as a phrase (`None`: all hold); the force balance is checked
    /// against `balance_limit` where given (a converged or a monolithic solution; an iterate
    /// stopped early by the balanced rule is not balanced by design).
    pub fn failure(&self, balance_limit: Option<f64>) -> Option<String> {
        for (k, r) in self.equilibrium.iter().enumerate() {
            if r.is_nan() || *r > EQUILIBRIUM_LIMIT {
                return Some(format!(
                    "body {b}'s equilibrium residual {r:.1e} > {EQUILIBRIUM_LIMIT:.0e} (its solves: -body{b}_ksp_rtol, -body{b}_pc_type)",
                    b = k + 1
                ));
            }
        }
        if let Some(limit) = balance_limit {
            let b = self.balance;
            if b.is_nan() || b > limit {
                return Some(format!(
                    "the bodies' contact forces do not balance: |T1 + T2|/max(|T1|, |T2|) = {b:.1e} > {limit:.0e}"
                ));
            }
        }
        for (name, v) in [
            ("penetration", self.penetration),
            ("tensile contact force", self.tension),
            ("complementarity product", self.complementarity),
            ("violation of the friction law", self.friction),
        ] {
            if v.is_nan() || v > CONTACT_LIMIT {
                return Some(format!("relative {name} {v:.1e} > {CONTACT_LIMIT:.0e}"));
            }
        }
        None
    }
}

/// The interface force balance ‖R‖ / max(‖T¹‖, ‖T²‖), R = T¹ + T² (0 where both vanish),
/// with `active` the contact set. Where no pair is in contact the bodies are apart: the
/// contact body exerts no force, R is the Dirichlet body's own Γc force, which tends to 0 with
/// the change in λ, and its ratio to itself is 1 whatever the iterate; the balance is then 0
/// (nothing to balance: a run whose bodies do not touch converges on the change in λ alone).
pub fn force_balance(r: &[f64], forces: &[Vec<f64>; 2], active: &[bool]) -> f64 {
    if !active.iter().any(|&a| a) {
        return 0.0;
    }
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let scale = norm(&forces[0]).max(norm(&forces[1]));
    let r = norm(r);
    if scale > 0.0 {
        r / scale
    } else {
        r
    }
}

/// Check the reported iterate `it` (fields formed): each body's equilibrium on its ranks, and
/// the contact conditions with the contact step's forces ([`Iterate::contact_forces`]) on the
/// ranks of its body; shared with every rank (collective).
pub fn check_solution(
    layout: &Layout,
    it: &Iterate,
    bodies: [Option<&Body>; 2],
) -> Result<SolutionCheck, BodyError> {
    let mut check = SolutionCheck::default();
    let mut r = [[0.0], [0.0]];
    let forces = [it.interface_forces(0), it.interface_forces(1)];
    for (k, b) in bodies.iter().enumerate() {
        if let Some(b) = b {
            r[k][0] = b.equilibrium_residual(&it.u[k], &forces[k])?;
        }
    }
    layout.share(1, &mut r[0]);
    layout.share(2, &mut r[1]);
    check.equilibrium = [r[0][0], r[1][0]];
    // Every rank holds both bodies' Γc forces.
    let r: Vec<f64> = forces[0]
        .iter()
        .zip(&forces[1])
        .map(|(a, b)| a + b)
        .collect();
    check.balance = force_balance(&r, &forces, &it.active);
    if let Some(t) = &it.tangential {
        check.friction = t.violation(&it.tangential_contact_forces());
    }
    if let Some(b) = bodies[it.contact_body - 1] {
        let gap0 = &b.problem.gap;
        let inf = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let u_scale = inf(&it.lambda).max(inf(&it.trace2)).max(inf(gap0));
        let t = it.contact_forces();
        let t_scale = inf(&t);
        let rel = |v: f64, s: f64| if s > 0.0 { v / s } else { v };
        for k in 0..it.lambda.len() {
            let gap = it.trace2[k] - (it.lambda[k] - gap0[k]);
            check.penetration = check.penetration.max(rel((-gap).max(0.0), u_scale));
            check.tension = check.tension.max(rel((-t[k]).max(0.0), t_scale));
            check.complementarity = check
                .complementarity
                .max(rel((t[k] * gap).abs(), t_scale * u_scale));
        }
    }
    // The contact figures from the contact body's root (each body shared its equilibrium).
    let mut contact = [check.penetration, check.tension, check.complementarity];
    layout.share(it.contact_body, &mut contact);
    [check.penetration, check.tension, check.complementarity] = contact;
    Ok(check)
}

/// The largest angle between the two bodies' boundaries beyond an end of Γc for which contact
/// may go on past that end: they leave it side by side (a flat block under a cylinder, a
/// rounded punch on its foundation), not apart (flush sides, a sharp punch's corner).
pub const SIDE_BY_SIDE_DEGREES: f64 = 30.0;

/// The unit direction in which body `p`'s boundary leaves Γc at the end pair `end` (0 or
/// m − 1): along its boundary edge at its Γc node there that is not a Γc edge (`None` without
/// one).
fn continuation(p: &BodyProblem, end: usize) -> Option<[f64; 2]> {
    // (its first or last Γc node: the pair's own node to node, under mortar body 2's extreme
    // node there)
    let nodes = &p.contact_nodes;
    let last = nodes.len().checked_sub(1)?;
    let (node, inner) = match end {
        0 => (nodes[0], nodes.get(1)),
        _ => (nodes[last], last.checked_sub(1).map(|i| &nodes[i])),
    };
    let other = (p.outline().edges.iter())
        .filter_map(|&[a, b]| match (a == node, b == node) {
            (true, _) => Some(b),
            (_, true) => Some(a),
            _ => None,
        })
        .find(|o| Some(o) != inner)?;
    let (a, b) = (p.boundary_point(node), p.boundary_point(other));
    let d = [b[0] - a[0], b[1] - a[1]];
    let l = d[0].hypot(d[1]);
    (l > 0.0).then(|| [d[0] / l, d[1] / l])
}

/// The warning of a contact zone that reaches an end of Γc where the bodies go on side by side
/// (so that the contact may extend beyond the named contact curves, unconstrained there), with
/// where; `None` otherwise. Every rank finds the same (Γc data and both bodies' outlines are
/// everywhere).
pub fn zone_reaches_open_end(problems: [&BodyProblem; 2], it: &Iterate) -> Option<String> {
    // (a closed Γc has no end: its pairs run from a cut that the constraints span)
    let closed = problems.iter().any(|p| match &p.trace {
        crate::problem::GcTrace::Mortar(c) => c.closing.is_some(),
        crate::problem::GcTrace::Nodes => false,
    });
    if closed {
        return None;
    }
    let m = it.active.len();
    let side_by_side = SIDE_BY_SIDE_DEGREES.to_radians().cos();
    let ends = if m > 1 { vec![0, m - 1] } else { vec![0] };
    ends.into_iter().find_map(|end| {
        let (d1, d2) = (continuation(problems[0], end)?, continuation(problems[1], end)?);
        let open = d1[0] * d2[0] + d1[1] * d2[1] > side_by_side;
        (it.active[end] && open).then(|| {
            let ps = problems[crate::problem::pair_side(problems)];
            let p = ps.boundary_point(ps.contact_nodes[end]);
            format!(
                "the contact zone reaches the end of the contact curves at ({:.6e}, {:.6e}), where the bodies go on side by side: contact may extend beyond it, where nothing keeps them apart (extend the contact curves, -nndd_contact)",
                p[0], p[1]
            )
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_solution_check_names_its_first_failure() {
        let ok = SolutionCheck {
            equilibrium: [2e-16, 1e-15],
            balance: 1e-12,
            penetration: 1e-14,
            tension: 0.0,
            complementarity: 3e-15,
            friction: 1e-15,
        };
        assert_eq!(ok.failure(Some(1e-8)), None);
        let slipping = SolutionCheck {
            friction: 2e-6,
            ..ok
        };
        assert_eq!(
            slipping.failure(None).unwrap(),
            "relative violation of the friction law 2.0e-6 > 1e-8"
        );
        let bad = SolutionCheck {
            equilibrium: [2e-16, 2e-2],
            ..ok
        };
        assert!(bad
            .failure(None)
            .unwrap()
            .starts_with("body 2's equilibrium residual 2.0e-2"));
        let nan = SolutionCheck {
            equilibrium: [f64::NAN, 0.0],
            ..ok
        };
        assert!(nan.failure(None).unwrap().starts_with("body 1's"));
        let through = SolutionCheck {
            penetration: 1e-6,
            ..ok
        };
        assert!(through
            .failure(None)
            .unwrap()
            .contains("penetration 1.0e-6"));
        let unbalanced = SolutionCheck {
            balance: 3e-4,
            ..ok
        };
        assert_eq!(unbalanced.failure(None), None);
        assert!(unbalanced
            .failure(Some(1e-8))
            .unwrap()
            .contains("do not balance: |T1 + T2|/max(|T1|, |T2|) = 3.0e-4 > 1e-8"));
    }
}
