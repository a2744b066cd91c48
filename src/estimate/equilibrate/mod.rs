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
//! - `Recovery::Eet`: the classical EET choice above.
//! - `Recovery::Star`: the star free parameters minimise the complementary energy (method.md
//!   §3.2: "or better, by minimising the resulting complementary energy"); a sparse SPD
//!   problem over 2 parameters per interior vertex (and per Dirichlet boundary star), solved
//!   by Jacobi-preconditioned conjugate gradients.
//! - `Recovery::PatchClassic`: drops the prolongation condition (which admissibility does not need:
//!   only the self-equilibrium of every element does) and relaxes the edge tractions by
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
//! per vertex-patch pattern (up to 262144 each, ≈ 680 MB and ≈ 2 GB at most): a structured
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
//! - `topology`: mesh edges, vertex stars, vertex colouring and sweep keys, owned elements.
//! - `eet`: EET edge tractions (boundary codes, moments ↔ tractions) and the star operators.
//! - `johnson_mercier`: the JM element (local frame, local problem, shape cache, JM fields).
//! - `energy`: complementary energy and the `Recovery::Star` star choice (Jacobi-PCG).
//! - `relaxation`: `Recovery::PatchClassic`, block Gauss–Seidel over vertex patches, and the patch
//!   operators (kernel basis, inverse Hessian, the step maps of `Recovery::Patch`).
//! - `plan`: `Recovery::Patch`, the same steps on the edge tractions with a per-mesh plan, and
//!   its warm start.
//! - `restricted`: the construction, [`equilibrate_restricted`] (whole mesh or sub-mesh).
//! - `stress`: evaluation and equilibrium check of an [`EquilibratedStress`].
//! - `testutil` (tests only): shared test problems and the FE reference solve.

#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

mod eet;
mod energy;
mod johnson_mercier;
mod plan;
mod relaxation;
mod restricted;
mod stress;
#[cfg(test)]
mod testutil;
mod topology;

pub use restricted::equilibrate_restricted;
pub use stress::element_cre;
pub use topology::{sweep_key, vertex_colours};

/// The local operators of the recovery, which depend on the mesh and the material only (the
/// JM element operators per triangle shape, the patch operators per vertex-patch pattern and
/// the element Hessians), kept from one recovery to the next (the later estimates
/// reuse everything that does not depend on the iterate). One per body and rank; its
/// capacities are those of the per-call caches.
#[derive(Default)]
pub struct OperatorCache {
    pub(crate) shapes: johnson_mercier::ShapeCache,
    pub(crate) patch_map: FastMap<Vec<i64>, usize>,
    pub(crate) patch_ops: Vec<relaxation::PatchOp>,
    pub(crate) hhat: FastMap<usize, Box<[f64; NT * NT]>>,
    /// The topology of the last mesh recovered on, with the mesh's fingerprint.
    topology: Option<(u64, topology::Topology)>,
    /// The plan of `Recovery::Patch` (per mesh, boundary codes and sweep order).
    pub(crate) plan: Option<plan::Plan>,
    /// The star problems' structure (per mesh and boundary codes).
    stars: Option<eet::Stars>,
    /// The change made by the last `Recovery::Patch` recovery (its warm start).
    pub(crate) warm: Option<plan::Warm>,
    /// The caller's record of the data that recovery was made from (the estimator keeps the
    /// body's displacement there, to decide whether the next one is close enough to start
    /// warm).
    pub warm_data: Option<Vec<f64>>,
    /// The caller's decision for the next recovery: it starts warm (near the last one's
    /// data); a rank that holds none of a split body's elements makes as many exchanges
    /// between sweeps as the others by it (`cre::View`).
    pub starts_warm: bool,
    /// The material the operators were built for (they are rebuilt for another).
    material: Option<Material>,
}

impl OperatorCache {
    /// Ready for `material`: emptied if it was filled for another one.
    pub(crate) fn for_material(&mut self, material: &Material) -> &mut OperatorCache {
        if self.material != Some(*material) {
            *self = OperatorCache {
                material: Some(*material),
                ..Default::default()
            };
        }
        self
    }

    /// The next recovery starts cold (the estimator calls it when the data moved too far
    /// since the last recovery, `cre::WARM_CHANGE`).
    pub fn forget_warm_start(&mut self) {
        self.warm = None;
        self.warm_data = None;
    }

