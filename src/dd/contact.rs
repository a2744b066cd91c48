//! The contact step (paper (11)–(14) on Ω², docs/method.md §2 step 2), condensed on Γc, on
//! the body that does not take the Dirichlet step. Written below for body 2; on body 1
//! (`-nndd_dirichlet_body 2`) the obstacle is on the other side, u¹_n ≤ λ_p + g₀, and the same
//! QP is solved in the variable −v (its multiplier is then −T¹ ≥ 0).
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
//! The QP is solved by the primal–dual active-set method of [`crate::qp::active_set`]
//! (`-nndd_qp_solver active_set`, the default), started from the previous contact step's
//! contact set (`-nndd_qp_warm_start`; the first step starts from the unconstrained solution's):
//! each of its steps is one dense solve on the smaller of the free set (with S²) and the
//! contact set (with D² = (S²)⁻¹, made once per run with S²), and it ends when the KKT
//! conditions certify its point, to round-off. Once the contact set has settled that is one
//! step. Should it not certify within `-nndd_qp_max_it` steps (or cycle), Clarabel (an
//! interior-point method, nonnegative cone, no penalty) solves the QP and its point is polished
//! to round-off by exact solves on its contact set; `-nndd_qp_solver clarabel` uses Clarabel
//! at every step (after the certified previous contact set, with the warm start). The history
//! records, per step, which method gave the answer and its iterations.

use crate::dd::body::{Body, BodyError};
use crate::dd::displacement::Displacement;
use crate::dd::friction::{Friction, Solved};
use crate::petsc::readers::{Bounds, SettingsError};
use crate::petsc::OptionsBlock;
use crate::qp::active_set::{self, ActiveSet, Operator};
use crate::qp::friction::FrictionSets;
use crate::qp::{solve_nonneg_qp, QpError, QpMethod, QpSettings};

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
    /// T^α_p = K u^α − f^α on the Γc normal dofs (T² ≥ 0, T¹ ≤ 0 in compression).
    pub forces: Vec<f64>,
    /// Nodes in contact (v = λ_p); with friction then the sticking pairs (v_t = λ_t).
    pub active: Vec<bool>,
    /// The sign conditions of the solution, each ≥ 0 and affine in λ while the sets stay (the
    /// secant update's guard): on the contact set the multiplier (T² ≥ 0, −T¹ ≥ 0), off it
    /// the gap v − (λ_p − g₀) on body 2, λ_p + g₀ − v on body 1; with friction on the
    /// tangential rows the margin g_k − |T_t,k| of a sticking pair, the slip |z_t,k| of a
    /// slipping one.
    pub margins: Vec<f64>,
    /// With friction: the nodal bounds g_k of the tangential forces (m), and the Coulomb
    /// fixed point's Tresca solves (0 under Tresca).
    pub bounds: Vec<f64>,
    pub coulomb_iterations: u32,
    /// v, the body's normal Γc displacement.
    pub trace: Vec<f64>,
    /// The active-set steps, or Clarabel's iterations ([`ContactSolution::method`]).
    pub qp_iterations: u32,
    /// The method whose point this is (Clarabel: the fallback, or `-nndd_qp_solver clarabel`).
    pub method: QpMethod,
    pub kkt_residual: f64,
}

/// How the contact step solves its QP (plain data, `-nndd_qp_*`).
#[derive(Clone, Debug)]
pub struct ContactSettings {
    /// `ActiveSet` (with Clarabel as the fallback), or `Clarabel` at every step.
    pub method: QpMethod,
    /// Active-set steps before the fallback to Clarabel.
    pub max_steps: usize,
    /// Start from the previous step's contact set.
    pub warm_start: bool,
    /// Clarabel's settings.
    pub clarabel: QpSettings,
}

impl Default for ContactSettings {
    fn default() -> Self {
        ContactSettings {
            method: QpMethod::ActiveSet,
            max_steps: 50,
            warm_start: true,
            clarabel: QpSettings::default(),
        }
    }
}

/// `-nndd_qp_tol`: in (0, 1).
const QP_TOL: Bounds<f64> = Bounds {
    accepted: "in (0, 1)",
    holds: |t| t > 0.0 && t < 1.0,
};

