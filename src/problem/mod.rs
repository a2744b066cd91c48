//! Layer `problem`: what the user asks to solve: each body's mesh, material, boundary
//! conditions (Γ_D, Γ_N) and its side of the contact interface Γc ([`BodyProblem`]), built by
//! [`build`] from the plain-data [`ProblemSettings`]. [`benchmarks`]: the built-in problems
//! `paper` and `uniform` (`docs/benchmarks.md`); [`meshed`]: a problem the user meshed in
//! Gmsh, with named boundary conditions and an initial gap; [`conform`]: its contact curves,
//! meshed on their own, made to match ([`matched`]: what it did), or coupled as meshed by the
//! [`mortar`] operators; [`settings`]: the problem's
//! options, read into
//! [`ProblemSettings`].
//!
//! May use: `parallel`, `qp`, `fem`, `petsc`, `os`.

pub mod benchmarks;
pub mod conform;
mod coupled;
mod curves;
mod frames;
pub mod matched;
pub mod meshed;
pub mod mortar;
pub mod outline;
pub mod parsed;
mod polyline;
pub mod settings;
mod sound;
pub mod transfer;
mod wire;

use std::rc::Rc;

use crate::fem::mesh::Mesh;
use crate::fem::{edge_load, Material};
pub use frames::Frames;
pub use outline::Outline;

/// The built-in problems (`-nndd_problem`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProblemKind {
    Paper,
    Uniform,
    /// A Gmsh mesh of the user's (`-nndd_mesh`).
    Mesh,
}

impl ProblemKind {
    pub fn name(self) -> &'static str {
        match self {
            ProblemKind::Paper => "paper",
            ProblemKind::Uniform => "uniform",
            ProblemKind::Mesh => "mesh",
        }
    }
}

/// What defines the problem to solve (plain data, read from the options by
/// [`ProblemSettings::from_options`]).
#[derive(Clone, Debug)]
pub struct ProblemSettings {
    pub kind: ProblemKind,
    /// Mesh level n: each body is an n × n grid unless overridden.
    pub n: usize,
    /// Per-body grids (nx, ny) for Ω¹ and Ω².
    pub grids: [(usize, usize); 2],
    /// The material of body 1 and of body 2.
    pub materials: [Material; 2],
    /// Prescribed vertical displacement of the top of Ω² (m).
    pub u_d: f64,
    /// Maximum of the linear load on the right edge of Ω² (Pa).
    pub f_max: f64,
    /// The user's meshed problem (`ProblemKind::Mesh`).
    pub mesh: Option<meshed::MeshSpec>,
    /// How each body is dealt over its group (`-nndd_partition`).
    pub partitioner: crate::parallel::partition::Partitioner,
    /// Where a Gmsh problem's bodies are built (`-nndd_mesh_input`).
    pub input: parsed::MeshInput,
}

impl ProblemSettings {
    /// (nx, ny) of body `alpha` (1 or 2).
    pub fn body_grid(&self, alpha: usize) -> (usize, usize) {
        self.grids[alpha - 1]
    }

    /// The same problem on the nested mesh refined `r` times (a Gmsh mesh where it is held:
    /// a rank that holds its facts alone is told the refined file's by world rank 0,
    /// [`ParsedFile::share_facts`](parsed::ParsedFile::share_facts)).
    pub fn refined(&self, r: usize) -> Result<ProblemSettings, meshed::MeshedError> {
        let mut s = self.clone();
        s.n *= r;
        for g in s.grids.iter_mut() {
            *g = (g.0 * r, g.1 * r);
        }
        if let Some(spec) = s.mesh.as_mut() {
            spec.gmsh = spec.gmsh.refined(r)?;
            spec.nested = Some(r);
        }
        Ok(s)
    }

