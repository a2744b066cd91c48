//! Step 2 of an iteration: the Neumann problems (paper (15)–(16), docs/method.md §2 step 4),
//! homogeneous Dirichlet data on Γ_D^α and the interface loads ∓½R_p on the Γc normal dofs.
//!
//! Which bodies take it ([`NeumannBodies`], `-nndd_neumann_bodies`): both, as in the paper,
//! or the Dirichlet step's body alone with the load ∓R_p (θ auto's default where that body is
//! the stiffer), a Dirichlet–Neumann update
//! (docs/method.md §2, "Relaxation"): with the contact set fixed its operator is
//! D^D(S^D + PŜ^CPᵀ) = I + D^D PŜ^CPᵀ (D the Dirichlet body, C the contact body), whose
//! eigenvalues lie in [1, 1 + ‖D^D Ŝ^C‖], below 2 when the Dirichlet body is the stiffer one
//! in every mode; the paper's ½(D^D + D^C)(S^D + PŜ^CPᵀ) adds ½D^C S^D, which is large
//! wherever the two bodies' Schur complements are not proportional (a nearly incompressible
//! body against a compressible one: 45 iterations of θ auto on tests/convergence/roof.geo's
//! flat roof, 14 with the Dirichlet body alone).
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

/// Which bodies take the Neumann step (`-nndd_neumann_bodies`, resolved).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NeumannBodies {
    /// Both, each with ∓½R_p: the paper's NNDD (the default with a fixed θ).
    Both,
    /// The Dirichlet step's body alone, with ∓R_p (the default with θ auto).
    Dirichlet,
    /// The contact step's body alone, with ∓R_p: where the Dirichlet step's body is held only
    /// by contact and has no Neumann problem.
    Contact,
}

impl NeumannBodies {
    /// Whether body `alpha` takes the Neumann step, the Dirichlet step being on
    /// `dirichlet_body`.
    pub fn includes(self, alpha: usize, dirichlet_body: usize) -> bool {
        match self {
            NeumannBodies::Both => true,
            NeumannBodies::Dirichlet => alpha == dirichlet_body,
            NeumannBodies::Contact => alpha != dirichlet_body,
        }
    }

    /// The share of R_p each body that takes the step receives: ½ with both, else all.
    pub fn weight(self) -> f64 {
        match self {
            NeumannBodies::Both => 0.5,
            NeumannBodies::Dirichlet | NeumannBodies::Contact => 1.0,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            NeumannBodies::Both => "both",
            NeumannBodies::Dirichlet => "dirichlet",
            NeumannBodies::Contact => "contact",
        }
    }
}

/// The Neumann step of one body, as decided at setup (the same on every rank of its group).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NeumannStep {
    Condensed,
    Solve,
    /// None: the body is held only by contact, or `-nndd_neumann_bodies` leaves it out.
    Omitted,
}

impl NeumannStep {
    /// `Omitted` for a body that does not take the step (`bodies`, the Dirichlet step on
    /// `dirichlet_body`) or has no Neumann problem; else `Condensed` when the body has D^α and
    /// the choice allows it.
    pub fn new(
        body: &Body,
        choice: NeumannChoice,
        bodies: NeumannBodies,
        dirichlet_body: usize,
    ) -> NeumannStep {
        let takes_part = bodies.includes(body.alpha(), dirichlet_body);
        if body.problem.support == Support::Contact || !takes_part {
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

    /// Step 4 on body α: the normal Γc trace of w^α, K^α w^α = ∓ω R_p on Γc (homogeneous
    /// data; ω = `weight`, ½ when both bodies take the step). With `Condensed` it is known on
    /// the body's first rank only (zero elsewhere: the loop shares the first rank's).
    pub fn solve(self, body: &Body, residual: &[f64], weight: f64) -> Result<Vec<f64>, BodyError> {
        // Body 1 receives −ωR, body 2 +ωR (docs/method.md §2 step 4).
        let sign = if body.alpha() == 1 { -weight } else { weight };
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
