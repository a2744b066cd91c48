//! The Neumann–Neumann iteration (paper §3, docs/method.md §2).
//!
//! Each iteration p: the Dirichlet step on one body and the contact step on the other (at the
//! same time on two ranks), the equilibrium defect R_p = T¹_p + T²_p, the two Neumann steps,
//! and the update λ_{p+1} = λ_p + θ (w¹ − w²)·n with a fixed θ, or (`-nndd_theta auto`, the
//! default) the secant update of [`crate::dd::secant`]. The paper puts the Dirichlet step on
//! body 1; `-nndd_dirichlet_body` (auto: the stiffer body) may put it on body 2, whose normal
//! Γc displacement λ then is, with the contact step on body 1 (u¹_n ≤ λ + g₀): the same
//! defect, Neumann steps and update, since T¹ and T² both grow with λ whichever body holds it
//! (docs/method.md §2, "Which body takes the Dirichlet step").

use crate::dd::body::{uses_superlu_dist, Body, BodyError};
use crate::dd::check::{check_solution, force_balance, SolutionCheck};
use crate::dd::contact::{ContactError, ContactSolution, ContactStep};
use crate::dd::dirichlet::{DirichletChoice, DirichletStep, Wanted};
use crate::dd::displacement::Displacement;
use crate::dd::friction::Interface;
pub use crate::dd::iterate::Iterate;
use crate::dd::neumann::{NeumannBodies, NeumannChoice, NeumannStep};
use crate::dd::secant::{SecantUpdate, AUTO_THETA_PROBE};
use crate::fem::Material;
use crate::parallel::fault::{self, InjectedFault, Phase};
use crate::parallel::layout::Layout;
use crate::petsc::log::{Stages, Timer};
use crate::petsc::readers::{Bounds, SettingsError};
use crate::petsc::OptionsBlock;
use crate::qp::QpMethod;

#[derive(Debug, thiserror::Error)]
pub enum NnddError {
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error(transparent)]
    Contact(#[from] ContactError),
    #[error(transparent)]
    Fault(#[from] InjectedFault),
    /// The reported solution fails its final check ([`crate::dd::check`]).
    #[error("{run}, but its solution fails the final check: {what}; no results are written")]
    CheckFailed { run: String, what: String },
}

/// The most secant columns `-nndd_theta auto` keeps (at most one per Γc pair is useful).
const SECANT_MEMORY: usize = 50;

/// When the NNDD stops (besides divergence and the iteration limit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StopRule {
    /// ‖λ_{p+1} − λ_p‖ ≤ tol ‖λ_{p+1}‖ (docs/method.md §2 step 6).
    Tol,
    /// Also at the first estimated iteration where η^NNDD ≤ κ η^FE, κ = `ratio` (the algebra
    /// no longer matters next to the mesh): the observer of [`solve`] says when
    /// (`crate::estimate::balanced`).
    Balanced { ratio: f64 },
    /// Exactly `max_it` iterations (studies at a fixed iteration count).
    None,
}

/// The relaxation of the update λ_{p+1} = λ_p + θ d_p (`-nndd_theta`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Relaxation {
    /// A fixed θ > 0 (the paper: 0.25).
    Fixed(f64),
    /// The secant update of [`crate::dd::secant`] (Anderson acceleration restarted at
    /// contact-set changes), its first θ from the first Neumann corrections.
    Auto,
}

impl Relaxation {
    /// `-nndd_theta`: `auto` or a number > 0.
    fn parse(text: &str) -> Result<Relaxation, SettingsError> {
        match text.trim() {
            "auto" => Ok(Relaxation::Auto),
            t => match t.parse::<f64>() {
                Ok(v) if v > 0.0 && v.is_finite() => Ok(Relaxation::Fixed(v)),
                _ => Err(SettingsError::out_of_range(
                    "-nndd_theta",
                    "a number > 0, or auto",
                    text,
                )),
            },
        }
    }

    /// `-nndd_theta` as the restart points' identity holds it: `auto` or the number.
    pub fn text(self) -> String {
        match self {
            Relaxation::Fixed(theta) => theta.to_string(),
            Relaxation::Auto => "auto".into(),
        }
    }

    /// θ of a plain step λ + θ d: the fixed θ, or with `auto` the probe of a step before
    /// anything is known of the interface map.
    fn plain_theta(self) -> f64 {
        match self {
            Relaxation::Fixed(theta) => theta,
            Relaxation::Auto => AUTO_THETA_PROBE,
        }
    }
}

/// The settings of the NNDD loop and its steps (plain data).
#[derive(Clone, Debug)]
pub struct NnddSettings {
    /// θ of the update λ ← λ + θ (w¹ − w²)·n, or the secant update.
    pub relaxation: Relaxation,
    /// Stopping tolerance on ‖λ_{p+1} − λ_p‖ / ‖λ_{p+1}‖.
    pub tol: f64,
    /// Stopping tolerance on the interface force balance ‖R_p‖ / max(‖T¹_p‖, ‖T²_p‖): a
    /// converged iterate satisfies both (a short step is no balance of the forces).
    pub force_tol: f64,
    pub max_it: usize,
    pub stop: StopRule,
    /// The body of the Dirichlet step (1, as in the paper, or 2): λ is its normal Γc
    /// displacement, and the other body's contact step holds it behind λ (docs/method.md §2,
    /// "Which body takes the Dirichlet step").
    pub dirichlet_body: usize,
    /// How the Dirichlet step is solved.
    pub dirichlet_step: DirichletChoice,
    /// How the Neumann steps are solved.
    pub neumann_step: NeumannChoice,
    /// Which bodies take the Neumann step.
    pub neumann_bodies: NeumannBodies,
    /// What the options named (`None`: auto), before a body held only by contact decides.
    pub requested: Requested,
}

/// The NNDD's body choices as the options named them (`None`: auto).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Requested {
    /// `-nndd_dirichlet_body`.
    pub dirichlet_body: Option<usize>,
    /// `-nndd_neumann_bodies`.
    pub neumann_bodies: Option<NeumannBodies>,
}

impl NnddSettings {
    /// The warning of a Dirichlet step forced onto a much softer body, if it is.
    pub fn soft_warning(&self, materials: &[Material; 2]) -> Option<String> {
        self.requested
            .dirichlet_body
            .and_then(|b| soft_dirichlet_body(materials, b))
    }

