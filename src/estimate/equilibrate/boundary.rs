//! The recovery's boundary data: per boundary edge, prescribed linear tractions or free
//! components (under Dirichlet conditions), and the constrained dofs.

/// Traction data of one boundary edge, per component: prescribed linear traction (values at
/// the edge's two end nodes, in the order of `nodes`) or free (component under Dirichlet).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EdgeComponent {
    Known([f64; 2]),
    Free,
}

/// One boundary edge of the mesh and its traction data (x and y components).
#[derive(Clone, Debug)]
pub struct BoundaryEdge {
    pub nodes: [usize; 2],
    pub comps: [EdgeComponent; 2],
}

/// Boundary data of one body. Boundary edges not listed are traction free (Known([0, 0]) in
/// both components).
#[derive(Clone, Debug, Default)]
pub struct Boundary {
    pub edges: Vec<BoundaryEdge>,
    /// Per dof (2 node + k): constrained by a Dirichlet condition.
    pub constrained: Vec<bool>,
}
