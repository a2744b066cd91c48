//! Run settings: every one is a PETSc option (`-nndd_…`), registered with its help text and
//! default so that `-help` lists it, and validated. Each layer reads its own
//! ([`ProblemSettings`], [`NnddSettings`], [`ContactSettings`], [`SchurChoice`],
//! [`EstimateSettings`], [`OutputSettings`]); [`Settings::from_options`] calls them in order
//! and reads the run's own (solver, ranks, restart points), then checks that every `-nndd_`
//! option given is one of them and applies to the problem.

use std::path::PathBuf;
use std::rc::Rc;

use super::adapt::AdaptSettings;
use crate::dd::body::SchurChoice;
use crate::dd::contact::ContactSettings;
use crate::dd::dirichlet::DirichletChoice;
use crate::dd::friction::FrictionLaw;
use crate::dd::neumann::NeumannBodies;
use crate::dd::nndd::NnddSettings;
use crate::estimate::EstimateSettings;
use crate::io::settings::OutputSettings;
use crate::parallel::fault::{Fault, Phase};
use crate::petsc::readers::Bounds;
pub use crate::petsc::readers::SettingsError;
use crate::petsc::{self, Comm, OptionsBlock};
use crate::problem::meshed::MeshedError;
use crate::problem::settings::option_applies;
use crate::problem::{BodyProblem, ContactDiscretisation, ProblemKind, ProblemSettings, Support};
use crate::qp::QpSettings;

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

/// What a run that the memory model (`app::capacity`) says does not fit does (`-nndd_memory_check`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MemoryCheck {
    /// It is refused before any mesh is built, with the estimate and what to change.
    #[default]
    Refuse,
    /// It runs, with the same line as a warning (where the model is known to be high).
    Warn,
}

/// All settings of a run, with the paper's defaults: each layer's own settings, and what the
/// run itself decides (solver, ranks, restart points).
#[derive(Clone, Debug)]
pub struct Settings {
    pub problem: ProblemSettings,
    pub solver: SolverKind,
    pub nndd: NnddSettings,
    /// How the contact step solves its QP.
    pub contact: ContactSettings,
    /// The friction law at the contact (`-nndd_friction`).
    pub friction: FrictionLaw,
    /// Clarabel's tolerances for the QPs (the contact step's fallback, the monolithic check,
    /// the estimates' admissible tractions).
    pub qp: QpSettings,
    /// How each body's interface operators S^α, D^α are formed.
    pub schur: SchurChoice,
    pub estimate: EstimateSettings,
    pub output: OutputSettings,
    /// Ranks of body 1's group (0: by the bodies' dof counts); checked against the world
    /// size by `Layout`.
    pub body1_ranks: usize,
    /// Write a restart point every k iterations (0: only when a signal stops the run).
    pub checkpoint_every: usize,
    /// Continue from this restart point.
    pub restart: Option<PathBuf>,
    /// Adapt the meshes to a tolerance (`-nndd_adapt_tol`; `None`: one solve).
    pub adapt: Option<AdaptSettings>,
    /// Test only: fail on one rank at one phase (`-nndd_fault RANK:PHASE[:panic]`).
    pub fault: Option<Fault>,
    /// What a run the memory model says does not fit does (`-nndd_memory_check`).
    pub memory_check: MemoryCheck,
    /// The most memory the run may use on each node (bytes; `-nndd_memory_limit`, given in
    /// MiB), where less than the node has available.
    pub memory_limit: Option<f64>,
    /// The memory model's warning under [`MemoryCheck::Warn`], said before any mesh is built
    /// (in the summary's warnings first).
    pub memory_warning: Option<String>,
    /// What the settings allow but the user should know (printed once, and in the summary).
    pub warnings: Vec<String>,
    /// Every option as given (command line and options files, PETSc's listing), before nndd
    /// adds the defaults of a body's group (the same on every rank).
    pub options_text: String,
}