    /// The choices the mortar discretisation decides (`-nndd_contact_discretisation mortar`):
    /// the Dirichlet step on the non-mortar body `side` (1 or 2), whose nodes carry Γc's
    /// constraints (the other meets them at points of its curve, which a Dirichlet step cannot
    /// prescribe), the Neumann step's bodies chosen for it as `auto` would. Returns the advice
    /// of a much softer non-mortar body.
    pub fn on_mortar(
        &mut self,
        materials: &[Material; 2],
        side: usize,
    ) -> Result<Option<String>, SettingsError> {
        if self.requested.dirichlet_body.is_some_and(|b| b != side) {
            return Err(SettingsError::named(
                "-nndd_dirichlet_body",
                format!("{} cannot be used with -nndd_contact_discretisation mortar here: body {side}'s contact curve, the coarser, carries the contact constraints at its nodes and the other body meets them at points of its curve, which a Dirichlet step cannot prescribe; use auto or {side}", 3 - side),
            ));
        }
        self.dirichlet_body = side;
        if self.requested.neumann_bodies.is_none() {
            self.neumann_bodies = auto_neumann_bodies(self.relaxation, materials, side);
        }
        Ok(soft_dirichlet_body(materials, side).map(|_| {
            let (d, c) = (&materials[side - 1], &materials[2 - side]);
            let ratio = c.plane_strain_modulus() / d.plane_strain_modulus();
            format!("-nndd_contact_discretisation mortar puts the Dirichlet step on body {side}, whose contact curve is the coarser, {ratio:.0} times softer than the other (E/(1 - nu^2)): the NNDD may need many iterations; mesh the stiffer body's contact curve coarser, or use node_to_node")
        }))
    }

    /// The body of the contact step.
    pub fn contact_body(&self) -> usize {
        3 - self.dirichlet_body
    }

    /// Read, register (for `-help`) and validate the NNDD's options. `materials` decide the
    /// Dirichlet step's body of `-nndd_dirichlet_body auto` (a Dirichlet step forced onto a
    /// much softer body: [`NnddSettings::soft_warning`]).
    pub fn from_options(
        o: &mut OptionsBlock,
        materials: &[Material; 2],
    ) -> Result<NnddSettings, SettingsError> {
        let (theta, _) = o.string(
            "-nndd_theta",
            "NNDD relaxation theta of the lambda update: auto (a secant update fitted to the iterates, restarted when the contact set changes) or a fixed number > 0 (the paper: 0.25)",
            "auto",
        )?;
        let relaxation = Relaxation::parse(&theta)?;
        let (tol, _) = o.real_in(
            "-nndd_tol",
            "NNDD stopping tolerance on |dlambda|/|lambda|",
            1e-8,
            Bounds::FRACTION,
        )?;
        let (force_tol, _) = o.real_in(
            "-nndd_force_tol",
            "NNDD stopping tolerance on the interface force balance |T1 + T2|/max(|T1|, |T2|), required with -nndd_tol",
            1e-8,
            Bounds::FRACTION,
        )?;
        let (max_it, _) = o.int_in(
            "-nndd_max_it",
            "Maximum number of NNDD iterations",
            1000,
            Bounds::POSITIVE_INT,
        )?;
        let (ratio, _) = o.real_in(
            "-nndd_stop_ratio",
            "kappa of -nndd_stop balanced: stop when eta_NNDD <= kappa eta_FE",
            0.1,
            Bounds::POSITIVE,
        )?;
        let stop = o.choice(
            "-nndd_stop",
            "Stopping rule: tol (|dlambda| <= tol |lambda|), balanced (also when eta_NNDD <= kappa eta_FE), none (exactly -nndd_max_it iterations)",
            &[
                ("tol", StopRule::Tol),
                ("balanced", StopRule::Balanced { ratio }),
                ("none", StopRule::None),
            ],
        )?;
        let neumann_step = o.choice(
            "-nndd_neumann_step",
            "Neumann steps: auto (condensed where the body has its interface operators), condensed (the trace D(-+R/2)), solve (a back-solve)",
            &[
                ("auto", NeumannChoice::Auto),
                ("condensed", NeumannChoice::Condensed),
                ("solve", NeumannChoice::Solve),
            ],
        )?;
        let bodies = o.choice(
            "-nndd_neumann_bodies",
            "Bodies of the Neumann step: auto (dirichlet with -nndd_theta auto when the Dirichlet body is the stiffer, else both), both (each with -+R/2, the paper), dirichlet (the Dirichlet step's body with -+R: a Dirichlet-Neumann update)",
            &[
                ("auto", None),
                ("both", Some(NeumannBodies::Both)),
                ("dirichlet", Some(NeumannBodies::Dirichlet)),
            ],
        )?;
        let dirichlet_step = o.choice(
            "-nndd_dirichlet_step",
            "Dirichlet step (on the body of -nndd_dirichlet_body): auto (condensed when that body has its interface operators: MUMPS on any rank count, SuperLU_DIST), system, condensed",
            &[
                ("auto", DirichletChoice::Auto),
                ("system", DirichletChoice::System),
                ("condensed", DirichletChoice::Condensed),
            ],
        )?;
        let requested = Requested {
            dirichlet_body: o.choice(
                "-nndd_dirichlet_body",
                "The body of the Dirichlet step (the other takes the contact step): auto (the stiffer body, by E/(1-nu^2), or the body held only by contact), 1, 2",
                &[("auto", None), ("1", Some(1)), ("2", Some(2))],
            )?,
            neumann_bodies: bodies,
        };
        let dirichlet_body = requested
            .dirichlet_body
            .unwrap_or_else(|| stiffer_body(materials));
        let neumann_bodies =
            bodies.unwrap_or_else(|| auto_neumann_bodies(relaxation, materials, dirichlet_body));
        // A second SuperLU_DIST factorisation on the Dirichlet body's communicator: see
        // `app::solve::setup_bodies`.
        if dirichlet_step == DirichletChoice::System && uses_superlu_dist(dirichlet_body)? {
            return Err(SettingsError::named(
                "-nndd_dirichlet_step",
                format!("system cannot be used with -body{dirichlet_body}_pc_factor_mat_solver_type superlu_dist on the body of the Dirichlet step (PETSc 3.18 frees the process grid of two SuperLU_DIST factorisations on one communicator twice); use auto or condensed"),
            ));
        }
        Ok(NnddSettings {
            relaxation,
            tol,
            force_tol,
            max_it,
            stop,
            dirichlet_body,
            dirichlet_step,
            neumann_step,
            neumann_bodies,
            requested,
        })
    }

