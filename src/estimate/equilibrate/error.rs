//! The failures of the construction.

/// Failures of the construction (bad input; the construction itself cannot fail on a valid
/// mesh).
#[derive(Debug, thiserror::Error)]
pub enum EquilibrationError {
    #[error("displacement has {found} entries, the mesh has {expected} dofs")]
    DisplacementLength { expected: usize, found: usize },
    #[error("`constrained` has {found} entries, the mesh has {expected} dofs")]
    ConstrainedLength { expected: usize, found: usize },
    #[error("triangle {element} is degenerate, clockwise or refers to a missing node")]
    BadTriangle { element: usize },
    #[error(
        "a mesh of {elements} triangles is past the recovery's 32-bit indices (2^30 triangles)"
    )]
    TooLarge { elements: usize },
    #[error("edge ({a}, {b}) belongs to more than two triangles")]
    NonManifoldEdge { a: usize, b: usize },
    #[error("boundary edge {index} ({a}, {b}) is not a boundary edge of the mesh")]
    NotABoundaryEdge { index: usize, a: usize, b: usize },
    #[error("boundary edge ({a}, {b}) is listed twice")]
    DuplicateBoundaryEdge { a: usize, b: usize },
    #[error("the Johnson-Mercier local problem of triangle {element} is singular")]
    SingularLocalProblem { element: usize },
    #[error("the minimum-energy recovery is a global solve: it is not exact on a sub-mesh")]
    RestrictedMinimumEnergy,
    #[error("restriction: `{what}` has {found} entries, the sub-mesh has {expected}")]
    RestrictionLength {
        what: &'static str,
        expected: usize,
        found: usize,
    },
}
