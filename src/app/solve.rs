//! The solve and its estimates: the bodies' setup, the NNDD loop (estimating where asked,
//! and the balanced stopping rule) or the monolithic check (the reference solution of (26):
//! `app::reference`).

use std::rc::Rc;
use std::time::Instant;

use super::agreed;
use super::options::{Settings, SettingsError, SolverKind};
use super::reported::{attach_estimates, keep_for_output, resolve_reported, Pending};
use super::{AppError, LONG_PHASE_DOFS};
use crate::dd::body::{uses_superlu_dist, Body, BodyError, SchurMode, SchurSource};
use crate::dd::check::check_solution;
use crate::dd::contact::ContactStep;
use crate::dd::dirichlet::{DirichletChoice, DirichletStep};
use crate::dd::friction::Friction;
use crate::dd::monolithic;
use crate::dd::neumann::{NeumannChoice, NeumannStep};
use crate::dd::nndd::{
    self, Iterate, IterationRecord, LoopState, LoopTimers, NnddError, Status, Steps, StopRule,
};
use crate::estimate::{BalancedRule, EstimateError, EstimateRecord, Estimator};
use crate::io::checkpoint::{self, Checkpoint, Identity};
use crate::io::monitor;
use crate::io::summary::Timings;
use crate::os::signals::{self, StopPhase};
use crate::parallel::fault::{self, Agreement, Phase};
use crate::parallel::layout::Layout;
use crate::parallel::partition::{Partition, Partitioner};
use crate::petsc;
use crate::petsc::log::Stages;
use crate::problem::{BodyProblem, Support};

/// What a solver hands to post-processing.
pub struct Solution {
    pub status: String,
    pub stop_reason: &'static str,
    pub converged: bool,
    /// The run ended as asked (converged, balanced, or the fixed iteration count).
    pub requested: bool,
    /// A signal stopped it (a restart point was written).
    pub interrupted: bool,
    pub iterations: usize,
    pub history: Vec<IterationRecord>,
    /// The reported iterate (λ = u¹_n, T¹, T², contact set, fields on their owners).
    pub last: Iterate,
    /// The estimates, in iteration order (the last one is of `last` when estimating).
    pub estimates: Vec<EstimateRecord>,
    pub dirichlet_step: &'static str,
    /// Each body's Neumann step (on the ranks of its group; `None` elsewhere and for the
    /// monolithic solve).
    pub neumann_step: [Option<NeumannStep>; 2],
    /// The a-posteriori check of the reported iterate.
    pub check: Option<crate::dd::check::SolutionCheck>,
    /// What the checks of the solution found that the user should know (printed, and in the
    /// summary's `warnings`).
    pub warnings: Vec<String>,
    /// The largest penetration over the whole contact curves (after the checks).
    pub penetration: Option<crate::dd::penetration::Penetration>,
    /// The reported iterate's estimate between its parts: re-solved, its recoveries left to
    /// [`super::reported::finish_reported`] once the bodies are freed.
    pub pending: Option<Pending>,
}

/// Meshes, assembly and factorisation of the bodies this rank owns: `owned`, the problems of
/// its group's bodies ([`owned`]; `None` for the others).
pub fn setup_bodies(
    settings: &Settings,
    owned: [Option<&Rc<BodyProblem>>; 2],
    partitions: [Option<Partition>; 2],
    layout: &Layout,
    stages: &Stages,
    timings: &mut Timings,
) -> Result<[Option<Body>; 2], AppError> {
    let nndd_run = settings.solver == SolverKind::Nndd;
    let mut bodies: [Option<Body>; 2] = [None, None];
    for (alpha, partition) in [1, 2].into_iter().zip(partitions) {
        let (Some(problem), Some(partition)) = (owned[alpha - 1], partition) else {
            continue;
        };
        // Every body forms its interface operators where its factorisation gives them (MUMPS,
        // on any rank count), body 2 always (its contact step is condensed); with
        // SuperLU_DIST, `auto` condenses body 1's Dirichlet step (S¹ from back-solves) rather
        // than factor a second system on its communicator (`uses_superlu_dist`).
        let superlu_dist = uses_superlu_dist(alpha)?;
        let contact_body = settings.nndd.contact_body();
        let held = problem.support == Support::Conditions;
        let schur = match (settings.solver, alpha, settings.nndd.dirichlet_step) {
            // A body held only by contact has no Neumann system to condense.
            _ if !held => SchurMode::None,
            (SolverKind::Monolithic, _, _) => SchurMode::Always,
            (_, a, _) if a == contact_body => SchurMode::Always,
            _ if settings.nndd.neumann_step == NeumannChoice::Condensed => SchurMode::Always,
            (_, _, DirichletChoice::Auto) if superlu_dist => SchurMode::Always,
            (_, _, DirichletChoice::Condensed) => SchurMode::Always,
            (_, _, DirichletChoice::Auto | DirichletChoice::System) => SchurMode::IfFactored,
        };
        let mut body = set_up_body(settings, problem, partition, layout, schur, stages)?;
        let system =
            settings.nndd.dirichlet_step == DirichletChoice::System || !body.has_condensed();
        // A body held only by contact takes the Dirichlet step, and the monolithic solve
        // condenses it through its Dirichlet system too (`monolithic::solve`).
        if (nndd_run && alpha == settings.nndd.dirichlet_body && system) || !held {
            body.add_dirichlet_system(stages)
                .map_err(|e| unknown_type(e, alpha))?;
        }
        timings.assembly += body.setup_seconds.0;
        timings.factorisation += body.setup_seconds.1;
        timings.interface += body.setup_seconds.2;
        bodies[alpha - 1] = Some(body);
    }
    Ok(bodies)
}

