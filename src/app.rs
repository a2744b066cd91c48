//! The run, as the algorithm reads: settings, setup (mesh, assembly, factorisation), the
//! reference solution when asked, the solve (NNDD or monolithic) with its error estimates,
//! post-processing, output.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::time::Instant;

use mpi::topology::SimpleCommunicator;

use crate::body::{Body, BodyError, SchurMode};
use crate::contact::{ContactError, ContactStep};
use crate::dirichlet::DirichletStep;
use crate::equilibrate::StarChoice;
use crate::estimate::{
    EstimateError, EstimateRecord, Estimator, Interface, NnddVariant, Reference,
};
use crate::fem::{self, Material};
use crate::layout::{Layout, LayoutError};
use crate::log::Stages;
use crate::monolithic::{self, MonolithicError};
use crate::nndd::{self, Iterate, IterationRecord, NnddError, Status};
use crate::output::{
    self, Center, Field, Grid, GridFields, Kind, OutputError, Results, Step, Topology,
};
use crate::partition::{Partition, PartitionError};
use crate::petsc::{self, Ksp, Matrix, Petsc, PetscError};
use crate::problem::{self, BodyProblem};
use crate::qp::QpSettings;
use crate::settings::{DirichletChoice, Settings, SettingsError, SolverKind, StopRule};
use crate::summary::{EquilibriumResiduals, FieldInfo, Summary, Timings};

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
    /// The error was detected and reported by rank 0; this rank only exits.
    #[error("(reported by rank 0)")]
    ReportedElsewhere,
}

impl AppError {
    /// Errors every rank detects alike (bad input): only rank 0 prints them.
    pub fn is_collective(&self) -> bool {
        matches!(
            self,
            AppError::Settings(_)
                | AppError::Layout(_)
                | AppError::ReportedElsewhere
                | AppError::Output(_)
        )
    }
}

/// How the run ended, for the process exit code.
pub enum Outcome {
    /// Solved (exit 0).
    Solved,
    /// The NNDD did not converge; results were written (exit 3).
    NotConverged,
    /// Only `-help` was asked (exit 0).
    Help,
}

/// What a solver hands to post-processing.
struct Solution {
    status: String,
    stop_reason: &'static str,
    converged: bool,
    /// The run ended as asked (converged, balanced, or the fixed iteration count).
    requested: bool,
    iterations: usize,
    history: Vec<IterationRecord>,
    /// The reported iterate (λ = u¹_n, T¹, T², contact set, fields on their owners).
    last: Iterate,
    /// The estimates, in iteration order (the last one is of `last` when estimating).
    estimates: Vec<EstimateRecord>,
    dirichlet_step: &'static str,
}

