//! The run, as the algorithm reads: settings, setup (mesh, assembly, factorisation), solve
//! (NNDD or monolithic), post-processing, output.

use std::path::Path;
use std::time::Instant;

use mpi::topology::SimpleCommunicator;

use crate::body::{Body, BodyError, SchurMode};
use crate::contact::{ContactError, ContactStep};
use crate::dirichlet::DirichletStep;
use crate::fem::{self, Material};
use crate::layout::{Layout, LayoutError};
use crate::log::Stages;
use crate::monolithic::{self, MonolithicError};
use crate::nndd::{self, IterationRecord, NnddError, Status};
use crate::output::{
    self, Center, Field, Grid, GridFields, Kind, OutputError, Results, Step, Topology,
};
use crate::petsc::{self, Ksp, Matrix, Petsc, PetscError};
use crate::problem::{self, interface_mass};
use crate::qp::QpSettings;
use crate::settings::{DirichletChoice, Settings, SettingsError, SolverKind};
use crate::summary::{FieldInfo, Summary, Timings};

/// Printed by `-help` before the option list.
pub const HELP: &str =
    "nndd: two-body frictionless contact in 2D plane-strain elasticity, solved by the\n\
Neumann-Neumann domain decomposition of Gallimard, Choi & Sassi (2013).\n\
Usage: mpirun -n 2 nndd -options_file petsc-options/paper.opts [-nndd_monitor] [-log_view]\n\
Subdomain solvers take the prefixes body1_ and body2_ (default: MUMPS Cholesky).\n\n";

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error(transparent)]
    Layout(#[from] LayoutError),
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
            AppError::Settings(_) | AppError::Layout(_) | AppError::ReportedElsewhere
        ) || matches!(self, AppError::Output(_))
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

/// The solution both solvers hand to post-processing.
struct Solution {
    status: String,
    converged: bool,
    iterations: usize,
    history: Vec<IterationRecord>,
    /// Body 1's normal Γc displacement (λ_p for the NNDD).
    lambda: Vec<f64>,
    u: [Vec<f64>; 2],
    /// Body 2's Γc nodal forces (≥ 0).
    forces: Vec<f64>,
    active: Vec<bool>,
    qp_kkt: f64,
}