impl ContactSettings {
    /// Read, register (for `-help`) and validate the `-nndd_qp_*` options. `clarabel` holds
    /// Clarabel's tolerance, which the run's other QPs (the monolithic check, the estimates'
    /// admissible tractions) take too.
    pub fn from_options(o: &mut OptionsBlock) -> Result<ContactSettings, SettingsError> {
        let (tol, _) = o.real_in(
            "-nndd_qp_tol",
            "Clarabel tolerance of the contact QPs (the result is then polished to round-off)",
            1e-8,
            QP_TOL,
        )?;
        let warm_start = o.flag(
            "-nndd_qp_warm_start",
            "Contact step: start the QP from the previous contact set (else from the unconstrained solution's; with -nndd_qp_solver clarabel: try the previous set, kept if the KKT conditions certify it)",
            true,
        )?;
        let method = o.choice(
            "-nndd_qp_solver",
            "Contact step QP: active_set (primal-dual active set on S2 and D2, Clarabel if it does not certify), clarabel",
            &[("active_set", QpMethod::ActiveSet), ("clarabel", QpMethod::Clarabel)],
        )?;
        let (max_steps, _) = o.int_in(
            "-nndd_qp_max_it",
            "Contact step: active-set steps before falling back to Clarabel",
            50,
            Bounds::POSITIVE_INT,
        )?;
        Ok(ContactSettings {
            method,
            max_steps,
            warm_start,
            clarabel: QpSettings {
                tol,
                ..QpSettings::default()
            },
        })
    }
}

/// σ of the contact step on `body`: 1 on body 2 (u²_n ≥ λ_p − g₀), −1 on body 1
/// (u¹_n ≤ λ_p + g₀, i.e. −u¹_n ≥ −λ_p − g₀).
fn side(body: &Body) -> f64 {
    if body.alpha() == 2 {
        1.0
    } else {
        -1.0
    }
}

/// The condensed contact problem of a body (set up once).
pub struct ContactStep {
    /// v* = B u₀, the interface trace of the body's solution u₀ with free Γc (its data only);
    /// u₀ itself is not held: a field is one solve with the data and the Γc forces.
    v_star: Vec<f64>,
    settings: ContactSettings,
    previous: std::cell::RefCell<Option<Vec<bool>>>,
    /// The active-set method, with the factorisation of its last step (reused while the
    /// contact set stays).
    active_set: std::cell::RefCell<ActiveSet>,
    /// The friction law on the pairs (`None`: frictionless), and the previous step's
    /// contact and stick/slip sets.
    friction: Option<Friction>,
    previous_sets: std::cell::RefCell<Option<FrictionSets>>,
    /// Coulomb: the previous step's bounds g = μ T_n, where the next fixed point starts.
    previous_bounds: std::cell::RefCell<Vec<f64>>,
}

impl ContactStep {
    /// v* (collective over the body's group).
    pub fn new(
        body: &Body,
        settings: ContactSettings,
        friction: Option<Friction>,
    ) -> Result<ContactStep, ContactError> {
        if !body.has_condensed() {
            return Err(ContactError::NoSchur(body.alpha()));
        }
        let v_star = body.neumann_trace(&vec![0.0; body.pairs()], true)?;
        Ok(ContactStep {
            v_star,
            settings,
            previous: Default::default(),
            active_set: Default::default(),
            friction,
            previous_sets: Default::default(),
            previous_bounds: Default::default(),
        })
    }

    /// The body's displacement u² = u₀ + K⁻¹Bᵀ T² for the Γc forces `forces` of a contact step
    /// at the interface position `lambda`. On the contact set the QP gives u²_n = λ − g₀
    /// (u¹_n = λ + g₀ on body 1)
    /// exactly; the back-solve reproduces it to round-off only, so the trace is set there (else the
    /// contact terms of the estimates, |t̂| ≈ 1e7 times a round-off gap, would not vanish).
    pub fn field(
        &self,
        body: &Body,
        forces: &[f64],
        lambda: &[f64],
        active: &[bool],
    ) -> Result<Displacement, ContactError> {
        let mut u = body.neumann_field(forces, true)?;
        let sigma = side(body);
        let gap = &body.problem.gap;
        for (i, l) in lambda.iter().enumerate() {
            if active[i] {
                let g = gap.get(i).copied().unwrap_or(0.0);
                body.set_trace(&mut u, i, l - sigma * g);
            }
        }
        Ok(u)
    }

    /// The contact set the next [`Self::solve`] tries first (a restart's last one).
    pub fn set_warm_start(&self, active: Vec<bool>) {
        if self.friction.is_some() {
            *self.previous_sets.borrow_mut() = Some(FrictionSets::from_flags(&active));
        }
        *self.previous.borrow_mut() = Some(active);
    }