pub fn run(world: SimpleCommunicator) -> Result<Outcome, AppError> {
    let t_start = Instant::now();
    let settings = Settings::from_options(Petsc::comm_world())?;
    if petsc::option_present("-help") {
        list_solver_options()?;
        return Ok(Outcome::Help);
    }
    let layout = Layout::new(world, settings.body1_ranks, settings.body_dofs())?;
    check_recovery(&settings, &layout)?;
    check_output(&settings, &layout)?;
    let stages = Stages::register()?;
    Petsc::track_memory()?;
    let mut timings = Timings::default();

    let bodies = setup_bodies(&settings, &layout, &stages, &mut timings)?;
    let refs = [bodies[0].as_ref(), bodies[1].as_ref()];
    if settings.monitor && layout.is_root() {
        println!(
            "nndd: {} n = {}, {} dofs, {} rank(s): setup {:.3} s",
            settings.problem.name(),
            settings.n,
            settings.dofs(),
            layout.size,
            t_start.elapsed().as_secs_f64()
        );
    }
    let reference = match settings.reference_factor {
        0 => None,
        r => Some(solve_reference(
            &settings,
            &layout,
            &stages,
            r,
            &mut timings,
        )?),
    };
    let estimator = settings.estimate.then(|| Estimator {
        iface: Interface::new(problem::body(&settings, 1).contact_x()),
        qp: qp_settings(&settings),
        recovery: settings.recovery,
        nndd_variant: settings.eta_nndd,
        layout: &layout,
        reference,
        overlaps: Default::default(),
    });

    let sol = match settings.solver {
        SolverKind::Nndd => solve_nndd(
            &settings,
            &layout,
            refs,
            estimator.as_ref(),
            &stages,
            &mut timings,
        )?,
        SolverKind::Monolithic => solve_monolithic(
            &settings,
            &layout,
            refs,
            estimator.as_ref(),
            &stages,
            &mut timings,
        )?,
    };

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
    let schur_source = schur_source(&layout, refs);
    let reference_iterations = estimator
        .as_ref()
        .and_then(|e| e.reference.as_ref())
        .map(|r| r.iterations);
    drop(estimator);
    max_over_ranks(&layout, &mut timings);
    let peaks = peak_memory_per_rank(&layout);
    drop(bodies);

    let t_out = Instant::now();
    let results = {
        let _s = stages.output.enter();
        let have = [layout.owns(1), layout.owns(2)];
        let results = results_files(&settings, &sol, have);
        let shares = output_shares(&layout, &results);
        output::write_results_parallel(&layout.world, &settings.output, &results, &shares)?;
        results
    };
    timings.output = layout.max(t_out.elapsed().as_secs_f64());
    timings.total = t_start.elapsed().as_secs_f64();
    if layout.is_root() {
        let summary = summarise(
            &settings,
            &layout,
            &sol,
            energy,
            schur_source,
            reference_iterations,
            &results,
            timings.clone(),
            &peaks,
        );
        let json =
            serde_json::to_string_pretty(&summary).map_err(|e| AppError::Json(e.to_string()))?;
        output::write_atomic(&with_ext(&settings.output, "json"), json.as_bytes())?;
        report(&settings, &summary, &sol);
    }
    Ok(if sol.requested {
        Outcome::Solved
    } else {
        Outcome::NotConverged
    })
}

/// The `star` recovery solves one global problem per body: exact only with the body on one
/// rank (the others are local and computed on overlapping element sets, see `overlap.rs`).
fn check_recovery(settings: &Settings, layout: &Layout) -> Result<(), AppError> {
    let spread = layout.group_sizes.iter().any(|&n| n > 1);
    if spread && matches!(settings.recovery, StarChoice::MinimumEnergy { .. }) && settings.estimate
    {
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
        output::check_writable(&settings.output)
    } else {
        Ok(())
    };
    if !layout.agree(checked.is_ok()) {
        checked?;
        return Err(AppError::ReportedElsewhere);
    }
    Ok(())
}

fn qp_settings(settings: &Settings) -> QpSettings {
    QpSettings {
        tol: settings.qp_tol,
        ..QpSettings::default()
    }
}

/// Meshes, assembly and factorisation of the bodies this rank owns.
fn setup_bodies(
    settings: &Settings,
    layout: &Layout,
    stages: &Stages,
    timings: &mut Timings,
) -> Result<[Option<Body>; 2], AppError> {
    let nndd_run = settings.solver == SolverKind::Nndd;
    let mut bodies: [Option<Body>; 2] = [None, None];
    for alpha in [1, 2] {
        if !layout.owns(alpha) {
            continue;
        }
        let schur = match (settings.solver, alpha, settings.dirichlet_step) {
            (SolverKind::Monolithic, _, _) | (_, 2, _) => SchurMode::Always,
            (_, _, DirichletChoice::Auto) => SchurMode::IfFactored,
            (_, _, DirichletChoice::Condensed) => SchurMode::Always,
            (_, _, DirichletChoice::System) => SchurMode::None,
        };
        let problem = problem::body(settings, alpha);
        let partition = Partition::new(
            &problem.mesh,
            alpha,
            layout.group_rank(),
            layout.group_sizes[alpha - 1],
        )?;
        let mut body = Body::setup(problem, layout.body_comm(), partition, schur, stages)?;
        if nndd_run && alpha == 1 && body.schur.is_none() {
            body.add_dirichlet_system(stages)?;
        }
        timings.assembly += body.setup_seconds.0;
        timings.factorisation += body.setup_seconds.1;
        bodies[alpha - 1] = Some(body);
    }
    Ok(bodies)
}

