//! Layer `app`: the run. [`options`] has each layer read its own `-nndd_` options into its
//! plain settings, in order, and reads the run's own; [`run`] reads as the algorithm (deal.II
//! step-42's `run()`), one named step a line: settings, problem, ranks, setup (mesh, assembly,
//! factorisation), the estimator, the solve (NNDD or monolithic) with its estimates
//! ([`solve`]), post-processing and output ([`report`]).
//!
//! May use: every layer below (`io`, `estimate`, `dd`, `problem`, `parallel`, `qp`, `fem`,
//! `petsc`, `os`).

mod adapt;
pub mod capacity;
mod cycles;
mod input;
pub mod options;
mod parts;
pub mod preflight;
mod reference;
mod relaxed;
mod report;
mod reported;
mod solve;
mod steps;

use std::rc::Rc;
use std::time::Instant;

use mpi::topology::SimpleCommunicator;
use mpi::traits::Communicator as _;

use crate::dd;
use crate::dd::body::{Body, BodyError};
use crate::dd::contact::ContactError;
use crate::dd::monolithic::MonolithicError;
use crate::dd::nndd::{LoopState, NnddError};
use crate::estimate::mortar::{MortarEstimates, MortarMaps};
use crate::estimate::{EstimateError, Estimator};
use crate::io::checkpoint::{self, CheckpointError, Identity};
use crate::io::fields;
use crate::io::output::{self, OutputError, Results};
use crate::io::summary::{EstimationParts, Timings};
use crate::os::{memory, signals};
use crate::parallel::fault::{self, Agreement, InjectedFault, Phase};
use crate::parallel::layout::{Layout, LayoutError};
use crate::parallel::partition::{Partition, PartitionError};
use crate::petsc::log::Stages;
use crate::petsc::{self, Ksp, Matrix, Petsc, PetscError};
use crate::problem::meshed::MeshedError;
use crate::problem::transfer::GapField;
use crate::problem::{self, BodyProblem, ContactDiscretisation};
use options::{Settings, SettingsError, SolverKind};
use solve::{Restart, Solution};
use steps::{PostProcessed, Run};

/// Printed by `-help` before the option list.
pub const HELP: &str =
    "nndd: two-body frictionless contact in 2D plane-strain elasticity, solved by the\n\
Neumann-Neumann domain decomposition of Gallimard, Choi & Sassi (2013), with error\n\
bounds (eta_glo; guaranteed where the contact side is straight, checked on curved ones)\n\
split into discretisation (eta_FE) and algebraic (eta_NNDD) parts.\n\
Usage: mpirun -n 2 nndd -options_file petsc-options/paper.opts [-nndd_monitor] [-log_view]\n\
Subdomain solvers take the prefixes body1_ and body2_ (default: MUMPS Cholesky).\n\n";

