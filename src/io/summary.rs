//! The JSON run summary (`PREFIX.json`), written by world rank 0 with serde.

use serde::Serialize;

use crate::dd::nndd::IterationRecord;

/// Seconds per phase (maximum over ranks).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Timings {
    /// Reading the options and the mesh file, and building both bodies' problems (with the
    /// pairing of Γc); under `-nndd_mesh_input root` also dealing every rank its parts (the
    /// partitions and the estimates' overlaps made on world rank 0).
    pub input: f64,
    pub assembly: f64,
    pub factorisation: f64,
    /// Each body's interface operators S^α, D^α, and the free solutions u^α₀ of the condensed
    /// steps.
    pub interface: f64,
    pub dirichlet_step: f64,
    pub contact_step: f64,
    pub neumann_step: f64,
    pub exchange: f64,
    /// The fields of the reported and the estimated iterates (a back-solve per body).
    pub fields: f64,
    /// The checks of the results: each subdomain solve's backward error and the final check
    /// of the reported iterate (equilibrium and contact conditions).
    pub checks: f64,
    pub monolithic: f64,
    pub estimation: f64,
    /// The estimation's parts (each also a `-log_view` stage nested in Estimation).
    pub estimation_parts: EstimationParts,
    pub reference: f64,
    pub output: f64,
    pub total: f64,
}

/// Seconds in each part of the estimates (maximum over ranks); their sum is the estimation
/// time up to the glue between the parts.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct EstimationParts {
    /// The admissible Γc tractions (Clarabel QPs).
    pub traction_qp: f64,
    /// The FE-equilibrated Neumann re-solves.
    pub resolves: f64,
    /// The stress recovery (and, at the first estimate on a body split over ranks, its overlap).
    pub recovery: f64,
    /// The element contributions.
    pub element_sums: f64,
    /// e_ref against the reference solution.
    pub e_ref: f64,
    /// Sums and maxima over the ranks (with the waits for the slower ranks).
    pub reduction: f64,
}

impl From<[f64; 6]> for EstimationParts {
    /// From the seconds in `estimate::Part`'s order.
    fn from(s: [f64; 6]) -> Self {
        EstimationParts {
            traction_qp: s[0],
            resolves: s[1],
            recovery: s[2],
            element_sums: s[3],
            e_ref: s[4],
            reduction: s[5],
        }
    }
}

#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct EquilibriumResiduals {
    pub divergence: f64,
    pub internal_jump: f64,
    pub element_jump: f64,
    pub boundary: f64,
    pub point_reaction: f64,
}

/// What η^glo, η^FE and η^NNDD bound (docs/output.md, docs/method.md §3.3), for the reader of
/// the summary.
#[derive(Clone, Debug, Serialize)]
pub struct EstimateMeaning {
    pub eta_glo: &'static str,
    pub eta_fe: &'static str,
    pub eta_nndd: &'static str,
    pub unit: &'static str,
}

impl EstimateMeaning {
    /// The meaning of a mortar run's estimates (docs/method.md §7, "The estimates").
    pub fn mortar() -> EstimateMeaning {
        EstimateMeaning {
            eta_glo: "guaranteed upper bound of the energy-norm error of the iterate against the exact solution of the continuous contact problem on the meshes' polygons, paired along body 1's interpolated normal field (or with a node within 1 % of a segment off it), with the initial gap the mortar nodal gaps interpolated along the non-mortar curve (docs/method.md section 7); includes the correction that moves apart the pairs the weighted constraint lets penetrate",
            eta_fe: "the part of the error due to the mesh: the same construction with each body re-solved under its own contact forces (docs/method.md section 7)",
            eta_nndd: "the part of the error due to stopping the NNDD: the error of the iterate against the mortar-discrete contact problem's solution; tends to 0 as the NNDD converges",
            ..EstimateMeaning::default()
        }
    }
}