    /// The settings of the reference solve of (26), which must converge whatever the run's own
    /// θ and stopping rule: θ auto, to 1e−8, with room for the iterations, and the Dirichlet
    /// step on the stiffer body (a body other than the run's takes it the way `auto` chooses:
    /// the run's `system` was checked against its own body's solver only).
    pub fn for_reference(&self, materials: &[Material; 2]) -> NnddSettings {
        let dirichlet_body = stiffer_body(materials);
        NnddSettings {
            relaxation: Relaxation::Auto,
            tol: 1e-8,
            force_tol: 1e-8,
            max_it: self.max_it.max(1000),
            stop: StopRule::Tol,
            dirichlet_body,
            dirichlet_step: if dirichlet_body == self.dirichlet_body {
                self.dirichlet_step
            } else {
                DirichletChoice::Auto
            },
            neumann_step: self.neumann_step,
            neumann_bodies: match self.neumann_bodies {
                NeumannBodies::Contact => NeumannBodies::Contact,
                _ => NeumannBodies::Dirichlet,
            },
            requested: Requested::default(),
        }
    }
}

impl Default for NnddSettings {
    /// The paper's fixed θ = 0.25 and tol 1e−8 (the command line's default is `auto`).
    fn default() -> Self {
        NnddSettings {
            relaxation: Relaxation::Fixed(0.25),
            tol: 1e-8,
            force_tol: 1e-8,
            max_it: 1000,
            stop: StopRule::Tol,
            dirichlet_body: 1,
            dirichlet_step: DirichletChoice::Auto,
            neumann_step: NeumannChoice::Auto,
            neumann_bodies: NeumannBodies::Both,
            requested: Requested::default(),
        }
    }
}

/// How much softer than the other the Dirichlet step's body must be for a warning.
pub const SOFT_DIRICHLET: f64 = 0.1;

/// The body of the Dirichlet step for `-nndd_dirichlet_body auto`: the stiffer one by its
/// plane-strain modulus, body 1 (the paper's) when they are equal.
/// `-nndd_neumann_bodies auto`: the Dirichlet body alone under θ auto when it is the stiffer
/// (by E/(1 − ν²)), both otherwise: with equal moduli the paper's update is as fast
/// (examples/hertz levels 1–4: 9–10 iterations, 7–11 with the Dirichlet body's alone). On a
/// Dirichlet body forced onto a much
/// softer body the Dirichlet–Neumann operator I + D^D PŜ^CPᵀ spreads by the stiffness ratio
/// (examples/hertz level 2 with the block 1000 times softer taking the Dirichlet step:
/// stagnated after 52 iterations, 65 with both), and a fixed θ keeps the paper's update.
fn auto_neumann_bodies(
    relaxation: Relaxation,
    materials: &[Material; 2],
    dirichlet_body: usize,
) -> NeumannBodies {
    let [d, c] =
        [dirichlet_body, 3 - dirichlet_body].map(|b| materials[b - 1].plane_strain_modulus());
    match relaxation {
        Relaxation::Auto if d > c => NeumannBodies::Dirichlet,
        _ => NeumannBodies::Both,
    }
}

pub fn stiffer_body(materials: &[Material; 2]) -> usize {
    if materials[1].plane_strain_modulus() > materials[0].plane_strain_modulus() {
        2
    } else {
        1
    }
}

/// The advice for a Dirichlet step given to a body much softer than the other
/// (`-nndd_dirichlet_body`): θ auto then needs many iterations where the contact set grows (the
/// interface operator's spectrum spreads by the stiffness ratio, `src/dd/secant.rs`).
fn soft_dirichlet_body(materials: &[Material; 2], body: usize) -> Option<String> {
    let (d, c) = (&materials[body - 1], &materials[2 - body]);
    (d.plane_strain_modulus() < SOFT_DIRICHLET * c.plane_strain_modulus()).then(|| {
        format!(
            "body {body} takes the Dirichlet step (-nndd_dirichlet_body {body}) but is {:.0} times softer than body {} (E/(1 - nu^2), E {:e} against {:e} Pa): the NNDD converges in far fewer iterations with the Dirichlet step on the stiffer body (-nndd_dirichlet_body auto)",
            c.plane_strain_modulus() / d.plane_strain_modulus(),
            3 - body,
            d.young,
            c.young
        )
    })
}

/// How an NNDD run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// ‖Δλ‖ ≤ tol ‖λ‖.
    Converged,
    /// Balanced stopping: η^NNDD ≤ κ η^FE at an estimated iteration.
    Balanced,
    MaxIterations,
    Diverged,
    Stagnated,
    /// A signal asked to stop (SIGTERM, SIGINT, SIGUSR1): a restart point was written.
    Interrupted,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::Balanced => "balanced",
            Status::MaxIterations => "max_it",
            Status::Diverged => "diverged",
            Status::Stagnated => "stagnated",
            Status::Interrupted => "interrupted",
        }
    }

    /// Why the run ended, for the summary's `stop_reason`.
    pub fn stop_reason(self) -> &'static str {
        match self {
            Status::Converged => "tol",
            other => other.name(),
        }
    }

    /// The run reached what it was asked for.
    pub fn succeeded(self) -> bool {
        matches!(self, Status::Converged | Status::Balanced)
    }

    fn from_code(c: u8) -> Option<Status> {
        [
            Status::Converged,
            Status::Balanced,
            Status::MaxIterations,
            Status::Diverged,
            Status::Stagnated,
            Status::Interrupted,
        ]
        .into_iter()
        .find(|s| *s as u8 + 1 == c)
    }
}

