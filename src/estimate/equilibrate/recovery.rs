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
    /// changed too much, `settings::WARM_CHANGE`). On a sub-mesh the caller refreshes the change
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

    /// σ̂ on an element depends on a bounded neighbourhood of it, so a recovery on an
    /// overlapping sub-mesh is exact on the own elements: all but `Star`, a global
    /// conjugate-gradient solve (refused on a sub-mesh, and on a body split over ranks).
    pub fn is_local(self) -> bool {
        !matches!(self, Recovery::Star { .. })
    }

    /// The conjugate gradients' `(max_iterations, tolerance)` of `Star`, whose star
    /// parameters minimise the complementary energy (the edge moments are then moved along
    /// the star null spaces, so they are kept after the first edge tractions).
    pub(crate) fn star_minimisation(self) -> Option<(usize, f64)> {
        match self {
            Recovery::Star {
                max_iterations,
                tolerance,
            } => Some((max_iterations, tolerance)),
            _ => None,
        }
    }

    /// The averaged-traction JM fields are built before the lowering, which updates them as it
    /// goes (`PatchClassic`, `Star`); the others build fields only in the final pass.
    pub(crate) fn updates_fields(self) -> bool {
        matches!(self, Recovery::PatchClassic { .. } | Recovery::Star { .. })
    }

    /// Sweeps over the vertex patches on the JM fields (`PatchClassic`; 0 otherwise).
    pub(crate) fn field_sweeps(self) -> usize {
        match self {
            Recovery::PatchClassic { sweeps } => sweeps,
            _ => 0,
        }
    }

    /// The planned sweeps on the edge tractions of `Patch`: (cold sweeps, warm sweeps).
    pub(crate) fn planned_sweeps(self) -> Option<(usize, usize)> {
        match self {
            Recovery::Patch {
                sweeps,
                warm_sweeps,
            } => Some((sweeps, warm_sweeps)),
            _ => None,
        }
    }

    /// Nothing lowers the averaged-traction field: the final field is that one (`Eet`).
    pub(crate) fn ends_at_averaged(self) -> bool {
        matches!(self, Recovery::Eet)
    }

    /// A recovery may start from the change the previous one made (`Patch` with
    /// `warm_sweeps` > 0).
    pub fn starts_warm(self) -> bool {
        matches!(self, Recovery::Patch { warm_sweeps, .. } if warm_sweeps > 0)
    }

    /// The sweeps a recovery makes, started warm or cold.
    pub fn sweeps_made(self, warm: bool) -> usize {
        match self {
            Recovery::Patch {
                sweeps,
                warm_sweeps,
            } => {
                if warm {
                    warm_sweeps
                } else {
                    sweeps
                }
            }
            Recovery::PatchClassic { sweeps } => sweeps,
            Recovery::Star { .. } | Recovery::Eet => 0,
        }
    }

    /// The most sweeps a recovery of this kind makes, warm or cold (the overlap it needs);
    /// none for a global solve (`Star`).
    pub fn most_sweeps(self) -> Option<usize> {
        match self {
            Recovery::Patch {
                sweeps,
                warm_sweeps,
            } => Some(sweeps.max(warm_sweeps)),
            Recovery::PatchClassic { sweeps } => Some(sweeps),
            Recovery::Star { .. } => None,
            Recovery::Eet => Some(0),
        }
    }

    /// On a sub-mesh, the values of the elements held but not owned are exchanged between
    /// two sweeps (`Restriction::between_sweeps`, called by the planned sweeps of `Patch`).
    pub fn exchanges_between_sweeps(self) -> bool {
        matches!(self, Recovery::Patch { .. })
    }

    /// The exchanges between sweeps of a recovery started warm or cold: one between two
    /// sweeps (what a rank that holds none of a split body's elements takes part in).
    pub fn exchanges(self, warm: bool) -> usize {
        if self.exchanges_between_sweeps() {
            self.sweeps_made(warm).saturating_sub(1)
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Recovery;

    /// Each recovery's answers, as the matches they replaced gave them.
    #[test]
    fn each_recovery_answers_as_before() {
        let patch = Recovery::Patch {
            sweeps: 6,
            warm_sweeps: 1,
        };
        let cold_patch = Recovery::Patch {
            sweeps: 4,
            warm_sweeps: 0,
        };
        let classic = Recovery::PatchClassic { sweeps: 10 };
        let (star, eet) = (Recovery::star(), Recovery::Eet);
        let all = [patch, cold_patch, classic, star, eet];
        let answers = |f: fn(Recovery) -> bool| all.map(f);
        assert_eq!(answers(Recovery::is_local), [true, true, true, false, true]);
        assert_eq!(
            answers(Recovery::updates_fields),
            [false, false, true, true, false]
        );
        assert_eq!(
            answers(Recovery::ends_at_averaged),
            [false, false, false, false, true]
        );
        assert_eq!(
            answers(Recovery::starts_warm),
            [true, false, false, false, false]
        );
        assert_eq!(
            answers(Recovery::exchanges_between_sweeps),
            [true, true, false, false, false]
        );
        assert_eq!(star.star_minimisation(), Some((5000, 1e-8)));
        assert_eq!(
            all.map(|r| r.star_minimisation().is_some()),
            answers(|r| !r.is_local())
        );
        assert_eq!(all.map(Recovery::field_sweeps), [0, 0, 10, 0, 0]);
        assert_eq!(
            all.map(Recovery::planned_sweeps),
            [Some((6, 1)), Some((4, 0)), None, None, None]
        );
        assert_eq!(all.map(|r| r.sweeps_made(false)), [6, 4, 10, 0, 0]);
        assert_eq!(all.map(|r| r.sweeps_made(true)), [1, 0, 10, 0, 0]);
        assert_eq!(all.map(|r| r.exchanges(false)), [5, 3, 0, 0, 0]);
        assert_eq!(all.map(|r| r.exchanges(true)), [0, 0, 0, 0, 0]);
        assert_eq!(
            all.map(Recovery::most_sweeps),
            [Some(6), Some(4), Some(10), None, Some(0)]
        );
    }
}