/// The partition of each body this rank's group works on, by `how` ([`Partition::on_group`]:
/// METIS on the group's first rank, or the output's index blocks; `None` for the others).
pub fn partitions(
    owned: [Option<&Rc<BodyProblem>>; 2],
    layout: &Layout,
    how: Partitioner,
) -> Result<[Option<Partition>; 2], AppError> {
    let mut parts = [None, None];
    for (alpha, problem) in [1, 2].into_iter().zip(owned) {
        if let Some(p) = problem {
            parts[alpha - 1] = Some(Partition::on_group(p.mesh(), alpha, layout, how)?);
            // METIS's work arrays (on the group's first rank) back to the system before the
            // assembly and the factorisation allocate theirs.
            crate::os::memory::release_free_memory(0);
        }
    }
    Ok(parts)
}

/// The problems of the bodies this rank's group works on (`None` for the others).
pub fn owned<'a>(
    problems: &'a [Rc<BodyProblem>; 2],
    layout: &Layout,
) -> [Option<&'a Rc<BodyProblem>>; 2] {
    [1, 2].map(|alpha| layout.owns(alpha).then(|| &problems[alpha - 1]))
}

/// The bodies of a mortar run's matched problems (its estimates' re-solves,
/// [`crate::estimate::mortar::MortarEstimates`]): factored on the run's groups, without
/// interface operators, each on this rank's partition `given` (world rank 0's, where it dealt
/// them) or on the partitions the groups make.
pub fn setup_matched_bodies(
    settings: &Settings,
    problems: &[Rc<BodyProblem>; 2],
    given: Option<[Option<Partition>; 2]>,
    layout: &Layout,
    stages: &Stages,
    timings: &mut Timings,
) -> Result<[Option<Body>; 2], AppError> {
    let mut bodies: [Option<Body>; 2] = [None, None];
    let how = settings.problem.partitioner;
    let parts = match given {
        Some(parts) => parts,
        None => partitions(owned(problems, layout), layout, how)?,
    };
    for (alpha, partition) in [1, 2].into_iter().zip(parts) {
        if let Some(partition) = partition {
            let problem = &problems[alpha - 1];
            let schur = SchurMode::None;
            let body = set_up_body(settings, problem, partition, layout, schur, stages)?;
            timings.assembly += body.setup_seconds.0;
            timings.factorisation += body.setup_seconds.1;
            // (the carried iterate held at the rank's block of the nodes, Γc and the outline)
            body.keep_fields_at(layout.block(alpha, problem.num_nodes()), []);
            bodies[alpha - 1] = Some(body);
        }
    }
    Ok(bodies)
}

/// One body's assembly and factorisation on its `partition` (with its interface operators as
/// `schur` says), on its group.
fn set_up_body(
    settings: &Settings,
    problem: &Rc<BodyProblem>,
    partition: Partition,
    layout: &Layout,
    schur: SchurMode,
    stages: &Stages,
) -> Result<Body, AppError> {
    let alpha = problem.alpha;
    announce_setup(alpha, problem, layout)?;
    Body::setup(
        Rc::clone(problem),
        layout.own_body_comm(),
        partition,
        schur,
        settings.schur,
        settings.friction.interface(),
        stages,
    )
    .map_err(|e| unknown_type(e, alpha))
}