    /// The problem the estimates of a mortar run work on (`None` for any other run): the
    /// user's meshes with each contact curve's nodes inserted into the other, nothing moved
    /// ([`conform::Snap::InsertOnly`]), coupled node to node (docs/method.md §7, "The
    /// estimates"; on a rank where world rank 0 alone holds the file, its facts until
    /// [`parsed::ParsedFile::share_facts`] gives it the matched file's). Every P1 field of the user's meshes is one of these meshes', so the mortar
    /// iterate carries over exactly ([`transfer::Transfer`]); its continuous problem is that of
    /// §6 on the user's polygons, and its nested refinements give the reference solution.
    pub fn for_estimates(&self) -> Result<Option<ProblemSettings>, meshed::MeshedError> {
        let Some(spec) = self.mesh.as_ref() else {
            return Ok(None);
        };
        if spec.discretisation != ContactDiscretisation::Mortar {
            return Ok(None);
        }
        let (gmsh, matched) = match spec.gmsh.is_on_root() {
            // (world rank 0 matches the curves of the file it holds alone, and tells the
            // others the matched file's facts: `ParsedFile::share_facts`)
            true => (spec.gmsh.clone(), Default::default()),
            false => {
                let snap = conform::Snap::InsertOnly;
                let (gmsh, matched) = conform::conform_with(spec.gmsh.mesh()?, &spec.contact, snap);
                (parsed::ParsedFile::new(gmsh), matched)
            }
        };
        let mut s = self.clone();
        s.mesh = Some(meshed::MeshSpec {
            gmsh,
            discretisation: ContactDiscretisation::NodeToNode,
            matched: Rc::new(matched),
            ..spec.clone()
        });
        Ok(Some(s))
    }

    /// Under `-nndd_contact_discretisation auto`, where it chose mortar for `problems` but a
    /// body is held only by contact (which mortar does not support yet): the problem switched to
    /// node to node, and why, in a line.
    pub fn node_to_node_instead(
        &mut self,
        problems: &[Rc<BodyProblem>; 2],
    ) -> Result<Option<String>, meshed::MeshedError> {
        let Some(spec) = self.mesh.as_mut() else {
            return Ok(None);
        };
        let Some(held) = problems.iter().find(|p| p.support == Support::Contact) else {
            return Ok(None);
        };
        if spec.choice != DiscretisationChoice::Auto
            || spec.discretisation != ContactDiscretisation::Mortar
        {
            return Ok(None);
        }
        *spec = spec.node_to_node()?;
        Ok(Some(format!(
            "the contact curves do not match, but body {} is held only by contact, which the mortar discretisation does not support yet: they are made to match and coupled node to node (-nndd_contact_discretisation auto)",
            held.alpha
        )))
    }

    /// Total number of dofs of both bodies.
    pub fn dofs(&self) -> usize {
        self.body_dofs().iter().sum()
    }

    /// Dofs of each body (they also size the rank groups).
    pub fn body_dofs(&self) -> [usize; 2] {
        match &self.mesh {
            Some(spec) => spec.gmsh.body_dofs,
            None => self.grids.map(|(nx, ny)| 2 * (nx + 1) * (ny + 1)),
        }
    }
}

/// Build both bodies of the problem (shared by the run and the bodies set up from them).
pub fn build(settings: &ProblemSettings) -> Result<[Rc<BodyProblem>; 2], meshed::MeshedError> {
    match &settings.mesh {
        Some(spec) => Ok(meshed::build(spec, settings.materials)?.map(Rc::new)),
        None => {
            let bodies = [1, 2].map(|alpha| Rc::new(benchmarks::body(settings, alpha)));
            check_meshes(&bodies)?;
            Ok(bodies)
        }
    }
}

/// The mesh checks of [`crate::fem::checks`] that apply to the built-in meshes (Gmsh meshes
/// are checked as they are read): no degenerate or inverted triangle (the grids are written
/// counter-clockwise, so a negative relative area is an inverted, folded triangle), no overlap
/// of the bodies.
fn check_meshes(bodies: &[Rc<BodyProblem>; 2]) -> Result<(), meshed::MeshedError> {
    use crate::fem::checks;
    let err = |option: String, message: String| meshed::MeshedError::Option { option, message };
    for b in bodies {
        let mesh = b.mesh();
        let q = (0..mesh.triangles.len())
            .map(|e| (e, checks::quality(mesh.triangle_points(e))))
            .min_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((e, q)) = q.filter(|(_, q)| *q < checks::MIN_QUALITY || q.is_nan()) {
            let p = mesh.triangle_points(e);
            return Err(err(
                format!("-nndd_body{}_nx, -nndd_body{}_ny", b.alpha, b.alpha),
                format!(
                    "body {}'s grid has a degenerate or inverted triangle ({:.6e}, {:.6e}), ({:.6e}, {:.6e}), ({:.6e}, {:.6e}): relative area 2·area/(longest edge)² = {q:.3e}, below {:e}",
                    b.alpha, p[0][0], p[0][1], p[1][0], p[1][1], p[2][0], p[2][1], checks::MIN_QUALITY
                ),
            ));
        }
    }
    if let Some(o) = checks::overlap([bodies[0].mesh(), bodies[1].mesh()]) {
        return Err(err(
            "-nndd_problem".into(),
            format!("the bodies' meshes overlap ({o:?})"),
        ));
    }
    Ok(())
}

