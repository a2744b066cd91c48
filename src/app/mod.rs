//! Layer `app`: the run. [`options`] reads every `-nndd_` option into the plain settings of
//! each layer; [`run`] reads as the algorithm (deal.II step-42's `run()`): settings, setup
//! (mesh, assembly, factorisation), the estimator, the solve (NNDD or monolithic) with its
//! estimates ([`solve`]), post-processing and output ([`report`]).
//!
//! May use: every layer below (`io`, `estimate`, `dd`, `problem`, `parallel`, `qp`, `fem`,
//! `petsc`).

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
use crate::dd::body::BodyError;
use crate::dd::contact::ContactError;
use crate::dd::monolithic::MonolithicError;
use crate::dd::nndd::NnddError;
use crate::estimate::{EstimateError, Estimator, Interface, Parts};
use crate::io::checkpoint::{self, CheckpointError, Identity};
use crate::io::fields;
use crate::io::output::{self, OutputError, Results};
use crate::io::summary::{EstimationParts, Timings};
use crate::parallel::fault::{self, Agreement, InjectedFault, Phase};
use crate::parallel::layout::{Layout, LayoutError};
use crate::parallel::partition::PartitionError;
use crate::petsc::log::Stages;
use crate::petsc::{self, Ksp, Matrix, Petsc, PetscError};
use crate::problem::meshed::MeshedError;
use crate::problem::{self, BodyProblem};
use options::{Settings, SettingsError, SolverKind};
use solve::{Restart, Solution};

/// Printed by `-help` before the option list.
pub const HELP: &str =
    "nndd: two-body frictionless contact in 2D plane-strain elasticity, solved by the\n\
Neumann-Neumann domain decomposition of Gallimard, Choi & Sassi (2013), with guaranteed\n\
error bounds (eta_glo) split into discretisation (eta_FE) and algebraic (eta_NNDD) parts.\n\
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