/// The reference solution of (26): the nested mesh r·n, NNDD to tol 1e−8.
fn solve_reference(
    settings: &Settings,
    layout: &Layout,
    stages: &Stages,
    r: usize,
    timings: &mut Timings,
) -> Result<Reference, AppError> {
    let t = Instant::now();
    let fine = settings.refined(r);
    let mut scratch = Timings::default();
    let bodies = setup_bodies(&fine, layout, stages, &mut scratch)?;
    let refs = [bodies[0].as_ref(), bodies[1].as_ref()];
    let sol = {
        let _s = stages.reference.enter();
        solve_nndd(&fine, layout, refs, None, stages, &mut scratch)?
    };
    timings.reference = t.elapsed().as_secs_f64();
    if layout.is_root() && settings.monitor {
        println!(
            "nndd: reference solution on mesh {} ({} dofs): {} after {} iterations, {:.2} s",
            fine.n,
            fine.dofs(),
            sol.status,
            sol.iterations,
            timings.reference
        );
    }
    Ok(Reference {
        factor: r,
        u: sol.last.u,
        iterations: sol.iterations,
        bodies,
    })
}

/// The NNDD loop (paper §3), estimating where asked.
fn solve_nndd(
    settings: &Settings,
    layout: &Layout,
    refs: [Option<&Body>; 2],
    estimator: Option<&Estimator>,
    stages: &Stages,
    timings: &mut Timings,
) -> Result<Solution, AppError> {
    let dirichlet = refs[0].map(DirichletStep::new).transpose()?;
    let qp = qp_settings(settings);
    let contact = refs[1]
        .map(|b2| ContactStep::new(b2, qp, settings.qp_warm_start))
        .transpose()?;
    let estimates: RefCell<Vec<EstimateRecord>> = RefCell::new(Vec::new());
    // Balanced stopping's cheap checks (iteration, η^NNDD) and the last full η^FE.
    let checks: RefCell<Vec<(usize, f64)>> = RefCell::new(Vec::new());
    let last_fe: std::cell::Cell<Option<f64>> = std::cell::Cell::new(None);
    let mut t_est = 0.0;
    let every = if estimator.is_some() && settings.estimate_every > 0 {
        Some(settings.estimate_every)
    } else {
        None
    };
    let root = layout.is_root();
    let res = nndd::solve(
        settings,
        layout,
        refs,
        dirichlet.as_ref(),
        contact.as_ref(),
        stages,
        every,
        |it| {
            let Some(est) = estimator else {
                return Ok(false);
            };
            let t = Instant::now();
            let _s = stages.estimation.enter();
            let balanced_rule =
                settings.stop == StopRule::Balanced && settings.eta_nndd == NnddVariant::Discrete;
            // Balanced stopping: check the cheap η^NNDD against κ η^FE of the last full
            // estimate; a full estimate only at the first check and when the rule may hold.
            if let (true, Some(fe)) = (balanced_rule, last_fe.get()) {
                let nndd = est.eta_nndd(refs, it)?;
                if nndd > settings.stop_ratio * fe {
                    checks.borrow_mut().push((it.iteration, nndd));
                    t_est += t.elapsed().as_secs_f64();
                    return Ok(false);
                }
            }
            let rec = est.estimate(refs, it)?;
            t_est += t.elapsed().as_secs_f64();
            last_fe.set(Some(rec.eta_fe));
            let balanced = settings.stop == StopRule::Balanced
                && rec.eta_nndd <= settings.stop_ratio * rec.eta_fe;
            estimates.borrow_mut().push(rec);
            Ok(balanced)
        },
        |r| {
            if settings.monitor && root {
                monitor_line(
                    settings,
                    r,
                    estimates
                        .borrow()
                        .last()
                        .filter(|e| e.iteration == r.iteration),
                );
            }
        },
    )?;
    let mut estimates = estimates.into_inner();
    if let Some(est) = estimator {
        if estimates.last().map(|e| e.iteration) != Some(res.iterations) {
            let t = Instant::now();
            let _s = stages.estimation.enter();
            let rec = est.estimate(refs, &res.last)?;
            t_est += t.elapsed().as_secs_f64();
            if settings.monitor && root {
                println!("{}", estimate_text(&rec));
            }
            estimates.push(rec);
        }
    }
    timings.estimation += t_est;
    timings.dirichlet_step = res.timers.dirichlet_step.seconds();
    timings.contact_step = res.timers.contact_step.seconds();
    timings.neumann_step = res.timers.neumann_step.seconds();
    timings.exchange = res.timers.exchange.seconds();
    let mut history = res.history;
    attach_estimates(&mut history, &estimates);
    for (iteration, nndd) in checks.into_inner() {
        if let Some(h) = history.iter_mut().find(|h| h.iteration == iteration) {
            h.eta_nndd = Some(nndd);
        }
    }
    Ok(Solution {
        status: res.status.name().to_string(),
        stop_reason: res.status.stop_reason(),
        // A fixed iteration count asked for (-nndd_stop none) is a success too.
        converged: res.status.succeeded(),
        requested: res.status.succeeded()
            || (settings.stop == StopRule::None && res.status == Status::MaxIterations),
        iterations: res.iterations,
        history,
        last: res.last,
        estimates,
        dirichlet_step: dirichlet.as_ref().map_or("", |d| d.name()),
    })
}