    /// The warm start's 12 traction values of each sub-mesh element in `elements`, each in
    /// the element's own orientation (so the same numbers on every sub-mesh holding the
    /// element), or none if no warm start is held (for the halo exchange of
    /// `overlap::Halo`).
    pub fn warm_values(&mut self, elements: &[usize]) -> Option<Vec<[f64; NT]>> {
        let (plan, warm) = (self.plan.as_ref()?, self.warm.as_mut()?);
        let (_, topo) = self.topology.as_ref()?;
        let (fp, delta) = warm.parts_mut();
        (fp == plan.fingerprint()).then(|| {
            elements
                .iter()
                .map(|&e| plan.element_values(topo, delta, e))
                .collect()
        })
    }

    /// Overwrite the warm start on the sub-mesh elements `elements` with `values`
    /// ([`OperatorCache::warm_values`]); false (and nothing written) if none is held.
    pub fn set_warm_values(&mut self, elements: &[usize], values: &[[f64; NT]]) -> bool {
        let (Some(plan), Some(warm), Some((_, topo))) = (
            self.plan.as_ref(),
            self.warm.as_mut(),
            self.topology.as_ref(),
        ) else {
            return false;
        };
        let (fp, delta) = warm.parts_mut();
        if fp != plan.fingerprint() {
            return false;
        }
        for (&e, v) in elements.iter().zip(values) {
            plan.set_element_values(topo, delta, e, v);
        }
        true
    }

