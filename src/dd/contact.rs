//! The contact step on Ω² (paper (11)–(14), docs/method.md §2 step 2), condensed on Γc.
//!
//! With S the interface Schur complement of body 2's Neumann system on the Γc normal dofs and
//! v* = B u₀ the normal trace of the unconstrained solution u₀ (K u₀ = f, u₀ = u_D on Γ_D),
//! body 2's potential energy as a function of its Γc normal displacements v is
//! ½ (v − v*)ᵀ S (v − v*) + const. The contact step is
//!   minimise ½ (v − v*)ᵀ S (v − v*)  subject to  v ≥ λ_p − g₀
//! (g₀ the initial gap of each Γc pair, 0 on the benchmarks), a small dense QP. With the
//! obstacle o = λ_p − g₀ and z = v − o ≥ 0 it reads min ½ zᵀS z + zᵀS(o − v*), z ≥ 0; its
//! multiplier μ = S(v − v*) ≥ 0 is exactly the Γc nodal force T² on body 2, and the body's
//! field is u² = u₀ + K⁻¹Bᵀμ (one back-solve, [`ContactStep::field`]). The iteration itself
//! needs only T² and the contact set, so the field is formed only where it is used (the
//! reported iterate, the estimates).
//!
//! Clarabel solves the QP (an interior-point method, nonnegative cone, no penalty), and its
//! point is polished to round-off by an exact solve on its contact set. The contact set
//! settles after a few NNDD iterations; with the warm start (`-nndd_qp_warm_start`, default
//! on) the previous contact set is tried first and accepted only when the KKT conditions
//! certify it optimal, which makes later contact steps O(m²) instead of an interior-point
//! solve. The history records Clarabel's iterations per step (0: certified warm start).

use crate::dd::body::{Body, BodyError};
use crate::qp::dense::SymMatrix;
use crate::qp::{solve_nonneg_qp, solve_with_active_set, QpError, QpSettings};

#[derive(Debug, thiserror::Error)]
pub enum ContactError {
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error("contact QP: {0}")]
    Qp(#[from] QpError),
    #[error("body {0} has no interface Schur complement")]
    NoSchur(usize),
}

/// The result of one contact step.
pub struct ContactSolution {
    /// T²_p = K u² − f² on the Γc normal dofs (≥ 0, compression).
    pub forces: Vec<f64>,
    /// Nodes in contact (v = λ_p).
    pub active: Vec<bool>,
    /// The gaps v − (λ_p − g₀) ≥ 0 (0 on the contact set).
    pub gaps: Vec<f64>,
    /// Clarabel's iterations (0 when the previous contact set was certified optimal).
    pub qp_iterations: u32,
    pub kkt_residual: f64,
}

/// The condensed contact problem of body 2 (set up once).
pub struct ContactStep {
    u0: Vec<f64>,
    v_star: Vec<f64>,
    qp: QpSettings,
    /// Try the previous contact set first (certified by the KKT conditions, else Clarabel).
    warm_start: bool,
    previous: std::cell::RefCell<Option<Vec<bool>>>,
}

impl ContactStep {
    pub fn new(body: &Body, qp: QpSettings, warm_start: bool) -> Result<ContactStep, ContactError> {
        if body.schur.is_none() {
            return Err(ContactError::NoSchur(body.alpha()));
        }
        let u0 = body.neumann_solve(&vec![0.0; body.gc.len()], true)?;
        let v_star = body.normal_trace(&u0);
        Ok(ContactStep {
            u0,
            v_star,
            qp,
            warm_start,
            previous: Default::default(),
        })
    }

    /// Body 2's displacement u² = u₀ + K⁻¹Bᵀ T² for the Γc forces `forces` of a contact step
    /// at the interface position `lambda`. On the contact set the QP gives u²_n = λ − g₀
    /// exactly; the back-solve reproduces it to round-off only, so the trace is set there (else the
    /// contact terms of the estimates, |t̂| ≈ 1e7 times a round-off gap, would not vanish).
    pub fn field(
        &self,
        body: &Body,
        forces: &[f64],
        lambda: &[f64],
        active: &[bool],
    ) -> Result<Vec<f64>, ContactError> {
        let w = body.neumann_solve(forces, false)?;
        let mut u: Vec<f64> = self.u0.iter().zip(&w).map(|(a, b)| a + b).collect();
        let obstacle = body.problem.obstacle(lambda);
        for (i, &o) in obstacle.iter().enumerate() {
            if active[i] {
                body.problem.set_normal_trace(&mut u, i, o);
            }
        }
        Ok(u)
    }

    /// The unconstrained solution u₀ and its normal trace v*.
    pub fn free_solution(&self) -> (&[f64], &[f64]) {
        (&self.u0, &self.v_star)
    }

    /// The contact set the next [`Self::solve`] tries first (a restart's last one).
    pub fn set_warm_start(&self, active: Vec<bool>) {
        *self.previous.borrow_mut() = Some(active);
    }

    /// Solve the contact step for the interface position λ_p (obstacle λ_p − g₀).
    pub fn solve(&self, body: &Body, lambda: &[f64]) -> Result<ContactSolution, ContactError> {
        let s: &SymMatrix = body
            .schur
            .as_ref()
            .ok_or(ContactError::NoSchur(body.alpha()))?;
        let m = lambda.len();
        let diff: Vec<f64> = body
            .problem
            .obstacle(lambda)
            .iter()
            .zip(&self.v_star)
            .map(|(l, v)| l - v)
            .collect();
        let mut q = vec![0.0; m];
        s.matvec(&diff, &mut q);
        let warm = match (self.warm_start, self.previous.borrow().as_deref()) {
            (true, Some(guess)) => solve_with_active_set(s, &q, guess),
            _ => None,
        };
        let sol = match warm {
            Some(sol) => sol,
            None => solve_nonneg_qp(s, &q, &self.qp)?,
        };
        *self.previous.borrow_mut() = Some(sol.active.clone());
        Ok(ContactSolution {
            forces: sol.y,
            active: sol.active,
            gaps: sol.x,
            qp_iterations: sol.iterations,
            kkt_residual: sol.kkt_residual,
        })
    }
}
