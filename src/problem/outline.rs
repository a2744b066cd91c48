//! A body's outline: its boundary edges, and its boundary nodes with their points, in the
//! mesh's numbering. O(√N) of a body of N dofs, it is what the ranks outside the body's group
//! read of the body (the final check's rays and Γc's ends, the output's Γc grid, the
//! summary's contact zone), so that they need not hold its mesh
//! ([`super::BodyProblem::released`]).

use crate::fem::mesh::Mesh;
use crate::fem::wire::{Reader, Writer};

/// The boundary of a mesh, by its own node numbers.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outline {
    /// The boundary edges, each as its triangle runs it ([`Mesh::boundary_edges`]: the body
    /// on its left).
    pub edges: Vec<[usize; 2]>,
    /// The boundary nodes, sorted.
    nodes: Vec<usize>,
    /// `points[i]` is node `nodes[i]`'s.
    points: Vec<[f64; 2]>,
}

impl Outline {
    /// The outline of `mesh` (one pass over its sides).
    pub fn of(mesh: &Mesh) -> Outline {
        let edges = mesh.boundary_edges();
        let mut nodes: Vec<usize> = edges.iter().flatten().copied().collect();
        nodes.sort_unstable();
        nodes.dedup();
        let points = nodes.iter().map(|&n| mesh.points.get(n)).collect();
        Outline {
            edges,
            nodes,
            points,
        }
    }

    /// The boundary nodes, sorted.
    pub fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// The outline as bytes ([`Writer`]).
    pub fn write(&self, w: &mut Writer) {
        w.list(&self.edges, |w, e| e.iter().for_each(|&n| w.int(n)));
        w.ints(&self.nodes);
        w.points(&self.points);
    }

    /// What [`Outline::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Outline> {
        let edges = r.list(16, |r| Some([r.int()?, r.int()?]))?;
        let (nodes, points) = (r.ints()?, r.points()?);
        let sound = nodes.windows(2).all(|w| w[0] < w[1]) && nodes.len() == points.len();
        sound.then_some(Outline {
            edges,
            nodes,
            points,
        })
    }

    /// The position of boundary node `node` in [`Outline::nodes`]; `None` off the boundary.
    pub fn index(&self, node: usize) -> Option<usize> {
        self.nodes.binary_search(&node).ok()
    }

    /// The point of boundary node `node`.
    ///
    /// # Panics
    /// Where `node` is not on the boundary: the outline's readers ask for the points of
    /// boundary nodes alone (Γc's nodes and candidates, and the ends of boundary edges).
    pub fn point(&self, node: usize) -> [f64; 2] {
        let i = self.index(node);
        self.points[i.unwrap_or_else(|| panic!("node {node} is not on the body's boundary"))]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_outline_is_its_perimeter() {
        // A 3 × 2 grid of [0, 3] × [0, 2]: 12 nodes, 10 of them on the boundary, 10 edges.
        let mesh = Mesh::structured([0.0, 0.0], [3.0, 2.0], 3, 2);
        let o = Outline::of(&mesh);
        assert_eq!(o.edges.len(), 10);
        let inner: Vec<usize> = (0..12).filter(|&n| o.index(n).is_none()).collect();
        assert_eq!(inner, vec![mesh.node(1, 1), mesh.node(2, 1)]);
        for n in o.nodes() {
            assert_eq!(o.point(*n), mesh.points.get(*n));
        }
        // Each edge is a unit side on the perimeter, with the body on its left.
        for &[a, b] in &o.edges {
            let (p, q) = (mesh.points.get(a), mesh.points.get(b));
            assert_eq!((q[0] - p[0]).hypot(q[1] - p[1]), 1.0);
            let mid = [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0];
            let left = [mid[0] - (q[1] - p[1]) * 0.25, mid[1] + (q[0] - p[0]) * 0.25];
            assert!((0.0..=3.0).contains(&left[0]) && (0.0..=2.0).contains(&left[1]));
        }
    }

    #[test]
    #[should_panic(expected = "not on the body's boundary")]
    fn an_inner_node_has_no_outline_point() {
        let mesh = Mesh::structured([0.0, 0.0], [2.0, 2.0], 2, 2);
        Outline::of(&mesh).point(mesh.node(1, 1));
    }
}
