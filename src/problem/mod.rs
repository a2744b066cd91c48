//! Layer `problem`: what the user asks to solve: each body's mesh, material, boundary
//! conditions (Γ_D, Γ_N) and its side of the contact interface Γc ([`BodyProblem`]), built by
//! [`build`] from the plain-data [`ProblemSettings`]. [`benchmarks`]: the built-in problems
//! `paper` and `uniform` (`docs/benchmarks.md`); [`meshed`]: a problem the user meshed in
//! Gmsh, with named boundary conditions and an initial gap.
//!
//! May use: `parallel`, `qp`, `fem`, `petsc`.

pub mod benchmarks;
pub mod meshed;

use std::rc::Rc;

use crate::fem::mesh::Mesh;
use crate::fem::{edge_load, Material};

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

/// What defines the problem to solve (plain data, filled from the options by `app`).
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
}

impl ProblemSettings {
    /// (nx, ny) of body `alpha` (1 or 2).
    pub fn body_grid(&self, alpha: usize) -> (usize, usize) {
        self.grids[alpha - 1]
    }

    /// The same problem on the nested mesh refined `r` times.
    pub fn refined(&self, r: usize) -> ProblemSettings {
        let mut s = self.clone();
        s.n *= r;
        for g in s.grids.iter_mut() {
            *g = (g.0 * r, g.1 * r);
        }
        if let Some(spec) = s.mesh.as_mut() {
            spec.gmsh = Rc::new(spec.gmsh.refined(r));
        }
        s
    }

    /// Total number of dofs of both bodies.
    pub fn dofs(&self) -> usize {
        self.body_dofs().iter().sum()
    }

    /// Dofs of each body (they also size the rank groups).
    pub fn body_dofs(&self) -> [usize; 2] {
        match &self.mesh {
            Some(spec) => meshed::BODY_NAMES.map(|n| 2 * spec.gmsh.surface_node_count(n)),
            None => self.grids.map(|(nx, ny)| 2 * (nx + 1) * (ny + 1)),
        }
    }
}

/// Build both bodies of the problem (shared by the run and the bodies set up from them).
pub fn build(settings: &ProblemSettings) -> Result<[Rc<BodyProblem>; 2], meshed::MeshedError> {
    match &settings.mesh {
        Some(spec) => Ok(meshed::build(spec, settings.materials)?.map(Rc::new)),
        None => Ok([1, 2].map(|alpha| Rc::new(benchmarks::body(settings, alpha)))),
    }
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
    pub mesh: Mesh,
    pub material: Material,
    /// Γ_D: prescribed dofs and their values, sorted by dof.
    pub dirichlet: Vec<(usize, f64)>,
    /// Non-zero tractions on Γ_N (edges not listed are traction free).
    pub neumann: Vec<NeumannEdge>,
    /// Γc nodes of this body, ordered by x (pair k of Γc is `contact_nodes[k]` of both bodies).
    pub contact_nodes: Vec<usize>,
    /// Initial gap g₀ ≥ 0 of each Γc pair (the same on both bodies): non-penetration reads
    /// u²_n − u¹_n ≥ −g₀.
    pub gap: Vec<f64>,
}

impl BodyProblem {
    /// The Neumann load vector f^α (exact for the linear tractions).
    pub fn load(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.mesh.num_dofs()];
        for e in &self.neumann {
            let [a, b] = e.nodes;
            let (fa, fb) = edge_load(
                self.mesh.points[a],
                self.mesh.points[b],
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

    /// The Γc normal dofs (u_y of the contact nodes), in pair order.
    pub fn contact_normal_dofs(&self) -> Vec<usize> {
        self.contact_nodes.iter().map(|&n| 2 * n + 1).collect()
    }

    /// The x coordinates of the Γc nodes.
    pub fn contact_x(&self) -> Vec<f64> {
        self.contact_nodes
            .iter()
            .map(|&n| self.mesh.points[n][0])
            .collect()
    }
}

/// The interface mass matrix M_Γ of P1 densities on Γc (tridiagonal: diagonal, upper).
pub fn interface_mass(x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let m = x.len();
    let mut diag = vec![0.0; m];
    let mut upper = vec![0.0; m.saturating_sub(1)];
    for k in 0..m.saturating_sub(1) {
        let h = (x[k + 1] - x[k]).abs();
        diag[k] += h / 3.0;
        diag[k + 1] += h / 3.0;
        upper[k] = h / 6.0;
    }
    (diag, upper)
}