/// A linear traction on a boundary edge: the two end nodes and the traction at each.
#[derive(Clone, Debug)]
pub struct NeumannEdge {
    pub nodes: [usize; 2],
    pub traction: [[f64; 2]; 2],
}

/// Everything that defines one body's discrete problem.
#[derive(Clone, Debug)]
pub struct BodyProblem {
    /// 1 (lower body Ω¹) or 2 (upper body Ω²).
    pub alpha: usize,
    /// Its mesh: whole, or released on a rank that reads the body's outline alone
    /// ([`BodyProblem::mesh`], [`BodyProblem::released`]).
    mesh: BodyMesh,
    /// Its boundary, made from the mesh when first read and kept where the mesh is released.
    outline: std::cell::OnceCell<Outline>,
    /// Its mesh's fingerprint ([`Mesh::fingerprint`]), made from the whole mesh when first read
    /// and kept with the part or the outline a rank holds after.
    fingerprint: std::cell::OnceCell<u64>,
    pub material: Material,
    /// Γ_D: prescribed dofs and their values, sorted by dof.
    pub dirichlet: Vec<(usize, f64)>,
    /// Non-zero tractions on Γ_N (edges not listed are traction free).
    pub neumann: Vec<NeumannEdge>,
    /// Γc nodes of this body in pair order: along body 1's side with body 1 on the right
    /// (by increasing x on a horizontal side with body 1 below); pair k of Γc is
    /// `contact_nodes[k]` of both bodies. The mortar body under the mortar discretisation
    /// ([`GcTrace::Mortar`]): the nodes of its curve the pairs' rows use, along its curve in
    /// the pairs' direction (not one per pair).
    pub contact_nodes: Vec<usize>,
    /// How the body meets the pairs: at its own nodes, or at points of its curve.
    pub trace: GcTrace,
    /// Initial gap g₀ ≥ 0 of each Γc pair (the same on both bodies): non-penetration reads
    /// u²_n − u¹_n ≥ −g₀.
    pub gap: Vec<f64>,
    /// The contact direction n_k of each pair: body 1's outward unit normal at its node (the
    /// mean of its sides' normals), the same on both bodies; (0, 1) on a horizontal side.
    /// u^α_n = n_k · u^α at the pair's node.
    pub contact_normals: Vec<[f64; 2]>,
    /// The lengths of body 1's Γc segments [k, k+1]: Γc's measure, on both bodies.
    pub contact_lengths: Vec<f64>,
    /// The whole contact curve the user named (Γc's nodes and those beyond, where the other
    /// body's curve does not reach): where the final check looks for penetration.
    pub contact_candidates: Vec<usize>,
    /// The body's outward unit normal at each candidate node (the mean of its segments').
    pub candidate_normals: Vec<[f64; 2]>,
    /// What holds the body against rigid motion.
    pub support: Support,
}

/// A body's mesh as a rank holds it.
#[derive(Clone, Debug)]
enum BodyMesh {
    Whole(Mesh),
    /// The part of a listed (Gmsh) mesh a rank reads once the bodies are partitioned
    /// ([`BodyProblem::part`]): its counts and numbering the whole's.
    Part(Mesh),
    /// Released on a rank outside the body's group that does not estimate it (its counts
    /// kept: the output's rows and the summary read them): the rank reads the body's
    /// [`Outline`] alone.
    Released {
        nodes: usize,
        elements: usize,
    },
}