/// A solver option of body α naming a type PETSc does not know (`-body1_ksp_type foo`) is bad
/// input (exit 1, one line naming the option), not a failure of the solve; every rank of the
/// body's group meets it in the same call.
pub(super) fn unknown_type(e: BodyError, alpha: usize) -> AppError {
    let BodyError::Petsc(p) = &e else {
        return e.into();
    };
    match petsc::unknown_type_option(&format!("body{alpha}_"), p) {
        Some((option, value)) => SettingsError::named(
            &option,
            format!(
                "'{value}' is not a known type ({}; -help lists the types)",
                p.message
            ),
        )
        .into(),
        None => e.into(),
    }
}

/// Word before a body's setup that may take long (assembly, and a factorisation or an
/// iterative solver's setup with the interface operators from m solves), from its group's
/// first rank.
fn announce_setup(alpha: usize, problem: &BodyProblem, layout: &Layout) -> Result<(), AppError> {
    let dofs = problem.num_dofs();
    if dofs < LONG_PHASE_DOFS || layout.group_rank() != 0 {
        return Ok(());
    }
    let pc = petsc::option_string(&format!("-body{alpha}_pc_type"))?;
    let how = match pc.as_deref() {
        None | Some("cholesky") | Some("lu") => format!(
            "factoring (-body{alpha}_pc_type {})",
            pc.as_deref().unwrap_or("cholesky")
        ),
        Some(other) => format!(
            "setting up -body{alpha}_pc_type {other}, the interface operators from {} solves",
            problem.interface_dofs().len()
        ),
    };
    println!(
        "nndd: body {alpha}: {dofs} dofs on {} rank(s): assembling and {how} …",
        layout.group_sizes[alpha - 1]
    );
    Ok(())
}

/// Where the restart points go, and where a run starts from.
pub struct Restart<'a> {
    /// The identity of this run's problem (written into each checkpoint).
    pub identity: Identity,
    /// Where to write them (`PREFIX.checkpoint.json`).
    pub path: std::path::PathBuf,
    /// The checkpoint this run continues from.
    pub from: Option<Checkpoint>,
    pub agreement: &'a Agreement,
}

/// The NNDD loop's caller: the estimates at the estimated iterations and the balanced
/// stopping rule, the monitor, the signals, and the restart points.
struct RunObserver<'a> {
    settings: &'a Settings,
    layout: &'a Layout,
    refs: [Option<&'a Body>; 2],
    estimator: Option<&'a Estimator<'a>>,
    stages: &'a Stages,
    m: usize,
    estimates: Vec<EstimateRecord>,
    /// Balanced stopping: κ, the last full η^FE, the cheap checks.
    balanced: BalancedRule,
    /// The time spent estimating.
    seconds: f64,
    restart: Option<&'a Restart<'a>>,
    /// When the loop started (the monitor's elapsed time).
    started: Instant,
}

impl<'a> RunObserver<'a> {
    /// The observer of the loop `ctx`, continuing the balanced rule's state of the restart
    /// point `from`.
    fn new(
        settings: &'a Settings,
        ctx: &nndd::Context<'a>,
        estimator: Option<&'a Estimator<'a>>,
        restart: Option<&'a Restart<'a>>,
        from: Option<&Checkpoint>,
    ) -> RunObserver<'a> {
        let mut balanced = BalancedRule::new(&settings.nndd.stop, settings.estimate.nndd_variant);
        if let Some(c) = from {
            balanced = balanced.resumed(c.balanced_fe, c.checks.clone());
        }
        RunObserver {
            settings,
            layout: ctx.layout,
            refs: ctx.bodies,
            estimator,
            stages: ctx.stages,
            m: ctx.m,
            estimates: Vec::new(),
            balanced,
            seconds: 0.0,
            restart,
            started: Instant::now(),
        }
    }

    /// `f` in the Estimation stage, its time counted. A stop signal during it (`Stopped`)
    /// means no estimate: the loop stops at this iteration's end.
    fn timed(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<bool, EstimateError>,
    ) -> Result<bool, AppError> {
        let stages = self.stages;
        let t = Instant::now();
        let _s = stages.estimation.enter();
        let r = f(self);
        self.seconds += t.elapsed().as_secs_f64();
        match r {
            Err(EstimateError::Stopped) => Ok(false),
            r => Ok(r?),
        }
    }
}

