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
/// Quantum of the shape key (normalised coordinates), 2⁻⁴⁰ ≈ 9.1e-13: above the rounding a
/// mesher leaves in its points (about 2e-16 · |x|, 1e-13 of a patch 2e-3 wide): at 2⁻⁴⁴
/// the patterns of `paper` drawn in Gmsh at n = 1024 (`examples/paper/paper.geo`, transfinite)
/// missed on body 1, whose recovery on 2 ranks then built 574 990 patch operators, 4.3 GB, and
/// peaked at 5691 MiB against 3546 with 2⁻⁴⁰ (estimate 38.8 s against 16.0, η^glo the same to
/// 1e-12); an operator shared by two patterns that differ by one quantum is off by about as
/// much, far below the 1e-10 of the equilibrium checks.
pub(super) const SHAPE_QUANTUM: f64 = 1.0 / 1_099_511_627_776.0;

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