/// How a body meets Γc's pairs (`-nndd_contact_discretisation`).
#[derive(Clone, Debug, PartialEq)]
pub enum GcTrace {
    /// Pair k is its node `contact_nodes[k]`: u_n = n_k · u there (node to node).
    Nodes,
    /// The mortar body under the mortar discretisation: pair k (the other body's node) meets
    /// the point Σ_j P_kj x_j of this body's curve, u_n = n_k · Σ_j P_kj u_j
    /// ([`mortar::Coupling`]).
    Mortar(Rc<mortar::Coupling>),
}

/// The body whose nodes are Γc's pairs (0: body 1, 1: body 2): body 1 node to node, under the
/// mortar discretisation the non-mortar body (the other meets the pairs at points of its
/// curve). Its `contact_nodes`, `contact_lengths` place the pairs.
pub fn pair_side(problems: [&BodyProblem; 2]) -> usize {
    match problems[0].trace {
        GcTrace::Mortar(_) => 1,
        GcTrace::Nodes => 0,
    }
}

/// Each pair's share of Γc (half its segments' lengths along the pair side): what a nodal
/// force is divided by to give the pair's pressure. On a closed curve coupled all round
/// ([`mortar::Coupling::closing`]) the segment that closes Γc counts for its two pairs.
pub fn pair_shares(problems: [&BodyProblem; 2]) -> Vec<f64> {
    let lengths = &problems[pair_side(problems)].contact_lengths;
    let mut share = vec![0.0; lengths.len() + 1];
    for (k, l) in lengths.iter().enumerate() {
        share[k] += 0.5 * l;
        share[k + 1] += 0.5 * l;
    }
    if let (Some(l), Some(last)) = (closing(problems), share.len().checked_sub(1)) {
        share[0] += 0.5 * l;
        share[last] += 0.5 * l;
    }
    share
}

/// The length of the segment that closes Γc where it goes all round a closed curve
/// ([`mortar::Coupling::closing`]).
fn closing(problems: [&BodyProblem; 2]) -> Option<f64> {
    problems.iter().find_map(|p| match &p.trace {
        GcTrace::Mortar(c) => c.closing,
        GcTrace::Nodes => None,
    })
}

/// Whether Γc closes on itself (its last pair followed by its first).
pub fn contact_closes(problems: [&BodyProblem; 2]) -> bool {
    closing(problems).is_some()
}

/// How the two bodies of a problem meet: mortar where one's trace is the coupling's.
pub fn discretisation(problems: [&BodyProblem; 2]) -> ContactDiscretisation {
    if problems
        .iter()
        .any(|p| matches!(p.trace, GcTrace::Mortar(_)))
    {
        ContactDiscretisation::Mortar
    } else {
        ContactDiscretisation::NodeToNode
    }
}

/// The contact discretisation of two curves (`-nndd_contact_discretisation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactDiscretisation {
    /// Node to node: curves meshed on their own are first made to match ([`conform`]).
    NodeToNode,
    /// Segment to segment with dual multipliers on the coarser curve ([`mortar`]), the
    /// curves as meshed.
    Mortar,
}

impl ContactDiscretisation {
    pub fn name(self) -> &'static str {
        match self {
            ContactDiscretisation::NodeToNode => "node_to_node",
            ContactDiscretisation::Mortar => "mortar",
        }
    }
}

/// What the user asked for (`-nndd_contact_discretisation`): a discretisation, or `auto`, the
/// default: mortar where the curves do not match (making them match would insert a node) and
/// node to node where they do, the two being the same there; node to node also
/// where mortar is not available (a body held only by contact, [`meshed::MeshSpec::node_to_node`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiscretisationChoice {
    Auto,
    Given(ContactDiscretisation),
}

/// What holds a body against rigid motion (translations and rotation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Its own prescribed displacements (Γ_D): its Neumann system is nonsingular.
    Conditions,
    /// Its prescribed displacements leave a rigid motion free that the contact holds (a
    /// roller and a load: force-controlled contact). Its Neumann system is singular, so it
    /// takes the NNDD's Dirichlet step (Γc normal displacements prescribed, which fix the
    /// motion) and no Neumann step (docs/method.md §2, "A body held only by contact").
    Contact,
}