impl nndd::Observer<AppError> for RunObserver<'_> {
    /// The balanced rule's cheap check (the Γc forces alone, without the fields): an estimate
    /// only when the rule may hold.
    fn wants_estimate(&mut self, it: &Iterate) -> Result<bool, AppError> {
        let (Some(est), refs) = (self.estimator, self.refs) else {
            return Ok(true);
        };
        self.timed(|o| o.balanced.may_hold(est, refs, it))
    }

    fn estimate(&mut self, it: &Iterate) -> Result<bool, AppError> {
        let (Some(est), refs) = (self.estimator, self.refs) else {
            return Ok(false);
        };
        self.timed(|o| {
            if !o.balanced.may_hold_with_fields(est, refs, it)? {
                return Ok(false);
            }
            let rec = est.estimate(refs, it)?;
            let holds = o.balanced.holds(&rec);
            keep_for_output(&mut o.estimates, o.layout, est);
            o.estimates.push(rec);
            Ok(holds)
        })
    }

    fn monitor(&mut self, r: &IterationRecord) {
        if self.settings.output.monitor && self.layout.is_root() {
            monitor::monitor_line(
                r,
                self.settings.friction.interface().pairs(self.m),
                self.started.elapsed().as_secs_f64(),
                self.estimates.last().filter(|e| e.iteration == r.iteration),
            );
        }
    }

    fn interrupted(&self) -> bool {
        self.restart.is_some() && signals::stop_requested()
    }

    fn checkpoint_due(&self, p: usize) -> bool {
        let k = self.settings.checkpoint_every;
        self.restart.is_some() && k > 0 && p.is_multiple_of(k)
    }

    fn checkpoint(&mut self, state: &LoopState) -> Result<(), AppError> {
        let Some(restart) = self.restart else {
            return Ok(());
        };
        let mut state = state.clone();
        attach_estimates(&mut state.history, &self.estimates);
        self.balanced.attach_checks(&mut state.history);
        let cp = Checkpoint {
            format: checkpoint::FORMAT.into(),
            identity: restart.identity.clone(),
            state,
            balanced_fe: self.balanced.last_fe(),
            checks: self.balanced.checks().to_vec(),
        };
        let written = fault::check(Phase::Checkpoint)
            .map_err(AppError::from)
            .and_then(|()| {
                if self.layout.is_root() {
                    checkpoint::write(&restart.path, &cp)?;
                }
                Ok(())
            });
        agreed(restart.agreement, written)?;
        if self.settings.output.monitor && self.layout.is_root() {
            println!(
                "nndd: restart point after iteration {} written to {}",
                cp.state.iteration,
                restart.path.display()
            );
        }
        Ok(())
    }
}

/// The NNDD loop (paper §3), estimating where asked; with `restart`, writing restart points
/// and stopping on a signal, or continuing from one.
pub fn solve_nndd(
    settings: &Settings,
    layout: &Layout,
    refs: [Option<&Body>; 2],
    estimator: Option<&Estimator>,
    stages: &Stages,
    timings: &mut Timings,
    restart: Option<&Restart>,
) -> Result<Solution, AppError> {
    let (dirichlet, contact) = set_up_steps(settings, refs, stages, timings)?;
    let dirichlet_name = dirichlet_step_name(layout, settings, dirichlet.as_ref());
    let n = &settings.nndd;
    let neumann = refs.map(|b| {
        b.map(|b| NeumannStep::new(b, n.neumann_step, n.neumann_bodies, n.dirichlet_body))
    });
    let steps = Steps {
        dirichlet_body: settings.nndd.dirichlet_body,
        dirichlet: dirichlet.as_ref(),
        contact: contact.as_ref(),
        neumann,
    };
    let ctx = nndd::Context {
        settings: &settings.nndd,
        // The number of Γc pairs (every rank holds at least one body).
        m: refs.iter().flatten().next().map_or(0, |b| b.pairs()),
        interface: settings.friction.interface(),
        layout,
        bodies: refs,
        steps: &steps,
        stages,
        estimate_every: Some(settings.estimate.every).filter(|&k| k > 0 && estimator.is_some()),
    };
    let from = restart.and_then(|r| r.from.clone());
    let mut observer = RunObserver::new(settings, &ctx, estimator, restart, from.as_ref());
    // The run's own loop stops at the end of an iteration on a signal (the reference
    // solve's, without restart points, ends at once: its phase stays).
    if restart.is_some() {
        signals::enter(StopPhase::Deferred);
    }
    let res = nndd::solve::<AppError>(&ctx, from.map(|c| c.state), &mut observer)?;
    let RunObserver {
        estimates,
        balanced,
        seconds,
        ..
    } = observer;
    let (reported, pending) = resolve_reported(settings, &ctx, estimator, &res, &estimates)?;
    timings.estimation += seconds + reported;
    add_loop_timings(timings, &res.timers, refs);
    let mut history = res.history;
    attach_estimates(&mut history, &estimates);
    balanced.attach_checks(&mut history);
    Ok(Solution {
        status: res.status.name().to_string(),
        stop_reason: res.status.stop_reason(),
        // A fixed iteration count asked for (-nndd_stop none) is a success too.
        converged: res.status.succeeded(),
        requested: res.status.succeeded()
            || (settings.nndd.stop == StopRule::None && res.status == Status::MaxIterations),
        interrupted: res.status == Status::Interrupted,
        iterations: res.iterations,
        history,
        last: res.last,
        estimates,
        dirichlet_step: dirichlet_name,
        neumann_step: neumann,
        check: Some(res.check),
        warnings: Vec::new(),
        penetration: None,
        pending,
    })
}

