//! Run settings: every one is a PETSc option (`-nndd_…`), registered with its help text and
//! default so that `-help` lists it, and validated into a plain struct.

use std::path::PathBuf;

use crate::dd::body::SchurChoice;
use crate::dd::contact::ContactSettings;
use crate::dd::dirichlet::DirichletChoice;
use crate::dd::neumann::NeumannChoice;
use crate::dd::nndd::{NnddSettings, StopRule};
use crate::estimate::equilibrate::Recovery;
use crate::estimate::NnddVariant;
use crate::fem::gmsh;
use crate::fem::Material;
use crate::parallel::fault::Phase;
use crate::petsc::{self, Comm, OptionsBlock};
use crate::problem::meshed::{CurveCondition, MeshSpec};
use crate::problem::{ProblemKind, ProblemSettings};
use crate::qp::{QpMethod, QpSettings};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverKind {
    /// The Neumann–Neumann iteration (docs/method.md §2).
    Nndd,
    /// The discrete global contact problem solved at once (the NNDD's check).
    Monolithic,
}

impl SolverKind {
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Nndd => "nndd",
            SolverKind::Monolithic => "monolithic",
        }
    }
}

/// Bad input, naming the option and what it accepts.
#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    #[error("{option} must be {accepted} (got {value})")]
    OutOfRange {
        option: &'static str,
        accepted: &'static str,
        value: String,
    },
    #[error("{option}: unknown value '{value}' (accepted: {accepted})")]
    UnknownValue {
        option: &'static str,
        value: String,
        accepted: &'static str,
    },
    /// An option whose name depends on the mesh (`-nndd_bc_NAME_…`), or a bad mesh file.
    #[error("{option}: {message}")]
    Named { option: String, message: String },
    #[error(transparent)]
    Petsc(#[from] petsc::PetscError),
}

/// All settings of a run, with the paper's defaults: each layer's own settings, and what the
/// run itself decides (solver, estimates, output, ranks).
#[derive(Clone, Debug)]
pub struct Settings {
    pub problem: ProblemSettings,
    pub solver: SolverKind,
    pub nndd: NnddSettings,
    pub dirichlet_step: DirichletChoice,
    /// Clarabel's tolerances for the QPs (the contact step's fallback, the monolithic check,
    /// the estimates' admissible tractions).
    pub qp: QpSettings,
    /// How the contact step solves its QP.
    pub contact: ContactSettings,
    /// How each body's interface operators S^α, D^α are formed.
    pub schur: SchurChoice,
    /// Write each body's S^α and D^α to `PREFIX.body<α>_schur.json`.
    pub schur_view: bool,
    /// How the Neumann steps are solved.
    pub neumann_step: NeumannChoice,
    /// Print one line per NNDD iteration.
    pub monitor: bool,
    /// Output prefix: PREFIX.h5, PREFIX.xdmf, PREFIX.json.
    pub output: PathBuf,
    /// Estimate the errors of the final iterate.
    pub estimate: bool,
    /// Also estimate every k-th iteration (0: never).
    pub estimate_every: usize,
    /// Reference mesh factor r of (26) (0: no reference solution).
    pub reference_factor: usize,
    /// How the equilibrated stresses are recovered (see `estimate::equilibrate`).
    pub recovery: Recovery,
    /// Largest relative change of a body's displacement (energy norm) between two recoveries
    /// for which the second starts warm (`estimate::cre::View::prepare`).
    pub warm_change: f64,
    /// The reference problem of η^NNDD (see `estimate`).
    pub eta_nndd: NnddVariant,
    /// κ of the balanced stopping rule.
    pub stop_ratio: f64,
    /// Ranks of body 1's group (0: by the bodies' dof counts); checked against the world
    /// size by `Layout`.
    pub body1_ranks: usize,
    /// `-nndd_theta` as given (`auto` or the number), for the checkpoints' identity.
    pub theta_text: String,
    /// Write a restart point every k iterations (0: only when a signal stops the run).
    pub checkpoint_every: usize,
    /// Continue from this restart point.
    pub restart: Option<PathBuf>,
    /// Test only: fail on one rank at one phase (`-nndd_fault RANK:PHASE`).
    pub fault: Option<(i32, Phase)>,
    /// What the settings allow but the user should know (printed once, and in the summary).
    pub warnings: Vec<String>,
    /// Every option as given (command line and options files, PETSc's listing), before nndd
    /// adds the defaults of a body's group (the same on every rank).
    pub options_text: String,
}

