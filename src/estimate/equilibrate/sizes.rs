//! The recovery's sizes and limits: the counts of the JM element ([`NC`] coefficients,
//! [`NT`] edge-traction values), the no-index mark, the capacities of the operator caches and
//! the quantum of the shape keys.

/// No index (an edge without a minus element, a vertex without an operator, …).
pub(super) const NONE: usize = usize::MAX;
/// Number of JM coefficients per element: 3 sub-triangles × 3 components × (1, ξ, η).
pub(crate) const NC: usize = 27;
/// Number of edge-traction values per element: 3 edges × 2 end points × 2 components.
pub(crate) const NT: usize = 12;
/// Shape-cache capacity; beyond it the local operator is recomputed per element.
pub(super) const MAX_SHAPES: usize = 1 << 18;
/// Quantum of the shape key (normalised coordinates), 2⁻⁴⁴ ≈ 5.7e-14.
pub(super) const SHAPE_QUANTUM: f64 = 1.0 / 17_592_186_044_416.0;

/// Capacity of the patch-operator cache; beyond it patch operators are recomputed.
pub(super) const MAX_PATCHES: usize = 1 << 18;

#[cfg(test)]
thread_local! {
    /// Test override of the cache capacities (shapes, patches), to exercise the uncached paths.
    pub(super) static CAPACITY: std::cell::Cell<(usize, usize)> = const { std::cell::Cell::new((MAX_SHAPES, MAX_PATCHES)) };
}

pub(super) fn shape_capacity() -> usize {
    #[cfg(test)]
    return CAPACITY.with(|c| c.get().0);
    #[cfg(not(test))]
    MAX_SHAPES
}

pub(super) fn patch_capacity() -> usize {
    #[cfg(test)]
    return CAPACITY.with(|c| c.get().1);
    #[cfg(not(test))]
    MAX_PATCHES
}
