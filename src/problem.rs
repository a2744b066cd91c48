//! The benchmark problems of `shared/docs/benchmarks.md`: geometry, meshes, material,
//! boundary conditions and the contact interface Γc.

use crate::fem::{edge_load, Material};
use crate::mesh::Mesh;
use crate::settings::{ProblemKind, Settings};

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

/// Build body `alpha` of the chosen benchmark.
pub fn body(settings: &Settings, alpha: usize) -> BodyProblem {
    let (nx, ny) = settings.body_grid(alpha);
    let y0 = if alpha == 1 { 0.0 } else { 1.0 };
    let mesh = Mesh::structured([0.0, y0], [1.0, 1.0], nx, ny);
    let material = settings.material;
    let mut dirichlet = Vec::new();
    let mut neumann = Vec::new();
    match (settings.problem, alpha) {
        (ProblemKind::Paper, 1) => {
            // Γ_D¹: the bottom edge is clamped.
            for n in mesh.bottom_nodes() {
                dirichlet.push((2 * n, 0.0));
                dirichlet.push((2 * n + 1, 0.0));
            }
        }
        (ProblemKind::Paper, _) => {
            // Γ_D²: top edge u = (0, u_D); Γ_N²: right edge, F² = (0, F_max (2 − y)).
            for n in mesh.top_nodes() {
                dirichlet.push((2 * n, 0.0));
                dirichlet.push((2 * n + 1, settings.u_d));
            }
            let f = |y: f64| [0.0, settings.f_max * (2.0 - y)];
            for [a, b] in mesh.right_edges() {
                let t = [f(mesh.points[a][1]), f(mesh.points[b][1])];
                if t[0] != [0.0, 0.0] || t[1] != [0.0, 0.0] {
                    neumann.push(NeumannEdge {
                        nodes: [a, b],
                        traction: t,
                    });
                }
            }
        }
        (ProblemKind::Uniform, 1) => {
            // Rollers on the bottom, u_x = 0 at the node (0, 0).
            for n in mesh.bottom_nodes() {
                dirichlet.push((2 * n + 1, 0.0));
            }
            dirichlet.push((2 * mesh.node(0, 0), 0.0));
        }
        (ProblemKind::Uniform, _) => {
            // Rollers on the top (u_y = u_D), u_x = 0 at the node (0, 2).
            for n in mesh.top_nodes() {
                dirichlet.push((2 * n + 1, settings.u_d));
            }
            dirichlet.push((2 * mesh.node(0, mesh.ny), 0.0));
        }
    }
    dirichlet.sort_by_key(|d| d.0);
    let contact_nodes = if alpha == 1 {
        mesh.top_nodes()
    } else {
        mesh.bottom_nodes()
    };
    BodyProblem {
        alpha,
        mesh,
        material,
        dirichlet,
        neumann,
        contact_nodes,
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