    /// Number of (shape, patch) operators held.
    pub fn len(&self) -> (usize, usize) {
        (self.shapes.ops.len(), self.patch_ops.len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == (0, 0)
    }
}

use crate::fem::mesh::Mesh;
use crate::fem::Material;

/// The maps of the local operators, keyed by integer patterns: hashed by [`FastHasher`].
pub(crate) type FastMap<K, V> = std::collections::HashMap<K, V, FastHash>;
pub(crate) type FastHash = std::hash::BuildHasherDefault<FastHasher>;

/// A multiply–rotate hasher for the integer keys of the operator maps (the keys are not
/// adversarial; SipHash cost more than the lookups it served).
#[derive(Default)]
pub(crate) struct FastHasher(u64);

impl std::hash::Hasher for FastHasher {
    fn finish(&self) -> u64 {
        // A final avalanche, so that the low bits the table uses depend on every input bit.
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut b = [0u8; 8];
            b[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(b));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn write_i64(&mut self, x: i64) {
        self.write_u64(x as u64);
    }
    fn write_i16(&mut self, x: i16) {
        self.write_u64(x as u16 as u64);
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
}

const NONE: usize = usize::MAX;
/// Number of JM coefficients per element: 3 sub-triangles × 3 components × (1, ξ, η).
pub(crate) const NC: usize = 27;
/// Number of edge-traction values per element: 3 edges × 2 end points × 2 components.
pub(crate) const NT: usize = 12;
/// Shape-cache capacity; beyond it the local operator is recomputed per element.
const MAX_SHAPES: usize = 1 << 18;
/// Quantum of the shape key (normalised coordinates), 2⁻⁴⁴ ≈ 5.7e-14.
const SHAPE_QUANTUM: f64 = 1.0 / 17_592_186_044_416.0;

/// Capacity of the patch-operator cache; beyond it patch operators are recomputed.
const MAX_PATCHES: usize = 1 << 18;

#[cfg(test)]
thread_local! {
    /// Test override of the cache capacities (shapes, patches), to exercise the uncached paths.
    static CAPACITY: std::cell::Cell<(usize, usize)> = const { std::cell::Cell::new((MAX_SHAPES, MAX_PATCHES)) };
}

fn shape_capacity() -> usize {
    #[cfg(test)]
    return CAPACITY.with(|c| c.get().0);
    #[cfg(not(test))]
    MAX_SHAPES
}

fn patch_capacity() -> usize {
    #[cfg(test)]
    return CAPACITY.with(|c| c.get().1);
    #[cfg(not(test))]
    MAX_PATCHES
}

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

/// The recovery of σ̂, named after its `-nndd_recovery` value: how the free parameters of the
/// star problems (one per interior vertex and direction, and one per boundary star with two
/// free edge components) are fixed, and how the estimate is lowered after them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Recovery {
    /// `patch`: the same steps as `PatchClassic`, carried out on the edge tractions with every
    /// mesh-only datum planned once and kept in the [`OperatorCache`] (`plan.rs`; the same
    /// iterates to round-off, several times faster): `sweeps` sweeps from the
    /// averaged-traction field. With `warm_sweeps` > 0, a recovery that follows another one
    /// with the same cache (on the same mesh, with the same boundary codes) starts instead
    /// from the averaged-traction field plus the change that recovery's sweeps made, which
    /// is admissible (the change lies in the data-independent patch kernel) and, for nearby
    /// data, nearly relaxed already; it then makes `warm_sweeps` sweeps. A recovery starts
    /// cold after [`OperatorCache::forget_warm_start`] (the estimator calls it when the data
    /// changed too much, `cre::WARM_CHANGE`). On a sub-mesh the caller refreshes the change
    /// outside the own elements from their owners first (`overlap::Halo`).
    Patch { sweeps: usize, warm_sweeps: usize },
    /// `patch-classic`: start from `Eet` and relax the EET prolongation condition: `sweeps`
    /// multicolour block Gauss–Seidel sweeps over the vertex patches, each step minimising the
    /// complementary energy over all changes of the linear tractions on the edges through
    /// the vertex that keep every element of the patch self-equilibrated (the patch kernel,
    /// which contains the star parameters). The vertices are visited by increasing sweep key
    /// ([`sweep_key`]: colour of [`vertex_colours`], then global index) in the even sweeps
    /// (0, 2, …) and by decreasing key in the odd ones (symmetric Gauss–Seidel: colours
    /// 0, 1, …, C−1, then C−1, …, 0). Every iterate is exactly admissible; the limit is the
    /// minimum of the complementary energy over the whole admissible JM space (the JM mixed
    /// solution).
    PatchClassic { sweeps: usize },
    /// `star`: start from `Eet`, then move every star parameter to minimise the
    /// complementary energy Σ_E ‖σ̂ − σ̃_h‖²_{K⁻¹,E} (sparse SPD system, Jacobi-preconditioned
    /// conjugate gradients, stopped at `tolerance` × the initial gradient or after
    /// `max_iterations`).
    Star {
        max_iterations: usize,
        tolerance: f64,
    },
    /// `eet`: closest (least squares in the edge moments) to the averaged FE traction
    /// ½(σ̃_E + σ̃_E') n on interior edges and σ̃_E n on free boundary components
    /// (method.md §3.2 (a), the classical EET choice).
    Eet,
}

impl Recovery {
    /// `Star` with default stopping rules (about 20 CG iterations on the structured meshes,
    /// 8×8 to 256×256).
    pub const fn star() -> Recovery {
        Recovery::Star {
            max_iterations: 5000,
            tolerance: 1e-8,
        }
    }
}

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

/// Restriction of an equilibration to an overlapping sub-mesh (see `overlap.rs`).
///
/// The sub-mesh must contain every element sharing a vertex with an owned element (at least
/// one ring): then every sub-mesh boundary edge of an owned element is a real boundary edge,
/// and the residual checks of [`EquilibratedStress::residuals_restricted`] never see the
/// artificial boundary.
#[derive(Clone, Copy)]
pub struct Restriction<'a> {
    /// Sweep-order key of every vertex of the sub-mesh: [`sweep_key`] of its colour in the
    /// FULL mesh ([`vertex_colours`]) and its global index.
    pub vertex_key: &'a [u64],
    /// Per sub-mesh element: its result is kept (the rank's own elements). The residuals,
    /// the FE-equilibrium defect, the point reactions and the energies of the statistics are
    /// measured only there.
    pub owned: &'a [bool],
    /// Called between two sweeps of a `Recovery::Patch` recovery (not before the first): a
    /// halo exchange that gives the elements the rank does not own their owners' traction
    /// values ([`SweepValues`]), so that the overlap needs the rings of one sweep only
    /// (`overlap::Overlap::rings_exchanged`). Collective: every rank of the exchange must
    /// make as many calls.
    pub between_sweeps: Option<&'a dyn Fn(&mut SweepValues)>,
}

/// The traction values of a `Recovery::Patch` recovery between two sweeps, element by element
/// (the 12 values of a sub-mesh element in its own orientation, as [`plan`] gathers them):
/// what [`Restriction::between_sweeps`] reads and overwrites. Writing an element's values
/// moves the warm start's change δ with them (t − δ, the start, is kept).
pub struct SweepValues<'a> {
    plan: &'a plan::Plan,
    topo: &'a topology::Topology,
    trac: &'a mut [f64],
    change: &'a mut [f64],
}