/// The discrete global contact problem at once (the NNDD's check).
fn solve_monolithic(
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
        monolithic::solve(layout, refs, &qp_settings(settings))?
    };
    timings.monolithic = t.elapsed().as_secs_f64();
    let mut lambda = refs[0]
        .map(|b| b.normal_trace(&res.u[0]))
        .unwrap_or_default();
    layout.share_vec(1, &mut lambda);
    let trace2 = nndd::shared_trace2(layout, refs[1], &res.u[1], lambda.len());
    let last = Iterate {
        lambda,
        trace2,
        u: res.u,
        forces: [res.forces.iter().map(|f| -f).collect(), res.forces.clone()],
        active: res.active,
        qp_kkt: res.kkt_residual,
        iteration: 0,
    };
    let mut estimates = Vec::new();
    if let Some(est) = estimator {
        let t = Instant::now();
        let _s = stages.estimation.enter();
        estimates.push(est.estimate(refs, &last)?);
        timings.estimation = t.elapsed().as_secs_f64();
    }
    Ok(Solution {
        status: "solved".into(),
        stop_reason: "direct",
        converged: true,
        requested: true,
        iterations: 0,
        history: Vec::new(),
        last,
        estimates,
        dirichlet_step: "",
    })
}

fn attach_estimates(history: &mut [IterationRecord], estimates: &[EstimateRecord]) {
    for e in estimates {
        if let Some(h) = history.iter_mut().find(|h| h.iteration == e.iteration) {
            h.eta_glo = Some(e.eta_glo);
            h.eta_fe = Some(e.eta_fe);
            h.eta_nndd = Some(e.eta_nndd);
            h.eta_ratio = Some(e.eta_ratio);
            h.e_ref = e.e_ref;
            h.effectivity = e.effectivity;
        }
    }
}

fn monitor_line(settings: &Settings, r: &IterationRecord, est: Option<&EstimateRecord>) {
    println!(
        "{:4} NNDD dlambda/lambda {} |R| {} active {}/{} qp_its {}",
        r.iteration,
        sci(r.lambda_change, 12),
        sci(r.residual, 6),
        r.active,
        settings.body_grid(1).0 + 1,
        r.qp_iterations
    );
    if let Some(e) = est {
        println!("{}", estimate_text(e));
    }
    use std::io::Write;
    let _ = std::io::stdout().flush();
}

fn estimate_text(e: &EstimateRecord) -> String {
    let mut s = format!(
        "{:4} NNDD eta_glo {} eta_FE {} eta_NNDD {} ratio {:.4}",
        e.iteration,
        sci(e.eta_glo, 6),
        sci(e.eta_fe, 6),
        sci(e.eta_nndd, 6),
        e.eta_ratio
    );
    if let (Some(r), Some(g)) = (e.e_ref, e.effectivity) {
        s += &format!(" e_ref {} effectivity {:.4}", sci(r, 6), g);
    }
    s
}

/// How body 2's interface Schur complement was formed (known on body 2's root).
fn schur_source(layout: &Layout, refs: [Option<&Body>; 2]) -> &'static str {
    let mut src = [refs[1].map_or(0.0, |b| (b.schur_source == "mumps") as u8 as f64)];
    layout.share(2, &mut src);
    if src[0] > 0.5 {
        "mumps"
    } else {
        "solves"
    }
}

/// Peak memory of every rank (MiB), on every rank.
fn peak_memory_per_rank(layout: &Layout) -> Vec<f64> {
    use mpi::traits::*;
    let mine = Petsc::peak_memory() / (1024.0 * 1024.0);
    let mut all = vec![0.0; layout.size as usize];
    layout.world.all_gather_into(&mine, &mut all[..]);
    all
}