pub fn run(world: SimpleCommunicator, agreement: &Agreement) -> Result<Outcome, AppError> {
    let t_start = Instant::now();
    // Settings: every -nndd_ option, validated; the ranks agree before going on.
    let settings = agreed(
        agreement,
        Settings::from_options(Petsc::comm_world())
            .map_err(AppError::from)
            .and_then(|s| {
                fault::arm(s.fault, world.rank());
                fault::check(Phase::Options)?;
                Ok(s)
            }),
    )?;
    if petsc::option_present("-help") {
        list_solver_options()?;
        return Ok(Outcome::Help);
    }
    // `-version`: PETSc has printed its own version; add nndd's and stop before any work.
    if petsc::option_present("-version") {
        if world.rank() == 0 {
            println!("nndd {}", env!("CARGO_PKG_VERSION"));
        }
        return Ok(Outcome::Help);
    }
    // Memory: the meshes must fit in the nodes' memory (before any mesh is built).
    agreed(
        agreement,
        capacity::check(&settings, &world).map_err(AppError::from),
    )?;
    if world.rank() == 0 {
        for w in &settings.warnings {
            crate::io::monitor::say(format_args!("nndd: warning: {w}"));
        }
    }
    // Problem: both bodies' meshes, materials, boundary conditions and Γc (every rank knows
    // the whole geometry, for the interface and the output).
    let problems = agreed(
        agreement,
        problem::build(&settings.problem)
            .map_err(AppError::from)
            .and_then(|p| {
                fault::check(Phase::Mesh)?;
                Ok(p)
            }),
    )?;
    if let (Some(spec), true) = (&settings.problem.mesh, world.rank() == 0) {
        let m = &spec.matched;
        if m.inserted != [0; 2] || m.moved != [0; 2] {
            let [c1, c2] = &spec.contact;
            println!(
                "nndd: contact curves '{c1}' and '{c2}' meshed independently, made to match: {} and {} node(s) inserted, {} and {} moved onto a partner; Γc: {} pairs where they overlap ({} and {} nodes on the curves)",
                m.inserted[0],
                m.inserted[1],
                m.moved[0],
                m.moved[1],
                problems[0].contact_nodes.len(),
                problems[0].contact_candidates.len(),
                problems[1].contact_candidates.len()
            );
        }
    }
    let input_seconds = t_start.elapsed().as_secs_f64();
    let dofs = [problems[0].mesh.num_dofs(), problems[1].mesh.num_dofs()];
    let layout = Layout::new(world, settings.body1_ranks, dofs)?;
    check_recovery(&settings, &layout)?;
    check_schur(&settings, &layout)?;
    check_output(&settings, &layout)?;
    // The restart point this run continues from, checked against this problem.
    let identity = Identity::of(
        settings.problem.kind.name(),
        &problems,
        settings.theta_text.clone(),
        settings.nndd.dirichlet_body,
    );
    let from = match &settings.restart {
        None => None,
        Some(path) => Some(agreed(
            agreement,
            checkpoint::read(path, &identity, settings.nndd.max_it).map_err(AppError::from),
        )?),
    };
    petsc::signals::catch_stop_requests().map_err(AppError::Signals)?;
    let stages = Stages::register()?;
    Petsc::track_memory()?;
    let mut timings = Timings {
        input: input_seconds,
        ..Timings::default()
    };

    // Setup: each rank's bodies (partition, assembly, factorisation); the ranks agree.
    let bodies = agreed(
        agreement,
        solve::setup_bodies(&settings, &problems, &layout, &stages, &mut timings),
    )?;
    let refs = [bodies[0].as_ref(), bodies[1].as_ref()];
    let unused = unused_solver_options(&settings, &layout)?;
    if layout.is_root() {
        for w in &unused {
            crate::io::monitor::say(format_args!("nndd: warning: {w}"));
        }
    }
    if settings.monitor && layout.is_root() {
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
        println!(
            "nndd: {problem}, {} dofs, {} rank(s){roles}: setup {:.3} s",
            dofs[0] + dofs[1],
            layout.size,
            t_start.elapsed().as_secs_f64()
        );
    }

    // Estimate: the estimator (with the reference solution of (26) when asked), used by the
    // solve at the estimated iterations and on the reported iterate.
    let mut warnings = unused;
    let reference = match settings.reference_factor {
        0 => None,
        r => match solve::solve_reference(&settings, &layout, &stages, r, &mut timings)? {
            Ok(reference) => Some(reference),
            Err(w) => {
                if layout.is_root() {
                    crate::io::monitor::say(format_args!("nndd: warning: {w}"));
                }
                warnings.push(w);
                None
            }
        },
    };
    let estimator = settings.estimate.then(|| Estimator {
        iface: Interface::new(problems[0].contact_lengths.clone()),
        qp: settings.qp.clone(),
        recovery: settings.recovery,
        warm_change: settings.warm_change,
        nndd_variant: settings.eta_nndd,
        layout: &layout,
        reference,
        problems: problems.clone(),
        owners: Default::default(),
        shares: Default::default(),
        parts: Parts::new(Some(stages.estimation_parts)),
        operators: Default::default(),
        cheap_nndd: Default::default(),
        cold: Default::default(),
    });

    // Solve: the NNDD (paper §3) or the monolithic check.
    let restart = Restart {
        identity: &identity,
        path: checkpoint::path_for(&settings.output),
        from,
        agreement,
    };
    let mut sol = match settings.solver {
        SolverKind::Nndd => end_job_on_local_failure(solve::solve_nndd(
            &settings,
            &layout,
            refs,
            estimator.as_ref(),
            &stages,
            &mut timings,
            Some(&restart),
        ))?,
        SolverKind::Monolithic => end_job_on_local_failure(solve::solve_monolithic(
            &settings,
            &layout,
            refs,
            estimator.as_ref(),
            &stages,
            &mut timings,
        ))?,
    };

    // Contact beyond Γc: a zone that reaches an end of Γc where the bodies go on side by side.
    let problem_refs = [&*problems[0], &*problems[1]];
    if let Some(w) = dd::check::zone_reaches_open_end(problem_refs, &sol.last) {
        if layout.is_root() {
            crate::io::monitor::say(format_args!("nndd: warning: {w}"));
        }
        sol.warnings.push(w);
    }
    sol.warnings.splice(0..0, warnings);
    // Penetration over the whole contact curves: beyond round-off, an error.
    let penetration = dd::check::penetration(&layout, problem_refs, &sol.last);
    if let Some(what) = penetration.failure(&contact_curves(&settings)) {
        return Err(AppError::Penetration(what));
    }
    sol.penetration = Some(penetration);

    // Post-processing: energy, Schur source, timings and memory over ranks.
    let energy = {
        let mut e = 0.0;
        for (k, b) in refs.iter().enumerate() {
            if let Some(b) = b {
                let energy = b.potential_energy(&sol.last.u[k])?;
                if b.is_root() {
                    e += energy; // every rank of the group has it: count it once
                }
            }
        }
        layout.sum(e)
    };
    let solvers = solve::body_solvers(&layout, refs, &sol);
    if settings.schur_view {
        write_interface_operators(&settings, &layout, refs)?;
    }
    let logged_flops = layout.sum(Petsc::logged_flops());
    let reference_iterations = estimator
        .as_ref()
        .and_then(|e| e.reference.as_ref())
        .map(|r| r.iterations);
    if let Some(e) = &estimator {
        timings.estimation_parts = EstimationParts::from(e.parts.seconds());
    }
    drop(estimator);
    report::max_over_ranks(&layout, &mut timings);
    drop(bodies);
    Petsc::release_free_memory(0);

    // Output: PREFIX.h5 + PREFIX.xdmf (collective), PREFIX.json (rank 0).
    let t_out = Instant::now();
    let results = {
        let _s = stages.output.enter();
        let have = [layout.owns(1), layout.owns(2)];
        let results = results_of(&settings, &problems, &sol, have);
        let shares = fields::shares(&layout, [&problems[0], &problems[1]]);
        output::write_results_parallel(&layout.world, &settings.output, &results, &shares)?;
        results
    };
    timings.output = layout.max(t_out.elapsed().as_secs_f64());
    timings.total = t_start.elapsed().as_secs_f64();
    // The high-water marks of the whole run, the output's fields included.
    let peaks = report::peak_memory_per_rank(&layout);
    let mut written = Ok(());
    if layout.is_root() {
        let summary = report::summarise(
            &settings,
            [&problems[0], &problems[1]],
            &layout,
            &sol,
            energy,
            &solvers,
            logged_flops,
            reference_iterations,
            &results,
            timings.clone(),
            &peaks,
        );
        let json =
            serde_json::to_string_pretty(&summary).map_err(|e| AppError::Json(e.to_string()))?;
        written =
            output::write_atomic(&output::with_ext(&settings.output, "json"), json.as_bytes())
                .map_err(AppError::from);
        if written.is_ok() {
            report::report(&settings, &summary, &sol);
        }
    }
    agreed(agreement, written)?;
    if petsc::signals::stop_requested() && !sol.interrupted && layout.is_root() {
        // The output is not interrupted: a signal during it is read once the files exist.
        crate::io::monitor::say(format_args!(
            "nndd: {} arrived while the results were written; they are complete",
            petsc::signals::received_name()
        ));
    }
    Ok(if sol.interrupted {
        Outcome::Interrupted
    } else if sol.requested {
        Outcome::Solved
    } else {
        Outcome::NotConverged
    })
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
        let path = output::with_ext(&settings.output, &format!("body{}_schur.json", k + 1));
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
    if spread && !settings.recovery.is_local() && settings.estimate {
        return Err(LayoutError::GlobalRecovery {
            ranks: layout.group_sizes,
        }
        .into());
    }
    Ok(())
}