impl SweepValues<'_> {
    /// The 12 traction values of sub-mesh element l.
    pub fn get(&self, l: usize) -> [f64; NT] {
        self.plan.element_values(self.topo, self.trac, l)
    }

    /// Overwrite the 12 traction values of sub-mesh element l (an edge shared with another
    /// element changes for both).
    pub fn set(&mut self, l: usize, v: &[f64; NT]) {
        if !self.change.is_empty() {
            let old = self.get(l);
            let mut d = self.plan.element_values(self.topo, self.change, l);
            for j in 0..NT {
                d[j] += v[j] - old[j];
            }
            self.plan.set_element_values(self.topo, self.change, l, &d);
        }
        self.plan.set_element_values(self.topo, self.trac, l, v);
    }
}

/// Equilibrium check of an [`EquilibratedStress`]; every entry is relative to max |σ̂| (the
/// boundary entry to max(|σ̂|, |g|); the star entries to the largest element nodal force).
#[derive(Clone, Copy, Debug, Default)]
pub struct Residuals {
    /// max |div σ̂| × element diameter, over every sub-triangle.
    pub divergence: f64,
    /// Traction jumps across the 3 internal edges of every element (at their end points).
    pub internal_jump: f64,
    /// Traction jumps across every inter-element edge (at its end points).
    pub element_jump: f64,
    /// σ̂n − g on every Known boundary component (at the end points).
    pub boundary: f64,
    /// Largest least-squares residual of a point-constraint star (a constrained dof whose
    /// star has no free edge component): the point reaction, relative.
    pub point_reaction: f64,
}

impl Residuals {
    /// The largest of the field residuals (divergence, jumps, boundary) and the point
    /// reaction.
    pub fn max(&self) -> f64 {
        self.divergence
            .max(self.internal_jump)
            .max(self.element_jump)
            .max(self.boundary)
            .max(self.point_reaction)
    }
}

/// Figures of the construction.
#[derive(Clone, Copy, Debug, Default)]
pub struct EquilibrationStats {
    /// Number of star free parameters (null-space directions of the star problems).
    pub star_parameters: usize,
    /// Distinct triangle shapes met (cached local operators).
    pub shapes: usize,
    /// Conjugate-gradient iterations of `Recovery::Star` (0 otherwise).
    pub cg_iterations: usize,
    /// Σ_E ‖σ̂ − σ̃_h‖²_{K⁻¹} with the averaged-traction choice (NaN with `Recovery::Patch`,
    /// which does not build that field).
    pub energy_averaged: f64,
    /// The same after the minimisation (= `energy_averaged` for `Recovery::Eet`).
    pub energy_final: f64,
    /// Distinct vertex-patch operators of `Recovery::PatchClassic` (0 otherwise).
    pub patch_patterns: usize,
    /// Largest residual of the star problems at unconstrained dofs, relative to the largest
    /// element nodal force: the FE equilibrium defect of the input (round-off for an
    /// FE-equilibrated ũ). A large value means the input was not FE-equilibrated and σ̂ is
    /// not admissible (which `Residuals::element_jump`/`boundary` then show too).
    pub fe_equilibrium: f64,
}

/// The equilibrated stress: per element, the JM coefficients (3 sub-triangles × (xx, yy, xy)
/// × (1, ξ, η)) in the local frame ξ = (x − barycentre) / diameter. Sub-triangle a is
/// (barycentre, p_a, p_{a+1}) of the element's vertices p.
#[derive(Clone, Debug)]
pub struct EquilibratedStress {
    coef: Vec<[f64; NC]>,
    /// Per constrained star (vertex, relative least-squares residual): the point reactions.
    reactions: Vec<(usize, f64)>,
    stats: EquilibrationStats,
    /// The equilibrium check made by the construction (on the owned elements).
    checked: Residuals,
}

/// Build σ̂ with the averaged-traction star choice (method.md §3.2 (a), (b)).
///
/// `u` is the FE-equilibrated displacement (length `mesh.num_dofs()`).
pub fn equilibrate(
    mesh: &Mesh,
    material: &Material,
    u: &[f64],
    boundary: &Boundary,
) -> Result<EquilibratedStress, EquilibrationError> {
    equilibrate_with(mesh, material, u, boundary, Recovery::Eet)
}

