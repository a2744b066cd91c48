//! A recovery on an overlapping sub-mesh ([`Restriction`], see `overlap.rs`).

use super::plan::SweepValues;

/// Restriction of an equilibration to an overlapping sub-mesh (see `overlap.rs`).
///
/// The sub-mesh must contain every element sharing a vertex with an owned element (at least
/// one ring): then every sub-mesh boundary edge of an owned element is a real boundary edge,
/// and the residual checks of [`EquilibratedStress::residuals_restricted`](super::EquilibratedStress::residuals_restricted) never see the
/// artificial boundary.
#[derive(Clone, Copy)]
pub struct Restriction<'a> {
    /// Sweep-order key of every vertex of the sub-mesh: [`sweep_key`](super::sweep_key) of its colour in the
    /// FULL mesh ([`vertex_colours`](super::vertex_colours)) and its global index.
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