/// `-nndd_schur mumps_schur` needs each body on one rank and factored by MUMPS, and
/// `mumps_inverse` a MUMPS factorisation (bad input, found alike on every rank).
fn check_schur(settings: &Settings, layout: &Layout) -> Result<(), AppError> {
    use dd::body::SchurChoice;
    let choice = settings.schur;
    for alpha in [1, 2] {
        let why = match choice {
            SchurChoice::MumpsSchur | SchurChoice::MumpsInverse
                if !options::uses_mumps(alpha)? =>
            {
                format!("body {alpha} is not factored by MUMPS (-body{alpha}_pc_factor_mat_solver_type mumps with -body{alpha}_pc_type cholesky or lu and -body{alpha}_ksp_type preonly); use auto or solves")
            }
            SchurChoice::MumpsSchur if layout.group_sizes[alpha - 1] > 1 => format!(
                "body {alpha} is on {} ranks, and PETSc 3.18 forms MUMPS's Schur complement on one only; use auto or mumps_inverse",
                layout.group_sizes[alpha - 1]
            ),
            _ => continue,
        };
        return Err(SettingsError::Named {
            option: format!("-nndd_schur {}", choice.name()),
            message: why,
        }
        .into());
    }
    Ok(())
}

/// Fail before any work when the output cannot be written (rank 0 checks, all agree).
fn check_output(settings: &Settings, layout: &Layout) -> Result<(), AppError> {
    let checked = if layout.is_root() {
        output::check_writable(&settings.output)
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
fn list_solver_options() -> Result<(), PetscError> {
    for prefix in ["body1_", "body2_"] {
        let mut a = Matrix::preallocated(Petsc::comm_self(), 2, &[1, 1], &[0, 0])?;
        for i in 0..2 {
            a.add_values(&[i], &[i], &[1.0])?;
        }
        a.assemble()?;
        let _ksp = Ksp::new(Petsc::comm_self(), a, prefix, None)?;
    }
    Ok(())
}