/// One line of the convergence history.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct IterationRecord {
    pub iteration: usize,
    /// ‖λ_{p+1} − λ_p‖ / ‖λ_{p+1}‖; with θ auto the larger of that and the plain step
    /// θ ‖d_p‖ / ‖λ_{p+1}‖ (a short secant step is not convergence).
    pub lambda_change: f64,
    /// ‖R_p‖ = ‖T¹_p + T²_p‖ (N/m, nodal forces).
    pub residual: f64,
    /// The interface force balance ‖R_p‖ / max(‖T¹_p‖, ‖T²_p‖) (0 where both vanish).
    #[serde(default)]
    pub force_balance: f64,
    /// Number of Γc nodes in contact at step p.
    pub active: usize,
    /// The contact step's QP iterations: the active-set steps (1: the previous contact set
    /// was certified optimal by the KKT conditions), or Clarabel's iterations.
    pub qp_iterations: u32,
    /// The method that solved the contact step's QP: `active_set`, or `clarabel` (its
    /// fallback, or `-nndd_qp_solver clarabel`).
    #[serde(default)]
    pub qp_solver: String,
    /// The relaxation θ of this iteration's update (with `-nndd_theta auto`, of its new
    /// direction).
    pub theta: f64,
    /// `-nndd_theta auto`: the secant columns (differences of earlier iterates in the same
    /// contact set) of this update; 0 for a plain step λ + θ d.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub secant_columns: Option<usize>,
    /// `-nndd_theta auto`: the fraction of the secant correction taken (< 1 when the model
    /// predicts a change of the contact set before its end).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub secant_fraction: Option<f64>,
    /// With friction: the pairs in contact that stick.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stick: Option<usize>,
    /// `-nndd_friction coulomb`: the Tresca solves of the contact step's fixed point
    /// g = μ T_n.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coulomb_iterations: Option<u32>,
    /// The estimates, at estimated iterations (paper (22)–(26)).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eta_glo: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eta_fe: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eta_nndd: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eta_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub e_ref: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effectivity: Option<f64>,
}

/// Per-phase wall times of the loop on this rank.
#[derive(Clone, Copy, Debug, Default)]
pub struct LoopTimers {
    pub dirichlet_step: Timer,
    pub contact_step: Timer,
    pub neumann_step: Timer,
    pub exchange: Timer,
    /// Forming the fields u¹_p, u²_p of the reported and the estimated iterates (a back-solve
    /// per body where the steps are condensed), outside the loop's steps.
    pub fields: Timer,
    /// The final check of the reported iterate ([`SolutionCheck`]).
    pub check: Timer,
}

pub struct NnddResult {
    pub status: Status,
    /// The reported iterate's a-posteriori check.
    pub check: SolutionCheck,
    pub iterations: usize,
    pub history: Vec<IterationRecord>,
    pub last: Iterate,
    pub timers: LoopTimers,
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// What the stopping rule measures at an iteration.
#[derive(Clone, Copy, Debug)]
struct Measures {
    /// The change of λ ([`LoopState::update`]).
    change: f64,
    /// [`force_balance`] of step 1's forces.
    force_balance: f64,
}

/// Iterations in a row whose ‖R‖ grows before a run is called diverged.
const DIVERGING_STEPS: usize = 5;

/// Iterations without a smaller change ‖Δλ‖/‖λ‖ before a run is called stagnated.
const STAGNATION_STEPS: usize = 50;

/// Whether the iteration diverges: ‖R_p‖ grew at each of the last [`DIVERGING_STEPS`]
/// iterations and is 10 times its smallest so far (iterates that grow without bound). A run
/// that still reduces ‖R‖ is never called diverged, however its ‖Δλ‖ goes.
fn diverging(history: &[IterationRecord]) -> bool {
    let r: Vec<f64> = history.iter().map(|h| h.residual).collect();
    let n = r.len();
    if n <= DIVERGING_STEPS {
        return false;
    }
    let smallest = r.iter().copied().fold(f64::INFINITY, f64::min);
    let grew = r[n - 1 - DIVERGING_STEPS..].windows(2).all(|w| w[1] > w[0]);
    grew && r[n - 1] > 10.0 * smallest
}

/// The steps of an iteration, as set up for this run: the Dirichlet step (on the ranks of body
/// `dirichlet_body`), the other body's contact step (on its ranks), and each body's Neumann
/// step (on its ranks).
pub struct Steps<'a> {
    pub dirichlet_body: usize,
    pub dirichlet: Option<&'a DirichletStep>,
    pub contact: Option<&'a ContactStep>,
    pub neumann: [Option<NeumannStep>; 2],
}

impl Steps<'_> {
    /// The indices (α − 1) of the Dirichlet step's body and of the contact step's.
    fn indices(&self) -> (usize, usize) {
        (self.dirichlet_body - 1, 2 - self.dirichlet_body)
    }
}

/// What the contact body's root shares of a contact step: the contact set, the QP's KKT
/// residual, iterations and method, the gaps and the body's normal Γc trace, packed into one
/// broadcast ([`ContactShare::shared`]).
struct ContactShare {
    active: Vec<bool>,
    kkt: f64,
    iterations: u32,
    clarabel: bool,
    coulomb_iterations: u32,
    margins: Vec<f64>,
    trace: Vec<f64>,
    /// With friction, the nodal bounds g_k (m; empty without).
    bounds: Vec<f64>,
}

impl ContactShare {
    /// What the ranks other than the contact body's root hold before the broadcast.
    fn none(len: usize, bounds: usize) -> ContactShare {
        ContactShare {
            active: vec![false; len],
            kkt: 0.0,
            iterations: 0,
            clarabel: false,
            coulomb_iterations: 0,
            margins: vec![0.0; len],
            trace: vec![0.0; len],
            bounds: vec![0.0; bounds],
        }
    }

    /// The shared part of a contact step's solution.
    fn of(sol: ContactSolution) -> ContactShare {
        ContactShare {
            active: sol.active,
            kkt: sol.kkt_residual,
            iterations: sol.qp_iterations,
            clarabel: sol.method == QpMethod::Clarabel,
            coulomb_iterations: sol.coulomb_iterations,
            margins: sol.margins,
            trace: sol.trace,
            bounds: sol.bounds,
        }
    }

    /// The contact body's root's share, on every rank (collective: `self` is read on that
    /// rank only).
    fn shared(self, layout: &Layout, contact_body: usize, len: usize) -> ContactShare {
        let mut packed = self.pack();
        layout.share(contact_body, &mut packed);
        ContactShare::unpack(&packed, len)
    }

