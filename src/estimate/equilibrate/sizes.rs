//! The recovery's sizes and limits: the counts of the JM element ([`NC`] coefficients,
//! [`NT`] edge-traction values), the no-index mark, the capacities of the operator caches and
//! the quantum of the shape keys.

use super::recovery::Recovery;

/// No index (an edge without a minus element, a vertex without an operator, …).
pub(super) const NONE: usize = usize::MAX;
/// Number of JM coefficients per element: 3 sub-triangles × 3 components × (1, ξ, η).
pub(crate) const NC: usize = 27;
/// Number of edge-traction values per element: 3 edges × 2 end points × 2 components.
pub(crate) const NT: usize = 12;
/// Shape-cache capacity of a recovery that reads a triangle's operator in every patch step
/// (`patch-classic`); beyond it the local operator is recomputed at each use.
pub(super) const MAX_SHAPES: usize = 1 << 18;
/// Quantum of the shape key (normalised coordinates), 2⁻⁴⁴ ≈ 5.7e-14.
pub(super) const SHAPE_QUANTUM: f64 = 1.0 / 17_592_186_044_416.0;

/// Capacity of the patch-operator cache's patterns of such a recovery; beyond it patch
/// operators are recomputed at each use (at 2¹⁶, the Hertz example at level 5 took 386 s
/// instead of 78 s).
pub(super) const MAX_PATCHES: usize = 1 << 18;

/// Both capacities of the planned recovery (`patch`), which reads a triangle's operator once
/// per recovery and builds every patch operator once for its plan, keeping those past the
/// capacity by their index alone. The caches pay where shapes and patterns repeat (a
/// structured mesh has a few); on an unstructured mesh each triangle is a shape of its own
/// (2.6 KB of operator) and each vertex patch a pattern (a key of about 1 KB), found again by
/// no other: with room for 2¹⁸, the Hertz example at level 5 (203 454 triangles) held 1 GB
/// more in its recovery on one rank, and took no less time.
pub(super) const MAX_PLANNED: usize = 1 << 14;

#[cfg(test)]
thread_local! {
    /// Test override of the cache capacities (shapes, patches), to exercise the uncached paths.
    pub(super) static CAPACITY: std::cell::Cell<(usize, usize)> = const { std::cell::Cell::new((MAX_SHAPES, MAX_PATCHES)) };
}

/// The (shape, patch-pattern) capacities of the caches for `recovery`.
pub(super) fn capacities(recovery: Recovery) -> (usize, usize) {
    let (shapes, patches) = match recovery.planned_sweeps() {
        Some(_) => (MAX_PLANNED, MAX_PLANNED),
        None => (MAX_SHAPES, MAX_PATCHES),
    };
    #[cfg(test)]
    let (shapes, patches) = CAPACITY.with(|c| (shapes.min(c.get().0), patches.min(c.get().1)));
    (shapes, patches)
}
