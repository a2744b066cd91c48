//! One body (subdomain) Ω^α on its communicator: the stiffness, its factorised systems and the
//! solves the NNDD steps are made of (docs/method.md §2).
//!
//! Two systems exist, both SPD with Dirichlet rows and columns eliminated symmetrically:
//! - the *Neumann* system: Γ_D^α prescribed; used for the contact step and the Neumann step;
//! - the *Dirichlet* system (body 1, when step 1 is not condensed): Γ_D¹ and the Γc normal dofs
//!   prescribed.
//!
//! Each is a PETSc KSP with prefix `body<α>_`, factored once at setup. From the factorisation
//! of the Neumann system come the body's *interface operators* ([`Condensed`]): the interface
//! Schur complement S^α on the Γc normal dofs (everything else condensed) and its inverse, the
//! Delassus operator D^α = B K⁻¹ Bᵀ (m × m, m the Γc pairs), which the condensed Dirichlet,
//! contact and Neumann steps use ([`SchurSource`] says how they were formed). They live on the
//! group's first rank, where the interface algebra of the loop runs.
//!
//! A body spans the ranks of its group ([`Partition`]): each rank assembles its own elements
//! into the distributed matrix (MPIAIJ) and owns a contiguous block of PETSc rows. Vectors cross
//! this module's boundary in mesh numbering, whole, on every rank of the group: a solution is
//! gathered from its owners (a `VecScatter`), or only its Γc normal entries when that is all the
//! caller needs (the Neumann step by back-solves, the Delassus operator by back-solves), or only
//! the nodes a rank's estimates read ([`FieldAt`]: the estimates' re-solves).

use std::cell::RefCell;
use std::collections::HashMap;

use crate::dd::displacement::Displacement;
use crate::dd::friction::Interface;
use crate::dd::load::{Load, Loading};
pub use crate::dd::schur::{uses_mumps, uses_superlu_dist, SchurChoice, SchurMode, SchurSource};
use crate::dd::stiffness::{self, Stiffness};
use crate::parallel::fault::{self, InjectedFault, Phase};
use crate::parallel::layout::OwnComm;
use crate::parallel::partition::Partition;
use crate::petsc::{self, Comm, Gather, Int, Ksp, MumpsFailure, Vector};
use std::rc::Rc;

use crate::fem::{Dofs, DofsMut};
use crate::problem::{BodyProblem, Frames, GcTrace, Support};
use crate::qp::dense::{DenseError, SymMatrix};

mod fields;
mod rows;

pub use fields::{FieldAt, Solved};

