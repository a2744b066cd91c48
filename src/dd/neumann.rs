//! Step 2 of an iteration: the two Neumann problems (paper (15)–(16), docs/method.md §2 step 4),
//! homogeneous Dirichlet data on Γ_D^α and the interface loads ∓½R_p on the Γc normal dofs.
//!
//! The update needs only the normal Γc trace of each solution, w^α_n = B K^α⁻¹ Bᵀ(∓½R_p) =
//! D^α(∓½R_p) with the body's Delassus operator D^α ([`crate::dd::body::Condensed`]): an m × m
//! product on the body's first rank (`Condensed`), exactly the back-solve's trace. Without the
//! interface operators (a body whose Dirichlet step is its own system, `-nndd_neumann_step
//! solve`) it is a KSP back-solve on the body's ranks (`Solve`). A body held only by contact
//! ([`crate::problem::Support::Contact`]) has no Neumann problem to solve: ∓½R would move it
//! as a rigid body. It takes none (`Omitted`, w = 0), and the update is the other body's
//! correction alone, a Dirichlet–Neumann iteration (docs/method.md §2, "A body held only by
//! contact").

use crate::dd::body::{Body, BodyError};
use crate::problem::Support;

/// How the Neumann steps are solved (`-nndd_neumann_step`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NeumannChoice {
    /// Condensed where the body has its interface operators, else back-solves.
    Auto,
    Condensed,
    Solve,
}

/// The Neumann step of one body, as decided at setup (the same on every rank of its group).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NeumannStep {
    Condensed,
    Solve,
    /// None: the body is held only by contact.
    Omitted,
}

impl NeumannStep {
    /// `Condensed` when the body has D^α and the choice allows it.
    pub fn new(body: &Body, choice: NeumannChoice) -> NeumannStep {
        if body.problem.support == Support::Contact {
            NeumannStep::Omitted
        } else if body.has_condensed() && choice != NeumannChoice::Solve {
            NeumannStep::Condensed
        } else {
            NeumannStep::Solve
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            NeumannStep::Condensed => "condensed",
            NeumannStep::Solve => "solve",
            NeumannStep::Omitted => "none",
        }
    }

    /// Step 4 on body α: the normal Γc trace of w^α, K^α w^α = ∓½ R_p on Γc (homogeneous
    /// data). With `Condensed` it is known on the body's first rank only (zero elsewhere: the
    /// loop shares the first rank's).
    pub fn solve(self, body: &Body, residual: &[f64]) -> Result<Vec<f64>, BodyError> {
        // Body 1 receives −½R, body 2 +½R (docs/method.md §2 step 4).
        let sign = if body.alpha() == 1 { -0.5 } else { 0.5 };
        let load: Vec<f64> = residual.iter().map(|r| sign * r).collect();
        match self {
            NeumannStep::Condensed => {
                let mut w = vec![0.0; load.len()];
                if let Some(c) = body.condensed() {
                    c.delassus.matvec(&load, &mut w);
                }
                Ok(w)
            }
            NeumannStep::Solve => body.neumann_trace(&load, false),
            NeumannStep::Omitted => Ok(vec![0.0; load.len()]),
        }
    }
}
