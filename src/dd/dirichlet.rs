//! The Dirichlet step (paper (8)–(10) on Ω¹, docs/method.md §2 step 1): on the body of
//! `-nndd_dirichlet_body` (body 1 in the paper, written ¹ below), u¹ = u_D on Γ_D¹,
//! u¹_n = λ_p on Γc (tangential Γc dofs free), and its reaction T¹_p = K u¹ − f¹ on the Γc
//! normal dofs. The same step on body 2 puts u²_n = λ_p and gives T²_p.
//!
//! Two exact ways, the same discrete solution:
//! - `System`: a KSP solve with the Dirichlet system (Γc normal dofs eliminated);
//! - `Condensed`: static condensation with the interface Schur complement S¹ of the Neumann
//!   system (from its one factorisation, [`crate::dd::body::Condensed`]): with u¹₀ the solution
//!   with free Γc and v¹* = B u¹₀, the Γc force that puts the interface at λ_p is
//!   T¹_p = S¹(λ_p − v¹*), an m × m product on the body's first rank, and
//!   u¹_p = u¹₀ + K⁻¹BᵀT¹_p (one back-solve, only when the field is wanted). This saves the
//!   second factorisation and a back-solve per iteration.

use crate::dd::body::{Body, BodyError};
use crate::dd::displacement::Displacement;

/// How the Dirichlet step is solved (`-nndd_dirichlet_step`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirichletChoice {
    /// Condensed when the body has its interface operators (a MUMPS factorisation, on any
    /// rank count, or SuperLU_DIST), else the Dirichlet system.
    Auto,
    System,
    Condensed,
}

pub enum DirichletStep {
    System,
    /// v¹* = B u¹₀ (u¹₀ itself is not held: u¹_p is one solve with the data and T¹_p).
    Condensed {
        v_star: Vec<f64>,
    },
}

/// What an iteration wants of its Dirichlet step: T¹_p alone, or u¹_p as well (an iteration
/// to be estimated, whose fields are formed at once).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wanted {
    Forces,
    ForcesAndField,
}

impl DirichletStep {
    /// Condensed when body 1 has its interface operators and `choice` is not `System`, else
    /// the Dirichlet system (which must exist). Collective over the body's group.
    pub fn new(body: &Body, choice: DirichletChoice) -> Result<DirichletStep, BodyError> {
        if body.has_condensed() && choice != DirichletChoice::System {
            let v_star = body.neumann_trace(&vec![0.0; body.pairs()], true)?;
            Ok(DirichletStep::Condensed { v_star })
        } else {
            assert!(
                body.has_dirichlet_system(),
                "the Dirichlet step's body needs its S or its Dirichlet system"
            );
            Ok(DirichletStep::System)
        }
    }

    pub fn name(&self) -> &'static str {
        Self::name_of(self.is_system())
    }

    /// The name of a step solved with its own system (`system`) or condensed (`condensed`).
    pub fn name_of(system: bool) -> &'static str {
        if system {
            "system"
        } else {
            "condensed"
        }
    }

    pub fn is_system(&self) -> bool {
        matches!(self, DirichletStep::System)
    }

    /// T¹_p for the interface position λ_p, and u¹_p from the same solve when `wanted` and
    /// the step solves its system (else the field is formed after the loop where it is wanted,
    /// [`Self::field`]: an iteration that is not estimated gathers no whole vector). Condensed,
    /// T¹_p is known on the body's first rank only (zero elsewhere: the loop shares the first
    /// rank's).
    pub fn solve(
        &self,
        body: &Body,
        lambda: &[f64],
        wanted: Wanted,
    ) -> Result<(Option<Displacement>, Vec<f64>), BodyError> {
        match self {
            DirichletStep::System => match wanted {
                Wanted::ForcesAndField => {
                    let (u, t) = body.dirichlet_solve(lambda)?;
                    Ok((Some(u), t))
                }
                Wanted::Forces => Ok((None, body.dirichlet_reaction(lambda)?)),
            },
            DirichletStep::Condensed { v_star, .. } => {
                let mut t = vec![0.0; lambda.len()];
                if let Some(c) = body.condensed() {
                    let d: Vec<f64> = lambda.iter().zip(v_star).map(|(l, v)| l - v).collect();
                    c.schur.matvec(&d, &mut t);
                }
                Ok((None, t))
            }
        }
    }

    /// u¹_p from its reaction T¹_p (condensed) or by a solve (system).
    pub fn field(
        &self,
        body: &Body,
        lambda: &[f64],
        forces: &[f64],
    ) -> Result<Displacement, BodyError> {
        match self {
            DirichletStep::System => Ok(body.dirichlet_solve(lambda)?.0),
            DirichletStep::Condensed { .. } => {
                // u¹₀ + K⁻¹BᵀT¹_p: the Neumann solve with the body's data and T¹_p.
                let mut u = body.neumann_field(forces, true)?;
                for (k, &l) in lambda.iter().enumerate() {
                    // equal to round-off; make the prescribed trace exact
                    body.set_trace(&mut u, k, l);
                }
                Ok(u)
            }
        }
    }
}