#[derive(Debug, thiserror::Error)]
pub enum BodyError {
    #[error(transparent)]
    Petsc(#[from] petsc::PetscError),
    #[error("body {alpha}: the {system} solve did not converge (KSP reason {reason}); check -body{alpha}_ksp_* options")]
    NotConverged {
        alpha: usize,
        system: &'static str,
        reason: i32,
    },
    #[error("body {alpha}: the {system} solve is inaccurate (backward error {error:.1e}; {limit:.0e} at most is accepted): {advice}")]
    Inaccurate {
        alpha: usize,
        system: &'static str,
        error: f64,
        limit: f64,
        advice: String,
    },
    /// A failed check that every rank of the group meets at once: the group's first rank
    /// reports it, the others end quietly ([`ECHO`]).
    #[error("{ECHO} {alpha}'s first rank")]
    Echo { alpha: usize },
    #[error("body {alpha}: interface Schur complement: {source}")]
    Schur { alpha: usize, source: DenseError },
    /// Under the mortar discretisation, the mortar body's trace on Γc's pairs is
    /// rank-deficient: more pairs than its curve's nodes can follow independently.
    #[error("-nndd_contact_discretisation mortar: body {alpha}'s contact curve cannot follow the other curve's nodes one by one (its trace on Γc's pairs is rank-deficient: {source}); the curve whose nodes carry the constraints (the one with fewer nodes where the curves overlap) is finer than body {alpha}'s where they touch: mesh them alike there, or use node_to_node")]
    MortarRank { alpha: usize, source: DenseError },
    #[error("-nndd_schur {choice}: body {alpha} {why}")]
    SchurChoice {
        alpha: usize,
        choice: &'static str,
        why: &'static str,
    },
    #[error(transparent)]
    Fault(#[from] InjectedFault),
    /// A Neumann solve asked of a body held only by contact ([`Support::Contact`]), whose
    /// Neumann system is singular and never formed.
    #[error("body {alpha} is held only by contact: it has no Neumann system (its rigid motion is free without the contact)")]
    NoNeumannSystem { alpha: usize },
}

/// The largest backward error accepted from a factorisation applied once (`preonly`): a
/// stable factorisation gives about 1e−16 whatever the condition of the matrix, a singular
/// factor or a preconditioner that is no solver (`-bodyα_pc_type gamg` with `preonly`) gives
/// 1e−6 and more. An iterative KSP is held to its own `-bodyα_ksp_rtol` when that is looser.
pub const BACKWARD_ERROR_LIMIT: f64 = 1e-10;

/// How the message of [`BodyError::Echo`] starts.
pub const ECHO: &str = "(reported by body";

/// Unit right-hand sides per multiple-RHS solve when S^α comes from back-solves.
const SCHUR_BATCH: usize = 64;

/// A body's interface operators on the Γc normal dofs in pair order (docs/method.md §2):
/// the Schur complement S^α of the Neumann system, and its inverse D^α = B K⁻¹ Bᵀ, the normal
/// Γc displacement of unit Γc forces. With them each step of the NNDD is m × m algebra: the
/// Dirichlet step's reaction S¹(λ − v¹*), the contact QP on S², and the Neumann step's trace
/// D^α(∓½R).
pub struct Condensed {
    pub schur: SymMatrix,
    pub delassus: SymMatrix,
}

/// Which factorised system to solve with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum System {
    Neumann,
    Dirichlet,
}

/// The Γc nodal loads of a Neumann re-solve ([`Body::neumann_solve_many`]), in pair order.
#[derive(Clone, Debug)]
pub enum GcForces {
    /// Along the pairs' contact directions n_k.
    Normal(Vec<f64>),
    /// (x, y) vectors: a traction with a component across n_k (the estimates' on a curved
    /// side, docs/method.md §5).
    Vector(Vec<[f64; 2]>),
}

/// Prescribed (frame dof, value) pairs of a solve.
type Prescribed = Vec<(usize, f64)>;

pub struct Body {
    /// The body's problem, shared with the run (which keeps both bodies' geometry).
    pub problem: Rc<BodyProblem>,
    /// The stiffness K^α without boundary conditions, in the nodal frames (held once:
    /// [`Stiffness`]).
    stiffness: Stiffness,
    /// ‖K^α‖∞ (an upper bound where K is split), the scale of equilibrium residuals.
    k_norm: f64,
    /// The rotated nodal frames of the Γc nodes whose normal is not (0, 1): the systems are
    /// assembled in them; every vector crossing this module's boundary is in global (x, y)
    /// components except the Γc normal entries (u_n, T_n).
    frames: Frames,
    /// Neumann load f^α, in the nodal frames: its non-zero entries (a boundary's worth),
    /// not a whole vector ([`Load`]).
    load: Load,
    /// Value on the diagonal of eliminated rows (mean diagonal of K, for conditioning).
    diag: f64,
    comm: Comm,
    /// The Neumann system, factored; `None` on a body held only by contact
    /// ([`Support::Contact`]), where it is singular.
    neumann: Option<Ksp>,
    dirichlet: Option<Ksp>,
    /// The dofs the Γc trace reads ([`BodyProblem::interface_dofs`]): the normal dofs in pair
    /// order, or on the mortar body both dofs of its Γc nodes.
    pub gc: Vec<usize>,
    /// The trace's rows over `gc` ([`BodyProblem::trace_rows`]): pair k's normal displacement
    /// is Σ c·u[gc[i]] over row k's (i, c), and a force T_k on pair k loads gc[i] with c·T_k.
    gc_rows: Vec<Vec<(usize, f64)>>,
    /// What the interface vectors hold: the pairs' normal components, or with friction their
    /// normal then their tangential ones (node to node).
    pub interface: Interface,
    /// How the interface operators were formed, on every rank of the group (`None`: the body
    /// has none).
    pub schur_source: Option<SchurSource>,
    /// The interface operators, on the group's first rank only.
    condensed: Option<Condensed>,
    /// MUMPS's factorisation flops (RINFOG(3)) of the Neumann system, when MUMPS factors it.
    pub factorisation_flops: Option<f64>,
    /// The nonzeros of K^α as assembled (over the group; [`stiffness::Assembled`]).
    pub nonzeros: f64,
    /// Counters of back-solves per system (for the summary).
    pub solves: std::cell::Cell<usize>,
    /// Wall time of assembly, of factorisation and of the interface operators (s).
    pub setup_seconds: (f64, f64, f64),
    /// The body's distribution over its group.
    pub partition: Partition,
    x: RefCell<Vector>,
    b: RefCell<Vector>,
    kx: RefCell<Vector>,
    trace: RefCell<Gather>,
    /// Where this rank keeps the body's displacement fields ([`Body::keep_fields_at`]):
    /// `None`, whole.
    field_nodes: RefCell<Option<fields::FieldNodes>>,
    /// The body's own communicator (`comm`): the last field, so that it is freed after
    /// every PETSc object on it.
    own_comm: OwnComm,
}

impl Body {
    /// Assemble K^α (this rank's elements of `partition`) and factor its Neumann system;
    /// `schur` says whether the interface operators are wanted, `choice` how to form them.
    pub fn setup(
        problem: Rc<BodyProblem>,
        own_comm: OwnComm,
        partition: Partition,
        schur: SchurMode,
        choice: SchurChoice,
        interface: Interface,
        stages: &crate::petsc::log::Stages,
    ) -> Result<Body, BodyError> {
        let comm = own_comm.petsc();
        let alpha = problem.alpha;
        let t0 = std::time::Instant::now();
        let frames = problem.frames();
        let held = problem.support == Support::Conditions;
        let nonzeros;
        let (stiffness, diag, k_norm, k_neu) = {
            let _s = stages.assembly.enter();
            fault::check(Phase::Assembly)?;
            let a = stiffness::assemble(&problem, &frames, &own_comm, &partition, held)?;
            nonzeros = a.nonzeros;
            match a.coupling {
                Some(coupling) => {
                    let mut k_neu = a.matrix;
                    let modes = stiffness::rigid_modes(&problem, &frames, &partition, &own_comm);
                    k_neu.set_near_null_space(comm, &modes)?;
                    (
                        Stiffness::Split { coupling },
                        a.diag,
                        a.norm_inf,
                        Some(k_neu),
                    )
                }
                None => (Stiffness::Whole(a.matrix), a.diag, a.norm_inf, None),
            }
        };
        let (gc, pair_rows) = interface_rows(&problem, interface);
        let gc_rows: Vec<petsc::Int> = gc.iter().map(|&d| partition.row(d)).collect();
        let t_assembly = t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        let factorisation = stages.factorisation.enter();
        // MUMPS forms S^α during the factorisation only on one rank (PETSc 3.18).
        let want = (schur != SchurMode::None
            && partition.size == 1
            && matches!(choice, SchurChoice::Auto | SchurChoice::MumpsSchur))
        .then_some(&gc_rows[..]);
        fault::check(Phase::Factorisation)?;
        let neumann = match k_neu {
            Some(k_neu) => Some(Ksp::new(comm, k_neu, &format!("body{alpha}_"), want)?),
            None => None,
        };
        let factorisation_flops = match &neumann {
            Some(n) => n.mumps_factorisation_flops()?,
            None => None,
        };
        let x = Vector::new(comm, partition.local_rows())?;
        let trace = Gather::new(&x, &gc_rows)?;
        let b = x.duplicate()?;
        let kx = x.duplicate()?;
        let load = Load::of(problem.load(), &frames);
        let mut body = Body {
            problem,
            comm,
            stiffness,
            k_norm,
            frames,
            load,
            diag,
            neumann,
            dirichlet: None,
            gc,
            gc_rows: pair_rows,
            interface,
            schur_source: None,
            condensed: None,
            factorisation_flops,
            nonzeros,
            solves: std::cell::Cell::new(0),
            setup_seconds: (t_assembly, 0.0, 0.0),
            partition,
            x: RefCell::new(x),
            b: RefCell::new(b),
            kx: RefCell::new(kx),
            trace: RefCell::new(trace),
            field_nodes: RefCell::new(None),
            own_comm,
        };
        drop(factorisation);
        body.setup_seconds.1 = t1.elapsed().as_secs_f64();
        let t2 = std::time::Instant::now();
        if let Some(source) = body.schur_source_for(schur, choice)? {
            let _s = stages.interface.enter();
            body.condensed = body.interface_operators(source)?;
            body.schur_source = Some(source);
        }
        body.setup_seconds.2 = t2.elapsed().as_secs_f64();
        Ok(body)
    }

