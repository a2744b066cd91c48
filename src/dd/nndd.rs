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

use crate::dd::body::{Body, BodyError};
use crate::dd::check::{check_solution, SolutionCheck};
use crate::dd::contact::{ContactError, ContactStep};
use crate::dd::dirichlet::DirichletStep;
use crate::dd::neumann::NeumannStep;
use crate::dd::secant::SecantUpdate;
use crate::parallel::fault::{self, InjectedFault, Phase};
use crate::parallel::layout::Layout;
use crate::petsc::log::{Stages, Timer};
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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopRule {
    /// ‖λ_{p+1} − λ_p‖ ≤ tol ‖λ_{p+1}‖ (docs/method.md §2 step 6).
    Tol,
    /// Also at the first estimated iteration where η^NNDD ≤ κ η^FE (the algebra no longer
    /// matters next to the mesh): the observer of [`solve`] says when.
    Balanced,
    /// Exactly `max_it` iterations (studies at a fixed iteration count).
    None,
}

/// The settings of the NNDD loop (plain data).
#[derive(Clone, Debug)]
pub struct NnddSettings {
    /// Relaxation θ of the update λ ← λ + θ (w¹ − w²)·n (with `auto`, only the θ of a first
    /// step without a stiffness estimate, see [`crate::dd::secant::SecantUpdate::new`]).
    pub theta: f64,
    /// `-nndd_theta auto`: the secant update of [`crate::dd::secant`] (Anderson acceleration
    /// restarted at contact-set changes) instead of the fixed θ.
    pub auto: bool,
    /// Stopping tolerance on ‖λ_{p+1} − λ_p‖ / ‖λ_{p+1}‖.
    pub tol: f64,
    pub max_it: usize,
    pub stop: StopRule,
    /// The body of the Dirichlet step (1, as in the paper, or 2): λ is its normal Γc
    /// displacement, and the other body's contact step holds it behind λ (docs/method.md §2,
    /// "Which body takes the Dirichlet step").
    pub dirichlet_body: usize,
}

impl NnddSettings {
    /// The body of the contact step.
    pub fn contact_body(&self) -> usize {
        3 - self.dirichlet_body
    }
}

impl Default for NnddSettings {
    /// The paper's fixed θ = 0.25 and tol 1e−8 (the command line's default is `auto`).
    fn default() -> Self {
        NnddSettings {
            theta: 0.25,
            auto: false,
            tol: 1e-8,
            max_it: 1000,
            stop: StopRule::Tol,
            dirichlet_body: 1,
        }
    }
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

/// The state the loop ends in: the fields of the last step 1 (at λ_p) and their data.
#[derive(Clone, Debug)]
pub struct Iterate {
    /// u¹_{p,n}, body 1's normal Γc displacement (λ_p itself when body 1 takes the Dirichlet
    /// step).
    pub lambda: Vec<f64>,
    /// λ_p, the Dirichlet body's normal Γc displacement (the loop's variable).
    pub interface: Vec<f64>,
    /// u¹_p on body 1's ranks, u²_p on body 2's (empty elsewhere; formed after the loop, for
    /// the reported step, where the steps did not produce them).
    pub u: [Vec<f64>; 2],
    /// T¹_p, T²_p on the Γc normal dofs (known on every rank).
    pub forces: [Vec<f64>; 2],
    /// The body whose contact step gave its forces (2, or 1 with the Dirichlet step on body 2;
    /// 2 for the monolithic solve, whose multiplier is T²).
    pub contact_body: usize,
    /// u²_{p,n}, body 2's normal Γc trace (known on every rank once the fields are formed).
    pub trace2: Vec<f64>,
    pub active: Vec<bool>,
    /// Relative KKT violation of the contact QP of this step.
    pub qp_kkt: f64,
    /// The iteration p.
    pub iteration: usize,
}

impl Iterate {
    /// The contact forces on body 2, ≥ 0 in compression and 0 off the contact set: the
    /// contact step's multipliers, T² or −T¹ (the Dirichlet step's reaction on the other body
    /// equals them only up to the defect R).
    pub fn contact_forces(&self) -> Vec<f64> {
        if self.contact_body == 2 {
            self.forces[1].clone()
        } else {
            self.forces[0].iter().map(|f| -f).collect()
        }
    }
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

/// Iterations in a row whose ‖R‖ grows before a run is called diverged.
const DIVERGING_STEPS: usize = 5;

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

/// What the contact body's root shares of a contact step: the contact set, the QP's KKT
/// residual, iterations and method, the gaps and the body's normal Γc trace, packed into one
/// broadcast.
struct ContactShare {
    active: Vec<bool>,
    kkt: f64,
    iterations: u32,
    clarabel: bool,
    gaps: Vec<f64>,
    trace: Vec<f64>,
}

impl ContactShare {
    fn pack(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.active.iter().map(|&a| a as u8 as f64).collect();
        v.extend([self.kkt, self.iterations as f64, self.clarabel as u8 as f64]);
        v.extend(&self.gaps);
        v.extend(&self.trace);
        v
    }