impl Settings {
    /// Read, register (for `-help`) and validate the `-nndd_` options.
    pub fn from_options(comm: Comm) -> Result<Settings, SettingsError> {
        let mut o = OptionsBlock::begin(
            comm,
            "nndd: two-body frictionless contact by Neumann-Neumann DD",
            "nndd",
        )?;
        let (problem, _) = o.string(
            "-nndd_problem",
            "Benchmark problem: paper, uniform",
            "paper",
        )?;
        let (mesh_file, mesh_given) = o.string(
            "-nndd_mesh",
            "Gmsh MSH 4.1 file of the two bodies (physical surfaces body1, body2); sets -nndd_problem mesh",
            "",
        )?;
        let (contact, _) = o.string(
            "-nndd_contact",
            "With -nndd_mesh: the contact curves as body 1's curve,body 2's curve (physical curve names); either may be curved, the two meshed on their own (Gamma_c is where they overlap)",
            "",
        )?;
        let problem = match problem.as_str() {
            _ if mesh_given => ProblemKind::Mesh,
            "paper" => ProblemKind::Paper,
            "uniform" => ProblemKind::Uniform,
            "mesh" => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_problem",
                    value: problem,
                    accepted: "paper, uniform; mesh needs -nndd_mesh FILE.msh",
                })
            }
            _ => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_problem",
                    value: problem,
                    accepted: "paper, uniform, mesh (with -nndd_mesh)",
                })
            }
        };
        let (n, _) = o.int(
            "-nndd_n",
            "Mesh level n: each body is an n x n grid of split squares",
            8,
        )?;
        let n = positive("-nndd_n", n)?;
        let mut grids = [(n, n); 2];
        for (b, grid) in grids.iter_mut().enumerate() {
            for (k, name) in [(0, "nx"), (1, "ny")] {
                let opt: &'static str = OPTS_GRID[2 * b + k];
                let (v, _) = o.int(
                    opt,
                    &format!("Body {} cells in {} (default n)", b + 1, &name[1..]),
                    n as i64,
                )?;
                let v = positive(opt, v)?;
                if k == 0 {
                    grid.0 = v
                } else {
                    grid.1 = v
                }
            }
        }
        if grids[0].0 != grids[1].0 {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_body2_nx",
                accepted: "equal to -nndd_body1_nx (matching nodes on the contact interface)",
                value: format!("{} vs {}", grids[1].0, grids[0].0),
            });
        }
        let (young, _) = o.real("-nndd_E", "Young's modulus E of both bodies (Pa)", 210e9)?;
        if !(young > 0.0 && young.is_finite()) {
            return Err(range("-nndd_E", "> 0", young));
        }
        let (poisson, _) = o.real(
            "-nndd_nu",
            "Poisson's ratio of both bodies, in (-1, 0.5)",
            0.27,
        )?;
        if !(poisson > -1.0 && poisson < 0.5) {
            return Err(range("-nndd_nu", "in (-1, 0.5)", poisson));
        }
        // Per body: -nndd_body{1,2}_{E,nu} override -nndd_E / -nndd_nu.
        let mut materials = [Material { young, poisson }; 2];
        let (mut e_given, mut nu_given) = ([false; 2], [false; 2]);
        for (b, m) in materials.iter_mut().enumerate() {
            let (e_opt, nu_opt) = OPTS_MATERIAL[b];
            let (e, given) = o.real(
                e_opt,
                &format!("Young's modulus of body {} (Pa; default -nndd_E)", b + 1),
                young,
            )?;
            if !(e > 0.0 && e.is_finite()) {
                return Err(range(e_opt, "> 0", e));
            }
            e_given[b] = given;
            let (nu, nu_set) = o.real(
                nu_opt,
                &format!(
                    "Poisson's ratio of body {}, in (-1, 0.5) (default -nndd_nu)",
                    b + 1
                ),
                poisson,
            )?;
            if !(nu > -1.0 && nu < 0.5) {
                return Err(range(nu_opt, "in (-1, 0.5)", nu));
            }
            nu_given[b] = nu_set;
            *m = Material {
                young: e,
                poisson: nu,
            };
        }
        let mut warnings = check_materials(&materials, e_given, nu_given)?;
        let mesh = if mesh_given {
            Some(mesh_spec(&mut o, &mesh_file, &contact)?)
        } else {
            None
        };
        let (u_d, _) = o.real(
            "-nndd_u_D",
            "Prescribed vertical displacement of the top of body 2 (m)",
            -1e-4,
        )?;
        if !u_d.is_finite() {
            return Err(range("-nndd_u_D", "a finite number", u_d));
        }
        let f_default = if problem == ProblemKind::Paper {
            1e7
        } else {
            0.0
        };
        let (f_max, _) = o.real(
            "-nndd_F_max",
            "Maximum of the linear load on the right edge of body 2 (Pa)",
            f_default,
        )?;
        if !f_max.is_finite() {
            return Err(range("-nndd_F_max", "a finite number", f_max));
        }
        let (solver, _) = o.string(
            "-nndd_solver",
            "Solver: nndd (Neumann-Neumann), monolithic (direct global QP)",
            "nndd",
        )?;
        let solver = match solver.as_str() {
            "nndd" => SolverKind::Nndd,
            "monolithic" => SolverKind::Monolithic,
            _ => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_solver",
                    value: solver,
                    accepted: "nndd, monolithic",
                })
            }
        };
        let (theta_text, _) = o.string(
            "-nndd_theta",
            "NNDD relaxation theta of the lambda update: auto (a secant update fitted to the iterates, restarted when the contact set changes) or a fixed number > 0 (the paper: 0.25)",
            "auto",
        )?;
        let (theta, auto) = match theta_text.trim() {
            "auto" => (AUTO_THETA_PROBE, true),
            t => match t.parse::<f64>() {
                Ok(v) if v > 0.0 && v.is_finite() => (v, false),
                _ => {
                    return Err(SettingsError::OutOfRange {
                        option: "-nndd_theta",
                        accepted: "a number > 0, or auto",
                        value: theta_text.clone(),
                    })
                }
            },
        };
        let (tol, _) = o.real(
            "-nndd_tol",
            "NNDD stopping tolerance on |dlambda|/|lambda|",
            1e-8,
        )?;
        if !(tol > 0.0 && tol.is_finite()) {
            return Err(range("-nndd_tol", "> 0", tol));
        }
        let (max_it, _) = o.int("-nndd_max_it", "Maximum number of NNDD iterations", 1000)?;
        let max_it = positive("-nndd_max_it", max_it)?;
        let monitor = o.flag("-nndd_monitor", "Print one line per NNDD iteration", false)?;
        let default_out = format!("results/{}", problem.name());
        let (output, _) = o.string(
            "-nndd_output",
            "Output prefix: PREFIX.h5, PREFIX.xdmf, PREFIX.json",
            &default_out,
        )?;
        if output.is_empty() {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_output",
                accepted: "a non-empty path prefix",
                value: "''".into(),
            });
        }
        let (qp_tol, _) = o.real(
            "-nndd_qp_tol",
            "Clarabel tolerance of the contact QPs (the result is then polished to round-off)",
            1e-8,
        )?;
        if !(qp_tol > 0.0 && qp_tol < 1.0) {
            return Err(range("-nndd_qp_tol", "in (0, 1)", qp_tol));
        }
        let qp_warm_start = o.flag(
            "-nndd_qp_warm_start",
            "Contact step: start the QP from the previous contact set (else from the unconstrained solution's; with -nndd_qp_solver clarabel: try the previous set, kept if the KKT conditions certify it)",
            true,
        )?;
        let qp_method = choice(
            &mut o,
            "-nndd_qp_solver",
            "Contact step QP: active_set (primal-dual active set on S2 and D2, Clarabel if it does not certify), clarabel",
            &[("active_set", QpMethod::ActiveSet), ("clarabel", QpMethod::Clarabel)],
        )?;
        let (qp_max_it, _) = o.int(
            "-nndd_qp_max_it",
            "Contact step: active-set steps before falling back to Clarabel",
            50,
        )?;
        let qp_max_it = positive("-nndd_qp_max_it", qp_max_it)?;
        let schur = choice(
            &mut o,
            "-nndd_schur",
            "Interface operators S, D of each body: auto (MUMPS's Schur complement on one rank, MUMPS's entries of the inverse on several, back-solves without MUMPS), mumps_schur, mumps_inverse, solves",
            &[
                ("auto", SchurChoice::Auto),
                ("mumps_schur", SchurChoice::MumpsSchur),
                ("mumps_inverse", SchurChoice::MumpsInverse),
                ("solves", SchurChoice::Solves),
            ],
        )?;
        let schur_view = o.flag(
            "-nndd_schur_view",
            "Write each body's interface operators S and D to PREFIX.body<alpha>_schur.json",
            false,
        )?;
        let neumann_step = choice(
            &mut o,
            "-nndd_neumann_step",
            "Neumann steps: auto (condensed where the body has its interface operators), condensed (the trace D(-+R/2)), solve (a back-solve)",
            &[
                ("auto", NeumannChoice::Auto),
                ("condensed", NeumannChoice::Condensed),
                ("solve", NeumannChoice::Solve),
            ],
        )?;
        let (d, _) = o.string(
            "-nndd_dirichlet_step",
            "Dirichlet step (on the body of -nndd_dirichlet_body): auto (condensed when that body has its interface operators: MUMPS on any rank count, SuperLU_DIST), system, condensed",
            "auto",
        )?;
        let dirichlet_step = match d.as_str() {
            "auto" => DirichletChoice::Auto,
            "system" => DirichletChoice::System,
            "condensed" => DirichletChoice::Condensed,
            _ => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_dirichlet_step",
                    value: d,
                    accepted: "auto, system, condensed",
                })
            }
        };
        let dirichlet_body = match choice(
            &mut o,
            "-nndd_dirichlet_body",
            "The body of the Dirichlet step (the other takes the contact step): auto (the stiffer body, by E/(1-nu^2)), 1, 2",
            &[("auto", None), ("1", Some(1)), ("2", Some(2))],
        )? {
            Some(b) => {
                warnings.extend(soft_dirichlet_body(&materials, b));
                b
            }
            None => stiffer_body(&materials),
        };
        // A second SuperLU_DIST factorisation on the Dirichlet body's communicator: see
        // `setup_bodies`.
        if dirichlet_step == DirichletChoice::System && uses_superlu_dist(dirichlet_body)? {
            return Err(SettingsError::Named {
                option: "-nndd_dirichlet_step".into(),
                message: format!("system cannot be used with -body{dirichlet_body}_pc_factor_mat_solver_type superlu_dist on the body of the Dirichlet step (PETSc 3.18 frees the process grid of two SuperLU_DIST factorisations on one communicator twice); use auto or condensed"),
            });
        }
        let estimate_flag = o.flag(
            "-nndd_estimate",
            "Estimate eta_glo, eta_FE, eta_NNDD of the final iterate (paper (22)-(24))",
            false,
        )?;
        let (every, _) = o.int(
            "-nndd_estimate_every",
            "Also estimate every k-th NNDD iteration (0: never)",
            0,
        )?;
        if !(0..=1 << 16).contains(&every) {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_estimate_every",
                accepted: "an integer >= 0 (0: never)",
                value: every.to_string(),
            });
        }
        let (reference, _) = o.int(
            "-nndd_reference_factor",
            "Solve the reference problem on the nested mesh r*n (a Gmsh mesh: each triangle split into r^2) and report e_ref and the effectivity (0: off; paper: 8)",
            0,
        )?;
        if reference < 0 || reference == 1 || reference > 64 {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_reference_factor",
                accepted: "0 (off) or an integer in [2, 64]",
                value: reference.to_string(),
            });
        }
        let (recovery, _) = o.string(
            "-nndd_recovery",
            "Equilibrated stress recovery: patch (EET then patch-wise complementary energy minimisation, planned on the edge tractions, the eta_FE recovery warm-started), patch-classic (the same minimisation on the Johnson-Mercier fields, every recovery from EET), star (EET, star parameters minimising it), eet (EET, averaged tractions)",
            "patch",
        )?;
        // patch-classic keeps the sweeps it had as the default recovery.
        let (sweeps, _) = o.int(
            "-nndd_recovery_sweeps",
            "Patch relaxation sweeps of -nndd_recovery patch (default 6) and patch-classic (default 10)",
            if recovery == "patch-classic" { 10 } else { 6 },
        )?;
        if !(1..=1000).contains(&sweeps) {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_recovery_sweeps",
                accepted: "an integer in [1, 1000]",
                value: sweeps.to_string(),
            });
        }
        let (warm_sweeps, _) = o.int(
            "-nndd_recovery_warm_sweeps",
            "Sweeps of a -nndd_recovery patch recovery started from the change the previous recovery's sweeps made (the eta_FE one after the eta_glo one, and each estimate's after the previous estimate's, when the displacement changed by at most -nndd_recovery_warm_change); 0: every recovery cold, with -nndd_recovery_sweeps",
            1,
        )?;
        if !(0..=1000).contains(&warm_sweeps) {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_recovery_warm_sweeps",
                accepted: "an integer in [0, 1000]",
                value: warm_sweeps.to_string(),
            });
        }
        let (warm_change, _) = o.real(
            "-nndd_recovery_warm_change",
            "Largest relative change of a body's displacement in the energy norm since the previous recovery for which a -nndd_recovery patch recovery starts warm (-nndd_recovery_warm_sweeps); further apart it starts cold, as the final iterate's eta_glo recovery always does",
            crate::estimate::cre::WARM_CHANGE,
        )?;
        if !(warm_change >= 0.0 && warm_change.is_finite()) {
            return Err(range("-nndd_recovery_warm_change", ">= 0", warm_change));
        }
        let (stop, _) = o.string(
            "-nndd_stop",
            "Stopping rule: tol (|dlambda| <= tol |lambda|), balanced (also when eta_NNDD <= kappa eta_FE), none (exactly -nndd_max_it iterations)",
            "tol",
        )?;
        let stop = match stop.as_str() {
            "tol" => StopRule::Tol,
            "balanced" => StopRule::Balanced,
            "none" => StopRule::None,
            _ => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_stop",
                    value: stop,
                    accepted: "tol, balanced, none",
                })
            }
        };
        let (stop_ratio, _) = o.real(
            "-nndd_stop_ratio",
            "kappa of -nndd_stop balanced: stop when eta_NNDD <= kappa eta_FE",
            0.1,
        )?;
        if !(stop_ratio > 0.0 && stop_ratio.is_finite()) {
            return Err(range("-nndd_stop_ratio", "> 0", stop_ratio));
        }
        let (variant, _) = o.string(
            "-nndd_eta_nndd",
            "eta_NNDD against: discrete (the discrete problem, nodal contact forces) or density (docs/method.md 3.3 as written)",
            "discrete",
        )?;
        let eta_nndd = match variant.as_str() {
            "discrete" => NnddVariant::Discrete,
            "density" => NnddVariant::Density,
            _ => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_eta_nndd",
                    value: variant,
                    accepted: "discrete, density",
                })
            }
        };
        let (body1_ranks, _) = o.int(
            "-nndd_body1_ranks",
            "Ranks of body 1's group when running on N >= 2 ranks (1 .. N-1; 0: in proportion to the bodies' dofs); body 2 gets the others",
            0,
        )?;
        if body1_ranks < 0 {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_body1_ranks",
                accepted: "an integer >= 0 (0: automatic)",
                value: body1_ranks.to_string(),
            });
        }
        let (checkpoint_every, _) = o.int(
            "-nndd_checkpoint_every",
            "Write a restart point PREFIX.checkpoint.json every k NNDD iterations (0: only when SIGTERM, SIGINT or SIGUSR1 stops the run)",
            0,
        )?;
        if checkpoint_every < 0 {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_checkpoint_every",
                accepted: "an integer >= 0",
                value: checkpoint_every.to_string(),
            });
        }
        let (restart, restart_given) = o.string(
            "-nndd_restart",
            "Continue the NNDD from this restart point (written by -nndd_checkpoint_every or a signal; any rank count)",
            "",
        )?;
        if restart_given && restart.trim().is_empty() {
            return Err(SettingsError::OutOfRange {
                option: "-nndd_restart",
                accepted: "a checkpoint file name",
                value: "''".into(),
            });
        }
        let (fault_text, fault_given) = o.string(
            "-nndd_fault",
            "Testing: fail on one rank at one phase, RANK:PHASE (PHASE: init, options, mesh, assembly, factorisation, ksp, qp, estimate, checkpoint, output)",
            "",
        )?;
        let fault = match (fault_given, Phase::parse_spec(&fault_text)) {
            (false, _) => None,
            (true, Some(spec)) => Some(spec),
            (true, None) => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_fault",
                    value: fault_text,
                    accepted: Phase::ACCEPTED,
                })
            }
        };
        let recovery = match recovery.as_str() {
            "patch" => Recovery::Patch {
                sweeps: sweeps as usize,
                warm_sweeps: warm_sweeps as usize,
            },
            "patch-classic" => Recovery::PatchClassic {
                sweeps: sweeps as usize,
            },
            "star" => Recovery::star(),
            "eet" => Recovery::Eet,
            _ => {
                return Err(SettingsError::UnknownValue {
                    option: "-nndd_recovery",
                    value: recovery,
                    accepted: "patch, patch-classic, star, eet",
                })
            }
        };
        given_options_apply(o.queried(), problem)?;
        o.end()?;
        Ok(Settings {
            problem: ProblemSettings {
                kind: problem,
                n,
                grids,
                materials,
                mesh,
                u_d,
                f_max,
            },
            solver,
            nndd: NnddSettings {
                theta,
                auto,
                tol,
                max_it,
                stop,
                dirichlet_body,
            },
            dirichlet_step,
            qp: QpSettings {
                tol: qp_tol,
                ..QpSettings::default()
            },
            contact: ContactSettings {
                method: qp_method,
                max_steps: qp_max_it,
                warm_start: qp_warm_start,
                clarabel: QpSettings {
                    tol: qp_tol,
                    ..QpSettings::default()
                },
            },
            schur,
            schur_view,
            neumann_step,
            monitor,
            output: PathBuf::from(output),
            // A reference solution is only of use with an estimate to compare; balanced
            // stopping estimates every iteration unless told otherwise.
            estimate: estimate_flag || every > 0 || reference > 0 || stop == StopRule::Balanced,
            estimate_every: if stop == StopRule::Balanced && every == 0 {
                1
            } else {
                every as usize
            },
            reference_factor: reference as usize,
            recovery,
            warm_change,
            eta_nndd,
            stop_ratio,
            body1_ranks: body1_ranks as usize,
            theta_text: theta_text.trim().to_string(),
            checkpoint_every: checkpoint_every as usize,
            restart: restart_given.then(|| PathBuf::from(restart)),
            fault,
            warnings,
            options_text: petsc::options_text()?,
        })
    }

    /// The same problem on the nested mesh refined `r` times, solved to tol 1e−8 without
    /// output, monitor or estimates (the reference of (26)).
    pub fn refined(&self, r: usize) -> Settings {
        let mut s = self.clone();
        s.problem = self.problem.refined(r);
        // Solved so that it converges whatever the run's own θ and stopping rule: θ auto, to
        // 1e−8, with room for the iterations.
        s.nndd.tol = 1e-8;
        s.nndd.stop = StopRule::Tol;
        s.nndd.auto = true;
        s.nndd.theta = AUTO_THETA_PROBE;
        s.nndd.max_it = self.nndd.max_it.max(1000);
        // With the Dirichlet step on the stiffer body (`-nndd_dirichlet_body auto`); a body
        // other than the run's takes the Dirichlet step the way `auto` chooses (the run's
        // `system` was checked against its own body's solver only).
        s.nndd.dirichlet_body = stiffer_body(&self.problem.materials);
        if s.nndd.dirichlet_body != self.nndd.dirichlet_body {
            s.dirichlet_step = DirichletChoice::Auto;
        }
        s.monitor = false;
        s.estimate = false;
        s.estimate_every = 0;
        s.reference_factor = 0;
        s.checkpoint_every = 0;
        s.restart = None;
        s
    }
}