    /// How to form the interface operators (after the factorisation), or `None` when they are
    /// not wanted or, with [`SchurMode::IfFactored`], would cost back-solves.
    fn schur_source_for(
        &self,
        mode: SchurMode,
        choice: SchurChoice,
    ) -> Result<Option<SchurSource>, BodyError> {
        let refuse = |why| BodyError::SchurChoice {
            alpha: self.alpha(),
            choice: choice.name(),
            why,
        };
        let Some(neumann) = self.neumann.as_ref().filter(|_| mode != SchurMode::None) else {
            return Ok(None);
        };
        let mumps = neumann.has_mumps_factor()?;
        let schur = neumann.schur_complement().is_some();
        Ok(Some(match choice {
            SchurChoice::MumpsSchur if schur => SchurSource::MumpsSchur,
            SchurChoice::MumpsSchur if !mumps => return Err(refuse("is not factored by MUMPS")),
            SchurChoice::MumpsSchur => {
                return Err(refuse(
                    "is on several ranks (PETSc 3.18 forms MUMPS's Schur complement on one only)",
                ))
            }
            SchurChoice::MumpsInverse if !mumps => return Err(refuse("is not factored by MUMPS")),
            SchurChoice::Auto if schur => SchurSource::MumpsSchur,
            SchurChoice::Auto | SchurChoice::MumpsInverse if mumps => SchurSource::MumpsInverse,
            _ if mode == SchurMode::IfFactored && choice != SchurChoice::Solves => return Ok(None),
            _ => SchurSource::Solves,
        }))
    }