    fn unpack(v: &[f64], m: usize) -> ContactShare {
        ContactShare {
            active: v[..m].iter().map(|&a| a > 0.5).collect(),
            kkt: v[m],
            iterations: v[m + 1] as u32,
            clarabel: v[m + 2] > 0.5,
            gaps: v[m + 3..2 * m + 3].to_vec(),
            trace: v[2 * m + 3..].to_vec(),
        }
    }
}

/// u²_n, the normal Γc trace of body 2's field `u2` (on its ranks), broadcast to every rank
/// (collective).
pub fn shared_trace2(layout: &Layout, body2: Option<&Body>, u2: &[f64], m: usize) -> Vec<f64> {
    let mut trace = body2.map_or(vec![0.0; m], |b| b.normal_trace(u2));
    layout.share(2, &mut trace);
    trace
}

/// Form u¹_p and u²_p on their owners where the steps did not (condensed steps give only the
/// Γc forces).
fn form_fields(
    layout: &Layout,
    it: &mut Iterate,
    bodies: [Option<&Body>; 2],
    steps: &Steps,
    stages: &Stages,
    timers: &mut LoopTimers,
) -> Result<(), NnddError> {
    let (dirichlet, contact) = (steps.dirichlet, steps.contact);
    let (di, ci) = (steps.dirichlet_body - 1, 2 - steps.dirichlet_body);
    let _s = stages.fields.enter();
    if let (Some(b), Some(d)) = (bodies[di], dirichlet) {
        if it.u[di].is_empty() {
            it.u[di] = timers
                .fields
                .time(|| d.field(b, &it.interface, &it.forces[di]))?;
        }
    }
    if let (Some(b), Some(c)) = (bodies[ci], contact) {
        if it.u[ci].is_empty() {
            it.u[ci] = timers
                .fields
                .time(|| c.field(b, &it.forces[ci], &it.interface, &it.active))?;
        }
    }
    it.trace2 = shared_trace2(layout, bodies[1], &it.u[1], it.lambda.len());
    Ok(())
}

/// What the loop needs to continue after iteration `iteration` (a restart point): written by
/// `-nndd_checkpoint_every` and on a signal, read by `-nndd_restart`. The same on every rank.
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

/// Run the NNDD loop on `m` Γc node pairs. `bodies[α-1]` is `Some` on the ranks owning body
/// α, with `steps` set up there (the Dirichlet step on the ranks of `steps.dirichlet_body`,
/// the contact step on the other body's, each body's Neumann step on its own). Every `estimate_every`
/// iterations (if set), the fields of step p are formed and `observer.estimate` is called
/// with the iterate (collectively). A run continues from `start` (`-nndd_restart`) when
/// given. Errors of type `E` (which the loop's own errors convert into) end the loop.
#[allow(clippy::too_many_arguments)]
pub fn solve<E: From<NnddError>>(
    settings: &NnddSettings,
    m: usize,
    layout: &Layout,
    bodies: [Option<&Body>; 2],
    steps: &Steps,
    stages: &Stages,
    estimate_every: Option<usize>,
    start: Option<LoopState>,
    observer: &mut impl Observer<E>,
) -> Result<NnddResult, E> {
    let mut timers = LoopTimers::default();
    let mut status = Status::MaxIterations;
    let mut last: Option<Iterate> = None;
    let fresh = LoopState {
        iteration: 0,
        lambda: vec![0.0; m],
        history: Vec::new(),
        active: Vec::new(),
        secant: settings
            .auto
            .then(|| SecantUpdate::new(settings.theta, SECANT_MEMORY.min(m.max(1)))),
        best: f64::INFINITY,
        best_at: 0,
    };
    let resumed = start.is_some();
    let LoopState {
        iteration: done,
        mut lambda,
        mut history,
        active: warm,
        mut secant,
        mut best,
        mut best_at,
    } = start.unwrap_or(fresh);
    let (dirichlet, contact) = (steps.dirichlet, steps.contact);
    let (di, ci) = (steps.dirichlet_body - 1, 2 - steps.dirichlet_body);
    // The sign of the contact body's multipliers: T² ≥ 0 on body 2, T¹ ≤ 0 on body 1.
    let sigma = if ci == 1 { 1.0 } else { -1.0 };
    if let (Some(c), true) = (contact, resumed && !warm.is_empty()) {
        c.set_warm_start(warm);
    }
    for p in done + 1..=settings.max_it {
        // Step 1: the Dirichlet problem at λ_p and the other body's contact problem behind
        // λ_p, concurrently; t[α − 1] = T^α_p.
        let mut t = [vec![0.0; m], vec![0.0; m]];
        let mut u_dirichlet = Vec::new();
        if let (Some(b), Some(d)) = (bodies[di], dirichlet) {
            let _s = stages.dirichlet_step.enter();
            let (u, f) = timers
                .dirichlet_step
                .time(|| d.solve(b, &lambda))
                .map_err(NnddError::from)?;
            u_dirichlet = u.unwrap_or_default();
            t[di] = f;
        }
        let mut act = ContactShare {
            active: vec![false; m],
            kkt: 0.0,
            iterations: 0,
            clarabel: false,
            gaps: vec![0.0; m],
            trace: vec![0.0; m],
        }
        .pack();
        fault::check(Phase::Qp).map_err(NnddError::from)?;
        // The contact QP lives on Γc: the contact body's root solves it, the broadcast below
        // shares it.
        if let (Some(b), Some(c)) = (bodies[ci].filter(|b| b.is_root()), contact) {
            let _s = stages.contact_step.enter();
            let sol = timers
                .contact_step
                .time(|| c.solve(b, &lambda))
                .map_err(NnddError::from)?;
            t[ci] = sol.forces;
            act = ContactShare {
                active: sol.active,
                kkt: sol.kkt_residual,
                iterations: sol.qp_iterations,
                clarabel: sol.method == QpMethod::Clarabel,
                gaps: sol.gaps,
                trace: sol.trace,
            }
            .pack();
        }
        timers.exchange.time(|| {
            layout.share(di + 1, &mut t[di]);
            layout.share(ci + 1, &mut t[ci]);
            layout.share(ci + 1, &mut act);
        });
        let act = ContactShare::unpack(&act, m);
        let [t1, t2] = t;
        // Step 3: equilibrium defect.
        let r: Vec<f64> = t1.iter().zip(&t2).map(|(a, b)| a + b).collect();
        // Step 4: two Neumann problems.
        let mut w1 = vec![0.0; m];
        let mut w2 = vec![0.0; m];
        {
            let _s = stages.neumann_step.enter();
            fault::check(Phase::Ksp).map_err(NnddError::from)?;
            if let (Some(b1), Some(n)) = (bodies[0], steps.neumann[0]) {
                w1 = timers
                    .neumann_step
                    .time(|| n.solve(b1, &r))
                    .map_err(NnddError::from)?;
            }
            if let (Some(b2), Some(n)) = (bodies[1], steps.neumann[1]) {
                w2 = timers
                    .neumann_step
                    .time(|| n.solve(b2, &r))
                    .map_err(NnddError::from)?;
            }
        }
        timers.exchange.time(|| {
            layout.share(1, &mut w1);
            layout.share(2, &mut w2);
        });
        // Step 5: update, λ + θ d or the secant update of `-nndd_theta auto`.
        let d: Vec<f64> = (0..m).map(|i| w1[i] - w2[i]).collect();
        let active_now = act.active.clone();
        let (new, theta, columns, fraction) = match secant.as_mut() {
            Some(s) => {
                if p == 1 {
                    let w = [&w1, &w2];
                    s.estimate_spectrum(w[di], w[ci]);
                }
                // The sign conditions of the contact step: its multipliers (T² ≥ 0, or
                // −T¹ ≥ 0) on the contact set, gap ≥ 0 off it (each affine in λ while the set
                // stays).
                let tc = if ci == 1 { &t2 } else { &t1 };
                let signs: Vec<f64> = (0..m)
                    .map(|i| {
                        if active_now[i] {
                            sigma * tc[i]
                        } else {
                            act.gaps[i]
                        }
                    })
                    .collect();
                let step = s.step(&lambda, &d, &active_now, &signs);
                (
                    step.lambda,
                    step.theta,
                    Some(step.columns),
                    Some(step.fraction),
                )
            }
            None => (
                (0..m).map(|i| lambda[i] + settings.theta * d[i]).collect(),
                settings.theta,
                None,
                None,
            ),
        };
        let dl: Vec<f64> = new.iter().zip(&lambda).map(|(a, b)| a - b).collect();
        // With θ auto a step may be short while the iterate is not converged (the secant
        // correction cancels most of θ d, or stops at a predicted change of the contact set):
        // the change measured is then also the plain step θ d_p, the fixed-θ iteration's.
        let step = match secant {
            Some(_) => norm(&dl).max(theta * norm(&d)),
            None => norm(&dl),
        };
        let nl = norm(&new);
        let change = if nl > 0.0 { step / nl } else { step };
        let record = IterationRecord {
            iteration: p,
            lambda_change: change,
            residual: norm(&r),
            active: act.active.iter().filter(|&&a| a).count(),
            qp_iterations: act.iterations,
            qp_solver: if act.clarabel {
                QpMethod::Clarabel
            } else {
                QpMethod::ActiveSet
            }
            .name()
            .into(),
            theta,
            secant_columns: columns,
            secant_fraction: fraction,
            eta_glo: None,
            eta_fe: None,
            eta_nndd: None,
            eta_ratio: None,
            e_ref: None,
            effectivity: None,
        };
        let mut u = [Vec::new(), Vec::new()];
        u[di] = u_dirichlet;
        let (trace1, trace2) = if di == 0 {
            (lambda.clone(), Vec::new())
        } else {
            (act.trace.clone(), lambda.clone())
        };
        let mut it = Iterate {
            lambda: trace1,
            interface: lambda.clone(),
            u,
            forces: [t1, t2],
            contact_body: ci + 1,
            trace2,
            active: active_now,
            qp_kkt: act.kkt,
            iteration: p,
        };
        let mut balanced = false;
        if estimate_every.is_some_and(|k| p % k == 0) && observer.wants_estimate(&it)? {
            form_fields(layout, &mut it, bodies, steps, stages, &mut timers)?;
            balanced = observer.estimate(&it)?;
        }
        observer.monitor(&record);
        history.push(record);
        // Step 6: stop? (all ranks computed the same numbers; rank 0 decides for all)
        let use_tol = settings.stop != StopRule::None;
        let verdict = if !change.is_finite() {
            Some(Status::Diverged)
        } else if use_tol && change <= settings.tol {
            Some(Status::Converged)
        } else if balanced {
            Some(Status::Balanced)
        } else {
            if change < best {
                best = change;
                best_at = p;
            }
            if use_tol && diverging(&history) {
                Some(Status::Diverged)
            } else if use_tol && p - best_at >= 50 {
                Some(Status::Stagnated)
            } else {
                None
            }
        };
        // Rank 0 decides for all (every rank computed the same numbers); a signal on any
        // rank stops all at the end of this iteration.
        let (code, interrupted) =
            layout.agree_stop(verdict.map_or(0u8, |s| s as u8 + 1), observer.interrupted());
        let stop = Status::from_code(code);
        let continues = stop.is_none() && p < settings.max_it;
        if interrupted && continues {
            status = Status::Interrupted;
        }
        if continues && (interrupted || observer.checkpoint_due(p)) {
            let active = it.active.clone();
            observer.checkpoint(&LoopState {
                iteration: p,
                lambda: new.clone(),
                history: history.clone(),
                active,
                secant: secant.clone(),
                best,
                best_at,
            })?;
        }
        last = Some(it);
        if let Some(s) = stop {
            status = s;
            break;
        }
        if status == Status::Interrupted {
            break;
        }
        lambda = new;
    }
    let iterations = history.len();
    let mut last = last.expect("the loop runs at least once (checked by the restart)");
    // The fields of the reported step (the loop needs only the Γc forces), checked.
    form_fields(layout, &mut last, bodies, steps, stages, &mut timers)?;
    let check = timers
        .check
        .time(|| check_solution(layout, &last, bodies))
        .map_err(NnddError::from)?;
    if status.succeeded() {
        if let Some(what) = check.failure() {
            return Err(NnddError::CheckFailed {
                run: format!("the NNDD {} after {iterations} iterations", status.name()),
                what,
            }
            .into());
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
}
