//! The recoveries of `-nndd_recovery` and what each one does after the star problems: the
//! questions [`equilibrate_restricted`](super::equilibrate_restricted), the overlap
//! (`overlap.rs`) and the estimator ask of a recovery, answered here variant by variant.
//!
//! | `-nndd_recovery` | star parameters | JM fields before the final pass | patch sweeps | local |
//! |---|---|---|---|---|
//! | `patch` ([`Recovery::Patch`]) | averaged traction | none | planned on the edge tractions, warm start | yes |
//! | `patch-classic` ([`Recovery::PatchClassic`]) | averaged traction | averaged-traction field, updated | on the JM fields | yes |
//! | `star` ([`Recovery::Star`]) | minimum energy (CG) | averaged-traction field, updated | none | no (global solve) |
//! | `eet` ([`Recovery::Eet`]) | averaged traction | none (the final field is the averaged one) | none | yes |

/// The recovery of σ̂, named after its `-nndd_recovery` value: how the free parameters of the
/// star problems (one per interior vertex and direction, and one per boundary star with two
/// free edge components) are fixed, and how the estimate is lowered after them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Recovery {
    /// `patch`: the same steps as `PatchClassic`, carried out on the edge tractions with every
    /// mesh-only datum planned once and kept in the [`OperatorCache`](super::OperatorCache) (`plan.rs`; the same
    /// iterates to round-off, several times faster): `sweeps` sweeps from the
    /// averaged-traction field. With `warm_sweeps` > 0, a recovery that follows another one
    /// with the same cache (on the same mesh, with the same boundary codes) starts instead
    /// from the averaged-traction field plus the change that recovery's sweeps made, which
    /// is admissible (the change lies in the data-independent patch kernel) and, for nearby
    /// data, nearly relaxed already; it then makes `warm_sweeps` sweeps. A recovery starts
    /// cold after [`OperatorCache::forget_warm_start`](super::OperatorCache::forget_warm_start) (the estimator calls it when the data
    /// changed too much, `cre::WARM_CHANGE`). On a sub-mesh the caller refreshes the change
    /// outside the own elements from their owners first (`overlap::Halo`).
    Patch { sweeps: usize, warm_sweeps: usize },
    /// `patch-classic`: start from `Eet` and relax the EET prolongation condition: `sweeps`
    /// multicolour block Gauss–Seidel sweeps over the vertex patches, each step minimising the
    /// complementary energy over all changes of the linear tractions on the edges through
    /// the vertex that keep every element of the patch self-equilibrated (the patch kernel,
    /// which contains the star parameters). The vertices are visited by increasing sweep key
    /// ([`sweep_key`](super::sweep_key): colour of [`vertex_colours`](super::vertex_colours), then global index) in the even sweeps
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
