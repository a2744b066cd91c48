//! Layer `app`: the run. [`options`] has each layer read its own `-nndd_` options into its
//! plain settings, in order, and reads the run's own; [`run`] reads as the algorithm (deal.II
//! step-42's `run()`), one named step a line: settings, problem, ranks, setup (mesh, assembly,
//! factorisation), the estimator, the solve (NNDD or monolithic) with its estimates
//! ([`solve`]), post-processing and output ([`report`]).
//!
//! May use: every layer below (`io`, `estimate`, `dd`, `problem`, `parallel`, `qp`, `fem`,
//! `petsc`, `os`).

pub mod capacity;
pub mod options;
pub mod preflight;
mod report;
mod solve;

use std::rc::Rc;
use std::time::Instant;

use mpi::topology::SimpleCommunicator;
use mpi::traits::Communicator as _;

use crate::dd;
use crate::dd::body::{Body, BodyError};
use crate::dd::contact::ContactError;
use crate::dd::monolithic::MonolithicError;
use crate::dd::nndd::NnddError;
use crate::estimate::mortar::MortarEstimates;
use crate::estimate::{EstimateError, Estimator};
use crate::io::checkpoint::{self, CheckpointError, Identity};
use crate::io::fields;
use crate::io::output::{self, OutputError, Results};
use crate::io::summary::{EstimationParts, Timings};
use crate::os::{memory, signals};
use crate::parallel::fault::{self, Agreement, InjectedFault, Phase};
use crate::parallel::layout::{Layout, LayoutError};
use crate::parallel::partition::PartitionError;
use crate::petsc::log::Stages;
use crate::petsc::{self, Ksp, Matrix, Petsc, PetscError};
use crate::problem::meshed::MeshedError;
use crate::problem::transfer::GapField;
use crate::problem::{self, BodyProblem, ContactDiscretisation};
use options::{Settings, SettingsError, SolverKind};
use solve::{Restart, Solution};