    /// Bytes of PETSc's copies of the body's matrices for MUMPS freed on this rank once
    /// factored (`Ksp::freed_copy_bytes`, both systems).
    pub fn freed_copy_bytes(&self) -> usize {
        [&self.neumann, &self.dirichlet]
            .iter()
            .filter_map(|k| k.as_ref())
            .map(Ksp::freed_copy_bytes)
            .sum()
    }

    /// The first rank of the body's group: the one that counts the body's replicated totals
    /// (energy, e_ref) once, and solves the contact QP.
    pub fn is_root(&self) -> bool {
        self.partition.rank == 0
    }

    /// Assemble and factor the Dirichlet system (Γ_D and the Γc normal dofs prescribed).
    pub fn add_dirichlet_system(
        &mut self,
        stages: &crate::petsc::log::Stages,
    ) -> Result<(), BodyError> {
        let t0 = std::time::Instant::now();
        let m = {
            let _s = stages.assembly.enter();
            let dofs = self.problem.dirichlet.iter().map(|d| d.0);
            let rows = stiffness::owned_rows(&self.partition, dofs.chain(self.gc.iter().copied()));
            // K_N (or K) with the Γc normal rows and columns eliminated too.
            let mut m = match &self.stiffness {
                Stiffness::Whole(k) => k.duplicate()?,
                Stiffness::Split { .. } => self.ksp(System::Neumann)?.operator().duplicate()?,
            };
            m.zero_rows_columns(&rows, self.diag)?;
            m.set_near_null_space(
                self.comm,
                &stiffness::rigid_modes(
                    &self.problem,
                    &self.frames,
                    &self.partition,
                    &self.own_comm,
                ),
            )?;
            m
        };
        self.setup_seconds.0 += t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        let _s = stages.factorisation.enter();
        self.dirichlet = Some(Ksp::new(
            self.comm,
            m,
            &format!("body{}_", self.alpha()),
            None,
        )?);
        self.setup_seconds.1 += t1.elapsed().as_secs_f64();
        Ok(())
    }

    /// The MUMPS factorisations of this body's systems that fell short of workspace and
    /// were made again, each with the relaxation ICNTL(14) of the next ([`Ksp::new`]).
    pub fn relaxed_factorisations(&self) -> Vec<(MumpsFailure, Int)> {
        let systems = [&self.neumann, &self.dirichlet];
        let solvers = systems.into_iter().flatten();
        solvers.flat_map(|k| k.relaxed().iter().copied()).collect()
    }

    pub fn has_dirichlet_system(&self) -> bool {
        self.dirichlet.is_some()
    }

    pub fn alpha(&self) -> usize {
        self.problem.alpha
    }