impl Default for EstimateMeaning {
    /// The meaning of the estimates.
    fn default() -> EstimateMeaning {
        EstimateMeaning {
            eta_glo: "guaranteed upper bound of the energy-norm error of the iterate against the exact solution of the continuous contact problem (paper (22)); on a curved contact side, the problem whose contact direction interpolates the nodal normals along each segment (docs/method.md section 5)",
            eta_fe: "the part of the error due to the mesh: the same bound for the contact problem at the iterate's interface displacement lambda_p (paper (23)); built from other admissible fields, so it may exceed eta_glo near convergence",
            eta_nndd: "the part of the error due to stopping the NNDD: the error of the iterate against the discrete contact problem's solution (paper (24)); tends to 0 as the NNDD converges",
            unit: "(J/m)^(1/2), the energy norm per unit thickness",
        }
    }
}

/// Where a field lives in `PREFIX.h5`.
#[derive(Clone, Debug, Serialize)]
pub struct FieldInfo {
    pub grid: String,
    pub name: String,
    /// "node" or "cell".
    pub center: &'static str,
    pub components: usize,
    pub dataset: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub problem: String,
    /// The built-in problems' mesh level and grids ((nx, ny) of body 1 and body 2); absent for
    /// a Gmsh problem.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub n: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grids: Option<[[usize; 2]; 2]>,
    /// A Gmsh problem as given: its file, contact curves and boundary conditions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshProblem>,
    pub dofs: usize,
    pub ranks: i32,
    pub solver: String,
    /// The fixed θ of `-nndd_theta VALUE`; absent with `theta_auto` (the history gives the θ
    /// of every iteration).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub theta: Option<f64>,
    /// `-nndd_theta auto`: the secant update (src/dd/secant.rs).
    pub theta_auto: bool,
    /// The body of the NNDD's Dirichlet step (`-nndd_dirichlet_body`); the other body takes the
    /// contact step.
    pub dirichlet_body: usize,
    pub tol: f64,
    pub max_it: usize,
    /// Young's modulus of body 1 and body 2 (Pa).
    pub young: [f64; 2],
    /// Poisson's ratio of body 1 and body 2.
    pub poisson: [f64; 2],
    /// The built-in problems' load: u_D on the top of body 2 (m), F_max on its right edge (Pa);
    /// absent for a Gmsh problem.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u_d: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub f_max: Option<f64>,
    pub converged: bool,
    /// "converged", "max_it", "diverged", "stagnated" (NNDD) or "solved" (monolithic).
    pub status: String,
    /// Why the run ended: "tol", "balanced", "max_it", "diverged", "stagnated" (NNDD) or
    /// "direct" (monolithic).
    pub stop_reason: String,
    pub iterations: usize,
    pub history: Vec<IterationRecord>,
    /// Σ_α ½ a^α(u, u) − ∫_{Γ_N} F·u (J/m).
    pub potential_energy: f64,
    /// ‖u_h‖_E of the reported iterate, both bodies: (Σ_E u_Eᵀ K_E u_E)^½ (η^glo / ‖u_h‖_E is
    /// the relative error an adaptive run's tolerance bounds).
    pub energy_norm: f64,
    /// Total normal force on Γc (N/m), positive in compression.
    pub contact_force: f64,
    /// [x_min, x_max] of the nodes in contact (null when none).
    pub contact_zone: Option<[f64; 2]>,
    pub active_nodes: usize,
    pub contact_nodes: usize,
    /// The contact zone of the reported iterate: where, how long, the peak pressure.
    pub contact: ContactZone,
    /// The contact curves: how they were made to match and the largest penetration over them.
    pub contact_curves: ContactCurves,
    /// How each body's interface operators S^α, D^α were formed: "mumps_schur",
    /// "mumps_inverse", "solves", or "none".
    pub schur_source: [String; 2],
    /// How the Dirichlet step was solved: "condensed" or "system" ("" for monolithic).
    pub dirichlet_step: String,
    /// How each body's Neumann steps were solved: "condensed" (the trace D^α(∓½R)), "solve"
    /// (a back-solve) or "none" (a body held only by contact, or one -nndd_neumann_bodies leaves
    /// out); "" for monolithic.
    pub neumann_step: [String; 2],
    /// MUMPS's count of each body's factorisation flops (RINFOG(3); null without MUMPS).
    pub factorisation_flops: [Option<f64>; 2],
    /// MiB of PETSc's copies of each body's matrices for MUMPS (their triples i, j, a_ij)
    /// freed once MUMPS factored them, over the body's group: 0 where MUMPS is asked for
    /// iterative refinement or error analysis (`-bodyα_mat_mumps_icntl_10`, `_11`), which
    /// read them in its solves, or does not factor the body.
    pub freed_matrix_copy_mib: [f64; 2],
    /// The nonzeros of each body's stiffness K^α as assembled (its Γ_D rows and columns
    /// included), over its group's ranks; the preallocation is checked exact.
    pub stiffness_nonzeros: [f64; 2],
    /// The flops PETSc logged, summed over the ranks (what `-log_view` totals).
    pub logged_flops: f64,
    /// Each body's setup on its first rank: assembly, factorisation and interface operators
    /// (s); the groups run them at the same time, so the shorter waits for the longer.
    pub body_setup_seconds: [f64; 2],
    /// Each body's dofs.
    pub body_dofs: [usize; 2],
    /// Largest relative KKT violation of the contact QPs of the reported step.
    pub qp_kkt_residual: f64,
    /// The estimated iterations (η^glo, η^FE, η^NNDD, ratio (25), e_ref and effectivity (26)).
    pub estimates: Vec<EstimateEntry>,
    pub timings: Timings,
    /// Peak resident memory over ranks (MiB): each process's high-water mark (getrusage).
    pub peak_memory_mib: f64,
    /// Peak resident memory of every rank (MiB), by world rank.
    pub peak_memory_mib_per_rank: Vec<f64>,
    /// Each rank's resident file-backed memory at the end (MiB), by world rank: its shared
    /// libraries' pages, part of its peak above but one copy for all the ranks of a machine
    /// (what the machine holds at most is about Σ (peak − this) + the largest of this).
    pub file_backed_memory_mib_per_rank: Vec<f64>,
    /// The elements of the bodies' meshes each rank holds through the run, by world rank: its
    /// group's body (and a body it estimates outside that body's group, or both in a mortar
    /// run that estimates or an adaptive run), of a Gmsh body the part it reads once the
    /// bodies are partitioned; the other's mesh released after the layout.
    pub held_mesh_elements_per_rank: Vec<usize>,
    /// The nodes at which each rank holds the reported iterate's displacement, by world rank:
    /// its rows of the output (its block of the body's nodes and its cells' nodes), Γc and the
    /// outline (a body's whole on the body's only rank).
    pub held_displacement_nodes_per_rank: Vec<usize>,
    /// The same of the reference solution's fields (`-nndd_reference_factor`), both fine
    /// bodies' nodes, when solved: its block of the fine elements' nodes, its block of the
    /// fine body's nodes, Γc and the outline.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_reference_displacement_nodes_per_rank: Option<Vec<usize>>,
    /// The elements of the reference solution's fine meshes each rank held through their
    /// set-up and solve, both bodies', when solved: a Gmsh body's part on a rank of its group
    /// (its partition, its block of the fine elements and Γc; whole where that would be most
    /// of it), a built-in body's grid whole (its formula: nothing stored).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_reference_mesh_elements_per_rank: Option<Vec<usize>>,
    /// The most nodes at which each rank held an estimated iterate's displacement u^α_p,
    /// both bodies' (what its recoveries read: its overlap of each body it estimates and Γc;
    /// a mortar run's iterate carried to the matched meshes; the iterate's whole field where
    /// the rank holds it so), when the run estimates.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_estimate_displacement_nodes_per_rank: Option<Vec<usize>>,
    /// The elements of a mortar run's estimates' matched meshes (docs/method.md §7) each rank
    /// held, both bodies', when it estimates: its parts where world rank 0 built them and
    /// dealt them (`-nndd_mesh_input root`), else as the run's own meshes are held.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_matched_mesh_elements_per_rank: Option<Vec<usize>>,
    /// The elements of a Gmsh problem's meshes each rank held in the input, by world rank:
    /// both bodies' on a rank that built them (world rank 0 alone under `-nndd_mesh_input
    /// root`, every rank under `every_rank` or where a later phase reads the whole meshes),
    /// else the part of its group's body world rank 0 sent it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_mesh_elements_per_rank: Option<Vec<usize>>,
    /// The points of a Gmsh problem's parsed file each rank held, by world rank: all on
    /// world rank 0, which reads it, and on every rank it is sent to (where the bodies are
    /// built on every rank), none on the others.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_file_points_per_rank: Option<Vec<usize>>,
    /// Peak resident memory of every rank (MiB) at the end of the input, by world rank: once
    /// the bodies' problems were built (or a rank's part sent) and the ranks laid out, before
    /// the bodies are set up (what building the whole bodies on a rank costs it).
    pub input_peak_memory_mib_per_rank: Vec<f64>,
    /// The elements of the reference solution's fine meshes each rank held in its input, when
    /// solved, by world rank: both bodies' on a rank that built them (world rank 0 alone under
    /// `-nndd_mesh_input root`, a mortar run's matched meshes refined there alike; every rank
    /// under `every_rank`), else the part world rank 0 sent it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_input_mesh_elements_per_rank: Option<Vec<usize>>,
    /// The same once the reference solution's fine bodies were built and cut to each rank's
    /// parts, before their set-up, when solved (`-nndd_reference_factor`: world rank 0 builds
    /// a Gmsh problem's under `-nndd_mesh_input root`, every rank under `every_rank`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_input_peak_memory_mib_per_rank: Option<Vec<f64>>,
    /// Ranks of each body's group.
    pub body_ranks: [usize; 2],
    /// Largest equilibrium residuals of the recovered stresses over the estimated iterations
    /// (relative; docs/method.md §3.1's "exact equilibrium" at round-off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub equilibrium_residuals: Option<EquilibriumResiduals>,
    /// Reference mesh factor and the reference NNDD's iterations (when solved).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_factor: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_iterations: Option<usize>,
    pub h5: String,
    /// The bodies' series (`PREFIX.xdmf`).
    pub xdmf: String,
    /// Γc's series and the reported iterate alone (docs/output.md).
    pub xdmf_contact: String,
    pub xdmf_final: String,
    pub fields: Vec<FieldInfo>,
    /// What each estimate bounds, and their unit (with estimates).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimate_meaning: Option<EstimateMeaning>,
    /// The warnings the run printed (`nndd: warning: …`), in order.
    pub warnings: Vec<String>,
    /// The check of the reported iterate: each body's equilibrium residual and the relative
    /// penetration, tension and complementarity on Γc (`src/dd/check.rs`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solution_check: Option<crate::dd::check::SolutionCheck>,
}