/// Printed by `-help` before the option list.
pub const HELP: &str =
    "nndd: two-body frictionless contact in 2D plane-strain elasticity, solved by the\n\
Neumann-Neumann domain decomposition of Gallimard, Choi & Sassi (2013), with error\n\
bounds (eta_glo; guaranteed where the contact side is straight, checked on curved ones)\n\
split into discretisation (eta_FE) and algebraic (eta_NNDD) parts.\n\
Usage: mpirun -n 2 nndd -options_file petsc-options/paper.opts [-nndd_monitor] [-log_view]\n\
Subdomain solvers take the prefixes body1_ and body2_ (default: MUMPS Cholesky).\n\n";

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
        )
    }

    /// The process exit code (README "Exit codes"): 1 for bad input, 2 for a failure of the
    /// solve.
    pub fn exit_code(&self) -> i32 {
        match self {
            AppError::Agreed(inner) => inner.exit_code(),
            AppError::ReportedElsewhere { code } => *code,
            // Every rank finds it (the check is shared), but it is a failure of the solve.
            AppError::Nndd(NnddError::CheckFailed { .. }) | AppError::Penetration(_) => 2,
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
    agreed(
        agreement,
        capacity::check(&settings, &world).map_err(AppError::from),
    )?;
    // Problem: both bodies' meshes, materials, boundary conditions and Γc (every rank knows
    // the whole geometry, for the interface and the output).
    let mut problems = build_problems(&settings, agreement, world.rank() == 0)?;
    if let Some(why) = settings.problem.node_to_node_instead(&problems) {
        // (`-nndd_contact_discretisation auto` where mortar is not available)
        settings.warnings.push(why);
        problems = build_problems(&settings, agreement, world.rank() == 0)?;
    }
    // The mortar discretisation, or a body held only by contact, decides the Dirichlet step's
    // body (the same on every rank).
    agreed(
        agreement,
        settings
            .mortar_rules(&problems)
            .and_then(|()| settings.hold_by_contact(&problems))
            .map_err(AppError::from),
    )?;
    let settings = settings;
    say_warnings(world.rank() == 0, &settings.warnings);
    let mut timings = Timings {
        input: t_start.elapsed().as_secs_f64(),
        ..Timings::default()
    };
    // Ranks: each body's group, and the choices that depend on it checked.
    let layout = lay_out(world, &settings, &problems)?;
    // The restart point this run continues from, checked against this problem.
    let restart = restart_point(&settings, &problems, agreement)?;
    let stages = prepare_solve()?;
    let run = Run::new(&settings, &layout, &problems, &stages, agreement);
    // Setup: each rank's bodies (partition, assembly, factorisation); the ranks agree.
    let bodies = run.set_up_bodies(&mut timings)?;
    let refs = [bodies[0].as_ref(), bodies[1].as_ref()];
    let mut warnings = unused_solver_options(&settings, &layout)?;
    say_warnings(layout.is_root(), &warnings);
    run.announce_setup(t_start);
    // Estimate: the estimator (with the reference solution of (26) when asked), used by the
    // solve at the estimated iterations and on the reported iterate.
    let estimator = run.estimator(&mut timings, &mut warnings)?;
    // Solve: the NNDD (paper §3) or the monolithic check; the contact checked on the curves.
    let mut sol = run.solve(refs, estimator.as_ref(), &mut timings, &restart)?;
    sol.warnings.splice(0..0, warnings);
    let t_contact = Instant::now();
    run.check_contact(&mut sol)?;
    timings.checks += layout.max(t_contact.elapsed().as_secs_f64());
    // Post-processing: energy, Schur source, timings and memory over ranks.
    let post = run.post_process(refs, &sol, estimator, &mut timings)?;
    drop(bodies);
    memory::release_free_memory(0);
    // Output: PREFIX.h5 + PREFIX.xdmf (collective), PREFIX.json (rank 0).
    run.write_output(&sol, &post, timings, t_start)?;
    Ok(Outcome::of(&sol))
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

/// Both bodies' problems (the ranks agree); a Gmsh problem's contact curves, made to match,
/// reported.
fn build_problems(
    settings: &Settings,
    agreement: &Agreement,
    root: bool,
) -> Result<[Rc<BodyProblem>; 2], AppError> {
    let built = problem::build(&settings.problem)
        .map_err(AppError::from)
        .and_then(|p| {
            fault::check(Phase::Mesh)?;
            Ok(p)
        });
    let problems = agreed(agreement, built)?;
    if let (Some(spec), true) = (&settings.problem.mesh, root) {
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
    Ok(problems)
}

/// The ranks of each body's group, and the choices that depend on them checked: the
/// recovery, the interface operators, the output's directory.
fn lay_out(
    world: SimpleCommunicator,
    settings: &Settings,
    problems: &[Rc<BodyProblem>; 2],
) -> Result<Layout, AppError> {
    let dofs = problems.each_ref().map(|p| p.mesh.num_dofs());
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

/// What the steps of a run from the setup on work with.
struct Run<'a> {
    settings: &'a Settings,
    layout: &'a Layout,
    problems: &'a [Rc<BodyProblem>; 2],
    stages: &'a Stages,
    agreement: &'a Agreement,
}

/// What post-processing gives the summary.
pub(crate) struct PostProcessed {
    /// The potential energy of the reported iterate, both bodies (J/m).
    pub(crate) energy: f64,
    pub(crate) solvers: [solve::BodySolver; 2],
    pub(crate) logged_flops: f64,
    pub(crate) reference_iterations: Option<usize>,
}

impl<'a> Run<'a> {
    fn new(
        settings: &'a Settings,
        layout: &'a Layout,
        problems: &'a [Rc<BodyProblem>; 2],
        stages: &'a Stages,
        agreement: &'a Agreement,
    ) -> Run<'a> {
        Run {
            settings,
            layout,
            problems,
            stages,
            agreement,
        }
    }

    /// Each rank's bodies (partition, assembly, factorisation); the ranks agree.
    fn set_up_bodies(&self, timings: &mut Timings) -> Result<[Option<Body>; 2], AppError> {
        let (settings, problems, layout) = (self.settings, self.problems, self.layout);
        let bodies = solve::setup_bodies(settings, problems, layout, self.stages, timings);
        agreed(self.agreement, bodies)
    }

    /// With `-nndd_monitor`: the problem, its size, the ranks and the steps' bodies, and the
    /// time to here.
    fn announce_setup(&self, t_start: Instant) {
        let (settings, layout) = (self.settings, self.layout);
        if !(settings.output.monitor && layout.is_root()) {
            return;
        }
        let problem = match &settings.problem.mesh {
            Some(spec) => format!("mesh {}", spec.gmsh.path),
            None => format!(
                "{} n = {}",
                settings.problem.kind.name(),
                settings.problem.n
            ),
        };
        let roles = match (settings.solver, settings.nndd.dirichlet_body) {
            (SolverKind::Nndd, 1) => ", Dirichlet step on body 1, contact step on body 2",
            (SolverKind::Nndd, _) => ", Dirichlet step on body 2, contact step on body 1",
            _ => "",
        };
        let dofs: usize = self.problems.iter().map(|p| p.mesh.num_dofs()).sum();
        println!(
            "nndd: {problem}, {dofs} dofs, {} rank(s){roles}: setup {:.3} s",
            layout.size,
            t_start.elapsed().as_secs_f64()
        );
    }

    /// The estimator when the run estimates, with the reference solution of (26) when asked
    /// (one that does not converge is a warning, added to `warnings`: no e_ref then). A mortar
    /// run's estimates and reference work on the matched meshes of
    /// [`crate::problem::ProblemSettings::for_estimates`], their bodies set up here.
    fn estimator(
        &self,
        timings: &mut Timings,
        warnings: &mut Vec<String>,
    ) -> Result<Option<Estimator<'a>>, AppError> {
        let (settings, layout) = (self.settings, self.layout);
        let matched = settings
            .problem
            .for_estimates()
            .filter(|_| settings.estimate.enabled)
            .map(|problem| Settings {
                problem,
                ..settings.clone()
            });
        let on = matched.as_ref().unwrap_or(settings);
        let problems = [&*self.problems[0], &*self.problems[1]];
        let gaps = matched.as_ref().map(|_| GapField::new(problems));
        let reference = match settings.estimate.reference_factor {
            0 => None,
            r => {
                match solve::solve_reference(on, layout, self.stages, r, timings, gaps.as_ref())? {
                    Ok(reference) => Some(reference),
                    Err(w) => {
                        say_warnings(layout.is_root(), std::slice::from_ref(&w));
                        warnings.push(w);
                        None
                    }
                }
            }
        };
        if !settings.estimate.enabled {
            return Ok(None);
        }
        let stages = Some(self.stages.estimation_parts);
        let qp = &settings.qp;
        let (Some(matched), Some(gaps)) = (matched, gaps) else {
            let e = Estimator::new(
                &settings.estimate,
                qp,
                layout,
                self.problems,
                reference,
                stages,
            );
            return Ok(Some(e));
        };
        let problems = gaps.apply(crate::problem::build(&matched.problem)?);
        let bodies = solve::setup_matched_bodies(&matched, &problems, layout, self.stages, timings);
        let bodies = agreed(self.agreement, bodies)?;
        let mortar = agreed(
            self.agreement,
            MortarEstimates::new(self.problems.clone(), &problems, bodies).map_err(AppError::from),
        )?;
        let e = Estimator::new(&settings.estimate, qp, layout, &problems, reference, stages);
        Ok(Some(e.with_mortar(mortar)))
    }

    /// The NNDD (paper §3) with its restart points, or the monolithic check; a failure of one
    /// rank alone ends the job.
    fn solve(
        &self,
        refs: [Option<&Body>; 2],
        estimator: Option<&Estimator>,
        timings: &mut Timings,
        restart: &Restart,
    ) -> Result<Solution, AppError> {
        let (settings, layout, stages) = (self.settings, self.layout, self.stages);
        end_job_on_local_failure(match settings.solver {
            SolverKind::Nndd => {
                let restart = Some(restart);
                solve::solve_nndd(settings, layout, refs, estimator, stages, timings, restart)
            }
            SolverKind::Monolithic => {
                solve::solve_monolithic(settings, layout, refs, estimator, stages, timings)
            }
        })
    }

    /// The contact over the whole contact curves: a zone that reaches an end of Γc where the
    /// bodies go on side by side is a warning; a penetration beyond round-off, an error.
    fn check_contact(&self, sol: &mut Solution) -> Result<(), AppError> {
        let problems = [&*self.problems[0], &*self.problems[1]];
        if let Some(w) = dd::check::zone_reaches_open_end(problems, &sol.last) {
            say_warnings(self.layout.is_root(), std::slice::from_ref(&w));
            sol.warnings.push(w);
        }
        let penetration = dd::penetration::penetration(self.layout, problems, &sol.last);
        if let Some(what) = penetration.failure(&contact_curves(self.settings)) {
            if sol.converged {
                return Err(AppError::Penetration(what));
            }
            // An iterate that is no answer (diverged, stagnated, at -nndd_max_it): its own exit
            // says why; the overlap is said with it, not blamed on the contact curves.
            let w = format!(
                "the reported iterate, which did not converge, overlaps the other body: {what}"
            );
            say_warnings(self.layout.is_root(), std::slice::from_ref(&w));
            sol.warnings.push(w);
        }
        sol.penetration = Some(penetration);
        Ok(())
    }

    /// The energy, each body's solver, `-nndd_schur_view`'s files, the flops and the
    /// estimates' parts; the estimator dropped, the timings made maxima over the ranks.
    fn post_process(
        &self,
        refs: [Option<&Body>; 2],
        sol: &Solution,
        estimator: Option<Estimator>,
        timings: &mut Timings,
    ) -> Result<PostProcessed, AppError> {
        let layout = self.layout;
        let energy = potential_energy(layout, refs, sol)?;
        let solvers = solve::body_solvers(layout, refs, sol);
        if self.settings.output.schur_view {
            write_interface_operators(self.settings, layout, refs)?;
        }
        let logged_flops = layout.sum(Petsc::logged_flops());
        let reference_iterations = estimator.as_ref().and_then(|e| e.reference_iterations());
        if let Some(e) = &estimator {
            timings.estimation_parts = EstimationParts::from(e.part_seconds());
        }
        drop(estimator);
        report::max_over_ranks(layout, timings);
        Ok(PostProcessed {
            energy,
            solvers,
            logged_flops,
            reference_iterations,
        })
    }

    /// PREFIX.h5 + PREFIX.xdmf (collective), then PREFIX.json and the closing report (rank 0;
    /// the ranks agree on its write).
    fn write_output(
        &self,
        sol: &Solution,
        post: &PostProcessed,
        mut timings: Timings,
        t_start: Instant,
    ) -> Result<(), AppError> {
        let (settings, layout, problems) = (self.settings, self.layout, self.problems);
        let t_out = Instant::now();
        let results = {
            let _s = self.stages.output.enter();
            let have = [layout.owns(1), layout.owns(2)];
            let results = results_of(settings, problems, sol, have);
            let shares = fields::shares(layout, [&problems[0], &problems[1]]);
            let prefix = settings.output.paths.prefix();
            output::write_results_parallel(&layout.world, prefix, &results, &shares)?;
            results
        };
        timings.output = layout.max(t_out.elapsed().as_secs_f64());
        timings.total = t_start.elapsed().as_secs_f64();
        // The high-water marks of the whole run, the output's fields included.
        let peaks = report::peak_memory_per_rank(layout);
        let mut written = Ok(());
        if layout.is_root() {
            let measured = report::Measured {
                results: &results,
                timings,
                peaks: &peaks,
            };
            let problems = [&*problems[0], &*problems[1]];
            let summary = report::summarise(settings, problems, layout, sol, post, measured);
            let json = serde_json::to_string_pretty(&summary)
                .map_err(|e| AppError::Json(e.to_string()))?;
            written = output::write_atomic(&settings.output.paths.json(), json.as_bytes())
                .map_err(AppError::from);
            if written.is_ok() {
                report::report(settings, &summary, sol);
            }
        }
        agreed(self.agreement, written)?;
        if signals::stop_requested() && !sol.interrupted && layout.is_root() {
            // The output is not interrupted: a signal during it is read once the files exist.
            crate::io::monitor::say(format_args!(
                "nndd: {} arrived while the results were written; they are complete",
                signals::received_name()
            ));
        }
        Ok(())
    }
}

/// The potential energy of the reported iterate, both bodies (each counted once per group).
fn potential_energy(
    layout: &Layout,
    refs: [Option<&Body>; 2],
    sol: &Solution,
) -> Result<f64, AppError> {
    let mut e = 0.0;
    for (k, b) in refs.iter().enumerate() {
        if let Some(b) = b {
            let energy = b.potential_energy(&sol.last.u[k])?;
            if b.is_root() {
                e += energy; // every rank of the group has it: count it once
            }
        }
    }
    Ok(layout.sum(e))
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

/// The result files' content: one step per estimated iteration, and the reported iterate as
/// the last step (estimated or not); the run's description as text attributes.
fn results_of(
    settings: &Settings,
    problems: &[Rc<BodyProblem>; 2],
    sol: &Solution,
    have: [bool; 2],
) -> Results {
    let mut steps: Vec<_> = sol
        .estimates
        .iter()
        .map(|e| (&e.iterate, Some(e)))
        .collect();
    if steps.last().map(|(it, _)| it.iteration) != Some(sol.last.iteration) {
        steps.push((&sol.last, None));
    }
    let mut attributes = vec![
        ("n".into(), settings.problem.n as f64),
        ("dofs".into(), settings.problem.dofs() as f64),
        ("iterations".into(), sol.iterations as f64),
    ];
    // Each body's rows of the `bodies` grid: body 1's points and cells first.
    for p in problems.iter() {
        let at = |what: &str| format!("body{}_{what}", p.alpha);
        attributes.push((at("points"), p.mesh.points.len() as f64));
        attributes.push((at("cells"), p.mesh.triangles.len() as f64));
    }
    let mesh = settings.problem.mesh.as_ref();
    let physical_names = mesh.map_or(String::new(), |m| {
        let names = m.gmsh.names.iter();
        let listed: Vec<String> = names.map(|((d, t), n)| format!("{d} {t} {n}")).collect();
        listed.join("; ")
    });
    let text = vec![
        (
            "program".into(),
            format!("nndd {}", env!("CARGO_PKG_VERSION")),
        ),
        ("options".into(), settings.options_text.clone()),
        ("problem".into(), settings.problem.kind.name().to_string()),
        (
            "mesh_file".into(),
            mesh.map_or(String::new(), |m| m.gmsh.path.clone()),
        ),
        ("physical_names".into(), physical_names),
    ];
    let problems = [&*problems[0], &*problems[1]];
    fields::results(problems, &steps, have, attributes, text)
}

/// `-nndd_schur_view`: each body's S^α and D^α (row-major, exact in JSON) from its first rank,
/// to `PREFIX.body<α>_schur.json` (the ranks agree on the writes).
fn write_interface_operators(
    settings: &Settings,
    layout: &Layout,
    refs: [Option<&dd::body::Body>; 2],
) -> Result<(), AppError> {
    let mut written = Ok(());
    for (k, body) in refs.iter().enumerate() {
        let Some(c) = body.and_then(|b| b.condensed()) else {
            continue;
        };
        let view = serde_json::json!({
            "alpha": k + 1,
            "source": body.and_then(|b| b.schur_source).map(|s| s.name()),
            "m": c.schur.n(),
            "schur": c.schur.data(),
            "delassus": c.delassus.data(),
        });
        let path = settings.output.paths.schur_json(k + 1);
        written = written.and_then(|()| {
            output::write_atomic(&path, view.to_string().as_bytes()).map_err(AppError::from)
        });
    }
    let failed = layout.max(written.is_err() as u8 as f64) > 0.0;
    match (written, failed) {
        (Err(e), _) => Err(e),
        (Ok(()), true) => Err(AppError::ReportedElsewhere { code: 1 }),
        (Ok(()), false) => Ok(()),
    }
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