    fn pack(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.active.iter().map(|&a| a as u8 as f64).collect();
        v.extend([
            self.kkt,
            self.iterations as f64,
            self.clarabel as u8 as f64,
            self.coulomb_iterations as f64,
        ]);
        v.extend(&self.margins);
        v.extend(&self.trace);
        v.extend(&self.bounds);
        v
    }

    fn unpack(v: &[f64], len: usize) -> ContactShare {
        let m = len;
        ContactShare {
            active: v[..m].iter().map(|&a| a > 0.5).collect(),
            kkt: v[m],
            iterations: v[m + 1] as u32,
            clarabel: v[m + 2] > 0.5,
            coulomb_iterations: v[m + 3] as u32,
            margins: v[m + 4..2 * m + 4].to_vec(),
            trace: v[2 * m + 4..3 * m + 4].to_vec(),
            bounds: v[3 * m + 4..].to_vec(),
        }
    }
}

/// u²_n, the normal Γc trace of body 2's field `u2` (on its ranks), broadcast to every rank
/// (collective).
pub fn shared_trace2(
    layout: &Layout,
    body2: Option<&Body>,
    u2: &Displacement,
    m: usize,
) -> Vec<f64> {
    let mut trace = body2.map_or(vec![0.0; m], |b| b.trace(u2));
    layout.share(2, &mut trace);
    trace
}

/// What the loop needs to continue after iteration `iteration` (a restart point): written by
/// `-nndd_checkpoint_every` and on a signal, read by `-nndd_restart`. The same on every rank.
/// In the loop, the state after the last iteration done.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct LoopState {
    /// The iterations done; the next one is `iteration + 1`.
    pub iteration: usize,
    /// λ_{p+1}: where the next iteration starts.
    pub lambda: Vec<f64>,
    /// The history of the iterations done.
    pub history: Vec<IterationRecord>,
    /// The contact set of the last contact step (the warm start of the next QP).
    pub active: Vec<bool>,
    /// `-nndd_theta auto`: the secant update's columns and estimates.
    pub secant: Option<SecantUpdate>,
    /// The stagnation guard: the best ‖Δλ‖/‖λ‖ and where.
    pub best: f64,
    pub best_at: usize,
}

impl LoopState {
    /// A first iteration from `lambda` (λ = 0 for a fresh run; an adaptive run's next cycle
    /// starts from the previous cycle's λ carried over), with a fresh secant update under
    /// θ auto.
    pub fn at(lambda: Vec<f64>, relaxation: Relaxation) -> LoopState {
        let memory = SECANT_MEMORY.min(lambda.len().max(1));
        LoopState {
            iteration: 0,
            lambda,
            history: Vec::new(),
            active: Vec::new(),
            secant: (relaxation == Relaxation::Auto)
                .then(|| SecantUpdate::new(AUTO_THETA_PROBE, memory)),
            best: f64::INFINITY,
            best_at: 0,
        }
    }
}

/// What the loop asks of its caller, besides the bodies and steps: the estimates, the
/// monitor, whether a stop was requested, and the restart points. Every method but
/// `monitor` and `interrupted` is called on every rank at the same point (collectively).
pub trait Observer<E> {
    /// At the iterations of `estimate_every`, before the fields of step p are formed (they
    /// cost a solve per body): whether to form them and call [`Observer::estimate`]. The
    /// balanced rule's check says no while it fails (it needs the Γc forces only).
    fn wants_estimate(&mut self, _it: &Iterate) -> Result<bool, E> {
        Ok(true)
    }
    /// With the fields of step p formed: whether the balanced stopping criterion holds.
    fn estimate(&mut self, it: &Iterate) -> Result<bool, E>;
    /// After each iteration.
    fn monitor(&mut self, record: &IterationRecord);
    /// Whether this rank was asked to stop (the loop agrees over the ranks).
    fn interrupted(&self) -> bool;
    /// Whether to write a restart point after iteration p (when the loop goes on).
    fn checkpoint_due(&self, p: usize) -> bool;
    /// Write the restart point `state`.
    fn checkpoint(&mut self, state: &LoopState) -> Result<(), E>;
}

/// What a run of the loop works with, the same at every iteration: its settings, the number m
/// of Γc node pairs, the ranks, the bodies and steps set up on this rank (`bodies[α-1]` is
/// `Some` on the ranks owning body α, with `steps` set up there: the Dirichlet step on the
/// ranks of `steps.dirichlet_body`, the contact step on the other body's, each body's Neumann
/// step on its own), the `-log_view` stages, and which iterations are estimated.
pub struct Context<'a> {
    pub settings: &'a NnddSettings,
    /// The length of the interface vectors: the number of Γc pairs, twice it with friction.
    pub m: usize,
    pub interface: Interface,
    pub layout: &'a Layout,
    pub bodies: [Option<&'a Body>; 2],
    pub steps: &'a Steps<'a>,
    pub stages: &'a Stages,
    /// Every k-th iteration is estimated (`None`: none in the loop).
    pub estimate_every: Option<usize>,
}

/// Step 1 of an iteration, on every rank: T¹_p, T²_p, the Dirichlet step's field where it
/// formed it, and the contact step's results.
struct StepOne {
    forces: [Vec<f64>; 2],
    u_dirichlet: Displacement,
    contact: ContactShare,
}

/// The update of step 5.
struct Update {
    /// λ_{p+1}.
    lambda: Vec<f64>,
    /// θ of the update (with θ auto, of its new direction).
    theta: f64,
    /// θ auto: the secant columns used and the fraction of the secant correction taken.
    columns: Option<usize>,
    fraction: Option<f64>,
    /// The change the stopping rule measures (see [`LoopState::update`]).
    change: f64,
}