/// The meshed problem of `-nndd_mesh`: the file, the contact curves, and for every physical
/// curve of the mesh its `-nndd_bc_NAME_{ux,uy,traction,traction_end}` options.
fn mesh_spec(o: &mut OptionsBlock, file: &str, contact: &str) -> Result<MeshSpec, SettingsError> {
    let named = |option: &str, message: String| SettingsError::Named {
        option: option.to_string(),
        message,
    };
    let gmsh = read_shared(file).map_err(|e| named("-nndd_mesh", e))?;
    // The bodies first: without them nothing else the options name can be found.
    let missing: Vec<&str> = crate::problem::meshed::BODY_NAMES
        .into_iter()
        .filter(|b| gmsh.tag(2, b).is_none())
        .collect();
    if !missing.is_empty() {
        return Err(named(
            "-nndd_mesh",
            format!(
                "{file} has no physical surface {} (its physical surfaces: {}; physical curves: {}); name the two bodies and the curves the options refer to in the .geo file: Physical Surface(\"body1\") = {{…}}; Physical Surface(\"body2\") = {{…}}; Physical Curve(\"NAME\") = {{…}};",
                missing
                    .iter()
                    .map(|b| format!("'{b}'"))
                    .collect::<Vec<_>>()
                    .join(" or "),
                gmsh.group_names(2),
                gmsh.group_names(1)
            ),
        ));
    }
    let curves: Vec<String> = gmsh
        .names
        .iter()
        .filter(|((d, _), _)| *d == 1)
        .map(|(_, n)| n.clone())
        .collect();
    let pair: Vec<&str> = contact.split(',').map(str::trim).collect();
    if pair.len() != 2 || pair.iter().any(|c| c.is_empty()) {
        return Err(named(
            "-nndd_contact",
            format!(
                "give body 1's and body 2's contact curves as NAME1,NAME2 (got '{contact}'; physical curves: {})",
                gmsh.group_names(1)
            ),
        ));
    }
    let vector = |option: &str, text: &str| -> Result<[f64; 2], SettingsError> {
        let v: Vec<f64> = text
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| named(option, format!("expects two numbers tx,ty (got '{text}')")))?;
        match v[..] {
            [a, b] if a.is_finite() && b.is_finite() => Ok([a, b]),
            _ => Err(named(
                option,
                format!("expects two finite numbers tx,ty (got '{text}')"),
            )),
        }
    };
    let mut conditions = Vec::new();
    let mut known = std::collections::BTreeSet::new();
    for c in &curves {
        let mut cond = CurveCondition {
            curve: c.clone(),
            ..Default::default()
        };
        for (k, comp) in ["ux", "uy"].iter().enumerate() {
            let opt = format!("-nndd_bc_{c}_{comp}");
            let (v, set) = o.real(
                &opt,
                &format!("Prescribed {comp} on the curve {c} (m)"),
                0.0,
            )?;
            if set {
                if !v.is_finite() {
                    return Err(named(&opt, format!("must be a finite number (got {v})")));
                }
                cond.u[k] = Some(v);
            }
            known.insert(opt);
        }
        let opt = format!("-nndd_bc_{c}_traction");
        let opt_end = format!("-nndd_bc_{c}_traction_end");
        let (t0, set0) = o.string(
            &opt,
            &format!("Traction tx,ty on the curve {c} (Pa), at its first point"),
            "",
        )?;
        let (t1, set1) = o.string(
            &opt_end,
            &format!("Traction tx,ty at the last point of {c} (Pa; linear in between; default: as -nndd_bc_{c}_traction)"),
            "",
        )?;
        if set1 && !set0 {
            return Err(named(
                &opt_end,
                format!("needs {opt} (the traction at the curve's first point)"),
            ));
        }
        if set0 {
            let a = vector(&opt, &t0)?;
            let b = if set1 { vector(&opt_end, &t1)? } else { a };
            if cond.u.iter().any(Option::is_some) {
                return Err(named(
                    &opt,
                    format!("conflicts with the prescribed displacement of the curve {c} (give one or the other)"),
                ));
            }
            cond.traction = Some([a, b]);
        }
        known.insert(opt);
        known.insert(opt_end);
        if cond.traction.is_some() || cond.u.iter().any(Option::is_some) {
            conditions.push(cond);
        }
    }
    // A -nndd_bc_ option that names no curve of the mesh is a typo: refuse it.
    for name in petsc::option_names()? {
        if name.starts_with("-nndd_bc_") && !known.contains(&name) {
            return Err(named(
                &name,
                format!(
                    "names no physical curve of {file} or no condition (accepted: -nndd_bc_NAME_ux, _uy, _traction, _traction_end with NAME in: {})",
                    gmsh.group_names(1)
                ),
            ));
        }
    }
    let contact = [pair[0].to_string(), pair[1].to_string()];
    let (gmsh, matched) = crate::problem::conform::conform(&gmsh, &contact);
    Ok(MeshSpec {
        gmsh: std::rc::Rc::new(gmsh),
        conditions,
        contact,
        nested: false,
        matched: std::rc::Rc::new(matched),
    })
}