/// The Dirichlet step on its body's ranks and the contact step on the other body's (set up in
/// the Interface stage, their time counted as the interface operators').
fn set_up_steps(
    settings: &Settings,
    refs: [Option<&Body>; 2],
    stages: &Stages,
    timings: &mut Timings,
) -> Result<(Option<DirichletStep>, Option<ContactStep>), AppError> {
    let t = Instant::now();
    let s = stages.interface.enter();
    let (di, ci) = (
        settings.nndd.dirichlet_body - 1,
        settings.nndd.contact_body() - 1,
    );
    let dirichlet = refs[di]
        .map(|b| DirichletStep::new(b, settings.nndd.dirichlet_step))
        .transpose()?;
    let contact = refs[ci]
        .map(|b| {
            let friction = Friction::on(settings.friction, &b.problem);
            ContactStep::new(b, settings.contact.clone(), friction)
        })
        .transpose()?;
    drop(s);
    timings.interface += t.elapsed().as_secs_f64();
    Ok((dirichlet, contact))
}

/// The Dirichlet step's kind, `system` or `condensed`, from its body's ranks to every rank
/// (for the summary; collective).
fn dirichlet_step_name(
    layout: &Layout,
    settings: &Settings,
    dirichlet: Option<&DirichletStep>,
) -> &'static str {
    let mut system = [dirichlet.is_some_and(|d| d.is_system()) as u8 as f64];
    layout.share(settings.nndd.dirichlet_body, &mut system);
    DirichletStep::name_of(system[0] > 0.5)
}

/// The loop's phases (maxima over ranks later) and the checks into the run's timings.
fn add_loop_timings(timings: &mut Timings, timers: &LoopTimers, refs: [Option<&Body>; 2]) {
    timings.dirichlet_step = timers.dirichlet_step.seconds();
    timings.contact_step = timers.contact_step.seconds();
    timings.neumann_step = timers.neumann_step.seconds();
    timings.exchange = timers.exchange.seconds();
    timings.fields = timers.fields.seconds();
    timings.checks = timers.check.seconds()
        + refs
            .iter()
            .flatten()
            .map(|b| b.check_seconds())
            .sum::<f64>();
}