pub fn run(world: SimpleCommunicator) -> Result<Outcome, AppError> {
    let t_start = Instant::now();
    let settings = Settings::from_options(Petsc::comm_world())?;
    if petsc::option_present("-help") {
        list_solver_options()?;
        return Ok(Outcome::Help);
    }
    let layout = Layout::new(world)?;
    // Fail before any work when the output cannot be written.
    let checked = if layout.is_root() {
        output::check_writable(&settings.output)
    } else {
        Ok(())
    };
    if !layout.agree(checked.is_ok()) {
        checked?;
        return Err(AppError::ReportedElsewhere);
    }
    let stages = Stages::register()?;
    Petsc::track_memory()?;
    let qp = QpSettings {
        tol: settings.qp_tol,
        ..QpSettings::default()
    };

    // Setup: meshes, assembly and factorisation of the bodies this rank owns.
    let nndd_run = settings.solver == SolverKind::Nndd;
    let mut bodies: [Option<Body>; 2] = [None, None];
    for alpha in [1, 2] {
        if layout.owns(alpha) {
            let p = problem::body(&settings, alpha);
            let schur = match (settings.solver, alpha, settings.dirichlet_step) {
                (SolverKind::Monolithic, _, _) | (_, 2, _) => SchurMode::Always,
                (_, _, DirichletChoice::Auto) => SchurMode::IfFactored,
                (_, _, DirichletChoice::Condensed) => SchurMode::Always,
                (_, _, DirichletChoice::System) => SchurMode::None,
            };
            let mut body = Body::setup(p, layout.body_comm(), schur, &stages)?;
            if nndd_run && alpha == 1 && body.schur.is_none() {
                body.add_dirichlet_system(&stages)?;
            }
            bodies[alpha - 1] = Some(body);
        }
    }
    let refs = [bodies[0].as_ref(), bodies[1].as_ref()];
    let mut timings = Timings::default();
    for b in refs.iter().flatten() {
        timings.assembly += b.setup_seconds.0;
        timings.factorisation += b.setup_seconds.1;
    }
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

    // Solve.
    let mut dirichlet_step = "";
    let sol = match settings.solver {
        SolverKind::Nndd => {
            let dirichlet = match refs[0] {
                Some(b1) => Some(DirichletStep::new(b1)?),
                None => None,
            };
            dirichlet_step = dirichlet.as_ref().map_or("", |d| d.name());
            let contact = match refs[1] {
                Some(b2) => Some(ContactStep::new(b2, qp.clone(), settings.qp_warm_start)?),
                None => None,
            };
            let root = layout.is_root();
            let monitor = settings.monitor;
            let res = nndd::solve(
                &settings,
                &layout,
                refs,
                dirichlet.as_ref(),
                contact.as_ref(),
                &stages,
                |r| {
                    if monitor && root {
                        println!(
                            "{:4} NNDD dlambda/lambda {} |R| {} active {}/{} qp_its {}",
                            r.iteration,
                            sci(r.lambda_change, 12),
                            sci(r.residual, 6),
                            r.active,
                            settings.body_grid(1).0 + 1,
                            r.qp_iterations
                        );
                        use std::io::Write;
                        let _ = std::io::stdout().flush();
                    }
                },
            )?;
            timings.dirichlet_step = res.timers.dirichlet_step.seconds();
            timings.contact_step = res.timers.contact_step.seconds();
            timings.neumann_step = res.timers.neumann_step.seconds();
            timings.exchange = res.timers.exchange.seconds();
            let last = res.last;
            Solution {
                status: res.status.name().to_string(),
                converged: res.status == Status::Converged,
                iterations: res.iterations,
                history: res.history,
                lambda: last.lambda,
                u: last.u,
                forces: last.forces[1].clone(),
                active: last.active,
                qp_kkt: last.qp_kkt,
            }
        }
        SolverKind::Monolithic => {
            let t = Instant::now();
            let res = {
                let _s = stages.monolithic.enter();
                monolithic::solve(&layout, refs, &qp)?
            };
            timings.monolithic = t.elapsed().as_secs_f64();
            let mut lambda = refs[0]
                .map(|b| b.normal_trace(&res.u[0]))
                .unwrap_or_default();
            layout.share_vec(1, &mut lambda);
            Solution {
                status: "solved".into(),
                converged: true,
                iterations: 0,
                history: Vec::new(),
                lambda,
                u: res.u,
                forces: res.forces,
                active: res.active,
                qp_kkt: res.kkt_residual,
            }
        }
    };

    // Post-processing: energy (summed over ranks), fields gathered to rank 0.
    let mut energy = 0.0;
    for (k, b) in refs.iter().enumerate() {
        if let Some(b) = b {
            energy += b.potential_energy(&sol.u[k])?;
        }
    }
    let energy = layout.sum(energy);
    let mut u = sol.u.clone();
    layout.share_vec(1, &mut u[0]);
    layout.share_vec(2, &mut u[1]);
    // How body 2's interface Schur complement was formed (known on body 2's root).
    let mut src = [refs[1].map_or(0.0, |b| (b.schur_source == "mumps") as u8 as f64)];
    layout.share(2, &mut src);
    let schur_source = if src[0] > 0.5 { "mumps" } else { "solves" };
    for t in [
        &mut timings.assembly,
        &mut timings.factorisation,
        &mut timings.dirichlet_step,
        &mut timings.contact_step,
        &mut timings.neumann_step,
        &mut timings.exchange,
        &mut timings.monolithic,
    ] {
        *t = layout.max(*t);
    }
    let peak = layout.max(Petsc::peak_memory()) / (1024.0 * 1024.0);
    drop(bodies);

    if layout.is_root() {
        let t_out = Instant::now();
        let _s = stages.output.enter();
        let p1 = problem::body(&settings, 1);
        let p2 = problem::body(&settings, 2);
        let x = p1.contact_x();
        let (mass_d, mass_u) = interface_mass(&x);
        let m = x.len();
        let lumped: Vec<f64> = (0..m)
            .map(|i| {
                mass_d[i]
                    + if i > 0 { mass_u[i - 1] } else { 0.0 }
                    + if i + 1 < m { mass_u[i] } else { 0.0 }
            })
            .collect();
        let u1n: Vec<f64> = p1.contact_normal_dofs().iter().map(|&d| u[0][d]).collect();
        let u2n: Vec<f64> = p2.contact_normal_dofs().iter().map(|&d| u[1][d]).collect();
        let gap: Vec<f64> = (0..m).map(|i| u2n[i] - u1n[i]).collect();
        let pressure: Vec<f64> = (0..m).map(|i| sol.forces[i] / lumped[i]).collect();
        let contact_force: f64 = sol.forces.iter().sum();
        let xs: Vec<f64> = (0..m).filter(|&i| sol.active[i]).map(|i| x[i]).collect();
        let zone = if xs.is_empty() {
            None
        } else {
            Some([
                xs.iter().cloned().fold(f64::INFINITY, f64::min),
                xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            ])
        };
        let time = sol.iterations as f64;
        let mut grids = Vec::new();
        let mut step = Step {
            time,
            grids: Vec::new(),
        };
        for (k, p) in [&p1, &p2].into_iter().enumerate() {
            let name = format!("body{}", k + 1);
            grids.push(Grid {
                name: name.clone(),
                points: p.mesh.points.clone(),
                topology: Topology::Triangle(
                    p.mesh
                        .triangles
                        .iter()
                        .map(|t| t.map(|v| v as u32))
                        .collect(),
                ),
            });
            step.grids.push(GridFields {
                grid: name,
                fields: body_fields(&p.mesh, &p.material, &u[k]),
            });
        }
        grids.push(Grid {
            name: "contact".into(),
            points: x.iter().map(|&xi| [xi, 1.0]).collect(),
            topology: Topology::Segment(
                (0..m.saturating_sub(1) as u32)
                    .map(|i| [i, i + 1])
                    .collect(),
            ),
        });
        let scalar = |name: &str, values: Vec<f64>| Field {
            name: name.into(),
            center: Center::Node,
            kind: Kind::Scalar,
            values,
        };
        step.grids.push(GridFields {
            grid: "contact".into(),
            fields: vec![
                scalar("lambda", sol.lambda.clone()),
                scalar("normal_force", sol.forces.clone()),
                scalar("pressure", pressure),
                scalar("gap", gap),
                scalar(
                    "active",
                    sol.active.iter().map(|&a| a as u8 as f64).collect(),
                ),
            ],
        });
        let fields = describe(&step);
        let results = Results {
            grids,
            steps: vec![step],
            attributes: vec![
                ("n".into(), settings.n as f64),
                ("dofs".into(), settings.dofs() as f64),
                ("iterations".into(), sol.iterations as f64),
                ("potential_energy".into(), energy),
                ("contact_force".into(), contact_force),
            ],
        };
        output::write_results(&settings.output, &results)?;
        timings.output = t_out.elapsed().as_secs_f64();
        timings.total = t_start.elapsed().as_secs_f64();
        let summary = Summary {
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
            iterations: sol.iterations,
            history: sol.history.clone(),
            potential_energy: energy,
            contact_force,
            contact_zone: zone,
            active_nodes: sol.active.iter().filter(|&&a| a).count(),
            contact_nodes: m,
            schur_source: schur_source.into(),
            dirichlet_step: dirichlet_step.into(),
            qp_kkt_residual: sol.qp_kkt,
            timings: timings.clone(),
            peak_memory_mib: peak,
            h5: file_name(&settings.output, "h5"),
            xdmf: file_name(&settings.output, "xdmf"),
            fields,
        };
        let json =
            serde_json::to_string_pretty(&summary).map_err(|e| AppError::Json(e.to_string()))?;
        let json_path = settings.output.with_extension_added("json");
        output::write_atomic(&json_path, json.as_bytes())?;
        println!(
            "nndd: {} n = {} ({} dofs, {} rank(s), {}): {} after {} iterations; energy {:.10e} J/m, contact force {:.6e} N/m, zone {}; {:.2} s; wrote {}.{{h5,xdmf,json}}",
            summary.problem,
            summary.n,
            summary.dofs,
            summary.ranks,
            summary.solver,
            summary.status,
            summary.iterations,
            energy,
            contact_force,
            zone.map_or("none".to_string(), |z| format!("[{:.4}, {:.4}]", z[0], z[1])),
            timings.total,
            settings.output.display()
        );
        if !sol.converged {
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
    Ok(if sol.converged {
        Outcome::Solved
    } else {
        Outcome::NotConverged
    })
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
fn body_fields(mesh: &crate::mesh::Mesh, mat: &Material, u: &[f64]) -> Vec<Field> {
    let s = fem::stresses(mesh, mat, u);
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
            values: u.to_vec(),
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

/// The JSON description of the fields of a step (dataset paths of `PREFIX.h5`).
fn describe(step: &Step) -> Vec<FieldInfo> {
    let mut out = Vec::new();
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
                dataset: format!("/steps/0/{}/{}", g.grid, f.name),
            });
        }
    }
    out
}

fn file_name(prefix: &Path, ext: &str) -> String {
    prefix.with_extension_added(ext).display().to_string()
}

/// `PREFIX` + `.ext` (a prefix may contain dots: never replace an extension).
trait WithExtensionAdded {
    fn with_extension_added(&self, ext: &str) -> std::path::PathBuf;
}

impl WithExtensionAdded for Path {
    fn with_extension_added(&self, ext: &str) -> std::path::PathBuf {
        let mut s = self.as_os_str().to_owned();
        s.push(".");
        s.push(ext);
        s.into()
    }
}

/// With `-help`: let both bodies' KSPs register their options (on a tiny matrix), so that
/// `-help` lists `-body1_ksp_type`, `-body2_pc_type`, ….
fn list_solver_options() -> Result<(), PetscError> {
    for prefix in ["body1_", "body2_"] {
        let a = Matrix::from_csr(Petsc::comm_world(), 2, &[0, 1, 2], &[0, 1], &[1.0, 1.0])?;
        let _ksp = Ksp::new(Petsc::comm_world(), a, prefix, None)?;
    }
    Ok(())
}