/// The options that define the built-in problems' meshes and loads (not a Gmsh problem's).
const BUILTIN_ONLY: [&str; 7] = [
    "-nndd_n",
    "-nndd_body1_nx",
    "-nndd_body1_ny",
    "-nndd_body2_nx",
    "-nndd_body2_ny",
    "-nndd_u_D",
    "-nndd_F_max",
];

/// Words a user may write for the material options' last part.
const SYNONYMS: [(&str, &str); 6] = [
    ("young", "E"),
    ("youngs", "E"),
    ("modulus", "E"),
    ("e_modulus", "E"),
    ("poisson", "nu"),
    ("poissons", "nu"),
];

/// The edit distance of two option names, ignoring case.
fn distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (
        a.to_lowercase().chars().collect(),
        b.to_lowercase().chars().collect(),
    );
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (diagonal + usize::from(ca != cb))
                .min(row[j] + 1)
                .min(row[j + 1] + 1);
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// The known option a misspelt `name` most likely means: a synonym of its last word, else the
/// nearest by edit distance (at most a third of the name's length).
fn nearest<'a>(name: &str, known: &'a [String]) -> Option<&'a str> {
    let lower = name.to_lowercase();
    for (word, meant) in SYNONYMS {
        if let Some(head) = lower.strip_suffix(word) {
            if let Some(k) = known
                .iter()
                .find(|k| k.to_lowercase() == format!("{head}{}", meant.to_lowercase()))
            {
                return Some(k);
            }
        }
    }
    known
        .iter()
        .map(|k| (distance(name, k), k))
        .filter(|(d, _)| *d <= name.len() / 3)
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k.as_str())
}