    /// The interface operators from `source`, on the group's first rank (`None` elsewhere).
    fn interface_operators(&mut self, source: SchurSource) -> Result<Option<Condensed>, BodyError> {
        let m = self.gc.len();
        let alpha = self.alpha();
        let rows: Vec<petsc::Int> = self.gc.iter().map(|&d| self.partition.row(d)).collect();
        let neumann = self.ksp(System::Neumann)?;
        // One of S^α, D^α (column-major), the other its inverse.
        let (block, is_schur) = match source {
            SchurSource::MumpsSchur => (
                neumann
                    .schur_complement()
                    .map(<[f64]>::to_vec)
                    .expect("MUMPS formed the Schur complement"),
                true,
            ),
            SchurSource::MumpsInverse => {
                let root = self.is_root();
                (
                    neumann
                        .mumps_inverse_block(root, &rows)?
                        .unwrap_or_default(),
                    false,
                )
            }
            SchurSource::Solves => {
                let nodes = self.partition.owned_nodes();
                let owned = (2 * nodes.start) as petsc::Int..(2 * nodes.end) as petsc::Int;
                let (cols, reason, backward) = neumann.inverse_block(
                    self.comm,
                    owned,
                    &rows,
                    &mut self.trace.borrow_mut(),
                    SCHUR_BATCH,
                )?;
                self.solves.set(self.solves.get() + m);
                self.check_solve(System::Neumann, reason, backward)?;
                (cols, false)
            }
        };
        if !self.is_root() {
            return Ok(None);
        }
        let mut a = SymMatrix::new(m);
        for j in 0..m {
            for i in 0..m {
                // A symmetric factorisation may fill only one triangle of MUMPS's Schur
                // complement: take the other where one is zero.
                let (x, y) = (block[j * m + i], block[i * m + j]);
                let v = match (x == 0.0, y == 0.0) {
                    (true, _) => y,
                    (_, true) => x,
                    _ => 0.5 * (x + y),
                };
                a.set(i, j, v);
            }
        }
        drop(block);
        let inverse = a
            .inverse_spd()
            .map_err(|source| BodyError::Schur { alpha, source })?;
        let (schur, delassus) = if is_schur { (a, inverse) } else { (inverse, a) };
        if self.problem.trace == GcTrace::Nodes {
            return Ok(Some(Condensed { schur, delassus }));
        }
        // The mortar body: D = R C Rᵀ on the pairs from the compliance C on its Γc dofs, S = D⁻¹.
        let delassus = delassus.congruence(&self.gc_rows);
        let schur = delassus
            .inverse_spd()
            .map_err(|source| BodyError::MortarRank { alpha, source })?;
        Ok(Some(Condensed { schur, delassus }))
    }

    /// The pairs' traces Σ c·x[i] of values `x` on `gc`.
    fn apply_rows(&self, x: &[f64]) -> Vec<f64> {
        self.gc_rows
            .iter()
            .map(|row| row.iter().map(|&(i, c)| c * x[i]).sum())
            .collect()
    }

    /// The length of the interface vectors: the number of Γc pairs, twice it with friction.
    pub fn pairs(&self) -> usize {
        self.gc_rows.len()
    }

    /// The interface operators, on the group's first rank (`None` on the others, and on a
    /// body without them).
    pub fn condensed(&self) -> Option<&Condensed> {
        self.condensed.as_ref()
    }

    /// Whether the body has its interface operators (on every rank of its group).
    pub fn has_condensed(&self) -> bool {
        self.schur_source.is_some()
    }

    /// The right-hand side (this rank's rows) of `load` (in the nodal frames) with prescribed
    /// values: Γ_D data (or zero when `homogeneous`) and `gc_values` on the Γc normal dofs;
    /// and the prescribed (dof, value) pairs (frame dofs).
    fn right_hand_side(
        &self,
        load: &Loading,
        homogeneous: bool,
        gc_values: Option<&[f64]>,
    ) -> Result<(Vec<f64>, Prescribed), BodyError> {
        // x_g: the prescribed values, zero elsewhere; rhs = load − K x_g, prescribed rows = diag·g.
        let mut fixed: Vec<(usize, f64)> =
            Vec::with_capacity(self.problem.dirichlet.len() + self.gc.len());
        for &(dof, v) in &self.problem.dirichlet {
            let v = if homogeneous { 0.0 } else { v };
            fixed.push((dof, v));
        }
        if let Some(vals) = gc_values {
            for (&dof, &v) in self.gc.iter().zip(vals) {
                fixed.push((dof, v));
            }
        }
        // This rank's rows: x_g and K x_g on them alone (no whole vector; a dof prescribed
        // twice takes its last value).
        let dofs = self.owned_dofs();
        let kg = match fixed.iter().any(|f| f.1 != 0.0) {
            true => {
                let mut g = vec![0.0; dofs.len()];
                for (row, v) in self.owned(&fixed) {
                    g[row] = v;
                }
                self.mult_k_local(&g)?;
                Some(self.kx.borrow().to_vec()?)
            }
            false => None,
        };
        let prescribed: HashMap<usize, f64> = fixed.iter().copied().collect();
        let rhs = (dofs.iter().enumerate())
            .map(|(i, d)| match prescribed.get(d) {
                Some(&v) => self.diag * v,
                None => load.at(*d) - kg.as_ref().map_or(0.0, |k| k[i]),
            })
            .collect();
        Ok((rhs, fixed))
    }