/// Run the NNDD loop (docs/method.md §2): from `start` (`-nndd_restart`) when given, else from
/// λ = 0. Every `ctx.estimate_every` iterations (if set), the fields of step p are formed and
/// `observer.estimate` is called with the iterate (collectively). Errors of type `E` (which
/// the loop's own errors convert into) end the loop.
pub fn solve<E: From<NnddError>>(
    ctx: &Context,
    start: Option<LoopState>,
    observer: &mut impl Observer<E>,
) -> Result<NnddResult, E> {
    let mut timers = LoopTimers::default();
    let mut state = ctx.start(start);
    let mut status = Status::MaxIterations;
    let mut last = None;
    for p in state.iteration + 1..=ctx.settings.max_it {
        // Step 1: the Dirichlet problem at λ_p and the other body's contact problem behind λ_p.
        let one = ctx.step_one(&state.lambda, ctx.wanted(p), &mut timers)?;
        // Step 3: the equilibrium defect R_p = T¹_p + T²_p.
        let r = one.defect();
        // Step 4: the two Neumann problems.
        let w = ctx.neumann_steps(&r, &mut timers)?;
        // Step 5: the update, λ + θ d or the secant update of `-nndd_theta auto`.
        let update = state.update(ctx, p, &one, &w);
        let record = one.record(p, &r, &update);
        let measures = Measures {
            change: update.change,
            force_balance: record.force_balance,
        };
        let mut it = one.into_iterate(ctx.steps, p, &state.lambda);
        let balanced = ctx.estimate_if_due(p, &mut it, observer, &mut timers)?;
        observer.monitor(&record);
        state.history.push(record);
        // Step 6: stop? Rank 0 decides for all (every rank computed the same numbers); a
        // signal on any rank stops all at the end of this iteration.
        let verdict = state.check_termination(ctx.settings, p, measures, balanced);
        let (code, interrupted) = ctx
            .layout
            .agree_stop(verdict.map_or(0, |s| s as u8 + 1), observer.interrupted());
        let stop = Status::from_code(code);
        let continues = stop.is_none() && p < ctx.settings.max_it;
        state.advance(p, update.lambda, &it.active);
        // A restart point where the loop goes on: every k iterations, or on a signal.
        if continues && (interrupted || observer.checkpoint_due(p)) {
            observer.checkpoint(&state)?;
        }
        last = Some(it);
        if let Some(s) = stop {
            status = s;
            break;
        }
        if interrupted && continues {
            status = Status::Interrupted;
            break;
        }
    }
    let last = last.expect("the loop runs at least once (checked by the restart)");
    Ok(ctx.finish(status, state.history, last, timers)?)
}

impl Context<'_> {
    /// The state the loop starts from: `start` (the QP warm-started from its contact set), or
    /// λ = 0 with a fresh secant update under θ auto.
    fn start(&self, start: Option<LoopState>) -> LoopState {
        if let Some(state) = start {
            if let (Some(c), false) = (self.steps.contact, state.active.is_empty()) {
                c.set_warm_start(state.active.clone());
            }
            return state;
        }
        LoopState::at(vec![0.0; self.m], self.settings.relaxation)
    }

    /// Step 1 at λ_p: the Dirichlet problem on its body's ranks and the other body's contact
    /// problem behind λ_p, concurrently; their Γc forces and the contact step's results then
    /// shared with every rank.
    fn step_one(
        &self,
        lambda: &[f64],
        wanted: Wanted,
        timers: &mut LoopTimers,
    ) -> Result<StepOne, NnddError> {
        let (di, ci) = self.steps.indices();
        let mut forces = [vec![0.0; self.m], vec![0.0; self.m]];
        let mut u_dirichlet = Displacement::default();
        if let (Some(b), Some(d)) = (self.bodies[di], self.steps.dirichlet) {
            let _s = self.stages.dirichlet_step.enter();
            let (u, f) = timers.dirichlet_step.time(|| d.solve(b, lambda, wanted))?;
            u_dirichlet = u.unwrap_or_default();
            forces[di] = f;
        }
        fault::check(Phase::Qp)?;
        // The contact QP lives on Γc: the contact body's root solves it, then shares it.
        let mut contact = ContactShare::none(self.m, self.m - self.interface.pairs(self.m));
        if let (Some(b), Some(c)) = (self.bodies[ci].filter(|b| b.is_root()), self.steps.contact) {
            let _s = self.stages.contact_step.enter();
            let mut sol = timers.contact_step.time(|| c.solve(b, lambda))?;
            forces[ci] = std::mem::take(&mut sol.forces);
            contact = ContactShare::of(sol);
        }
        let contact = timers.exchange.time(|| {
            self.layout.share(di + 1, &mut forces[di]);
            self.layout.share(ci + 1, &mut forces[ci]);
            contact.shared(self.layout, ci + 1, self.m)
        });
        Ok(StepOne {
            forces,
            u_dirichlet,
            contact,
        })
    }

    /// Step 4: each body's Neumann problem with the loads ∓½R_p on Γc, on its ranks; the
    /// normal Γc traces w¹, w² shared with every rank.
    fn neumann_steps(
        &self,
        r: &[f64],
        timers: &mut LoopTimers,
    ) -> Result<[Vec<f64>; 2], NnddError> {
        let mut w = [vec![0.0; self.m], vec![0.0; self.m]];
        {
            let _s = self.stages.neumann_step.enter();
            fault::check(Phase::Ksp)?;
            for (k, w) in w.iter_mut().enumerate() {
                if let (Some(b), Some(n)) = (self.bodies[k], self.steps.neumann[k]) {
                    let weight = self.settings.neumann_bodies.weight();
                    *w = timers.neumann_step.time(|| n.solve(b, r, weight))?;
                }
            }
        }
        timers.exchange.time(|| {
            let [w1, w2] = &mut w;
            self.layout.share(1, w1);
            self.layout.share(2, w2);
        });
        Ok(w)
    }

    /// The Dirichlet step's field at iteration p with its forces where it is estimated (the
    /// iterations of `estimate_every`), else its forces alone.
    fn wanted(&self, p: usize) -> Wanted {
        match self.estimate_every.is_some_and(|k| p.is_multiple_of(k)) {
            true => Wanted::ForcesAndField,
            false => Wanted::Forces,
        }
    }

    /// At the iterations of `estimate_every`, when the observer wants it: the fields of step
    /// p formed and the iterate estimated. Whether the balanced stopping rule holds.
    fn estimate_if_due<E: From<NnddError>>(
        &self,
        p: usize,
        it: &mut Iterate,
        observer: &mut impl Observer<E>,
        timers: &mut LoopTimers,
    ) -> Result<bool, E> {
        if self.wanted(p) == Wanted::Forces || !observer.wants_estimate(it)? {
            return Ok(false);
        }
        self.form_fields(it, timers)?;
        it.split_tangential();
        observer.estimate(it)
    }

    /// Form u¹_p and u²_p on their owners where the steps did not (condensed steps, and a
    /// system Dirichlet step at an iteration not estimated, give only the Γc forces).
    fn form_fields(&self, it: &mut Iterate, timers: &mut LoopTimers) -> Result<(), NnddError> {
        if it.tangential.is_some() {
            return Ok(()); // formed before it was split
        }
        let (di, ci) = self.steps.indices();
        let _s = self.stages.fields.enter();
        if let (Some(b), Some(d)) = (self.bodies[di], self.steps.dirichlet) {
            if it.u[di].is_empty() {
                it.u[di] = timers
                    .fields
                    .time(|| d.field(b, &it.interface, &it.forces[di]))?;
            }
        }
        if let (Some(b), Some(c)) = (self.bodies[ci], self.steps.contact) {
            if it.u[ci].is_empty() {
                it.u[ci] = timers
                    .fields
                    .time(|| c.field(b, &it.forces[ci], &it.interface, &it.active))?;
            }
        }
        it.trace2 = shared_trace2(self.layout, self.bodies[1], &it.u[1], it.lambda.len());
        Ok(())
    }

    /// The end of the run: the fields of the reported step formed (the loop needs only the Γc
    /// forces) and checked; a solution that fails its check is no success.
    fn finish(
        &self,
        status: Status,
        history: Vec<IterationRecord>,
        mut last: Iterate,
        mut timers: LoopTimers,
    ) -> Result<NnddResult, NnddError> {
        let iterations = history.len();
        self.form_fields(&mut last, &mut timers)?;
        last.split_tangential();
        let check = timers
            .check
            .time(|| check_solution(self.layout, &last, self.bodies))?;
        if status.succeeded() {
            let balance = (status == Status::Converged).then_some(self.settings.force_tol);
            if let Some(what) = check.failure(balance) {
                return Err(NnddError::CheckFailed {
                    run: format!("the NNDD {} after {iterations} iterations", status.name()),
                    what,
                });
            }
        }
        Ok(NnddResult {
            status,
            check,
            iterations,
            history,
            last,
            timers,
        })
    }
}

