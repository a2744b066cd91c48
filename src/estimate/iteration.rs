//! What an estimate of iteration p reads: the iteration's Γc data ([`IterationData`]) and each
//! body's fields ([`BodyFields`]): u^α_p and the Neumann re-solves with the Γc data of η^glo,
//! η^NNDD and η^FE ([`body_fields`]), cut to the rank's view of the body for its recoveries.

use super::equilibrate::Recovery;
use super::error::EstimateError;
use super::friction::FrictionData;
use super::parts::{Part, Parts};
use super::polygon::{EdgeValues, SegmentGap};
use super::settings::NnddVariant;
use super::traction::Interface;
use crate::dd::body::{Body, FieldAt, GcForces, Solved};
use crate::dd::displacement::Displacement;
use crate::problem::BodyProblem;

/// What the estimates of iteration p need beyond the bodies: λ_p, the Γc densities t̂^c (for
/// η^glo, η^NNDD) and t̂^c_p (for η^FE), and T¹_p.
pub struct IterationData<'a> {
    pub lambda: &'a [f64],
    pub t_glo: &'a [f64],
    /// η^glo's traction on body 1, t̂¹ = s(t)m(t) per segment ([`crate::estimate::polygon::factors`]): the
    /// factors s, the edge values and the consistent nodal forces (x, y).
    pub glo_factors: &'a [[f64; 2]],
    pub glo_edges: &'a [EdgeValues],
    pub glo_forces: &'a [[f64; 2]],
    /// The iterate's gap along each segment ([`crate::estimate::polygon::segment_gaps`]; empty with `fe_only`).
    pub gaps: &'a [SegmentGap],
    pub t_fe: &'a [f64],
    pub reaction1: Reaction<'a>,
    /// Nodal contact forces μ̂ ≥ 0 on body 2 (for the discrete η^NNDD).
    pub mu_hat: &'a [f64],
    /// With friction: the tangential halves of the above ([`FrictionData`]).
    pub friction: Option<&'a FrictionData>,
    pub nndd_variant: NnddVariant,
    pub recovery: Recovery,
    /// η^FE alone (the balanced rule's first check): no η^glo re-solve and recovery, no
    /// η^NNDD; `glo` and `nndd` stay zero.
    pub fe_only: bool,
}

/// Body 1's Γc forces T¹_p and what its η^FE recovery does with them.
#[derive(Clone, Copy)]
pub enum Reaction<'a> {
    /// The NNDD's own iterate: T¹_p is u¹_p's reaction, and σ(u¹_p) is equilibrated with its
    /// density M_Γ⁻¹T¹_p.
    Own(&'a [f64]),
    /// A mortar iterate carried to the matched meshes of its estimates: its reaction there is
    /// the FE traction of each element at the inserted nodes plus the mortar forces at the
    /// non-mortar nodes (a density that spikes at those), so body 1 is re-solved with the
    /// forces T¹_p of its smooth density, as body 2 is with −t̂^c_p, and the re-solve is
    /// equilibrated.
    Resolved(&'a [f64]),
}

/// The fields of one body's estimate: u^α_p and the Neumann re-solves with the Γc data of
/// η^glo (ũ^α), of the discrete η^NNDD (ũ^α_d) and, for body 2, of η^FE, at what the rank's
/// view of the body reads ([`body_fields`]; where the body's elements are estimated outside
/// its group, gathered from the group's blocks, `Estimator::fields_from_blocks`; empty when
/// not needed: `fe_only`, the density variant, body 1's η^FE).
#[derive(Default)]
pub struct BodyFields<'a> {
    /// u^α_p where this rank's recoveries and contact terms read it: the caller's iterate's
    /// where that is whole, else gathered at the rank's overlap of the body and Γc
    /// ([`Body::displacement_at`]).
    pub u_p: std::borrow::Cow<'a, Displacement>,
    pub u_tilde: Vec<f64>,
    pub u_d: Vec<f64>,
    pub u_fe: Vec<f64>,
}