    /// Seconds this rank spent checking the body's solves (their backward errors).
    pub fn check_seconds(&self) -> f64 {
        self.neumann.as_ref().map_or(0.0, Ksp::check_seconds)
            + self.dirichlet.as_ref().map_or(0.0, Ksp::check_seconds)
    }

    fn ksp(&self, system: System) -> Result<&Ksp, BodyError> {
        match system {
            System::Neumann => self.neumann.as_ref().ok_or(BodyError::NoNeumannSystem {
                alpha: self.alpha(),
            }),
            System::Dirichlet => Ok(self
                .dirichlet
                .as_ref()
                .expect("the Dirichlet step's body has its Dirichlet system")),
        }
    }

    /// A failed or inaccurate solve of `system` as an error: a negative converged reason, or a
    /// backward error above [`BACKWARD_ERROR_LIMIT`] (or the KSP's own relative tolerance,
    /// when looser) or not finite. Every rank of the group finds it (the norms are global);
    /// the group's first rank reports it, the others return [`BodyError::Echo`].
    fn check_solve(&self, system: System, reason: i32, backward: f64) -> Result<(), BodyError> {
        let alpha = self.alpha();
        let failed = self.solve_failure(system, reason, backward)?;
        match failed {
            Some(_) if !self.is_root() => Err(BodyError::Echo { alpha }),
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The error of a failed or inaccurate solve, if it failed (see [`Body::check_solve`]).
    fn solve_failure(
        &self,
        system: System,
        reason: i32,
        backward: f64,
    ) -> Result<Option<BodyError>, BodyError> {
        let alpha = self.alpha();
        let name = if system == System::Neumann {
            "Neumann"
        } else {
            "Dirichlet"
        };
        if reason < 0 {
            return Ok(Some(BodyError::NotConverged {
                alpha,
                system: name,
                reason,
            }));
        }
        let ksp = self.ksp(system)?;
        let direct = ksp.is_direct()?;
        let rtol = ksp.rtol()?;
        let limit = if direct {
            BACKWARD_ERROR_LIMIT
        } else {
            BACKWARD_ERROR_LIMIT.max(rtol)
        };
        if backward <= limit {
            return Ok(None);
        }
        let (ksp_type, pc_type) = ksp.types()?;
        let p = format!("-body{alpha}_");
        let factored = matches!(pc_type.as_str(), "cholesky" | "lu");
        let advice = if !backward.is_finite() {
            format!("the solution is not finite: body {alpha}'s matrix is singular or its data overflow (check its Dirichlet conditions, E and ν, and the mesh)")
        } else if direct && !factored {
            format!("{p}ksp_type {ksp_type} applies {p}pc_type {pc_type} once, which does not solve the system; use a factorisation ({p}pc_type cholesky) or iterate ({p}ksp_type cg {p}ksp_rtol 1e-12)")
        } else if direct {
            format!("the factorisation ({p}pc_type {pc_type}) is not accurate: body {alpha}'s matrix is singular or nearly so (check its Dirichlet conditions, E and ν, and the mesh)")
        } else {
            format!("{p}ksp_type {ksp_type} stopped at {p}ksp_rtol {rtol:.0e} without an accurate solution; tighten {p}ksp_rtol (1e-12) or use a factorisation ({p}ksp_type preonly {p}pc_type cholesky)")
        };
        Ok(Some(BodyError::Inaccurate {
            alpha,
            system: name,
            error: backward,
            limit,
            advice,
        }))
    }

    /// Solve `system` with right-hand side `load` (in the nodal frames) and prescribed values:
    /// Γ_D data (or zero when `homogeneous`) and, for the Dirichlet system, `gc_values` on the
    /// Γc normal dofs. The solution stays in the PETSc vector `x`; returns the prescribed
    /// (dof, value) pairs (frame dofs).
    fn solve(
        &self,
        system: System,
        load: &Loading,
        homogeneous: bool,
        gc_values: Option<&[f64]>,
    ) -> Result<Vec<(usize, f64)>, BodyError> {
        let ksp = self.ksp(system)?;
        let (rhs, fixed) = self.right_hand_side(load, homogeneous, gc_values)?;
        let mut b = self.b.borrow_mut();
        let mut x = self.x.borrow_mut();
        b.copy_from(&rhs)?;
        let info = ksp.solve(&b, &mut x)?;
        self.solves.set(self.solves.get() + 1);
        self.check_solve(system, info.reason, info.backward_error)?;
        Ok(fixed)
    }

    /// Solve the Dirichlet system: u = u_D on Γ_D, u_n = λ on Γc, tangential Γc free.
    /// Returns the displacement and the reaction T = K u − f on the Γc normal dofs.
    /// The displacement is held as [`Body::keep_fields_at`] says.
    pub fn dirichlet_solve(&self, lambda: &[f64]) -> Result<(Displacement, Vec<f64>), BodyError> {
        let fixed = self.solve_dirichlet(lambda)?;
        let u = self.field(&fixed)?;
        let t = self.reaction(&fixed)?;
        Ok((u, t))
    }

    /// The reaction T = K u − f on the Γc normal dofs of the Dirichlet solve at `lambda`
    /// alone ([`Body::dirichlet_solve`] without its field; the NNDD loop's Dirichlet step, the
    /// monolithic solve's columns): no whole vector on any rank.
    pub fn dirichlet_reaction(&self, lambda: &[f64]) -> Result<Vec<f64>, BodyError> {
        let fixed = self.solve_dirichlet(lambda)?;
        self.reaction(&fixed)
    }

    /// The Dirichlet system solved with the body's data at `lambda` (the solution in `x`).
    fn solve_dirichlet(&self, lambda: &[f64]) -> Result<Prescribed, BodyError> {
        let data = Loading::new(Some(&self.load));
        self.solve(System::Dirichlet, &data, false, Some(lambda))
    }

    /// The Neumann load (in the nodal frames): nodal forces `gc_forces` on the Γc normal dofs
    /// (Rᵀ T: a force T_k on pair k loads gc[i] with c·T_k for row k's (i, c)), plus the
    /// body's f^α when `with_data`.
    fn neumann_load(&self, gc_forces: &[f64], with_data: bool) -> Loading<'_> {
        let mut load = Loading::new(with_data.then_some(&self.load));
        for (row, &t) in self.gc_rows.iter().zip(gc_forces) {
            for &(i, c) in row {
                load.add(self.gc[i], c * t);
            }
        }
        load
    }

    /// Solve the Neumann system with nodal forces `gc_forces` on the Γc normal dofs, plus the
    /// body's own data (f^α and u_D) when `with_data`, else homogeneous (paper (15)–(16)).
    pub fn neumann_solve(&self, gc_forces: &[f64], with_data: bool) -> Result<Vec<f64>, BodyError> {
        let load = self.neumann_load(gc_forces, with_data);
        let fixed = self.solve(System::Neumann, &load, !with_data, None)?;
        self.solution(&fixed)
    }

    /// [`Body::neumann_solve`]'s solution as a field of the body, held as
    /// [`Body::keep_fields_at`] says (an iterate's u^α).
    pub fn neumann_field(
        &self,
        gc_forces: &[f64],
        with_data: bool,
    ) -> Result<Displacement, BodyError> {
        let load = self.neumann_load(gc_forces, with_data);
        let fixed = self.solve(System::Neumann, &load, !with_data, None)?;
        self.field(&fixed)
    }

    /// [`Body::neumann_solve`] for several Γc loads at once, all with the body's data (the
    /// estimates' re-solves): one multiple-right-hand-side solve, which with a factorisation
    /// reads the factor once for all of them. The solutions stay on their owners until
    /// [`Body::fields_at`] gathers them.
    pub fn neumann_solve_many(&self, gc_forces: &[GcForces]) -> Result<Solved, BodyError> {
        if gc_forces.len() < 2 {
            let (mut columns, mut fixed) = (Vec::new(), Vec::new());
            for f in gc_forces {
                fixed = self.solve(System::Neumann, &self.gc_load(f), false, None)?;
                columns.push(self.x.borrow().to_vec()?);
            }
            return Ok(Solved { columns, fixed });
        }
        // (each column formed on this rank's rows alone)
        let mut columns = Vec::with_capacity(gc_forces.len());
        let mut fixed = Vec::new();
        for f in gc_forces {
            let (rhs, fx) = self.right_hand_side(&self.gc_load(f), false, None)?;
            columns.push(rhs);
            fixed = fx;
        }
        let neumann = self.ksp(System::Neumann)?;
        let (solved, reason, backward) = neumann.solve_many(self.comm, columns)?;
        self.solves.set(self.solves.get() + solved.len());
        self.check_solve(System::Neumann, reason, backward)?;
        Ok(Solved {
            columns: solved,
            fixed,
        })
    }

    /// The body's data plus the Γc loads `f`, in the nodal frames.
    fn gc_load(&self, f: &GcForces) -> Loading<'_> {
        match f {
            GcForces::Normal(t) => self.neumann_load(t, true),
            GcForces::Vector(v) => {
                let mut load = Loading::new(Some(&self.load));
                if let GcTrace::Mortar(c) = &self.problem.trace {
                    // Pair k's force reaches the mortar body's node j as P_kj f_k (no rotated
                    // frames there).
                    for (row, f) in c.rows.iter().zip(v) {
                        for &(node, p) in row {
                            load.add(2 * node, p * f[0]);
                            load.add(2 * node + 1, p * f[1]);
                        }
                    }
                    return load;
                }
                for ((&d, f), n) in self.gc.iter().zip(v).zip(&self.problem.contact_normals) {
                    // The node's frame: (τ, n), τ = (n_y, −n_x); d is its normal dof.
                    load.add(d - 1, n[1] * f[0] - n[0] * f[1]);
                    load.add(d, n[0] * f[0] + n[1] * f[1]);
                }
                load
            }
        }
    }

