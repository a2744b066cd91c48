//! Friction at the contact (docs/method.md §9): the law (`-nndd_friction`), and what it makes
//! of the interface.
//!
//! With friction the NNDD's interface unknown carries both components of the Dirichlet body's
//! Γc displacement at each of the m pairs, λ = (λ_n, λ_t) ∈ R^{2m} (normal rows first, then
//! tangential rows, τ_k = (n_y, −n_x) for the pair's contact direction n_k): the Dirichlet step
//! prescribes both, the contact step solves the frictional contact of the other body behind
//! them, and the Neumann steps and the update act on both parts. The law bounds each pair's
//! tangential nodal force: |T_t,k| ≤ g_k with g_k = g·s_k (Tresca, threshold g in Pa, s_k the
//! pair's share ∫_Γc φ_k of Γc) or g_k = μ·T_n,k (Coulomb, the nodal law, solved as Tresca
//! problems with the bound updated to a fixed point).

use crate::petsc::readers::{Bounds, SettingsError};
use crate::petsc::OptionsBlock;
use crate::problem::{pair_shares, BodyProblem};
use crate::qp::dense::SymMatrix;
use crate::qp::friction::{self as fqp, FrictionSets, FrictionSolution};
use crate::qp::{QpError, QpSettings};

/// The friction law on Γc (`-nndd_friction`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrictionLaw {
    /// No tangential force (the paper's problem): the interface is the m normal components.
    Frictionless,
    /// |t_t| ≤ g, a fixed threshold (Pa): a convex problem, a minimisation.
    Tresca { threshold: f64 },
    /// |t_t| ≤ μ |t_n|.
    Coulomb { coefficient: f64 },
}

impl FrictionLaw {
    /// Read, register (for `-help`) and validate `-nndd_friction`,
    /// `-nndd_friction_coefficient` and `-nndd_friction_threshold`.
    pub fn from_options(o: &mut OptionsBlock) -> Result<FrictionLaw, SettingsError> {
        #[derive(Clone, Copy)]
        enum Kind {
            None,
            Tresca,
            Coulomb,
        }
        let kind = o.choice(
            "-nndd_friction",
            "Friction at the contact: none (frictionless, the paper's), tresca (|t_t| <= g, -nndd_friction_threshold), coulomb (|t_t| <= mu |t_n|, -nndd_friction_coefficient)",
            &[
                ("none", Kind::None),
                ("tresca", Kind::Tresca),
                ("coulomb", Kind::Coulomb),
            ],
        )?;
        let (coefficient, mu_given) = o.real_in(
            "-nndd_friction_coefficient",
            "Coulomb friction coefficient mu >= 0 (with -nndd_friction coulomb)",
            0.0,
            Bounds::NON_NEGATIVE,
        )?;
        let (threshold, g_given) = o.real_in(
            "-nndd_friction_threshold",
            "Tresca friction threshold g >= 0, Pa (with -nndd_friction tresca)",
            0.0,
            Bounds::NON_NEGATIVE,
        )?;
        let law = match kind {
            Kind::None => FrictionLaw::Frictionless,
            Kind::Tresca => FrictionLaw::Tresca { threshold },
            Kind::Coulomb => FrictionLaw::Coulomb { coefficient },
        };
        law.validate(mu_given, g_given)?;
        Ok(law)
    }

    /// A coefficient given without `coulomb`, or a threshold without `tresca`, is a mistake
    /// (it would be ignored); so is a law without its parameter.
    fn validate(self, mu_given: bool, g_given: bool) -> Result<(), SettingsError> {
        let law = self.name();
        match self {
            FrictionLaw::Coulomb { .. } | FrictionLaw::Frictionless if g_given => Err(SettingsError::named(
                "-nndd_friction_threshold",
                format!("is the Tresca threshold, and the friction law is {law}; use -nndd_friction tresca with it, or -nndd_friction_coefficient for coulomb"),
            )),
            FrictionLaw::Tresca { .. } | FrictionLaw::Frictionless if mu_given => Err(SettingsError::named(
                "-nndd_friction_coefficient",
                format!("is the Coulomb coefficient, and the friction law is {law}; use -nndd_friction coulomb with it, or -nndd_friction_threshold for tresca"),
            )),
            FrictionLaw::Coulomb { .. } if !mu_given => Err(SettingsError::named(
                "-nndd_friction coulomb",
                "needs -nndd_friction_coefficient mu (a number >= 0)",
            )),
            FrictionLaw::Tresca { .. } if !g_given => Err(SettingsError::named(
                "-nndd_friction tresca",
                "needs -nndd_friction_threshold g (Pa, a number >= 0)",
            )),
            _ => Ok(()),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            FrictionLaw::Frictionless => "none",
            FrictionLaw::Tresca { .. } => "tresca",
            FrictionLaw::Coulomb { .. } => "coulomb",
        }
    }