/// The rows of each grid this rank writes: a body's points and cells split evenly over its
/// group's ranks (which all hold its fields); the Γc grid by rank 0.
fn output_shares(layout: &Layout, results: &Results) -> Vec<output::Share> {
    results
        .grids
        .iter()
        .map(|g| {
            let alpha = match g.name.as_str() {
                "body1" => 1,
                "body2" => 2,
                _ => 0,
            };
            let (mine, k, parts) = if alpha == 0 {
                (layout.is_root(), 0, 1)
            } else {
                (
                    layout.owns(alpha),
                    layout.group_rank(),
                    layout.group_sizes[alpha - 1],
                )
            };
            let block = |len: usize| {
                if mine {
                    len * k / parts..len * (k + 1) / parts
                } else {
                    0..0
                }
            };
            let cells = match &g.topology {
                Topology::Triangle(t) => t.len(),
                Topology::Segment(t) => t.len(),
            };
            output::Share {
                points: block(g.points.len()),
                cells: block(cells),
            }
        })
        .collect()
}

fn max_over_ranks(layout: &Layout, t: &mut Timings) {
    for x in [
        &mut t.assembly,
        &mut t.factorisation,
        &mut t.dirichlet_step,
        &mut t.contact_step,
        &mut t.neumann_step,
        &mut t.exchange,
        &mut t.monolithic,
        &mut t.estimation,
        &mut t.reference,
    ] {
        *x = layout.max(*x);
    }
}

/// The quantities of the summary that come from the reported iterate.
struct Contact {
    force: f64,
    zone: Option<[f64; 2]>,
    active: usize,
    nodes: usize,
}

fn contact_of(p1: &BodyProblem, last: &Iterate) -> Contact {
    let x = p1.contact_x();
    let xs: Vec<f64> = (0..x.len())
        .filter(|&i| last.active[i])
        .map(|i| x[i])
        .collect();
    let zone = (!xs.is_empty()).then(|| {
        [
            xs.iter().cloned().fold(f64::INFINITY, f64::min),
            xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        ]
    });
    Contact {
        force: last.forces[1].iter().sum(),
        zone,
        active: xs.len(),
        nodes: x.len(),
    }
}

/// The HDF5/XDMF content: the meshes and one time step per estimated iteration (or the
/// reported iterate alone).
/// Body α's fields are filled on the ranks of its group (`have`), empty elsewhere; the
/// geometry and the Γc fields are known everywhere.
fn results_files(settings: &Settings, sol: &Solution, have: [bool; 2]) -> Results {
    let last = &sol.last;
    let problems = [problem::body(settings, 1), problem::body(settings, 2)];
    let iface = Interface::new(problems[0].contact_x());
    let m = iface.len();
    let mut grids: Vec<Grid> = problems
        .iter()
        .map(|p| Grid {
            name: format!("body{}", p.alpha),
            points: p.mesh.points.clone(),
            topology: Topology::Triangle(
                p.mesh
                    .triangles
                    .iter()
                    .map(|t| t.map(|v| v as u32))
                    .collect(),
            ),
        })
        .collect();
    grids.push(Grid {
        name: "contact".into(),
        points: iface.x.iter().map(|&xi| [xi, 1.0]).collect(),
        topology: Topology::Segment(
            (0..m.saturating_sub(1) as u32)
                .map(|i| [i, i + 1])
                .collect(),
        ),
    });
    let step = |it: &Iterate, est: Option<&EstimateRecord>| {
        let mut grids = Vec::new();
        for (k, p) in problems.iter().enumerate() {
            let mut fields = body_fields(&p.mesh, &p.material, &it.u[k], have[k]);
            if let Some(e) = est {
                for (name, map) in ["eta_glo", "eta_fe", "eta_nndd"].iter().zip(&e.maps[k]) {
                    fields.push(Field {
                        name: name.to_string(),
                        center: Center::Cell,
                        kind: Kind::Scalar,
                        values: if have[k] { map.clone() } else { Vec::new() },
                    });
                }
            }
            grids.push(GridFields {
                grid: format!("body{}", p.alpha),
                fields,
            });
        }
        // u²_n − u¹_n = u²_n − λ (step 1 puts u¹_n at λ exactly); u²_n is shared by body 2.
        let u2n = &it.trace2;
        let lumped = iface.forces(&vec![1.0; m]);
        let scalar = |name: &str, values: Vec<f64>| Field {
            name: name.into(),
            center: Center::Node,
            kind: Kind::Scalar,
            values,
        };
        let mut fields = vec![
            scalar("lambda", it.lambda.clone()),
            scalar("normal_force", it.forces[1].clone()),
            scalar(
                "pressure",
                (0..m).map(|i| it.forces[1][i] / lumped[i]).collect(),
            ),
            scalar("gap", (0..m).map(|i| u2n[i] - it.lambda[i]).collect()),
            scalar(
                "active",
                it.active.iter().map(|&a| a as u8 as f64).collect(),
            ),
        ];
        if let Some(e) = est {
            fields.push(scalar("t_hat", e.t_hat.clone()));
        }
        grids.push(GridFields {
            grid: "contact".into(),
            fields,
        });
        Step {
            time: it.iteration as f64,
            grids,
        }
    };
    let steps = if sol.estimates.is_empty() {
        vec![step(last, None)]
    } else {
        sol.estimates
            .iter()
            .map(|e| step(&e.iterate, Some(e)))
            .collect()
    };
    Results {
        grids,
        steps,
        attributes: vec![
            ("n".into(), settings.n as f64),
            ("dofs".into(), settings.dofs() as f64),
            ("iterations".into(), sol.iterations as f64),
        ],
    }
}