impl Settings {
    /// Read, register (for `-help`) and validate the `-nndd_` options: each layer's, then the
    /// run's own.
    pub fn from_options(comm: Comm) -> Result<Settings, SettingsError> {
        let mut o = OptionsBlock::begin(
            comm,
            "nndd: two-body contact (frictionless, Tresca or Coulomb friction) by Neumann-Neumann DD",
            "nndd",
        )?;
        let mut warnings = Vec::new();
        // An adaptive run estimates each cycle's answer (the balanced rule's κ 0.01 where it is
        // asked for), and couples its remeshed curves node to node, unless told otherwise.
        let adapt = AdaptSettings::from_options(&mut o)?;
        if adapt.is_some() {
            petsc::option_default("-nndd_estimate", "true")?;
            petsc::option_default("-nndd_stop_ratio", super::adapt::STOP_RATIO)?;
            if petsc::option_present("-nndd_mesh") {
                petsc::option_default(
                    "-nndd_contact_discretisation",
                    super::adapt::DISCRETISATION,
                )?;
            }
        }
        // Friction couples meshed curves node to node (made to match) unless told otherwise.
        let friction_named = petsc::option_string("-nndd_friction")?;
        if matches!(friction_named.as_deref(), Some("tresca" | "coulomb"))
            && petsc::option_present("-nndd_mesh")
        {
            petsc::option_default("-nndd_contact_discretisation", "node_to_node")?;
        }
        let problem = ProblemSettings::from_options(&mut o, &mut warnings)?;
        let solver = o.choice(
            "-nndd_solver",
            "Solver: nndd (Neumann-Neumann), monolithic (direct global QP)",
            &[
                ("nndd", SolverKind::Nndd),
                ("monolithic", SolverKind::Monolithic),
            ],
        )?;
        let nndd = NnddSettings::from_options(&mut o, &problem.materials)?;
        let contact = ContactSettings::from_options(&mut o)?;
        let friction = FrictionLaw::from_options(&mut o)?;
        let schur = SchurChoice::from_options(&mut o)?;
        let balanced = matches!(nndd.stop, crate::dd::nndd::StopRule::Balanced { .. });
        let estimate = EstimateSettings::from_options(&mut o, balanced)?;
        let output = OutputSettings::from_options(&mut o, problem.kind)?;
        if friction.is_frictional() && balanced {
            return Err(SettingsError::named(
                "-nndd_stop balanced",
                format!("is not available with friction (-nndd_friction {}) yet: its cheap eta_NNDD check is normal-only; use -nndd_stop tol", friction.name()),
            ));
        }
        let (body1_ranks, _) = o.int_in(
            "-nndd_body1_ranks",
            "Ranks of body 1's group when running on N >= 2 ranks (1 .. N-1; 0: in proportion to the bodies' dofs); body 2 gets the others",
            0,
            Bounds {
                accepted: "an integer >= 0 (0: automatic)",
                ..Bounds::NON_NEGATIVE_INT
            },
        )?;
        let (checkpoint_every, _) = o.int_in(
            "-nndd_checkpoint_every",
            "Write a restart point PREFIX.checkpoint.json every k NNDD iterations (0: only when SIGTERM, SIGINT or SIGUSR1 stops the run)",
            0,
            Bounds::NON_NEGATIVE_INT,
        )?;
        let restart = read_restart(&mut o)?;
        let memory_check = o.choice(
            "-nndd_memory_check",
            "A run whose meshes the memory model (docs/scaling.md, \"Memory, and the size check\") says would not fit in the nodes' available memory: refuse (before any mesh is built, naming the estimate), warn (run it, with the same line as a warning: where the model is known to be high, by up to a third on the measured runs with factored bodies)",
            &[("refuse", MemoryCheck::Refuse), ("warn", MemoryCheck::Warn)],
        )?;
        let (limit_mib, _) = o.real_in(
            "-nndd_memory_limit",
            "The most memory (MiB) the run may use on each node, where less than the node has available (a shared node's share): the size check's memory model is held to it, before the run and before each adaptive cycle (0: the node's available memory)",
            0.0,
            Bounds {
                accepted: ">= 0 (MiB per node; 0: no limit)",
                ..Bounds::NON_NEGATIVE
            },
        )?;
        let memory_limit = (limit_mib > 0.0).then_some(limit_mib * 1024.0 * 1024.0);
        if let Some(a) = &adapt {
            a.check_problem(&problem)?;
            check_adaptive(&nndd.stop, restart.is_some())?;
        }
        let fault = read_fault(&mut o)?;
        given_options_apply(o.queried(), problem.kind)?;
        o.end()?;
        Ok(Settings {
            qp: contact.clarabel.clone(),
            problem,
            solver,
            nndd,
            contact,
            friction,
            schur,
            estimate,
            output,
            body1_ranks,
            checkpoint_every,
            restart,
            adapt,
            fault,
            memory_check,
            memory_limit,
            memory_warning: None,
            warnings,
            options_text: petsc::options_text()?,
        })
    }

    /// The same problem on the nested mesh refined `r` times, solved to tol 1e−8 without
    /// output, monitor or estimates (the reference of (26)).
    pub fn refined(&self, r: usize) -> Result<Settings, MeshedError> {
        let mut s = self.clone();
        s.problem = self.problem.refined(r)?;
        s.nndd = self.nndd.for_reference(&self.problem.materials);
        s.output.monitor = false;
        s.estimate.enabled = false;
        s.estimate.every = 0;
        s.estimate.reference_factor = 0;
        s.checkpoint_every = 0;
        s.restart = None;
        s.adapt = None;
        Ok(s)
    }

