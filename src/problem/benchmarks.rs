//! The built-in benchmarks of `docs/benchmarks.md` on structured grids: `paper` (the
//! two-block problem of Gallimard, Choi & Sassi (2013)) and `uniform` (the patch test).

use super::{segment_lengths, BodyProblem, NeumannEdge, ProblemKind, ProblemSettings, UP};
use crate::fem::mesh::Mesh;

/// Build body `alpha` of the chosen benchmark.
pub fn body(settings: &ProblemSettings, alpha: usize) -> BodyProblem {
    let (nx, ny) = settings.body_grid(alpha);
    let y0 = if alpha == 1 { 0.0 } else { 1.0 };
    let mesh = Mesh::structured([0.0, y0], [1.0, 1.0], nx, ny);
    let material = settings.materials[alpha - 1];
    let mut dirichlet = Vec::new();
    let mut neumann = Vec::new();
    match (settings.kind, alpha) {
        (ProblemKind::Mesh, _) => unreachable!("problem::build builds meshed problems"),
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
                let t = [f(mesh.points.get(a)[1]), f(mesh.points.get(b)[1])];
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
    let gap = vec![0.0; contact_nodes.len()];
    // Both sides of Γc have the same nodes' x: body 2's segments are body 1's.
    let points: Vec<[f64; 2]> = contact_nodes.iter().map(|&n| mesh.points.get(n)).collect();
    let contact_lengths = segment_lengths(&points);
    let contact_normals = vec![UP; contact_nodes.len()];
    BodyProblem {
        alpha,
        mesh: super::BodyMesh::Whole(mesh),
        outline: Default::default(),
        fingerprint: Default::default(),
        material,
        dirichlet,
        neumann,
        contact_candidates: contact_nodes.clone(),
        candidate_normals: vec![if alpha == 1 { UP } else { [0.0, -1.0] }; contact_nodes.len()],
        contact_nodes,
        trace: super::GcTrace::Nodes,
        gap,
        contact_normals,
        contact_lengths,
        support: super::Support::Conditions,
    }
}