impl StepOne {
    /// Step 3: the equilibrium defect R_p = T¹_p + T²_p.
    fn defect(&self) -> Vec<f64> {
        let [t1, t2] = &self.forces;
        t1.iter().zip(t2).map(|(a, b)| a + b).collect()
    }

    /// The sign conditions of the contact step (each ≥ 0, affine in λ while the sets stay):
    /// its multipliers on the contact set, the gap off it, and with friction each pair's
    /// stick margin or slip ([`ContactSolution::margins`]).
    fn sign_conditions(&self) -> &[f64] {
        &self.contact.margins
    }

    /// The history's line of iteration p.
    fn record(&self, p: usize, r: &[f64], update: &Update) -> IterationRecord {
        let c = &self.contact;
        IterationRecord {
            iteration: p,
            lambda_change: update.change,
            residual: norm(r),
            force_balance: force_balance(r, &self.forces, &c.active),
            // With friction the flags hold the contact set, then the stick set.
            active: c.active[..c.active.len() - c.bounds.len()]
                .iter()
                .filter(|&&a| a)
                .count(),
            stick: (!c.bounds.is_empty()).then(|| {
                let m = c.bounds.len();
                (0..m).filter(|&k| c.active[k] && c.active[m + k]).count()
            }),
            qp_iterations: c.iterations,
            qp_solver: if c.clarabel {
                QpMethod::Clarabel
            } else {
                QpMethod::ActiveSet
            }
            .name()
            .into(),
            theta: update.theta,
            secant_columns: update.columns,
            secant_fraction: update.fraction,
            coulomb_iterations: (c.coulomb_iterations > 0).then_some(c.coulomb_iterations),
            ..IterationRecord::default()
        }
    }

    /// The iterate of step 1 at λ_p (`lambda`), the fields not formed yet but the Dirichlet
    /// step's where it gave it.
    fn into_iterate(self, steps: &Steps, p: usize, lambda: &[f64]) -> Iterate {
        let (di, ci) = steps.indices();
        let mut u: [Displacement; 2] = Default::default();
        u[di] = self.u_dirichlet;
        let (trace1, trace2) = if di == 0 {
            (lambda.to_vec(), Vec::new())
        } else {
            (self.contact.trace, lambda.to_vec())
        };
        Iterate {
            lambda: trace1,
            interface: lambda.to_vec(),
            u,
            forces: self.forces,
            contact_body: ci + 1,
            trace2,
            active: self.contact.active,
            qp_kkt: self.contact.kkt,
            iteration: p,
            friction_bounds: self.contact.bounds,
            tangential: None,
        }
    }
}

impl LoopState {
    /// Step 5: λ_{p+1} = λ_p + θ d_p, d_p = (w¹ − w²)·n, with the fixed θ, or the secant
    /// update of θ auto ([`SecantUpdate::step`]); and the change the stopping rule measures,
    /// ‖λ_{p+1} − λ_p‖ / ‖λ_{p+1}‖. With θ auto a step may be short while the iterate is not
    /// converged (the secant correction cancels most of θ d, or stops at a predicted change of
    /// the contact set): the change measured is then max(‖Δλ‖, θ‖d_p‖) / ‖λ_{p+1}‖, the plain
    /// step's too.
    fn update(&mut self, ctx: &Context, p: usize, one: &StepOne, w: &[Vec<f64>; 2]) -> Update {
        let (di, ci) = ctx.steps.indices();
        let lambda = &self.lambda;
        let d: Vec<f64> = w[0].iter().zip(&w[1]).map(|(a, b)| a - b).collect();
        let (new, theta, columns, fraction) = match self.secant.as_mut() {
            Some(s) => {
                if p == 1 {
                    s.estimate_spectrum(&w[di], &w[ci]);
                }
                let signs = one.sign_conditions();
                let step = s.step(lambda, &d, &one.contact.active, signs);
                let (columns, fraction) = (Some(step.columns), Some(step.fraction));
                (step.lambda, step.theta, columns, fraction)
            }
            None => {
                let theta = ctx.settings.relaxation.plain_theta();
                let new = lambda.iter().zip(&d).map(|(l, d)| l + theta * d).collect();
                (new, theta, None, None)
            }
        };
        let dl: Vec<f64> = new.iter().zip(lambda).map(|(a, b)| a - b).collect();
        let step = match self.secant {
            Some(_) => norm(&dl).max(theta * norm(&d)),
            None => norm(&dl),
        };
        let nl = norm(&new);
        Update {
            lambda: new,
            theta,
            columns,
            fraction,
            change: if nl > 0.0 { step / nl } else { step },
        }
    }