    /// Whether a phase after the bodies are built reads a Gmsh problem's parsed mesh: the
    /// reference solution refines it, a mortar run's estimates match its curves
    /// ([`ProblemSettings::for_estimates`]), an adaptive run's cycles remesh its geometry.
    pub fn reads_mesh_after_build(&self) -> bool {
        let mortar = self.problem.mesh.as_ref().map(|m| m.discretisation)
            == Some(ContactDiscretisation::Mortar);
        self.adapt.is_some()
            || self.estimate.reference_factor > 0
            || (mortar && self.estimate.enabled)
    }

    /// A Gmsh problem's parsed mesh let go where no later phase reads it (these settings' hold
    /// on it: the run holds no other once its bodies are built).
    pub fn release_mesh_unread_later(&mut self) {
        let unread = !self.reads_mesh_after_build();
        if let (Some(spec), true) = (self.problem.mesh.as_mut(), unread) {
            spec.gmsh.release();
        }
    }

    /// The choices the mortar discretisation decides (a body's trace
    /// [`crate::problem::GcTrace::Mortar`]): the Dirichlet step on the other, non-mortar body
    /// ([`NnddSettings::on_mortar`]); a body held only by contact is not available with it yet,
    /// and refused.
    pub fn mortar_rules(&mut self, problems: &[Rc<BodyProblem>; 2]) -> Result<(), SettingsError> {
        let pair = [&*problems[0], &*problems[1]];
        if crate::problem::discretisation(pair) == ContactDiscretisation::NodeToNode {
            return Ok(());
        }
        const OPT: &str = "-nndd_contact_discretisation mortar";
        if self.friction.is_frictional() {
            return Err(SettingsError::named(
                OPT,
                format!("friction (-nndd_friction {}) is not available with the mortar discretisation yet; use node_to_node (the curves are then made to match)", self.friction.name()),
            ));
        }
        // (read from the file where the run estimates, on the ranks that hold it: world rank 0
        // alone under `-nndd_mesh_input root`, `app::input::on_root`, the ranks agreeing on
        // its verdict)
        let closed = match (&self.problem.mesh, self.estimate.enabled) {
            (Some(spec), true) if !spec.gmsh.is_on_root() => spec
                .closed_contact()
                .map_err(|e| SettingsError::named("-nndd_contact", e.to_string()))?,
            _ => None,
        };
        if let Some(curve) = closed {
            return Err(SettingsError::named(
                "-nndd_contact",
                format!("the contact curve '{curve}' is closed: the error estimates are not available on closed contact curves yet (their matched meshes need open ones); solve without -nndd_estimate, -nndd_estimate_every, -nndd_reference_factor and -nndd_stop balanced, or name open arcs"),
            ));
        }
        if let Some(held) = problems.iter().find(|p| p.support == Support::Contact) {
            return Err(SettingsError::named(
                OPT,
                format!("body {} is held only by contact, which the mortar discretisation does not support yet; prescribe displacements that hold it, or use node_to_node", held.alpha),
            ));
        }
        let side = crate::problem::pair_side(pair) + 1;
        let warning = self.nndd.on_mortar(&self.problem.materials, side)?;
        self.warnings.extend(warning);
        Ok(())
    }

    /// The choices a body held only by contact ([`Support::Contact`], found when the mesh is
    /// read) decides: it takes the NNDD's Dirichlet step, which its Dirichlet system solves
    /// (its Neumann system is singular); the estimates, whose admissible tractions are not yet
    /// balanced against its free rigid motion, are refused. Without such a body, a Dirichlet step
    /// the options forced onto a much softer body is warned about.
    /// Friction's estimates need a straight Γc (one contact direction: docs/method.md §9):
    /// refused on a curved one, in one line.
    pub fn friction_rules(&self, problems: &[Rc<BodyProblem>; 2]) -> Result<(), SettingsError> {
        if !(self.friction.is_frictional() && self.estimate.enabled) {
            return Ok(());
        }
        let n = &problems[0].contact_normals;
        if n.iter()
            .any(|v| (v[0] - n[0][0]).abs() + (v[1] - n[0][1]).abs() > 1e-12)
        {
            return Err(SettingsError::named(
                "-nndd_estimate",
                format!("the error estimates with friction (-nndd_friction {}) need a straight contact curve, and this one turns (its friction term along a turning tangent is not written yet, docs/method.md section 9); solve without -nndd_estimate, -nndd_estimate_every, -nndd_reference_factor and -nndd_adapt_tol", self.friction.name()),
            ));
        }
        Ok(())
    }