/// Every `-nndd_` option given must be one nndd reads (else a typo, taken silently) and must
/// apply to the problem: the built-in problems' mesh and load options not to a Gmsh problem,
/// `-nndd_contact` and `-nndd_bc_…` (checked against the mesh's curves as they are read) only
/// to one.
fn given_options_apply(known: &[String], problem: ProblemKind) -> Result<(), SettingsError> {
    let named = |option: &str, message: String| SettingsError::Named {
        option: option.to_string(),
        message,
    };
    let mesh = problem == ProblemKind::Mesh;
    for given in petsc::option_names()? {
        // PETSc's option names are case-insensitive.
        let Some(name) = known
            .iter()
            .find(|k| k.eq_ignore_ascii_case(&given))
            .cloned()
            .or_else(|| given.to_lowercase().starts_with("-nndd_").then_some(given))
        else {
            continue;
        };
        if name.starts_with("-nndd_bc_") {
            if !mesh {
                return Err(named(
                    &name,
                    "sets a boundary condition of a Gmsh problem (-nndd_mesh); the built-in problems have theirs (docs/benchmarks.md)".into(),
                ));
            }
            continue;
        }
        if !known.contains(&name) {
            let hint =
                nearest(&name, known).map_or(String::new(), |k| format!("; did you mean {k}?"));
            return Err(named(
                &name,
                format!("unknown option{hint} (-help lists them all)"),
            ));
        }
        if mesh && BUILTIN_ONLY.contains(&name.as_str()) {
            return Err(named(
                &name,
                "sets the built-in problems' mesh or load and does not apply to a Gmsh problem (-nndd_mesh): its mesh sizes are the .geo file's, its conditions -nndd_bc_NAME_ux, _uy, _traction".into(),
            ));
        }
        if !mesh && name == "-nndd_contact" {
            return Err(named(
                &name,
                "names the contact curves of a Gmsh problem and needs -nndd_mesh FILE.msh".into(),
            ));
        }
    }
    Ok(())
}