    /// Step 6, the verdict of iteration p, whose record is the history's last (as Clarabel's
    /// `check_termination`): diverged (a change that is not finite, or a growing ‖R‖,
    /// [`diverging`]), converged (change ≤ tol and the force balance ≤ force_tol: a short step
    /// alone is not convergence where a stiff body's forces amplify what is left of λ's
    /// error), balanced (the estimate of this iteration says so), stagnated (no smaller change
    /// in [`STAGNATION_STEPS`] iterations), or none: go on. `-nndd_stop none` goes on but for
    /// a change that is not finite, or balance.
    fn check_termination(
        &mut self,
        settings: &NnddSettings,
        p: usize,
        m: Measures,
        balanced: bool,
    ) -> Option<Status> {
        let use_tol = settings.stop != StopRule::None;
        let change = m.change;
        if !change.is_finite() || !m.force_balance.is_finite() {
            return Some(Status::Diverged);
        }
        if use_tol && change <= settings.tol && m.force_balance <= settings.force_tol {
            return Some(Status::Converged);
        }
        if balanced {
            return Some(Status::Balanced);
        }
        // Progress: the distance to convergence, the larger of the two measures over their
        // tolerances.
        let distance = (change / settings.tol).max(m.force_balance / settings.force_tol);
        if distance < self.best {
            self.best = distance;
            self.best_at = p;
        }
        if use_tol && diverging(&self.history) {
            Some(Status::Diverged)
        } else if use_tol && p - self.best_at >= STAGNATION_STEPS {
            Some(Status::Stagnated)
        } else {
            None
        }
    }

    /// Iteration p done: the next starts at `lambda`, its QP warm-started from `active`.
    fn advance(&mut self, p: usize, lambda: Vec<f64>, active: &[bool]) {
        self.iteration = p;
        self.lambda = lambda;
        self.active = active.to_vec();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn history(residuals: &[f64]) -> Vec<IterationRecord> {
        residuals
            .iter()
            .enumerate()
            .map(|(k, &r)| IterationRecord {
                iteration: k + 1,
                residual: r,
                ..Default::default()
            })
            .collect()
    }

    #[test]
    fn only_a_growing_residual_is_divergence() {
        // Down, then up five times in a row to 10 times the smallest: diverging.
        let up = [1.0, 0.1, 0.2, 0.4, 0.8, 1.6, 3.2];
        assert!(diverging(&history(&up)));
        // Up five times but still below 10 times the smallest: not yet.
        assert!(!diverging(&history(&[1.0, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0])));
        // Reducing ‖R‖ (however ‖Δλ‖ goes), or growth broken by one decrease: not diverging.
        assert!(!diverging(&history(&[
            1.0, 0.5, 0.25, 0.12, 0.06, 0.03, 0.01
        ])));
        assert!(!diverging(&history(&[1.0, 0.1, 0.2, 0.4, 0.3, 1.6, 3.2])));
        assert!(!diverging(&history(&up[..5])));
    }

    #[test]
    fn theta_is_auto_or_a_positive_number() {
        assert_eq!(Relaxation::parse(" auto ").unwrap(), Relaxation::Auto);
        assert_eq!(Relaxation::parse("0.250").unwrap(), Relaxation::Fixed(0.25));
        assert_eq!(Relaxation::Fixed(0.25).text(), "0.25");
        assert_eq!(Relaxation::Auto.text(), "auto");
        for bad in ["0", "-0.5", "quarter", "inf", "NaN"] {
            let e = Relaxation::parse(bad).unwrap_err().to_string();
            assert_eq!(
                e,
                format!("-nndd_theta must be a number > 0, or auto (got {bad})")
            );
        }
    }

    #[test]
    fn the_verdict_of_an_iteration() {
        let tol = NnddSettings::default();
        let mut state = LoopState {
            iteration: 0,
            lambda: Vec::new(),
            history: history(&[1.0]),
            active: Vec::new(),
            secant: None,
            best: f64::INFINITY,
            best_at: 0,
        };
        let at = |change: f64, force_balance: f64| Measures {
            change,
            force_balance,
        };
        let diverged = Some(Status::Diverged);
        assert_eq!(
            state.check_termination(&tol, 1, at(f64::NAN, 0.0), false),
            diverged
        );
        assert_eq!(
            state.check_termination(&tol, 1, at(0.0, f64::NAN), false),
            diverged
        );
        let converged = Some(Status::Converged);
        assert_eq!(
            state.check_termination(&tol, 1, at(1e-9, 1e-9), false),
            converged
        );
        // A short step whose forces do not balance is not convergence.
        assert_eq!(
            state.check_termination(&tol, 1, at(1e-9, 1e-3), false),
            None
        );
        let balanced = Some(Status::Balanced);
        assert_eq!(
            state.check_termination(&tol, 1, at(1e-3, 1e-3), true),
            balanced
        );
        assert_eq!(
            state.check_termination(&tol, 1, at(1e-3, 1e-3), false),
            None
        );
        // No nearer convergence in 50 iterations (the forces count: a change of 1e-12 with a
        // force balance of 1e-2 is farther than 1e-9 and 1e-3).
        assert_eq!(
            state.check_termination(&tol, 50, at(1e-12, 1e-2), false),
            None
        );
        let stagnated = Some(Status::Stagnated);
        assert_eq!(
            state.check_termination(&tol, 51, at(1e-2, 1e-9), false),
            stagnated
        );
        // -nndd_stop none: neither the tolerance nor stagnation stops it.
        let none = NnddSettings {
            stop: StopRule::None,
            ..NnddSettings::default()
        };
        assert_eq!(
            state.check_termination(&none, 120, at(1e-12, 0.0), false),
            None
        );
        assert_eq!(
            state.check_termination(&none, 200, at(1.0, 1.0), false),
            None
        );
    }
}