#[allow(clippy::too_many_arguments)]
fn summarise(
    settings: &Settings,
    layout: &Layout,
    sol: &Solution,
    energy: f64,
    schur_source: &str,
    reference_iterations: Option<usize>,
    results: &Results,
    timings: Timings,
    peaks: &[f64],
) -> Summary {
    let contact = contact_of(&problem::body(settings, 1), &sol.last);
    let residuals = (!sol.estimates.is_empty()).then(|| {
        let mut r = EquilibriumResiduals::default();
        for e in &sol.estimates {
            let x = &e.residuals;
            r.divergence = r.divergence.max(x.divergence);
            r.internal_jump = r.internal_jump.max(x.internal_jump);
            r.element_jump = r.element_jump.max(x.element_jump);
            r.boundary = r.boundary.max(x.boundary);
            r.point_reaction = r.point_reaction.max(x.point_reaction);
        }
        r
    });
    Summary {
        problem: settings.problem.name().into(),
        n: settings.n,
        grids: [0, 1].map(|k| [settings.grids[k].0, settings.grids[k].1]),
        dofs: settings.dofs(),
        ranks: layout.size,
        solver: settings.solver.name().into(),
        theta: settings.theta,
        tol: settings.tol,
        max_it: settings.max_it,
        young: settings.material.young,
        poisson: settings.material.poisson,
        u_d: settings.u_d,
        f_max: settings.f_max,
        converged: sol.converged,
        status: sol.status.clone(),
        stop_reason: sol.stop_reason.into(),
        iterations: sol.iterations,
        history: sol.history.clone(),
        potential_energy: energy,
        contact_force: contact.force,
        contact_zone: contact.zone,
        active_nodes: contact.active,
        contact_nodes: contact.nodes,
        schur_source: schur_source.into(),
        dirichlet_step: sol.dirichlet_step.into(),
        qp_kkt_residual: sol.last.qp_kkt,
        estimates: sol.estimates.iter().map(summary_estimate).collect(),
        equilibrium_residuals: residuals,
        reference_factor: (settings.reference_factor > 0).then_some(settings.reference_factor),
        reference_iterations,
        timings,
        peak_memory_mib: peaks.iter().cloned().fold(0.0, f64::max),
        peak_memory_mib_per_rank: peaks.to_vec(),
        body_ranks: layout.group_sizes,
        h5: with_ext(&settings.output, "h5").display().to_string(),
        xdmf: with_ext(&settings.output, "xdmf").display().to_string(),
        fields: describe(results),
    }
}

fn summary_estimate(e: &EstimateRecord) -> IterationRecord {
    IterationRecord {
        iteration: e.iteration,
        eta_glo: Some(e.eta_glo),
        eta_fe: Some(e.eta_fe),
        eta_nndd: Some(e.eta_nndd),
        eta_ratio: Some(e.eta_ratio),
        e_ref: e.e_ref,
        effectivity: e.effectivity,
        ..Default::default()
    }
}