    /// The law with its parameter, as a restart point records it (`None` frictionless).
    pub fn text(self) -> Option<String> {
        match self {
            FrictionLaw::Frictionless => None,
            FrictionLaw::Tresca { threshold } => Some(format!("tresca {threshold:e}")),
            FrictionLaw::Coulomb { coefficient } => Some(format!("coulomb {coefficient}")),
        }
    }

    /// Whether the interface carries the tangential components too.
    pub fn is_frictional(self) -> bool {
        self != FrictionLaw::Frictionless
    }

    /// The interface of a body under this law.
    pub fn interface(self) -> Interface {
        if self.is_frictional() {
            Interface::Frictional
        } else {
            Interface::Normal
        }
    }
}

/// The Coulomb fixed point's tolerance on the bounds g = μ T_n (relative,
/// [`crate::qp::friction::solve_coulomb`]).
const COULOMB_TOL: f64 = 1e-12;
/// The most Tresca solves of one Coulomb contact problem.
const COULOMB_MAX_OUTER: usize = 100;

/// A Coulomb fixed point that took all [`COULOMB_MAX_OUTER`] solves did not converge: an
/// error naming the coefficient (the fixed point contracts for small μ).
fn coulomb_converged(outer: usize) -> Result<(), crate::qp::QpError> {
    if outer < COULOMB_MAX_OUTER {
        return Ok(());
    }
    Err(crate::qp::QpError::NotConverged {
        status: format!("the Coulomb fixed point g = mu T_n (tolerance {COULOMB_TOL:.0e}) did not settle in {COULOMB_MAX_OUTER} Tresca solves; a smaller -nndd_friction_coefficient, or -nndd_friction tresca"),
        iterations: outer as u32,
    })
}

/// What the NNDD's interface vectors hold at the m Γc pairs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    /// The m normal components (frictionless).
    Normal,
    /// The m normal components, then the m tangential ones (friction).
    Frictional,
}

impl Interface {
    /// The number of pairs of an interface vector of length `len`.
    pub fn pairs(self, len: usize) -> usize {
        match self {
            Interface::Normal => len,
            Interface::Frictional => len / 2,
        }
    }

    /// The length of an interface vector on m pairs.
    pub fn len(self, m: usize) -> usize {
        match self {
            Interface::Normal => m,
            Interface::Frictional => 2 * m,
        }
    }
}

/// The law on Γc's pairs: what bounds each pair's tangential nodal force.
#[derive(Clone, Debug)]
pub struct Friction {
    pub law: FrictionLaw,
    /// Each pair's share ∫_Γc φ_k of Γc (m), which turns a threshold (Pa) into a nodal force.
    pub shares: Vec<f64>,
}

/// A frictional contact QP's answer ([`Friction::solve`]).
pub struct Solved {
    pub sol: FrictionSolution,
    /// Coulomb's Tresca solves (0 under Tresca).
    pub outer: usize,
    /// The nodal bounds g_k of the answer's tangential forces.
    pub bounds: Vec<f64>,
}

impl Friction {
    /// Solve min ½ zᵀP z + qᵀz + Σ g_k |z_t,k|, z_n ≥ 0 (P 2m × 2m) under this law: Tresca by
    /// the active-set method with stick and slip sets from `start` (the cold start of z = 0
    /// without one) in at most `steps` steps, Clarabel its fallback; Coulomb by the fixed
    /// point g = μ y_n from the bounds `g_start` (empty: 0), an error if it does not settle
    /// ([`crate::qp::friction`]).
    pub fn solve(
        &self,
        p: &SymMatrix,
        q: &[f64],
        start: Option<FrictionSets>,
        g_start: &[f64],
        steps: usize,
        settings: &QpSettings,
    ) -> Result<Solved, QpError> {
        let m = q.len() / 2;
        let start =
            start.unwrap_or_else(|| FrictionSets::cold_start(q, &self.bounds(&vec![0.0; m])));
        let (sol, outer) = match self.law {
            FrictionLaw::Coulomb { coefficient } => {
                let (sol, outer) = fqp::solve_coulomb(
                    p,
                    q,
                    coefficient,
                    g_start,
                    &start,
                    steps,
                    settings,
                    COULOMB_TOL,
                    COULOMB_MAX_OUTER,
                )?;
                coulomb_converged(outer)?;
                (sol, outer)
            }
            _ => (
                fqp::solve_tresca(p, q, &self.bounds(&[]), &start, steps, settings)?,
                0,
            ),
        };
        Ok(Solved {
            bounds: self.bounds(&sol.y[..m]),
            sol,
            outer,
        })
    }