/// A phase with at least this many dofs may take seconds or more: a line says so before it.
pub const LONG_PHASE_DOFS: usize = 100_000;

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error(transparent)]
    Problem(#[from] MeshedError),
    #[error(transparent)]
    Layout(#[from] LayoutError),
    #[error(transparent)]
    Partition(#[from] PartitionError),
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error(transparent)]
    Petsc(#[from] PetscError),
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error(transparent)]
    Contact(#[from] ContactError),
    #[error(transparent)]
    Nndd(#[from] NnddError),
    #[error(transparent)]
    Monolithic(#[from] MonolithicError),
    #[error(transparent)]
    Estimate(#[from] EstimateError),
    #[error("{0}")]
    Json(String),
    /// The solution passes through the other body somewhere on the contact curves.
    #[error("-nndd_contact: {0}")]
    Penetration(String),
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    #[error(transparent)]
    Fault(#[from] InjectedFault),
    /// An adaptive run could not make its next mesh (the size view, or Gmsh).
    #[error("-nndd_adapt_tol: {0}")]
    Adapt(String),
    /// What world rank 0 sent of the file it read or the bodies it built did not read back.
    #[error("-nndd_mesh: {0}")]
    Input(String),
    #[error("cannot catch the stop signals: {0}")]
    Signals(std::io::Error),
    /// An error that every rank learnt at an agreement: all exit together.
    #[error(transparent)]
    Agreed(Box<AppError>),
    /// Another rank failed and reports it; this rank exits with the same `code`.
    #[error("(reported by another rank)")]
    ReportedElsewhere { code: i32 },
}

impl AppError {
    /// Errors every rank detects alike (bad input, the final check of the NNDD's solution):
    /// only rank 0 prints them.
    pub fn is_collective(&self) -> bool {
        matches!(
            self,
            AppError::Settings(_)
                | AppError::Problem(_)
                | AppError::Layout(_)
                | AppError::ReportedElsewhere { .. }
                | AppError::Output(_)
                | AppError::Checkpoint(_)
                | AppError::Fault(_)
                | AppError::Agreed(_)
                | AppError::Nndd(NnddError::CheckFailed { .. })
                | AppError::Penetration(_)
                | AppError::Adapt(_)
        )
    }

    /// The process exit code (README "Exit codes"): 1 for bad input, 2 for a failure of the
    /// solve.
    pub fn exit_code(&self) -> i32 {
        match self {
            AppError::Agreed(inner) => inner.exit_code(),
            AppError::ReportedElsewhere { code } => *code,
            // Every rank finds it (the check is shared), but it is a failure of the solve.
            AppError::Nndd(NnddError::CheckFailed { .. })
            | AppError::Penetration(_)
            | AppError::Adapt(_) => 2,
            e if e.is_collective() => 1,
            _ => 2,
        }
    }
}

/// The warnings for PETSc options of the bodies' solvers (`-body1_…`, `-body2_…`) that no rank
/// read once the bodies are set up (PETSc's `-options_left`, over all ranks): misspelt, or for
/// a solver the run does not use (collective).
fn unused_solver_options(settings: &Settings, layout: &Layout) -> Result<Vec<String>, AppError> {
    // The options as the user gave them (the same on every rank; the defaults each body's
    // group sets for its own solver come later and differ between the groups).
    let given: Vec<String> = petsc::names_in(&settings.options_text)
        .into_iter()
        .filter(|n| {
            let n = n.to_lowercase();
            n.starts_with("-body1_") || n.starts_with("-body2_")
        })
        .collect();
    let left = petsc::unused_options()?;
    let mut used: Vec<f64> = given
        .iter()
        .map(|n| f64::from(!left.iter().any(|l| l.eq_ignore_ascii_case(n))))
        .collect();
    layout.world_sum(&mut used);
    Ok(given
        .iter()
        .zip(used)
        .filter(|(_, u)| *u == 0.0)
        .map(|(n, _)| {
            format!("the option {n} was given but no solver of the bodies read it (misspelt, or for a solver this run does not use; -help lists the solvers' options)")
        })
        .collect())
}

/// The names of the contact curves (`-nndd_contact`), or of the built-in problems' sides.
pub fn contact_curves(settings: &Settings) -> [String; 2] {
    match &settings.problem.mesh {
        Some(spec) => spec.contact.clone(),
        None => ["top of body 1".into(), "bottom of body 2".into()],
    }
}

/// How the run ended, for the process exit code.
pub enum Outcome {
    /// Solved (exit 0).
    Solved,
    /// The NNDD did not converge; results were written (exit 3).
    NotConverged,
    /// An adaptive run ended its cycles above its tolerance; results were written (exit 3).
    Unreached,
    /// A signal stopped the NNDD; a restart point and the results so far were written (exit 4).
    Interrupted,
    /// Only `-help` was asked (exit 0).
    Help,
}

impl Outcome {
    /// How a run that reached its output ended.
    fn of(sol: &Solution) -> Outcome {
        if sol.interrupted {
            Outcome::Interrupted
        } else if sol.requested {
            Outcome::Solved
        } else {
            Outcome::NotConverged
        }
    }
}

pub fn run(world: SimpleCommunicator, agreement: &Agreement) -> Result<Outcome, AppError> {
    let t_start = Instant::now();
    // Settings: every -nndd_ option, validated; the ranks agree before going on.
    let mut settings = read_settings(agreement, world.rank())?;
    if let Some(outcome) = help_or_version(world.rank())? {
        return Ok(outcome);
    }
    // Memory: the meshes must fit in the nodes' memory (before any mesh is built).
    settings.memory_warning = agreed(
        agreement,
        capacity::check(&settings, &world, capacity::Meshes::Given).map_err(AppError::from),
    )?;
    say_warnings(world.rank() == 0, settings.memory_warning.as_slice());
    let stages = prepare_solve()?;
    match &settings.adapt {
        // One solve on the given mesh.
        None => {
            let start = Start::default();
            Ok(solve_cycle(&world, settings, &stages, agreement, start, t_start)?.outcome)
        }
        // Cycles of solve, estimate and remesh until η^glo ≤ ε ‖u_h‖_E (docs/method.md §8).
        Some(adapt) => cycles::run(&world, &settings, adapt, &stages, agreement),
    }
}

/// Where a solve's NNDD starts: λ = 0, or an adaptive run's previous cycle's λ carried over
/// to this cycle's pairs (used where the Dirichlet step's body is the same).
#[derive(Clone, Debug, Default)]
pub(crate) struct Start {
    pub(crate) lambda: Option<Vec<f64>>,
    /// The points of `lambda`'s pairs, in pair order.
    pub(crate) from: Vec<[f64; 2]>,
    /// The body whose normal Γc displacement `lambda` is.
    pub(crate) dirichlet_body: usize,
}

/// What one solve leaves an adaptive run: its ending, the problem solved (as the rules made
/// it), the ranks, the solution and ‖u_h‖_E.
pub(crate) struct Cycle {
    pub(crate) outcome: Outcome,
    pub(crate) settings: Settings,
    pub(crate) problems: [Rc<BodyProblem>; 2],
    pub(crate) layout: Layout,
    pub(crate) solution: Solution,
    /// ‖u_h‖_E of the reported iterate, both bodies (every rank).
    pub(crate) energy_norm: f64,
    /// The solve's wall time, output included (s).
    pub(crate) seconds: f64,
}

/// One solve of the problem `settings` describes, from `start`: the problem built, the ranks
/// laid out, the bodies set up, the NNDD (or the monolithic check) with its estimates, the
/// checks, and the output (PREFIX.h5, .xdmf, .json).
pub(crate) fn solve_cycle(
    world: &SimpleCommunicator,
    mut settings: Settings,
    stages: &Stages,
    agreement: &Agreement,
    start: Start,
    t_start: Instant,
) -> Result<Cycle, AppError> {
    // Problem: both bodies' meshes, materials, boundary conditions and Γc, built on world
    // rank 0 alone where the run allows it (the others hold their outlines and Γc until rank
    // 0 sends them their parts), else on every rank (after the layout a rank keeps the meshes
    // its phases read).
    let on_root = input::on_root(&settings, world.size());
    let mut problems = match on_root {
        true => input::build_on_root(&settings, None, agreement, world)?,
        false => {
            // (world rank 0 read the file: every rank builds from it)
            let file = settings.problem.parsed_file_mut();
            let shared = file.map_or(Ok(()), |f| f.share(world));
            agreed(agreement, shared.map_err(AppError::Input))?;
            build_problems(&settings, agreement)?
        }
    };
    if let Some(why) = settings.problem.node_to_node_instead(&problems)? {
        // (`-nndd_contact_discretisation auto` where mortar is not available: the curves made
        // to match on world rank 0, the bodies built again as before)
        settings.warnings.push(why);
        problems = match on_root {
            true => input::build_on_root(&settings, None, agreement, world)?,
            false => build_problems(&settings, agreement)?,
        };
    }
    say_contact_curves(&settings, &problems, world.rank() == 0);
    // The mortar discretisation, or a body held only by contact, decides the Dirichlet step's
    // body (the same on every rank).
    agreed(
        agreement,
        settings
            .mortar_rules(&problems)
            .and_then(|()| settings.hold_by_contact(&problems))
            .and_then(|()| settings.friction_rules(&problems))
            .map_err(AppError::from),
    )?;
    // The parsed Gmsh mesh freed before the bodies are set up, where nothing after reads it.
    settings.release_mesh_unread_later();
    let settings = settings;
    say_warnings(world.rank() == 0, &settings.warnings);
    let mut timings = Timings {
        input: t_start.elapsed().as_secs_f64(),
        ..Timings::default()
    };
    // Ranks: each body's group, and the choices that depend on it checked.
    let layout = lay_out(world.duplicate(), &settings, &problems)?;
    // The restart point this run continues from, checked against this problem, or the
    // previous cycle's λ.
    let mut restart = restart_point(&settings, &problems, agreement)?;
    let carried = start.checkpoint(&settings, &restart, &problems);
    restart.from = restart.from.take().or(carried);
    // Input: world rank 0 partitions the bodies it built and sends each rank its part, or
    // each rank lets go of the meshes it does not read.
    // (a mortar run's estimates map the whole bodies onto their matched meshes on world rank 0,
    // which keeps them until then: `Run::estimator`)
    let mortar_estimates = settings.estimate.enabled && parts::mortar([&problems[0], &problems[1]]);
    let whole = (on_root && mortar_estimates && layout.is_root()).then(|| problems.clone());
    let (problems, dealt, input_elements) = match on_root {
        true => {
            let t_deal = Instant::now();
            let (dealt, n) = input::deal_parts(problems, &settings, &layout, agreement)?;
            timings.input += t_deal.elapsed().as_secs_f64();
            // (world rank 0's whole bodies and the parts it sent, back to the system before
            // the assembly and the factorisation allocate theirs)
            memory::release_free_memory(0);
            (dealt.problems.clone(), Some(dealt), n)
        }
        false => {
            let n = parts::input_mesh_elements(&problems);
            let problems = parts::release_unread_meshes(problems, &settings, &layout);
            (problems, None, n)
        }
    };
    let input_peak = memory::peak_memory() / (1024.0 * 1024.0);
    let run = Run::new(&settings, &layout, &problems, stages, agreement);
    // Estimate: the estimator (with the reference solution of (26) when asked), used by the
    // solve at the estimated iterations and on the reported iterate; made first, so that the
    // reference's fine factorisations are freed before the run's own are made.
    let mut setup_warnings = Vec::new();
    let mut estimator = run.estimator(whole, &mut timings, &mut setup_warnings)?;
    // Partition: each body over its group (METIS); then a Gmsh body's mesh cut, on each rank,
    // to the part it reads from here on.
    let (partitions, problems) = match dealt {
        Some(dealt) => dealt.hold(&mut estimator),
        None => {
            let partitions = run.partitions()?;
            let held =
                parts::keep_read_parts(problems, &settings, &layout, &partitions, &mut estimator);
            (partitions, held)
        }
    };
    drop(run);
    let run = Run::new(&settings, &layout, &problems, stages, agreement);
    // Setup: each rank's bodies (assembly, factorisation); the ranks agree.
    let bodies = run.set_up_bodies(partitions, &mut timings, &mut setup_warnings)?;
    let refs = [bodies[0].as_ref(), bodies[1].as_ref()];
    let mut warnings = unused_solver_options(&settings, &layout)?;
    say_warnings(layout.is_root(), &warnings);
    warnings.append(&mut setup_warnings);
    run.announce_setup(t_start);
    // Solve: the NNDD (paper §3) or the monolithic check; the contact checked on the curves.
    let mut sol = run.solve(refs, estimator.as_ref(), &mut timings, &restart)?;
    sol.warnings.splice(0..0, warnings);
    let t_contact = Instant::now();
    run.check_contact(&mut sol)?;
    timings.checks += layout.max(t_contact.elapsed().as_secs_f64());
    // Post-processing: energy, each body's solver.
    let mut post = run.post_process(refs, &sol)?;
    post.input_mesh_elements = settings.problem.mesh.as_ref().map(|_| input_elements);
    post.input_file_points = settings.problem.mesh.as_ref().map(|m| m.gmsh.held_points);
    post.input_peak_memory_mib = input_peak;
    drop(bodies);
    memory::release_free_memory(0);
    // The reported iterate's estimate finished (its recoveries) with the factorisations
    // freed; the flops, timings and memory over ranks.
    run.finish_estimates(&mut sol, estimator, &mut post, &mut timings)?;
    // Output: PREFIX.h5 + PREFIX.xdmf (collective), PREFIX.json (rank 0).
    run.write_output(&sol, &post, timings, t_start)?;
    Ok(Cycle {
        outcome: Outcome::of(&sol),
        seconds: t_start.elapsed().as_secs_f64(),
        settings,
        problems,
        layout,
        energy_norm: post.energy_norm,
        solution: sol,
    })
}

impl Start {
    /// The loop's start at the carried λ, where it fits this solve (the same Dirichlet step's
    /// body): the previous λ at this solve's pairs ([`adapt::carry_over`]).
    fn checkpoint(
        &self,
        settings: &Settings,
        restart: &Restart,
        problems: &[Rc<BodyProblem>; 2],
    ) -> Option<checkpoint::Checkpoint> {
        let lambda = self.lambda.as_ref()?;
        if self.dirichlet_body != settings.nndd.dirichlet_body {
            return None;
        }
        let to = adapt::pair_points([&problems[0], &problems[1]]);
        // (with friction, the normal half and the tangential half each along Γc)
        let halves = lambda.len() / self.from.len().max(1);
        let lambda: Vec<f64> = lambda
            .chunks(self.from.len().max(1))
            .take(halves.max(1))
            .flat_map(|half| adapt::carry_over(&self.from, half, &to))
            .collect();
        Some(checkpoint::Checkpoint {
            format: checkpoint::FORMAT.into(),
            identity: restart.identity.clone(),
            state: LoopState::at(lambda, settings.nndd.relaxation),
            balanced_fe: None,
            checks: Vec::new(),
        })
    }
}

/// Every `-nndd_` option, validated, and the injected fault armed (`-nndd_fault`); the ranks
/// agree.
fn read_settings(agreement: &Agreement, rank: i32) -> Result<Settings, AppError> {
    let settings = Settings::from_options(Petsc::comm_world())
        .map_err(AppError::from)
        .and_then(|s| {
            fault::arm(s.fault, rank);
            fault::check(Phase::Options)?;
            Ok(s)
        });
    agreed(agreement, settings)
}

/// `-help` (with the bodies' solver options) or `-version` (PETSc has printed its own; nndd's
/// follows): what was asked, without any work.
fn help_or_version(rank: i32) -> Result<Option<Outcome>, AppError> {
    if petsc::option_present("-help") {
        list_solver_options()?;
        return Ok(Some(Outcome::Help));
    }
    if petsc::option_present("-version") {
        if rank == 0 {
            println!("nndd {}", env!("CARGO_PKG_VERSION"));
        }
        return Ok(Some(Outcome::Help));
    }
    Ok(None)
}

/// `nndd: warning: …` lines, on the root.
fn say_warnings(root: bool, warnings: &[String]) {
    if root {
        for w in warnings {
            crate::io::monitor::say(format_args!("nndd: warning: {w}"));
        }
    }
}

/// Both bodies' problems, built on every rank (the ranks agree).
fn build_problems(
    settings: &Settings,
    agreement: &Agreement,
) -> Result<[Rc<BodyProblem>; 2], AppError> {
    let built = problem::build(&settings.problem)
        .map_err(AppError::from)
        .and_then(|p| {
            fault::check(Phase::Mesh)?;
            Ok(p)
        });
    agreed(agreement, built)
}

/// On world rank 0 (`root`), a Gmsh problem's contact curves, made to match or coupled by
/// mortar, reported.
fn say_contact_curves(settings: &Settings, problems: &[Rc<BodyProblem>; 2], root: bool) {
    let (Some(spec), true) = (&settings.problem.mesh, root) else {
        return;
    };
    let m = &spec.matched;
    let side = problem::pair_side([&problems[0], &problems[1]]);
    if problem::discretisation([&problems[0], &problems[1]]) == ContactDiscretisation::Mortar {
        let [c1, c2] = &spec.contact;
        println!(
            "nndd: contact curves '{c1}' and '{c2}' coupled by mortar as meshed: Γc's {} pairs at body {}'s nodes (the coarser curve), which body {} meets at points of its curve ({} of its nodes)",
            problems[side].pairs(),
            side + 1,
            2 - side,
            problems[1 - side].contact_nodes.len()
        );
    } else if m.inserted != [0; 2] || m.moved != [0; 2] {
        let [c1, c2] = &spec.contact;
        println!(
            "nndd: contact curves '{c1}' and '{c2}' meshed independently, made to match: {} and {} node(s) inserted, {} and {} moved onto a partner; Γc: {} pairs where they overlap ({} and {} nodes on the curves)",
            m.inserted[0],
            m.inserted[1],
            m.moved[0],
            m.moved[1],
            problems[0].pairs(),
            problems[0].contact_candidates.len(),
            problems[1].contact_candidates.len()
        );
    }
}

/// The ranks of each body's group, and the choices that depend on them checked: the
/// recovery, the interface operators, the output's directory.
fn lay_out(
    world: SimpleCommunicator,
    settings: &Settings,
    problems: &[Rc<BodyProblem>; 2],
) -> Result<Layout, AppError> {
    let dofs = problems.each_ref().map(|p| p.num_dofs());
    let layout = Layout::new(world, settings.body1_ranks, dofs)?;
    check_recovery(settings, &layout)?;
    settings.schur.check(layout.group_sizes)?;
    check_output(settings, &layout)?;
    Ok(layout)
}

/// Where this run writes its restart points, and the one it continues from
/// (`-nndd_restart`), checked against this problem (the ranks agree).
fn restart_point<'a>(
    settings: &Settings,
    problems: &[Rc<BodyProblem>; 2],
    agreement: &'a Agreement,
) -> Result<Restart<'a>, AppError> {
    let identity = Identity::of(
        settings.problem.kind.name(),
        problems,
        settings.nndd.relaxation.text(),
        settings.nndd.dirichlet_body,
        settings.nndd.neumann_bodies.name(),
    );
    let rows = settings.friction.interface().len(identity.pairs);
    let identity = identity.with_friction(settings.friction.text(), rows);
    let from = match &settings.restart {
        None => None,
        Some(path) => {
            let read = checkpoint::read(path, &identity, settings.nndd.max_it);
            Some(agreed(agreement, read.map_err(AppError::from))?)
        }
    };
    Ok(Restart {
        identity,
        path: settings.output.paths.checkpoint(),
        from,
        agreement,
    })
}

/// Before the solve: the stop signals caught, the `-log_view` stages registered, the memory
/// tracked.
fn prepare_solve() -> Result<Stages, AppError> {
    signals::catch_stop_requests().map_err(AppError::Signals)?;
    let stages = Stages::register()?;
    Petsc::track_memory()?;
    Ok(stages)
}

/// `local` on every rank if no rank failed; else, after every rank learnt it, the rank's own
/// error, or [`AppError::ReportedElsewhere`] where it did not fail (collective, on the
/// ranks' [`Agreement`]). A rank that failed and whose partners do not arrive ends the job.
pub fn agreed<T>(agreement: &Agreement, local: Result<T, AppError>) -> Result<T, AppError> {
    let code = local.as_ref().err().map(|e| e.exit_code() as u8);
    let message = local.as_ref().err().map(|e| e.to_string());
    let first = agreement.first_failure(code, || abort_with(message.as_deref()));
    match (first, local) {
        (None, local) => local,
        (Some(_), Err(e)) if e.is_collective() => Err(e),
        (Some(_), Err(e)) => Err(AppError::Agreed(Box::new(e))),
        (Some((_, code)), Ok(_)) => Err(AppError::ReportedElsewhere { code: code as i32 }),
    }
}

/// A failure of this rank alone in the solve (a KSP, the QP, an estimate) leaves the other
/// ranks waiting in a collective: end the job here, before the bodies are dropped (destroying
/// a factorisation spread over ranks is itself collective, and would wait for ever).
pub(crate) fn end_job_on_local_failure<T>(r: Result<T, AppError>) -> Result<T, AppError> {
    match r {
        Err(e) if !e.is_collective() && SimpleCommunicator::world().size() > 1 => {
            abort_with(Some(&e.to_string()))
        }
        r => r,
    }
}

/// Print this rank's error (if any) and end the job (every rank). A failure that another rank
/// of the body's group reports ([`dd::body::BodyError::Echo`]) is not printed twice: this rank
/// gives that rank time to print and end the job, and ends it itself only if it did not.
pub fn abort_with(message: Option<&str>) -> ! {
    let world = SimpleCommunicator::world();
    match message {
        Some(m) if m.starts_with(dd::body::ECHO) => {
            std::thread::sleep(std::time::Duration::from_secs(5));
        }
        Some(m) => {
            crate::io::monitor::say(format_args!("nndd: error (rank {}): {m}", world.rank()))
        }
        None => {}
    }
    world.abort(2)
}

/// The `star` recovery solves one global problem per body: exact only with the body on one
/// rank (the others are local and computed on overlapping element sets, see `overlap.rs`).
fn check_recovery(settings: &Settings, layout: &Layout) -> Result<(), AppError> {
    let spread = layout.group_sizes.iter().any(|&n| n > 1);
    let estimate = &settings.estimate;
    if spread && !estimate.recovery.is_local() && estimate.enabled {
        return Err(LayoutError::GlobalRecovery {
            ranks: layout.group_sizes,
        }
        .into());
    }
    Ok(())
}

/// Fail before any work when the output cannot be written (rank 0 checks, all agree).
fn check_output(settings: &Settings, layout: &Layout) -> Result<(), AppError> {
    let checked = if layout.is_root() {
        output::check_writable(settings.output.paths.prefix())
    } else {
        Ok(())
    };
    if !layout.agree(checked.is_ok()) {
        checked?;
        return Err(AppError::ReportedElsewhere { code: 1 });
    }
    Ok(())
}

/// With `-help`: let both bodies' KSPs register their options (on a tiny matrix), so that
/// `-help` lists `-body1_ksp_type`, `-body2_pc_type`, ….
fn list_solver_options() -> Result<(), AppError> {
    for alpha in [1, 2] {
        let prefix = format!("body{alpha}_");
        let listed = (|| {
            let mut a = Matrix::preallocated(Petsc::comm_self(), 2, &[1, 1], &[0, 0])?;
            for i in 0..2 {
                a.add_values(&[i], &[i], &[1.0])?;
            }
            a.assemble()?;
            Ksp::new(Petsc::comm_self(), a, &prefix, None).map(drop)
        })();
        // An unknown type among the listed options is bad input here too (exit 1, its option
        // named), as in a run.
        listed.map_err(|e| solve::unknown_type(crate::dd::body::BodyError::Petsc(e), alpha))?;
    }
    Ok(())
}