/// The two contact curves of a run (`-nndd_contact`; the top of body 1 and the bottom of body
/// 2 on the built-in problems).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ContactCurves {
    pub names: [String; 2],
    /// The nodes of each whole curve (the candidates), after matching.
    pub nodes: [usize; 2],
    /// Γc's node pairs: where the curves overlap (under mortar, the non-mortar curve's nodes
    /// the other covers).
    pub pairs: usize,
    /// `-nndd_contact_discretisation`: node_to_node or mortar.
    pub discretisation: &'static str,
    /// Under mortar, the body whose nodes carry the pairs (the coarser curve); null otherwise.
    pub non_mortar: Option<usize>,
    /// Under mortar, the wall time of the mortar operators and the coupling's rows (s).
    pub coupling_seconds: Option<f64>,
    /// Nodes inserted into each curve, and nodes moved onto a partner's projection, to make
    /// curves meshed independently match (0 on matching meshes).
    pub inserted: [usize; 2],
    pub moved: [usize; 2],
    /// The largest penetration of the reported solution over both whole curves (a value
    /// beyond round-off is an error, so this is round-off or 0).
    pub max_penetration: crate::dd::penetration::Penetration,
}

/// The contact zone of the reported iterate (the pairs in contact), on body 1's side of Γc.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ContactZone {
    /// The zone as an arc-length interval along Γc from its first node (m); null when no pair
    /// is in contact.
    pub zone: Option<[f64; 2]>,
    /// The zone's two end points (x, y).
    pub zone_ends: Option<[[f64; 2]; 2]>,
    /// Its length along Γc (m).
    pub zone_length: f64,
    /// The largest lumped nodal pressure (Pa: a pair's normal force over its share of Γc) and
    /// where.
    pub peak_pressure: f64,
    pub peak_pressure_at: Option<[f64; 2]>,
    /// The total normal force on Γc (N/m, positive in compression).
    pub normal_force: f64,
    /// With friction (`-nndd_friction`): where the pairs stick and slip, the tangential force.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub friction: Option<FrictionZones>,
}