/// The Γc normal of a horizontal side with the body below: its contact node needs no
/// rotated frame.
pub const UP: [f64; 2] = [0.0, 1.0];

impl BodyProblem {
    /// The body's mesh.
    ///
    /// # Panics
    /// Where this rank released it ([`BodyProblem::released`]): a rank releases the mesh of a
    /// body only where nothing after reads it there (`app::parts::release_unread_meshes`). Where it
    /// holds a part ([`BodyProblem::part`]), on reading an element or a node beyond it.
    pub fn mesh(&self) -> &Mesh {
        match &self.mesh {
            BodyMesh::Whole(m) | BodyMesh::Part(m) => m,
            BodyMesh::Released { .. } => {
                panic!(
                    "body {}'s mesh is read on a rank that released it",
                    self.alpha
                )
            }
        }
    }

    /// The mesh nodes `nodes` and Γc's, ascending, once each: what an estimating rank reads
    /// of a field on its overlap of the body (its contact terms read Γc).
    pub fn with_contact_nodes(&self, nodes: &[usize]) -> Vec<usize> {
        let mut all: Vec<usize> = nodes.iter().chain(&self.contact_nodes).copied().collect();
        all.sort_unstable();
        all.dedup();
        all
    }

    /// Whether this rank holds the body's mesh (whole or the part it reads).
    pub fn holds_mesh(&self) -> bool {
        matches!(self.mesh, BodyMesh::Whole(_) | BodyMesh::Part(_))
    }

    /// Whether this rank holds the body's mesh whole, listed (not a grid's formula): what
    /// [`BodyProblem::part`] makes smaller.
    pub fn holds_listed_mesh(&self) -> bool {
        matches!(&self.mesh, BodyMesh::Whole(m) if !m.is_structured())
    }

    /// The body's nodes (held or released).
    pub fn num_nodes(&self) -> usize {
        match &self.mesh {
            BodyMesh::Whole(m) | BodyMesh::Part(m) => m.num_nodes(),
            BodyMesh::Released { nodes, .. } => *nodes,
        }
    }

    /// The body's dofs, two per node.
    pub fn num_dofs(&self) -> usize {
        2 * self.num_nodes()
    }

    /// The body's elements (held or released).
    pub fn num_elements(&self) -> usize {
        match &self.mesh {
            BodyMesh::Whole(m) | BodyMesh::Part(m) => m.triangles.len(),
            BodyMesh::Released { elements, .. } => *elements,
        }
    }

    /// The body's boundary ([`Outline`]), made from its mesh when first read.
    pub fn outline(&self) -> &Outline {
        self.outline.get_or_init(|| Outline::of(self.mesh()))
    }

    /// The fingerprint of the body's whole mesh ([`Mesh::fingerprint`]: what a restart point
    /// is checked against), made from the mesh when first read.
    ///
    /// # Panics
    /// Where the rank holds a part of the mesh or its outline alone and the fingerprint was
    /// not made before (from the whole mesh, or by the rank that built it).
    pub fn mesh_fingerprint(&self) -> u64 {
        *self.fingerprint.get_or_init(|| self.mesh().fingerprint())
    }

    /// The point of Γc node or boundary node `node`, from the mesh where held, else from the
    /// outline.
    pub fn boundary_point(&self, node: usize) -> [f64; 2] {
        match &self.mesh {
            BodyMesh::Whole(m) => m.points.get(node),
            BodyMesh::Part(_) | BodyMesh::Released { .. } => self.outline().point(node),
        }
    }

    /// This problem with its mesh released, its outline and its counts kept: what a rank
    /// holds of a body whose mesh nothing there reads after the layout.
    pub fn released(&self) -> BodyProblem {
        self.with_mesh(BodyMesh::Released {
            nodes: self.num_nodes(),
            elements: self.num_elements(),
        })
    }

    /// This problem with its mesh held as the part a rank reads ([`Mesh::part`]): the
    /// elements `elements` and the nodes `nodes` (the outline kept whole, O(√N)).
    pub fn part(&self, elements: &[u32], nodes: &[u32]) -> BodyProblem {
        self.with_mesh(BodyMesh::Part(self.mesh().part(elements, nodes)))
    }