/// The re-solves of body α (collective over its group), held on their owners until
/// [`body_fields`] gathers them: ũ^α (η^glo's), ũ^α_d (the discrete η^NNDD's), ũ^α_FE (η^FE's),
/// those the estimate needs, in that order.
pub fn body_resolves(
    body: &Body,
    iface: &Interface,
    data: &IterationData,
    parts: &Parts,
) -> Result<Solved, EstimateError> {
    let alpha = body.problem.alpha;
    let sign = if alpha == 1 { 1.0 } else { -1.0 };
    // One multiple-right-hand-side solve for all of them.
    parts.run(Part::Resolves, || {
        let mut loads = Vec::with_capacity(3);
        if !data.fe_only {
            let f: Vec<[f64; 2]> = data
                .glo_forces
                .iter()
                .map(|v| [sign * v[0], sign * v[1]])
                .collect();
            loads.push(GcForces::Vector(f));
            if data.nndd_variant == NnddVariant::Discrete {
                let normal: Vec<f64> = data.mu_hat.iter().map(|m| -sign * m).collect();
                loads.push(match data.friction {
                    None => GcForces::Normal(normal),
                    Some(f) => {
                        let tangential: Vec<f64> = f.mu_t.iter().map(|m| -sign * m).collect();
                        along(&body.problem, &normal, &tangential, f.tau)
                    }
                });
            }
        }
        if alpha == 2 {
            let t2: Vec<f64> = data.t_fe.iter().map(|t| -t).collect();
            loads.push(match data.friction {
                None => GcForces::Normal(iface.forces(&t2)),
                Some(f) => {
                    let t2t: Vec<f64> = f.fe_t.iter().map(|t| -t).collect();
                    along(
                        &body.problem,
                        &iface.forces(&t2),
                        &iface.forces(&t2t),
                        f.tau,
                    )
                }
            });
        } else if let Some(t1) = resolved_reaction1(data, alpha) {
            loads.push(GcForces::Normal(t1.to_vec()));
        }
        Ok(body.neumann_solve_many(&loads)?)
    })
}

/// Body 1's Γc forces where its η^FE data are re-solved with them (a mortar iterate's).
fn resolved_reaction1<'d>(data: &IterationData<'d>, alpha: usize) -> Option<&'d [f64]> {
    match data.reaction1 {
        Reaction::Resolved(t1) if alpha == 1 => Some(t1),
        _ => None,
    }
}

/// Body α's re-solves ([`body_resolves`]) gathered on this rank at `at`, and u^α_p (`u_p`)
/// where it is not whole (collective over its group).
pub fn body_fields<'a>(
    body: &Body,
    solved: Solved,
    u_p: &'a Displacement,
    data: &IterationData,
    parts: &Parts,
    at: FieldAt,
) -> Result<BodyFields<'a>, EstimateError> {
    let alpha = body.problem.alpha;
    let mut f = BodyFields::default();
    parts.run(Part::Resolves, || {
        f.u_p = match u_p.as_whole() {
            Some(_) => std::borrow::Cow::Borrowed(u_p),
            None => std::borrow::Cow::Owned(body.displacement_at(u_p, at)?),
        };
        let mut solved = body.fields_at(solved, at)?.into_iter();
        if !data.fe_only {
            f.u_tilde = solved.next().expect("ũ");
            if data.nndd_variant == NnddVariant::Discrete {
                f.u_d = solved.next().expect("ũ_d");
            }
        }
        if alpha == 2 || resolved_reaction1(data, alpha).is_some() {
            f.u_fe = solved.next().expect("ũ_FE");
        }
        Ok::<_, EstimateError>(())
    })?;
    Ok(f)
}

/// The Γc loads (x, y) of nodal forces `normal` along the pairs' normals and `tangential`
/// along the tangent `tau` (friction, a straight Γc).
fn along(p: &BodyProblem, normal: &[f64], tangential: &[f64], tau: [f64; 2]) -> GcForces {
    GcForces::Vector(
        normal
            .iter()
            .zip(tangential)
            .zip(&p.contact_normals)
            .map(|((a, b), n)| [a * n[0] + b * tau[0], a * n[1] + b * tau[1]])
            .collect(),
    )
}
