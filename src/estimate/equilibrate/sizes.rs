//! The recovery's sizes and limits: the counts of the JM element ([`NC`] coefficients,
//! [`NT`] edge-traction values), the no-index mark, the capacities of the operator caches and
//! the quantum of the shape keys.

/// No index (an edge without a minus element, a vertex without an operator, …).
pub(super) const NONE: usize = usize::MAX;
/// Number of JM coefficients per element: 3 sub-triangles × 3 components × (1, ξ, η).
pub(crate) const NC: usize = 27;
/// Number of edge-traction values per element: 3 edges × 2 end points × 2 components.
pub(crate) const NT: usize = 12;
/// Shape-cache capacity; beyond it the local operator is recomputed per element. The caches
/// pay where shapes and patch patterns repeat (a structured mesh has a few); on an
/// unstructured mesh each triangle is a shape of its own (2.6 KB of operator each) and each
/// vertex patch a pattern (a key of about 1 KB besides its operator), found again by no other:
/// with room for 2¹⁸, the Hertz example at level 5 (203 454 triangles) held 1 GB more per rank
/// in its recovery, and took no less time.
pub(super) const MAX_SHAPES: usize = 1 << 14;
/// Quantum of the shape key (normalised coordinates), 2⁻⁴⁴ ≈ 5.7e-14.
pub(super) const SHAPE_QUANTUM: f64 = 1.0 / 17_592_186_044_416.0;

/// Capacity of the patch-operator cache's patterns ([`MAX_SHAPES`]); beyond it a patch
/// operator is recomputed, or kept by its index alone where a plan reads it in every sweep.
pub(super) const MAX_PATCHES: usize = 1 << 14;

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