    /// This problem with its mesh held as `mesh` (its outline made first: it is kept).
    fn with_mesh(&self, mesh: BodyMesh) -> BodyProblem {
        BodyProblem {
            alpha: self.alpha,
            mesh,
            outline: std::cell::OnceCell::from(self.outline().clone()),
            fingerprint: self.fingerprint.clone(),
            material: self.material,
            dirichlet: self.dirichlet.clone(),
            neumann: self.neumann.clone(),
            contact_nodes: self.contact_nodes.clone(),
            trace: self.trace.clone(),
            gap: self.gap.clone(),
            contact_normals: self.contact_normals.clone(),
            contact_lengths: self.contact_lengths.clone(),
            contact_candidates: self.contact_candidates.clone(),
            candidate_normals: self.candidate_normals.clone(),
            support: self.support,
        }
    }

    /// The Neumann load vector f^α (exact for the linear tractions).
    pub fn load(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.num_dofs()];
        for e in &self.neumann {
            let [a, b] = e.nodes;
            let (fa, fb) = edge_load(
                self.boundary_point(a),
                self.boundary_point(b),
                e.traction[0],
                e.traction[1],
            );
            for k in 0..2 {
                f[2 * a + k] += fa[k];
                f[2 * b + k] += fb[k];
            }
        }
        f
    }

    /// The obstacle of body 2's contact step for the interface position λ: u²_n ≥ λ − g₀.
    pub fn obstacle(&self, lambda: &[f64]) -> Vec<f64> {
        lambda.iter().zip(&self.gap).map(|(l, g)| l - g).collect()
    }

    /// The number of Γc pairs.
    pub fn pairs(&self) -> usize {
        self.gap.len()
    }

    /// The dofs the body's Γc trace reads: the normal dof of each pair's node in its nodal
    /// frame ([`Frames`]: u_y where n = (0, 1), else u · n); under the mortar discretisation
    /// both dofs (x, y) of each of the mortar body's `contact_nodes`.
    pub fn interface_dofs(&self) -> Vec<usize> {
        match self.trace {
            GcTrace::Nodes => self.contact_nodes.iter().map(|&n| 2 * n + 1).collect(),
            GcTrace::Mortar(_) => self
                .contact_nodes
                .iter()
                .flat_map(|&n| [2 * n, 2 * n + 1])
                .collect(),
        }
    }

    /// The trace as rows over [`Self::interface_dofs`]: u_n of pair k = Σ c·x[i] over row k's
    /// (i, c) (one (k, 1) per pair node to node).
    pub fn trace_rows(&self) -> Vec<Vec<(usize, f64)>> {
        match &self.trace {
            GcTrace::Nodes => (0..self.contact_nodes.len())
                .map(|k| vec![(k, 1.0)])
                .collect(),
            GcTrace::Mortar(c) => {
                let at: std::collections::HashMap<usize, usize> = self
                    .contact_nodes
                    .iter()
                    .enumerate()
                    .map(|(i, &n)| (n, i))
                    .collect();
                c.rows
                    .iter()
                    .zip(&c.normals)
                    .map(|(row, n)| {
                        row.iter()
                            .flat_map(|&(node, p)| {
                                let i = at[&node];
                                [(2 * i, p * n[0]), (2 * i + 1, p * n[1])]
                            })
                            .collect()
                    })
                    .collect()
            }
        }
    }
}

/// The lengths of the segments [k, k+1] of a polyline.
pub fn segment_lengths(points: &[[f64; 2]]) -> Vec<f64> {
    points
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .collect()
}

/// The interface mass matrix M_Γ of P1 densities on Γc from its segment lengths
/// (tridiagonal: diagonal, upper).
pub fn interface_mass(lengths: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let m = lengths.len() + 1;
    let mut diag = vec![0.0; m];
    let mut upper = vec![0.0; m - 1];
    for k in 0..m - 1 {
        let h = lengths[k];
        diag[k] += h / 3.0;
        diag[k + 1] += h / 3.0;
        upper[k] = h / 6.0;
    }
    (diag, upper)
}