/// Build σ̂ with a given choice of the star free parameters (on the whole mesh).
pub fn equilibrate_with(
    mesh: &Mesh,
    material: &Material,
    u: &[f64],
    boundary: &Boundary,
    choice: Recovery,
) -> Result<EquilibratedStress, EquilibrationError> {
    equilibrate_restricted(mesh, material, u, boundary, choice, None, None, None)
}

/// Unit-test helpers are shared with `overlap.rs` (`fe_solve`, `block_rect`, `STEEL`).
#[cfg(test)]
pub(crate) mod tests {
    pub(crate) use super::testutil::{block_rect, fe_solve, STEEL};

    use super::johnson_mercier::triangle_area;
    use super::testutil::*;
    use super::*;
    use crate::fem;

    #[test]
    fn patch_test_reproduces_uniform_stress() {
        let s = [3e6, -1e7, 2e6];
        let (mesh, bd) = patch(5, s);
        let u = fe_solve(&mesh, &bd);
        for choice in CHOICES {
            let eq = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
            let r = eq.residuals(&mesh, &bd);
            println!("patch {choice:?}: {r:?}");
            assert_admissible(&r, 1e-10);
            assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
            assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
            let mut worst: f64 = 0.0;
            let mut cre = 0.0;
            let mut energy = 0.0;
            for e in 0..mesh.triangles.len() {
                let p = mesh.triangle_points(e);
                let c = [
                    (p[0][0] + p[1][0] + p[2][0]) / 3.0,
                    (p[0][1] + p[1][1] + p[2][1]) / 3.0,
                ];
                let mut probes = vec![c];
                for a in 0..3 {
                    probes.push(p[a]);
                    probes.push([0.5 * (p[a][0] + c[0]), 0.5 * (p[a][1] + c[1])]);
                }
                for x in probes {
                    let sh = eq.stress_at(&mesh, e, x);
                    for r in 0..3 {
                        worst = worst.max((sh[r] - s[r]).abs() / 1e7);
                    }
                }
                let sfe = fem::element_stress(&mesh, e, &STEEL, &u);
                cre += eq.cre_squared(&mesh, e, sfe, &STEEL);
                energy += 2.0 * STEEL.compliance_energy(&s) * triangle_area(&p);
            }
            println!(
                "patch: max |σ̂ − σ|/|σ| = {worst:.2e}, cre²/energy = {:.2e}",
                cre / energy
            );
            assert!(
                worst < 1e-10,
                "σ̂ differs from the uniform stress by {worst:e}"
            );
            assert!(cre < 1e-20 * energy, "cre² = {cre:e} vs energy {energy:e}");
        }
    }

    #[test]
    fn block_is_exactly_equilibrated() {
        let (mesh, bd) = block(6);
        let u = fe_solve(&mesh, &bd);
        for choice in CHOICES {
            let eq = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
            let r = eq.residuals(&mesh, &bd);
            println!("block 6x6 {choice:?}: {r:?}, {:?}", eq.stats());
            assert_admissible(&r, 1e-10);
            assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
            assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
            // The cre map sums to the total and is non-negative.
            let map = eq.cre_map(&mesh, &STEEL, &u);
            assert!(map.iter().all(|&v| v >= 0.0));
            let total: f64 = map.iter().sum();
            assert!((total - eq.stats().energy_final).abs() < 1e-10 * total);
        }
    }

    #[test]
    fn distorted_mesh_is_exactly_equilibrated() {
        // Every triangle a different shape (no cache sharing), boundary kept straight.
        let (mesh, bd) = distorted_block(6, 7);
        let u = fe_solve(&mesh, &bd);
        for choice in CHOICES {
            let eq = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
            let r = eq.residuals(&mesh, &bd);
            println!("distorted {choice:?}: {r:?} {:?}", eq.stats());
            assert!(eq.stats().shapes > 50);
            assert_admissible(&r, 1e-10);
            assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
            assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
        }
    }

