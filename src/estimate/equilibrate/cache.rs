//! The local operators kept from one recovery to the next ([`OperatorCache`]).

use super::fast_map::FastMap;
use super::sizes::NT;
use super::{eet, johnson_mercier, plan, relaxation, topology};
use crate::fem::Material;

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
    pub(super) topology: Option<(u64, topology::Topology)>,
    /// The plan of `Recovery::Patch` (per mesh, boundary codes and sweep order).
    pub(crate) plan: Option<plan::Plan>,
    /// The star problems' structure (per mesh and boundary codes).
    pub(super) stars: Option<eet::Stars>,
    /// The change made by the last `Recovery::Patch` recovery (its warm start).
    pub(crate) warm: Option<plan::Warm>,
    /// The caller's record of the data that recovery was made from (the estimator keeps the
    /// displacement on the rank's view of the body there, `view::View::local_of`, to decide
    /// whether the next one is close enough to start warm).
    pub warm_data: Option<Vec<f64>>,
    /// The caller's decision for the next recovery: it starts warm (near the last one's
    /// data); a rank that holds none of a split body's elements makes as many exchanges
    /// between sweeps as the others by it (`view::View`).
    pub starts_warm: bool,
    /// The material the operators were built for (they are rebuilt for another).
    pub(super) material: Option<Material>,
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
    /// since the last recovery, `settings::WARM_CHANGE`).
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