/// `-nndd_theta auto`'s θ for a step before anything is known of the interface map. The first
/// step normally takes θ = 1/μ₀ from the first Neumann corrections instead (src/dd/secant.rs);
/// this value is used only when they are zero.
const AUTO_THETA_PROBE: f64 = 1e-3;

/// The largest λ/μ = 2ν/(1 − 2ν) (plane strain) accepted: ν ≤ 0.499999995. Nearly
/// incompressible P1 triangles lock, and the stiffness matrix carries λ/μ as a condition
/// factor on top of the mesh's: on `paper` n = 16 the NNDD equals the monolithic solve to
/// 1e−8 at ν = 0.49999999 (λ/μ = 5e7) but is 1.6 % off at ν = 0.4999999999 (5e9).
pub const MAX_LAME_RATIO: f64 = 1e8;
/// λ/μ above which a warning says so (ν > 0.4995): the locking of P1 triangles makes the
/// displacements visibly too small.
pub const WARN_LAME_RATIO: f64 = 1e3;
/// The largest ratio of the two bodies' Young's moduli accepted. Beyond it the stiffer body's
/// deformation is below the round-off of its displacement, and its energy is noise (on
/// `paper`, E¹/E² = 1e289 gives 1.1e285 J/m against 1290.7).
pub const MAX_STIFFNESS_RATIO: f64 = 1e16;

