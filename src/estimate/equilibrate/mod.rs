//! Strictly (exactly) equilibrated stress fields from an FE-equilibrated P1 displacement:
//! method.md §3.2, items (a) and (b); paper: Gallimard, Choi & Sassi (2013), §4.2 (the
//! "third step", which the paper delegates to a recovery we cannot read); the edge tractions
//! are those of Ladevèze & Leguillon (1983) (EET, "element equilibration technique").
//!
//! Input: a P1 field ũ that is equilibrated *in the FE sense* with linear boundary tractions g
//! and no body force: for every unconstrained dof (i, k),
//! Σ_E ∫_E K ε(ũ) : ε(φ_i e_k) = Σ_{Γ ∋ i} ∫_Γ g · φ_i e_k.
//! Output: σ̂, exactly statically admissible (to round-off):
//! - in every triangle the Johnson–Mercier field: the triangle is split at its barycentre
//!   into three sub-triangles, σ̂ is symmetric and linear on each, divergence free in each,
//!   with continuous normal traction across the three internal edges;
//! - σ̂ n continuous across every inter-element edge;
//! - σ̂ n = g on every boundary edge component that is prescribed (Neumann data; unlisted
//!   boundary edges are traction free); components under Dirichlet conditions are free.
//!
//! The construction (method.md §3.2):
//! (a) EET edge tractions F̂, linear on every edge, from the prolongation condition
//!     ∫_∂E F̂_E · φ_i e_k = ∫_E σ̃_h : ε(φ_i e_k) for every element E, vertex i, direction k.
//!     Unknowns are the edge moments b_Γ^{(i,k)} = ∫_Γ F̂_Γ · e_k φ_i, solved star by star
//!     (vertex i, direction k) as the solution of the star system A b = Q that is closest in
//!     least squares to a reference (the averaged FE traction, see [`Recovery`]):
//!     b = b̄ + A⁺ (Q − A b̄). Interior stars are rank deficient by one and consistent (their
//!     equations sum to the FE equilibrium at (i, k)); a constrained dof without any free edge
//!     component in its star (a point constraint) is solved in least squares and its residual
//!     (the point reaction) is reported. The linear traction on Γ = [i, j] follows from its two
//!     moments through the edge mass matrix (|Γ|/6) [[2, 1], [1, 2]].
//! (b) In each triangle, the unique divergence-free JM field whose traction is F̂_E on the
//!     three edges: 27 unknowns (3 sub-triangles × 3 stress components × (a + b ξ + c η) in a
//!     local frame ξ = (x − barycentre)/diameter), 30 equations (divergence 6, internal
//!     traction continuity 12, external tractions 12) of rank 27, solved in least squares by
//!     Householder QR. The map from the 12 edge-traction values to the 27 coefficients only
//!     depends on the shape of the triangle (not its position or size), so it is cached per
//!     shape (a structured mesh has two). The cache key is the normalised shape rounded to
//!     2⁻⁴⁴, so congruent triangles whose coordinates differ by round-off share an operator;
//!     the resulting equilibrium defects stay at round-off (5e-14 on a 256 × 256 mesh), and
//!     [`EquilibratedStress::residuals`] measures them on the actual geometry.
//!
//! Lowering the estimate ([`Recovery`]; every choice gives an exactly admissible field, the
//! choices only differ in the complementary energy Σ_E ‖σ̂ − σ̃_h‖²_{K⁻¹,E}, i.e. in η):
//! - `Recovery::Eet` (`eet`): the classical EET choice above.
//! - `Recovery::Star` (`star`): the star free parameters minimise the complementary energy (method.md
//!   §3.2: "or better, by minimising the resulting complementary energy"); a sparse SPD
//!   problem over 2 parameters per interior vertex (and per Dirichlet boundary star), solved
//!   by Jacobi-preconditioned conjugate gradients.
//! - `Recovery::PatchClassic` (`patch-classic`): drops the prolongation condition (which
//!   admissibility does not need: only the self-equilibrium of every element does) and relaxes the edge tractions by
//!   multicolour symmetric block Gauss–Seidel over vertex patches, each step an exact
//!   minimisation of the complementary energy over the admissible changes of the tractions on
//!   the edges through the vertex. The patch spaces span the whole admissible JM space (Airy
//!   functions of the Hsieh–Clough–Tocher space are vertex- and edge-local), so the sweeps
//!   converge to the global minimum (the JM mixed solution). Measured effectivities (tests):
//!   averaged ≈ 2.8–3.9, star minimum ≈ 2.1–2.75, 3 patch sweeps ≈ 1.01–1.16.
//!
//! Locality and sub-meshes ([`Restriction`], `overlap.rs`): the star problems and the
//! averaged-traction field of an element only depend on the elements around its vertices,
//! and every patch step only on the elements around its vertex; the vertices are coloured
//! ([`vertex_colours`]) so that the steps of one colour are independent, and the sweeps run
//! colour by colour. The result on an element therefore depends on a bounded neighbourhood
//! (`overlap::Overlap::rings_for`), and [`equilibrate_restricted`] on an overlapping sub-mesh
//! reproduces the full-mesh field on the owned elements (to round-off). `Recovery::Star` (a
//! global conjugate-gradient solve) has no such locality and is refused on a sub-mesh.
//!
//! Costs (2-core machine, release, 256 × 256 mesh, 131k triangles): averaged 0.2 s, minimum
//! energy 0.7 s, 3 patch sweeps 1.2 s. The local operators are cached per triangle shape and
//! per vertex-patch pattern (up to 262144 each, ≈ 680 MB and ≈ 2 GB at most; 16384 for the
//! planned recovery below, which keeps a patch operator past them by its index alone and
//! reads a triangle's once per recovery, `sizes::MAX_PLANNED`): a structured
//! mesh has a handful of each, an unstructured one about one per element and per vertex,
//! so its first estimate builds them all (the Hertz level-2 mesh, 4024 dofs: 5 s on 2 ranks)
//! and beyond the capacities they are rebuilt at every use (at 65536, Hertz level 5's estimate
//! took 386 s instead of 78 s). An [`OperatorCache`] keeps them from one recovery to the next
//! (the estimator holds one per body: 57.5 s).
//!
//! `Recovery::Patch` (the default of `-nndd_recovery patch`) makes the same sweeps
//! on the edge tractions with a per-mesh plan (`plan.rs`): one sweep of the 256 × 256 mesh
//! takes 0.05 s instead of about 0.5 s, the patch kernels come from a pivoted QR instead of a
//! Jacobi eigen-decomposition, the plan, the topology and the operators are built once per
//! run, and every recovery starts from the change the previous one made when its data is
//! close (the η^FE recovery after the η^glo one, and each estimate's after the previous
//! estimate's late in the NNDD: one sweep then lowers the energy below six cold ones, and
//! the sweeps accumulate over the estimates). The final pass builds each element's field
//! from its edge tractions and hands it to the caller (the estimator stores none: 216 bytes
//! per element less), with the energy and the equilibrium check. `Recovery::PatchClassic`
//! (`-nndd_recovery patch-classic`) is the recovery it replaced, kept to compare.
//!
//! Files, one concept each:
//! - `recovery`: the [`Recovery`] of `-nndd_recovery` and what each one does.
//! - `boundary`: the boundary data ([`Boundary`]); `error`: [`EquilibrationError`].
//! - `restriction`: a recovery on an overlapping sub-mesh ([`Restriction`]).
//! - `cache`: the local operators kept from one recovery to the next ([`OperatorCache`]).
//! - `sizes`: the JM element's counts, the caches' capacities; `fast_map`: the operator maps.
//! - `topology`: mesh edges, vertex stars, vertex colouring and sweep keys, owned elements.
//! - `eet`: EET edge tractions (boundary codes, moments ↔ tractions), the star operators and
//!   one star's system.
//! - `johnson_mercier`: the JM element (local problem, shape cache, JM fields); its triangle
//!   geometry is `fem::geometry`'s.
//! - `energy`: complementary energy and the `Recovery::Star` star choice (Jacobi-PCG).
//! - `relaxation`: `Recovery::PatchClassic`, block Gauss–Seidel over vertex patches, and the
//!   patch operators (kernel basis, inverse Hessian, the step maps of `Recovery::Patch`).
//! - `plan`: `Recovery::Patch`, the same steps on the edge tractions with a per-mesh plan, its
//!   warm start and the values exchanged between sweeps ([`SweepValues`]).
//! - `restricted`: the construction, [`equilibrate_restricted`] (whole mesh or sub-mesh), phase
//!   by phase.
//! - `stress`: the result, [`EquilibratedStress`], its evaluation and equilibrium check
//!   ([`Residuals`]).
//! - `testutil`, `tests` (tests only): shared test problems, the FE reference solve, the
//!   construction's tests.

#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

mod boundary;
mod cache;
mod eet;
mod energy;
mod error;
mod fast_map;
mod johnson_mercier;
mod plan;
mod recovery;
mod relaxation;
mod restricted;
mod restriction;
mod sizes;
mod stress;
#[cfg(test)]
pub(crate) mod tests;
#[cfg(test)]
mod testutil;
mod topology;

pub use boundary::{Boundary, BoundaryEdge, EdgeComponent};
pub use cache::OperatorCache;
pub use error::EquilibrationError;
pub use plan::SweepValues;
pub use recovery::Recovery;
pub use restricted::{equilibrate, equilibrate_restricted, equilibrate_with, FieldVisitor};
pub use restriction::Restriction;
pub(crate) use sizes::{NC, NT};
pub use stress::{
    element_cre, element_cre_varying, EquilibratedStress, EquilibrationStats, Residuals,
};
pub use topology::{sweep_key, vertex_colours, Stars};