    /// The normal Γc trace of [`Body::neumann_solve`]'s solution, gathered alone.
    pub fn neumann_trace(&self, gc_forces: &[f64], with_data: bool) -> Result<Vec<f64>, BodyError> {
        let load = self.neumann_load(gc_forces, with_data);
        self.solve(System::Neumann, &load, !with_data, None)?;
        let values = self.trace.borrow_mut().gather(&self.x.borrow())?;
        Ok(self.apply_rows(&values))
    }

    /// Normal Γc displacements B u.
    pub fn normal_trace<U: Dofs + ?Sized>(&self, u: &U) -> Vec<f64> {
        self.problem.normal_trace(u)
    }

    /// The interface trace of `u`: its normal Γc displacements, and with friction its
    /// tangential ones after them.
    pub fn trace<U: Dofs + ?Sized>(&self, u: &U) -> Vec<f64> {
        let mut v = self.problem.normal_trace(u);
        if self.interface == Interface::Frictional {
            v.extend(self.problem.tangential_trace(u));
        }
        v
    }

    /// Set row `row` of the interface trace of `u` to `value` (a normal row, or with friction
    /// a tangential one), keeping the other component.
    pub fn set_trace<U: DofsMut + ?Sized>(&self, u: &mut U, row: usize, value: f64) {
        let m = self.problem.pairs();
        if row < m {
            self.problem.set_normal_trace(u, row, value);
        } else {
            self.problem.set_tangential_trace(u, row - m, value);
        }
    }
}

/// The dofs the interface trace reads and its rows over them: the problem's
/// ([`BodyProblem::interface_dofs`], [`BodyProblem::trace_rows`]), and with friction (node to
/// node) each pair's tangential dof (2n in the node's frame (τ, n)) after the normal ones.
fn interface_rows(
    problem: &BodyProblem,
    interface: Interface,
) -> (Vec<usize>, Vec<Vec<(usize, f64)>>) {
    let mut gc = problem.interface_dofs();
    let mut rows = problem.trace_rows();
    if interface == Interface::Frictional {
        assert!(
            problem.trace == GcTrace::Nodes,
            "friction is refused under the mortar discretisation"
        );
        let m = gc.len();
        gc.extend(problem.contact_nodes.iter().map(|&n| 2 * n));
        rows.extend((m..2 * m).map(|k| vec![(k, 1.0)]));
    }
    (gc, rows)
}