    /// The law on the pairs of `problem`'s Γc (node to node), `None` when frictionless.
    pub fn on(law: FrictionLaw, problem: &BodyProblem) -> Option<Friction> {
        law.is_frictional().then(|| Friction {
            law,
            shares: pair_shares([problem, problem]),
        })
    }

    /// The nodal bounds g_k of the tangential forces for the normal nodal forces `normal`
    /// (≥ 0 in compression): g·s_k (Tresca), μ·max(T_n,k, 0) (Coulomb), 0 (frictionless).
    pub fn bounds(&self, normal: &[f64]) -> Vec<f64> {
        match self.law {
            FrictionLaw::Frictionless => vec![0.0; self.shares.len()],
            FrictionLaw::Tresca { threshold } => {
                self.shares.iter().map(|s| threshold * s).collect()
            }
            FrictionLaw::Coulomb { coefficient } => {
                normal.iter().map(|t| coefficient * t.max(0.0)).collect()
            }
        }
    }
}

/// A pair's state under friction (the output's `contact_state`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairState {
    /// Not in contact (a gap, no force).
    Separated,
    /// In contact, no relative tangential motion: |T_t| < g.
    Stick,
    /// In contact and sliding: |T_t| = g, opposing the slip.
    Slip,
}

impl PairState {
    /// The state as the output's number: 0 separated, 1 stick, 2 slip.
    pub fn code(self) -> f64 {
        match self {
            PairState::Separated => 0.0,
            PairState::Stick => 1.0,
            PairState::Slip => 2.0,
        }
    }
}

/// The tangential part of a frictional iterate, at the m pairs (known on every rank).
#[derive(Clone, Debug, Default)]
pub struct Tangential {
    /// u¹_t, body 1's tangential Γc displacement.
    pub trace1: Vec<f64>,
    /// u²_t, body 2's.
    pub trace2: Vec<f64>,
    /// T¹_t, T²_t: the tangential nodal forces on each body.
    pub forces: [Vec<f64>; 2],
    /// The nodal bounds g_k of the contact body's tangential forces.
    pub bounds: Vec<f64>,
    /// Stick (true) or slip, from the contact step.
    pub stick: Vec<bool>,
    /// λ_t, the tangential half of the loop's variable.
    pub interface: Vec<f64>,
}

impl Tangential {
    /// The slip w_t = u¹_t − u²_t at each pair.
    pub fn slip(&self) -> Vec<f64> {
        self.trace1
            .iter()
            .zip(&self.trace2)
            .map(|(a, b)| a - b)
            .collect()
    }

    /// Each pair's state, from the contact set `active` (normal) and the stick set.
    pub fn states(&self, active: &[bool]) -> Vec<PairState> {
        active
            .iter()
            .zip(&self.stick)
            .map(|(&a, &s)| match (a, s) {
                (false, _) => PairState::Separated,
                (true, true) => PairState::Stick,
                (true, false) => PairState::Slip,
            })
            .collect()
    }

    /// The worst violation of the friction law by the contact body's forces `t` (tangential
    /// part of body 2's, ≥ 0 normal convention) relative to the largest bound: |t| − g where
    /// positive, and on slipping pairs a force that does not oppose the slip.
    pub fn violation(&self, t: &[f64]) -> f64 {
        let scale = self
            .bounds
            .iter()
            .chain(t)
            .fold(0.0_f64, |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        let slip = self.slip();
        // A slip at round-off of the traces has no direction.
        let small = 1e-9
            * self
                .trace1
                .iter()
                .chain(&self.trace2)
                .fold(0.0_f64, |m, v| m.max(v.abs()));
        let mut worst = 0.0_f64;
        for k in 0..t.len() {
            worst = worst.max(t[k].abs() - self.bounds[k]);
            // Body 1 drags body 2 along the slip w_t = u¹_t − u²_t: t = g sign(w_t).
            if !self.stick[k] && slip[k].abs() > small {
                worst = worst.max((t[k] - self.bounds[k] * slip[k].signum()).abs());
            }
        }
        worst / scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coulomb_bounds_follow_the_normal_force_and_tresca_the_shares() {
        let shares = vec![0.5, 1.0, 0.5];
        let t = Friction {
            law: FrictionLaw::Tresca { threshold: 2.0 },
            shares: shares.clone(),
        };
        assert_eq!(t.bounds(&[9.0, 9.0, 9.0]), vec![1.0, 2.0, 1.0]);
        let c = Friction {
            law: FrictionLaw::Coulomb { coefficient: 0.3 },
            shares,
        };
        assert_eq!(c.bounds(&[10.0, -1.0, 0.0]), vec![3.0, 0.0, 0.0]);
    }
}