/// The closing line (and the warning of a run that did not converge), on rank 0.
fn report(settings: &Settings, summary: &Summary, sol: &Solution) {
    println!(
        "nndd: {} n = {} ({} dofs, {} rank(s), {}): {} after {} iterations; energy {} J/m, contact force {} N/m, zone {}; {:.2} s; wrote {}.{{h5,xdmf,json}}",
        summary.problem,
        summary.n,
        summary.dofs,
        summary.ranks,
        summary.solver,
        summary.status,
        summary.iterations,
        sci(summary.potential_energy, 10),
        sci(summary.contact_force, 6),
        summary.contact_zone.map_or("none".to_string(), |z| format!("[{:.4}, {:.4}]", z[0], z[1])),
        summary.timings.total,
        settings.output.display()
    );
    if let Some(e) = sol.estimates.last() {
        println!(
            "nndd: estimates at iteration {}: {}",
            e.iteration,
            estimate_text(e).trim_start()
        );
    }
    if !sol.requested {
        let last = sol.history.last().map_or(f64::NAN, |r| r.lambda_change);
        eprintln!(
            "nndd: warning: the NNDD {} after {} iterations (dlambda/lambda {} > -nndd_tol {}); try a smaller -nndd_theta (now {})",
            match sol.status.as_str() {
                "diverged" => "diverged",
                "stagnated" => "stagnated",
                _ => "reached -nndd_max_it",
            },
            sol.iterations,
            sci(last, 3),
            sci(settings.tol, 1),
            settings.theta
        );
    }
}

/// C's `%.{digits}e` (PETSc's monitors): `1.234e-03`, not Rust's `1.234e-3`.
pub fn sci(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    let s = format!("{:.*e}", digits, x);
    let (mant, exp) = s.split_once('e').expect("scientific format");
    let e: i32 = exp.parse().expect("exponent");
    format!("{mant}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

/// Displacement (node vector), stress (cell tensor, plane strain σ_zz) and von Mises stress.
/// Empty values unless `have` (the ranks of the body's group).
fn body_fields(mesh: &crate::mesh::Mesh, mat: &Material, u: &[f64], have: bool) -> Vec<Field> {
    let s = if have {
        fem::stresses(mesh, mat, u)
    } else {
        Vec::new()
    };
    let mut tensor = Vec::with_capacity(6 * s.len());
    let mut mises = Vec::with_capacity(s.len());
    for si in &s {
        let zz = mat.sigma_zz(si);
        tensor.extend_from_slice(&[si[0], si[1], zz, si[2], 0.0, 0.0]);
        let (a, b, c) = (si[0] - si[1], si[1] - zz, zz - si[0]);
        mises.push((0.5 * (a * a + b * b + c * c) + 3.0 * si[2] * si[2]).sqrt());
    }
    vec![
        Field {
            name: "displacement".into(),
            center: Center::Node,
            kind: Kind::Vector,
            values: if have { u.to_vec() } else { Vec::new() },
        },
        Field {
            name: "stress".into(),
            center: Center::Cell,
            kind: Kind::Tensor,
            values: tensor,
        },
        Field {
            name: "von_mises".into(),
            center: Center::Cell,
            kind: Kind::Scalar,
            values: mises,
        },
    ]
}

/// The JSON description of the fields of the last step (dataset paths of `PREFIX.h5`).
fn describe(results: &Results) -> Vec<FieldInfo> {
    let k = results.steps.len().saturating_sub(1);
    let mut out = Vec::new();
    if let Some(step) = results.steps.last() {
        for g in &step.grids {
            for f in &g.fields {
                out.push(FieldInfo {
                    grid: g.grid.clone(),
                    name: f.name.clone(),
                    center: if matches!(f.center, Center::Node) {
                        "node"
                    } else {
                        "cell"
                    },
                    // Columns as stored (vectors padded to 3, tensors as full 3 × 3).
                    components: match f.kind {
                        Kind::Scalar => 1,
                        Kind::Vector => 3,
                        Kind::Tensor => 9,
                    },
                    dataset: format!("/steps/{k}/{}/{}", g.grid, f.name),
                });
            }
        }
    }
    out
}

/// `PREFIX` + `.ext` (a prefix may contain dots: never replace an extension).
fn with_ext(prefix: &Path, ext: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    s.into()
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