    /// Solve the contact step for the interface position λ_p (obstacle λ_p − g₀ on body 2,
    /// λ_p + g₀ on body 1), on the body's first rank (which holds its S and D).
    pub fn solve(&self, body: &Body, lambda: &[f64]) -> Result<ContactSolution, ContactError> {
        let c = body
            .condensed()
            .ok_or(ContactError::NoSchur(body.alpha()))?;
        let m = lambda.len();
        // In the variable σv (σ = 1 on body 2, −1 on body 1) the obstacle is σλ_p − g₀ (the
        // tangential rows of a frictional interface have no gap).
        let sigma = side(body);
        let gap = &body.problem.gap;
        let obstacle: Vec<f64> = (0..m)
            .map(|i| sigma * lambda[i] - gap.get(i).copied().unwrap_or(0.0))
            .collect();
        let diff: Vec<f64> = (0..m)
            .map(|i| obstacle[i] - sigma * self.v_star[i])
            .collect();
        // q = S²(o − v*), and D² q = o − v* (D² = (S²)⁻¹): the dual form's right-hand side
        // without a product.
        let mut q = vec![0.0; m];
        c.schur.matvec(&diff, &mut q);
        if let Some(friction) = &self.friction {
            return self.solve_frictional(&c.schur, friction, &q, &obstacle, sigma);
        }
        let op = Operator {
            p: &c.schur,
            inverse: Some(&c.delassus),
        };
        let settings = &self.settings;
        let previous = self
            .previous
            .borrow()
            .clone()
            .filter(|_| settings.warm_start);
        let mut method = self.active_set.borrow_mut();
        let certified = match settings.method {
            QpMethod::ActiveSet => {
                let start = previous.unwrap_or_else(|| active_set::cold_start(op, &q));
                method.solve(op, &q, Some(&diff), &start, settings.max_steps)
            }
            // Clarabel at every step, after the previous contact set if it certifies at once.
            QpMethod::Clarabel => previous.and_then(|p| method.solve(op, &q, Some(&diff), &p, 1)),
        };
        let sol = match certified {
            Some(sol) => sol,
            None => solve_nonneg_qp(&c.schur, &q, &settings.clarabel)?,
        };
        *self.previous.borrow_mut() = Some(sol.active.clone());
        let trace = (0..m).map(|i| sigma * (sol.x[i] + obstacle[i])).collect();
        let margins = (0..m)
            .map(|i| if sol.active[i] { sol.y[i] } else { sol.x[i] })
            .collect();
        Ok(ContactSolution {
            forces: sol.y.iter().map(|y| sigma * y).collect(),
            active: sol.active,
            trace,
            margins,
            bounds: Vec::new(),
            coulomb_iterations: 0,
            qp_iterations: sol.iterations,
            method: sol.method,
            kkt_residual: sol.kkt_residual,
        })
    }

    /// The frictional contact step (docs/method.md §9): in z = σv − o (o the obstacle, λ_t on
    /// the tangential rows), minimise ½ zᵀS z + qᵀz + Σ g_k |z_t,k| subject to z_n ≥ 0, by the
    /// active-set method with stick and slip sets (Clarabel as its fallback), g_k = g s_k
    /// (Tresca) or μ T_n,k to a fixed point (Coulomb, [`crate::qp::friction`]).
    fn solve_frictional(
        &self,
        schur: &crate::qp::dense::SymMatrix,
        friction: &Friction,
        q: &[f64],
        obstacle: &[f64],
        sigma: f64,
    ) -> Result<ContactSolution, ContactError> {
        let m = q.len() / 2;
        let settings = &self.settings;
        // `-nndd_qp_solver clarabel`: no active-set step, Clarabel (polished) at every step.
        let steps = match settings.method {
            QpMethod::ActiveSet => settings.max_steps,
            QpMethod::Clarabel => 0,
        };
        let start = self
            .previous_sets
            .borrow()
            .clone()
            .filter(|_| settings.warm_start);
        let g_start = self.previous_bounds.borrow().clone();
        let Solved { sol, outer, bounds } =
            friction.solve(schur, q, start, &g_start, steps, &settings.clarabel)?;
        *self.previous_sets.borrow_mut() = Some(sol.sets.clone());
        *self.previous_bounds.borrow_mut() = bounds.clone();
        let active = sol.sets.flags();
        *self.previous.borrow_mut() = Some(active.clone());
        let margins = (0..2 * m)
            .map(|i| match (i < m, active[i]) {
                (true, true) => sol.y[i],
                (true, false) => sol.z[i],
                (false, true) => bounds[i - m] - sol.y[i].abs(),
                (false, false) => sol.z[i].abs(),
            })
            .collect();
        Ok(ContactSolution {
            forces: sol.y.iter().map(|y| sigma * y).collect(),
            trace: (0..2 * m)
                .map(|i| sigma * (sol.z[i] + obstacle[i]))
                .collect(),
            active,
            margins,
            bounds,
            coulomb_iterations: outer as u32,
            qp_iterations: sol.iterations,
            method: sol.method,
            kkt_residual: sol.kkt_residual,
        })
    }
}