    pub fn hold_by_contact(
        &mut self,
        problems: &[Rc<BodyProblem>; 2],
    ) -> Result<(), SettingsError> {
        let Some(held) = problems.iter().find(|p| p.support == Support::Contact) else {
            self.warnings
                .extend(self.nndd.soft_warning(&self.problem.materials));
            return Ok(());
        };
        let alpha = held.alpha;
        let why = format!("body {alpha} is held only by contact (its prescribed displacements leave a rigid motion free)");
        if self.estimate.enabled {
            return Err(SettingsError::named(
                "-nndd_estimate",
                format!("{why}: the error estimates are not available for such a body yet (their admissible tractions would have to balance its load in that motion too); solve without -nndd_estimate, -nndd_estimate_every, -nndd_reference_factor and -nndd_stop balanced"),
            ));
        }
        if self.solver == SolverKind::Monolithic {
            return Ok(());
        }
        if self
            .nndd
            .requested
            .dirichlet_body
            .is_some_and(|b| b != alpha)
        {
            return Err(SettingsError::named(
                "-nndd_dirichlet_body",
                format!("{why}, so it takes the Dirichlet step (its Neumann problem is singular); use auto or {alpha}"),
            ));
        }
        if self.nndd.dirichlet_step == DirichletChoice::Condensed {
            return Err(SettingsError::named(
                "-nndd_dirichlet_step condensed",
                format!("{why}: its Neumann system is singular, so its Dirichlet step has no condensed form; use auto or system"),
            ));
        }
        // The held body has no Neumann problem: the contact step's body takes the Neumann
        // step alone, whatever the rule would choose.
        if self.nndd.requested.neumann_bodies.is_some() {
            return Err(SettingsError::named(
                "-nndd_neumann_bodies",
                format!("{why}: it has no Neumann problem, so the other body takes the Neumann step alone; use auto"),
            ));
        }
        // (and no stiffness warning of a forced Dirichlet body: there is no choice)
        self.nndd.neumann_bodies = NeumannBodies::Contact;
        self.nndd.dirichlet_body = alpha;
        Ok(())
    }
}

/// `-nndd_restart`: the restart point to continue from, if given.
fn read_restart(o: &mut OptionsBlock) -> Result<Option<PathBuf>, SettingsError> {
    let (restart, given) = o.string(
        "-nndd_restart",
        "Continue the NNDD from this restart point (written by -nndd_checkpoint_every or a signal; any rank count)",
        "",
    )?;
    if given && restart.trim().is_empty() {
        return Err(SettingsError::out_of_range(
            "-nndd_restart",
            "a checkpoint file name",
            "''",
        ));
    }
    Ok(given.then(|| PathBuf::from(restart)))
}

/// `-nndd_fault RANK:PHASE[:panic]` (testing), if given.
fn read_fault(o: &mut OptionsBlock) -> Result<Option<Fault>, SettingsError> {
    let (text, given) = o.string(
        "-nndd_fault",
        "Testing: fail on one rank at one phase, RANK:PHASE (PHASE: init, options, mesh, assembly, factorisation, ksp, qp, estimate, checkpoint, output), or panic there, RANK:PHASE:panic",
        "",
    )?;
    match (given, Fault::parse(&text)) {
        (false, _) => Ok(None),
        (true, Some(fault)) => Ok(Some(fault)),
        (true, None) => Err(SettingsError::UnknownValue {
            option: "-nndd_fault".into(),
            value: text,
            accepted: Phase::ACCEPTED.into(),
        }),
    }
}

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
/// apply to the problem ([`option_applies`]: the `-nndd_bc_…` options were checked against
/// the mesh's curves as they were read).
fn given_options_apply(known: &[String], problem: ProblemKind) -> Result<(), SettingsError> {
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
        option_applies(problem, &name)?;
        if !name.starts_with("-nndd_bc_") && !known.contains(&name) {
            let hint =
                nearest(&name, known).map_or(String::new(), |k| format!("; did you mean {k}?"));
            return Err(SettingsError::named(
                &name,
                format!("unknown option{hint} (-help lists them all)"),
            ));
        }
    }
    Ok(())
}

/// An adaptive run's cycles stop their NNDD by a rule that ends with an answer (`tol` or
/// `balanced`), estimate it (`-nndd_estimate` is on), and start from the previous cycle, not
/// from a restart point.
fn check_adaptive(stop: &crate::dd::nndd::StopRule, restart: bool) -> Result<(), SettingsError> {
    if *stop == crate::dd::nndd::StopRule::None {
        return Err(SettingsError::named(
            "-nndd_stop",
            "must be tol (the default) or balanced with -nndd_adapt_tol: each cycle estimates the error of an answer",
        ));
    }
    if restart {
        return Err(SettingsError::named(
            "-nndd_restart",
            "cannot be used with -nndd_adapt_tol: each cycle starts from the previous cycle's answer",
        ));
    }
    Ok(())
}