/// The stick and slip zones of a frictional contact, and its tangential force.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrictionZones {
    /// The friction law (`tresca`, `coulomb`).
    pub friction: String,
    /// Each run of consecutive sticking pairs in contact, as an arc-length interval along Γc
    /// from its first node (m), between the run's first and last pairs.
    pub stick_zone: Vec<[f64; 2]>,
    /// Each run of consecutive slipping pairs in contact, likewise.
    pub slip_zone: Vec<[f64; 2]>,
    /// Pairs sticking, slipping.
    pub stick_nodes: usize,
    pub slip_nodes: usize,
    /// The total tangential force on body 2 (N/m, along τ = (n_y, −n_x) of each pair: +x
    /// on a horizontal Γc).
    pub tangential_force: f64,
    /// The largest lumped nodal shear |T_t,k| / s_k (Pa) and where.
    pub peak_shear: f64,
    pub peak_shear_at: Option<[f64; 2]>,
    /// The largest slip |u¹_t − u²_t| of a slipping pair in contact (m).
    pub max_slip: f64,
}

/// A Gmsh problem as the options gave it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MeshProblem {
    pub file: String,
    /// A `.geo` file's parameters as `-nndd_geo_set` gave them (empty for a mesh file).
    pub geometry_parameters: std::collections::BTreeMap<String, f64>,
    /// The physical surfaces of the two bodies.
    pub bodies: [&'static str; 2],
    /// `-nndd_contact`: body 1's and body 2's contact curves.
    pub contact: [String; 2],
    /// The `-nndd_bc_NAME_…` conditions: per curve, the prescribed (u_x, u_y) (null where free)
    /// or the traction at its first and last point (Pa).
    pub conditions: Vec<crate::problem::meshed::CurveCondition>,
}

/// The estimates of one estimated iteration (paper (22)–(26)).
#[derive(Clone, Debug, serde::Serialize)]
pub struct EstimateEntry {
    pub iteration: usize,
    pub eta_glo: f64,
    pub eta_fe: f64,
    pub eta_nndd: f64,
    /// (η^FE² + η^NNDD²)/η^glo², relation (25).
    pub eta_ratio: f64,
    /// ‖δ‖_E, the part of η^glo due to the correction that keeps û in contact between the
    /// nodes of a curved Γc (docs/method.md §5; 0 on a straight side).
    pub eta_glo_correction: f64,
    /// Against the reference solution (`-nndd_reference_factor`), when solved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub e_ref: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effectivity: Option<f64>,
}