/// The discrete global contact problem at once (the NNDD's check).
pub fn solve_monolithic(
    settings: &Settings,
    layout: &Layout,
    refs: [Option<&Body>; 2],
    estimator: Option<&Estimator>,
    stages: &Stages,
    timings: &mut Timings,
) -> Result<Solution, AppError> {
    let t = Instant::now();
    let res = {
        let _s = stages.monolithic.enter();
        signals::enter(StopPhase::Monolithic);
        let friction = refs
            .iter()
            .flatten()
            .next()
            .and_then(|b| Friction::on(settings.friction, &b.problem));
        monolithic::solve(layout, refs, &settings.qp, friction.as_ref())?
    };
    timings.monolithic = t.elapsed().as_secs_f64();
    let mut lambda = refs[0].map(|b| b.trace(&res.u[0])).unwrap_or_default();
    layout.share_vec(1, &mut lambda);
    let trace2 = nndd::shared_trace2(layout, refs[1], &res.u[1], lambda.len());
    let mut last = Iterate {
        interface: lambda.clone(),
        lambda,
        trace2,
        u: res.u,
        forces: [res.forces.iter().map(|f| -f).collect(), res.forces.clone()],
        contact_body: 2,
        active: res.active,
        qp_kkt: res.kkt_residual,
        iteration: 0,
        friction_bounds: res.bounds,
        tangential: None,
    };
    last.split_tangential();
    let check = check_solution(layout, &last, refs)?;
    // T¹ = −T² by construction: the balance is exact.
    if let Some(what) = check.failure(Some(crate::dd::check::CONTACT_LIMIT)) {
        return Err(NnddError::CheckFailed {
            run: "the monolithic solve succeeded".into(),
            what,
        }
        .into());
    }
    let mut estimates = Vec::new();
    if let Some(est) = estimator {
        let t = Instant::now();
        let _s = stages.estimation.enter();
        signals::enter(StopPhase::MonolithicEstimate);
        estimates.push(est.estimate(refs, &last)?);
        timings.estimation = t.elapsed().as_secs_f64();
    }
    // Post-processing and output: a signal is read once the files are complete.
    signals::enter(StopPhase::Deferred);
    Ok(Solution {
        status: "solved".into(),
        stop_reason: "direct",
        converged: true,
        requested: true,
        interrupted: false,
        iterations: 0,
        history: Vec::new(),
        last,
        estimates,
        dirichlet_step: "",
        neumann_step: [None, None],
        check: Some(check),
        warnings: Vec::new(),
        penetration: None,
        pending: None,
    })
}

/// What the summary says of each body's solver, known on the body's ranks.
pub struct BodySolver {
    pub schur_source: &'static str,
    pub neumann_step: &'static str,
    pub factorisation_flops: Option<f64>,
    /// The nonzeros of K^α as assembled (`Body::nonzeros`).
    pub nonzeros: f64,
    /// Assembly, factorisation and interface operators on the body's first rank (s).
    pub setup_seconds: f64,
    /// PETSc's copies of the body's matrices for MUMPS freed once factored, over its group
    /// (MiB; `Body::freed_copy_bytes`).
    pub freed_copy_mib: f64,
}

/// Each body's [`BodySolver`], shared from its first rank to every rank (collective).
pub fn body_solvers(layout: &Layout, refs: [Option<&Body>; 2], sol: &Solution) -> [BodySolver; 2] {
    const SOURCES: [SchurSource; 3] = [
        SchurSource::MumpsSchur,
        SchurSource::MumpsInverse,
        SchurSource::Solves,
    ];
    const STEPS: [NeumannStep; 3] = [
        NeumannStep::Condensed,
        NeumannStep::Solve,
        NeumannStep::Omitted,
    ];
    [1, 2].map(|alpha| {
        let mut facts = [-1.0, -1.0, f64::NAN, 0.0, 0.0, 0.0];
        // (summed over the group first: each rank frees its own rows' copy)
        let mut freed = [refs[alpha - 1].map_or(0.0, |b| b.freed_copy_bytes() as f64)];
        layout.group_sum(&mut freed);
        if let Some(b) = refs[alpha - 1] {
            let source = b
                .schur_source
                .and_then(|s| SOURCES.iter().position(|&x| x == s));
            let step = sol.neumann_step[alpha - 1].and_then(|s| STEPS.iter().position(|&x| x == s));
            let (a, f, i) = b.setup_seconds;
            facts = [
                source.map_or(-1.0, |k| k as f64),
                step.map_or(-1.0, |k| k as f64),
                b.factorisation_flops.unwrap_or(f64::NAN),
                a + f + i,
                b.nonzeros,
                freed[0] / (1u64 << 20) as f64,
            ];
        }
        layout.share(alpha, &mut facts);
        let pick = |code: f64, names: &[&'static str], none: &'static str| {
            names
                .get(code as usize)
                .copied()
                .filter(|_| code >= 0.0)
                .unwrap_or(none)
        };
        BodySolver {
            schur_source: pick(facts[0], &SOURCES.map(SchurSource::name), "none"),
            neumann_step: pick(facts[1], &STEPS.map(NeumannStep::name), ""),
            factorisation_flops: facts[2].is_finite().then_some(facts[2]),
            setup_seconds: facts[3],
            nonzeros: facts[4],
            freed_copy_mib: facts[5],
        }
    })
}