    #[test]
    fn rollers_give_exact_uniaxial_stress() {
        let n = 4;
        let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], n, n);
        let p = 1.3e7;
        let mut constrained = vec![false; mesh.num_dofs()];
        let mut edges = Vec::new();
        let bottom = mesh.bottom_nodes();
        for &b in &bottom {
            constrained[2 * b + 1] = true;
        }
        constrained[2 * mesh.node(0, 0)] = true;
        for w in bottom.windows(2) {
            edges.push(BoundaryEdge {
                nodes: [w[0], w[1]],
                comps: [known(0.0, 0.0), EdgeComponent::Free],
            });
        }
        for w in mesh.top_nodes().windows(2) {
            edges.push(BoundaryEdge {
                nodes: [w[0], w[1]],
                comps: [known(0.0, 0.0), known(-p, -p)],
            });
        }
        let bd = Boundary { edges, constrained };
        let u = fe_solve(&mesh, &bd);
        let eq = equilibrate(&mesh, &STEEL, &u, &bd).unwrap();
        let r = eq.residuals(&mesh, &bd);
        println!("rollers: {r:?}");
        assert_admissible(&r, 1e-10);
        assert!(eq.stats().fe_equilibrium < 1e-10, "{:?}", eq.stats());
        let mut worst: f64 = 0.0;
        for e in 0..mesh.triangles.len() {
            let pts = mesh.triangle_points(e);
            for x in pts {
                for sub in 0..3 {
                    let s = eq.sub_stress_at(&mesh, e, sub, x);
                    worst = worst.max(s[0].abs().max((s[1] + p).abs()).max(s[2].abs()) / p);
                }
            }
        }
        println!("rollers: max |σ̂ − σ|/p = {worst:.2e}");
        assert!(worst < 1e-10);
    }

    /// `block(4)` with its centre node moved (so its patches are not all alike) and its FE
    /// solution.
    fn skewed_block() -> (Mesh, Boundary, Vec<f64>) {
        let (mut mesh, bd) = block(4);
        let centre = mesh.node(2, 2);
        mesh.points[centre][0] += 0.03;
        let u = fe_solve(&mesh, &bd);
        (mesh, bd, u)
    }

    #[test]
    fn uncached_paths_agree_with_cached() {
        let (mesh, bd, u) = skewed_block();
        let choice = Recovery::PatchClassic { sweeps: 2 };
        let cached = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
        CAPACITY.with(|c| c.set((3, 2)));
        let uncached = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
        CAPACITY.with(|c| c.set((MAX_SHAPES, MAX_PATCHES)));
        assert_eq!(uncached.stats().shapes, 3);
        assert_eq!(uncached.stats().patch_patterns, 2);
        assert_admissible(&uncached.residuals(&mesh, &bd), 1e-10);
        let smax = (0..mesh.triangles.len())
            .flat_map(|e| cached.coefficients(e).to_vec())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        for e in 0..mesh.triangles.len() {
            for (a, b) in cached.coefficients(e).iter().zip(uncached.coefficients(e)) {
                assert!((a - b).abs() < 1e-10 * smax);
            }
        }
    }

    #[test]
    fn kept_operators_give_the_same_stress_and_grow_no_more() {
        let (mesh, bd, u) = skewed_block();
        let v: Vec<f64> = u
            .iter()
            .enumerate()
            .map(|(i, x)| x * (1.0 + 0.1 * (i % 3) as f64))
            .collect();
        let choice = Recovery::PatchClassic { sweeps: 2 };
        let mut ops = OperatorCache::default();
        let with = |w: &[f64], ops: &mut OperatorCache| {
            equilibrate_restricted(&mesh, &STEEL, w, &bd, choice, None, Some(ops), None).unwrap()
        };
        let first = with(&u, &mut ops);
        let filled = ops.len();
        assert!(filled.0 > 0 && filled.1 > 0, "{filled:?}");
        // Another field on the same mesh: the same operators, reused, and the same σ̂ as a
        // recovery with fresh ones, bit for bit.
        let second = with(&v, &mut ops);
        assert_eq!(ops.len(), filled);
        let fresh = equilibrate_with(&mesh, &STEEL, &v, &bd, choice).unwrap();
        let fresh_u = equilibrate_with(&mesh, &STEEL, &u, &bd, choice).unwrap();
        for e in 0..mesh.triangles.len() {
            assert_eq!(second.coefficients(e), fresh.coefficients(e));
            assert_eq!(first.coefficients(e), fresh_u.coefficients(e));
        }
        // Another material: the operators are rebuilt for it.
        let soft = Material {
            young: STEEL.young / 3.0,
            poisson: 0.4,
        };
        let third =
            equilibrate_restricted(&mesh, &soft, &v, &bd, choice, None, Some(&mut ops), None)
                .unwrap();
        let fresh_soft = equilibrate_with(&mesh, &soft, &v, &bd, choice).unwrap();
        for e in 0..mesh.triangles.len() {
            assert_eq!(third.coefficients(e), fresh_soft.coefficients(e));
        }
    }
}