/// Refuse materials whose solve would lose its digits; return the warnings for those that
/// cost some. `e_given`, `nu_given`: whether `-nndd_body<α>_E`, `-nndd_body<α>_nu` were
/// given (else a message names `-nndd_E`, `-nndd_nu`).
fn check_materials(
    materials: &[Material; 2],
    e_given: [bool; 2],
    nu_given: [bool; 2],
) -> Result<Vec<String>, SettingsError> {
    let mut warnings = Vec::new();
    for (b, m) in materials.iter().enumerate() {
        let nu_opt = if nu_given[b] {
            OPTS_MATERIAL[b].1
        } else {
            "-nndd_nu"
        };
        let lame = 2.0 * m.poisson / (1.0 - 2.0 * m.poisson);
        if lame > MAX_LAME_RATIO {
            return Err(SettingsError::Named {
                option: format!("{nu_opt} {}", m.poisson),
                message: format!(
                    "body {} is too nearly incompressible for a displacement formulation (λ/μ = {lame:.1e}; at most {MAX_LAME_RATIO:.0e}, ν ≤ 0.499999995, keeps 8 of the 16 digits)",
                    b + 1
                ),
            });
        }
        if lame > WARN_LAME_RATIO {
            warnings.push(format!(
                "{nu_opt} {}: body {} is nearly incompressible (λ/μ = {lame:.1e}): P1 triangles lock, so its displacements are too small, and the solve loses about {:.0} digits",
                m.poisson,
                b + 1,
                lame.log10()
            ));
        }
    }
    let (e1, e2) = (materials[0].young, materials[1].young);
    let ratio = e1.max(e2) / e1.min(e2);
    if ratio > MAX_STIFFNESS_RATIO {
        let b = if e_given[0] { 0 } else { 1 };
        return Err(SettingsError::Named {
            option: format!("{} {:e}", OPTS_MATERIAL[b].0, materials[b].young),
            message: format!(
                "the bodies' stiffness ratio {ratio:.1e} is beyond {MAX_STIFFNESS_RATIO:.0e}: the stiffer body deforms less than the round-off of its displacement; bring the moduli closer, or model the stiffer body as rigid (a displacement condition on the other body's contact curve)"
            ),
        });
    }
    Ok(warnings)
}

/// How much softer than the other the Dirichlet step's body must be for a warning.
pub const SOFT_DIRICHLET: f64 = 0.1;

/// The plane-strain modulus E/(1 − ν²), the stiffness that decides the Dirichlet body.
fn modulus(m: &Material) -> f64 {
    m.young / (1.0 - m.poisson * m.poisson)
}

/// The advice for a Dirichlet step given to a body much softer than the other
/// (`-nndd_dirichlet_body`): θ auto then needs many iterations where the contact set grows (the
/// interface operator's spectrum spreads by the stiffness ratio, `src/dd/secant.rs`).
fn soft_dirichlet_body(materials: &[Material; 2], body: usize) -> Option<String> {
    let (d, c) = (&materials[body - 1], &materials[2 - body]);
    (modulus(d) < SOFT_DIRICHLET * modulus(c)).then(|| {
        format!(
            "body {body} takes the Dirichlet step (-nndd_dirichlet_body {body}) but is {:.0} times softer than body {} (E/(1 - nu^2), E {:e} against {:e} Pa): the NNDD converges in far fewer iterations with the Dirichlet step on the stiffer body (-nndd_dirichlet_body auto)",
            modulus(c) / modulus(d),
            3 - body,
            d.young,
            c.young
        )
    })
}

const OPTS_MATERIAL: [(&str, &str); 2] = [
    ("-nndd_body1_E", "-nndd_body1_nu"),
    ("-nndd_body2_E", "-nndd_body2_nu"),
];

const OPTS_GRID: [&str; 4] = [
    "-nndd_body1_nx",
    "-nndd_body1_ny",
    "-nndd_body2_nx",
    "-nndd_body2_ny",
];

/// Whether body α's solver is a MUMPS factorisation (`-body<α>_ksp_type preonly`,
/// `-body<α>_pc_type cholesky` or `lu`, `-body<α>_pc_factor_mat_solver_type mumps`: the
/// defaults).
pub fn uses_mumps(alpha: usize) -> Result<bool, petsc::PetscError> {
    let get = |what: &str, default: &str| -> Result<String, petsc::PetscError> {
        Ok(petsc::option_string(&format!("-body{alpha}_{what}"))?
            .unwrap_or_else(|| default.to_string()))
    };
    Ok(get("ksp_type", "preonly")? == "preonly"
        && matches!(get("pc_type", "cholesky")?.as_str(), "cholesky" | "lu")
        && get("pc_factor_mat_solver_type", "mumps")? == "mumps")
}

/// Whether body α's factorisation is SuperLU_DIST (`-body<α>_pc_factor_mat_solver_type`).
/// PETSc 3.18 keeps one SuperLU_DIST process grid per communicator and frees it twice when two
/// factorisations shared it, so a body that uses it gets no second factorisation.
pub fn uses_superlu_dist(alpha: usize) -> Result<bool, petsc::PetscError> {
    let name = format!("-body{alpha}_pc_factor_mat_solver_type");
    Ok(petsc::option_string(&name)?.as_deref() == Some("superlu_dist"))
}

/// The mesh file, read and parsed on world rank 0 and sent to the other ranks as bytes (a parse
/// on every rank costs the machine one parse per rank: Hertz level 6 on 8 ranks of 2 cores took
/// 2.6 s). Collective; an error on rank 0 reaches every rank (the others' message says so).
fn read_shared(file: &str) -> Result<gmsh::GmshMesh, String> {
    use crate::parallel::wait::politely;
    use mpi::traits::{Communicator, Root};
    let world = mpi::topology::SimpleCommunicator::world();
    let read = || gmsh::read(std::path::Path::new(file)).map_err(|e| e.to_string());
    if world.size() == 1 {
        return read();
    }
    let root = world.process_at_rank(0);
    // [read, length], then the bytes.
    let mut head = [0u64; 2];
    if world.rank() == 0 {
        let mesh = read();
        let mut bytes = mesh.as_ref().map_or(Vec::new(), |m| m.to_bytes());
        head = [mesh.is_ok() as u64, bytes.len() as u64];
        // (a non-blocking broadcast matches only non-blocking ones on the other ranks)
        mpi::request::scope(|scope| politely(root.immediate_broadcast_into(scope, &mut head[..])));
        if mesh.is_ok() {
            root.broadcast_into(&mut bytes[..]);
        }
        return mesh;
    }
    // The other ranks wait for rank 0's parse without taking a core from it.
    mpi::request::scope(|scope| politely(root.immediate_broadcast_into(scope, &mut head[..])));
    if head[0] == 0 {
        return Err(format!("{file}: world rank 0 could not read it"));
    }
    let mut bytes = vec![0u8; head[1] as usize];
    root.broadcast_into(&mut bytes[..]);
    gmsh::GmshMesh::from_bytes(&bytes)
        .ok_or_else(|| format!("{file}: the mesh sent by world rank 0 is damaged"))
}

/// The body of the Dirichlet step for `-nndd_dirichlet_body auto`: the stiffer one by its
/// plane-strain modulus, body 1 (the paper's) when they are equal.
pub fn stiffer_body(materials: &[Material; 2]) -> usize {
    if modulus(&materials[1]) > modulus(&materials[0]) {
        2
    } else {
        1
    }
}

/// An option whose value is one of `values` (the first is the default): registered with its
/// help text, or refused naming the accepted values.
fn choice<T: Copy>(
    o: &mut OptionsBlock,
    option: &'static str,
    help: &str,
    values: &[(&'static str, T)],
) -> Result<T, SettingsError> {
    let (given, _) = o.string(option, help, values[0].0)?;
    values
        .iter()
        .find(|(name, _)| *name == given)
        .map(|&(_, v)| v)
        .ok_or_else(|| SettingsError::Named {
            option: option.into(),
            message: format!(
                "unknown value '{given}' (accepted: {})",
                values
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        })
}

fn range(option: &'static str, accepted: &'static str, value: f64) -> SettingsError {
    SettingsError::OutOfRange {
        option,
        accepted,
        value: format!("{value}"),
    }
}

fn positive(option: &'static str, v: i64) -> Result<usize, SettingsError> {
    if v <= 0 || v > 1 << 16 {
        return Err(SettingsError::OutOfRange {
            option,
            accepted: "a positive integer (at most 65536)",
            value: v.to_string(),
        });
    }
    Ok(v as usize)
}
