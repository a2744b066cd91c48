//! Where a rank's recoveries of one body run ([`View`]): the whole body, or the rank's
//! elements plus the rings that make the recovery there the whole body's ([`Overlap`]), and
//! what they read of the body's fields there.

use std::collections::HashMap;

use super::equilibrate::{
    equilibrate_restricted, Boundary, BoundaryEdge, EdgeComponent, OperatorCache, Recovery,
    Residuals, SweepValues, NC,
};
use super::error::EstimateError;
use super::overlap::{Halo, Overlap};
use super::polygon::EdgeValues;
use crate::dd::body::FieldAt;
use crate::dd::displacement::Displacement;
use crate::fem::elasticity::element_energy as energy;
use crate::fem::mesh::Mesh;
use crate::fem::{element_dofs, element_stiffness};
use crate::parallel::layout::Layout;
use crate::problem::BodyProblem;

/// Where a rank's recovery runs: the whole body mesh (the body on one rank), or the rank's
/// own elements with enough rings of neighbours that the recovered σ̂ on its own elements is
/// exactly the whole-mesh one ([`Overlap`]), the warm starts refreshed from the owners
/// ([`Halo`]) over the body group of `Layout`.
pub enum View<'a> {
    Whole,
    Overlap(&'a Overlap, &'a Halo, &'a Layout),
    /// None of the body's elements, which other ranks estimate: this rank only takes part in
    /// their warm-start exchanges.
    Idle(&'a Halo, &'a Layout),
}

impl View<'_> {
    /// Before a recovery of the data u (on this view, [`View::local_of`]): start it warm only
    /// from nearby data (a relative change of at most `warm_change`,
    /// `-nndd_recovery_warm_change`, default [`super::settings::WARM_CHANGE`]; every rank
    /// decides alike, from the body's energy norms, [`View::relative_change`]), and on a
    /// split body refresh the warm start from the owners (collective over all ranks: the
    /// estimator prepares every body's recovery before making any, so that no rank waits for
    /// another's).
    pub fn prepare(
        &self,
        p: &BodyProblem,
        u: &[f64],
        choice: Recovery,
        warm_change: f64,
        operators: &mut OperatorCache,
    ) {
        let near = operators
            .warm_data
            .as_ref()
            .is_some_and(|prev| self.relative_change(p, u, prev) <= warm_change);
        if !near {
            operators.forget_warm_start();
        }
        operators.starts_warm = near && choice.starts_warm();
        if let (true, View::Overlap(_, halo, layout) | View::Idle(halo, layout)) =
            (operators.starts_warm, self)
        {
            halo.refresh(layout, operators);
        }
    }

    /// Recover σ̂ of the data (u, Γc traction `gc` per segment) on this view ([`View::prepare`]d) and hand
    /// every element's field to `visit` (sub-mesh element index, its JM coefficients; none
    /// is stored); returns the construction's equilibrium check.
    pub(super) fn equilibrate(
        &self,
        p: &BodyProblem,
        u: &[f64],
        gc: &[EdgeValues],
        choice: Recovery,
        operators: &mut OperatorCache,
        visit: &mut dyn FnMut(usize, &[f64; NC]),
    ) -> Result<Residuals, EstimateError> {
        let b = boundary(p, gc);
        let err = |source| EstimateError::Equilibration {
            alpha: p.alpha,
            source,
        };
        let s = match self {
            View::Idle(..) => None,
            View::Whole => Some(equilibrate_restricted(
                p.mesh(),
                &p.material,
                u,
                &b,
                choice,
                None,
                Some(operators),
                Some(visit),
            )),
            View::Overlap(o, halo, layout) => {
                // Between sweeps, the elements held but not owned take their owners' values.
                let between = |v: &mut SweepValues| halo.exchange_sweep(layout, Some(v));
                Some(equilibrate_restricted(
                    &o.mesh,
                    &p.material,
                    u,
                    &o.restrict_boundary(&b),
                    choice,
                    Some(&o.restriction_with(Some(&between))),
                    Some(operators),
                    Some(visit),
                ))
            }
        };
        if let View::Idle(halo, layout) = self {
            // As many exchanges as the ranks that recover: one between two sweeps.
            for _ in 0..choice.exchanges(operators.starts_warm) {
                halo.exchange_sweep(layout, None);
            }
        }
        let checked = match s {
            Some(s) => s.map_err(err)?.checked_residuals(),
            None => Residuals::default(),
        };
        // After the recovery: its first use sets the cache up for the material, afresh.
        operators.warm_data = Some(u.to_vec());
        Ok(checked)
    }

    /// Where a solve gathers a field that this view's recoveries read ([`View::local_of`]'s
    /// entries, gathered there alone): whole, at the overlap's nodes, nowhere when idle.
    pub fn field_at(&self) -> FieldAt<'_> {
        match self {
            View::Whole => FieldAt::Whole,
            View::Overlap(o, ..) => FieldAt::Nodes(&o.nodes),
            View::Idle(..) => FieldAt::Nodes(&[]),
        }
    }

    /// What this view's recoveries read of a field held whole or at the view's nodes at
    /// least: all of it on the whole body (borrowed), its sub-mesh's dofs on an overlap
    /// ([`Overlap::restrict_dofs`]), nothing on an idle rank (a field not made, empty, stays
    /// so).
    pub(super) fn local_of<'b>(&self, u: &'b Displacement) -> std::borrow::Cow<'b, [f64]> {
        use std::borrow::Cow;
        match self {
            _ if u.is_empty() => Cow::Borrowed(&[]),
            View::Whole => Cow::Borrowed(u.whole_values()),
            View::Overlap(o, ..) => Cow::Owned(o.restrict_dofs(u)),
            View::Idle(..) => Cow::Owned(Vec::new()),
        }
    }

    /// ‖u − v‖_E / ‖u‖_E on the body, of two fields on this view ([`View::local_of`]): the
    /// element sums over the elements this rank estimates, added over the ranks that share
    /// the body's recovery (collective over them; the same number on each).
    fn relative_change(&self, p: &BodyProblem, u: &[f64], v: &[f64]) -> f64 {
        let (mesh, kept) = self.kept(p.mesh());
        let mut sums = [0.0; 2];
        for (l, _) in kept.iter().enumerate().filter(|(_, &e)| e != u32::MAX) {
            let ke = element_stiffness(&mesh.triangle_points(l), &p.material);
            let dofs = element_dofs(&mesh.triangles.get(l));
            let a: [f64; 6] = std::array::from_fn(|r| u[dofs[r]]);
            let d: [f64; 6] = std::array::from_fn(|r| u[dofs[r]] - v[dofs[r]]);
            sums[0] += energy(&ke, &d);
            sums[1] += energy(&ke, &a);
        }
        if let View::Overlap(_, halo, layout) | View::Idle(halo, layout) = self {
            halo.sum(layout, &mut sums);
        }
        let [du, uu] = sums;
        if uu > 0.0 {
            (du / uu).sqrt()
        } else if du > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }

    /// The mesh the recovered stress lives on, and for each of its elements the body element
    /// this rank estimates there (`u32::MAX`: none, a ring of the overlap).
    pub(super) fn kept<'b>(&'b self, mesh: &'b Mesh) -> (&'b Mesh, Vec<u32>) {
        match self {
            View::Whole => (mesh, (0..mesh.triangles.len() as u32).collect()),
            View::Overlap(o, ..) => (
                &o.mesh,
                o.elements
                    .iter()
                    .zip(&o.owned)
                    .map(|(&e, &own)| if own { e as u32 } else { u32::MAX })
                    .collect(),
            ),
            View::Idle(..) => (mesh, Vec::new()),
        }
    }
}

/// The traction data of body α for the equilibration: Γ_N data, on Γc the traction `gc` per
/// segment (per unit length of body 1's side), traction free elsewhere; components under
/// Dirichlet conditions on both ends of an edge are free.
pub fn boundary(p: &BodyProblem, gc: &[EdgeValues]) -> Boundary {
    let mesh = p.mesh();
    let mut constrained = vec![false; mesh.num_dofs()];
    for &(d, _) in &p.dirichlet {
        constrained[d] = true;
    }
    let mut known: HashMap<(usize, usize), [[f64; 2]; 2]> = HashMap::new();
    for e in &p.neumann {
        let [a, b] = e.nodes;
        // traction[node][component] → per component, values at (a, b)
        known.insert(
            (a, b),
            [
                [e.traction[0][0], e.traction[1][0]],
                [e.traction[0][1], e.traction[1][1]],
            ],
        );
    }
    // The Γc densities are per unit length of body 1's side (M_Γ integrates along it). On an
    // edge of the other side, of another length |Γ|, the same force is spread over |Γ|, so its
    // density there is c·|Γ¹|/|Γ| (1 on body 1's side and where both sides are parallel).
    for (k, [ca, cb]) in gc.iter().enumerate() {
        let (a, b) = (p.contact_nodes[k], p.contact_nodes[k + 1]);
        let (pa, pb) = (mesh.points.get(a), mesh.points.get(b));
        let scale = p.contact_lengths[k] / (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
        known.insert(
            (a, b),
            [
                [ca[0] * scale, cb[0] * scale],
                [ca[1] * scale, cb[1] * scale],
            ],
        );
    }
    let sides = if mesh.is_structured() {
        // The four sides, in the orientation of the benchmarks' data.
        let (nx, ny) = (mesh.nx, mesh.ny);
        let mut sides: Vec<[usize; 2]> = Vec::new();
        for i in 0..nx {
            sides.push([mesh.node(i, 0), mesh.node(i + 1, 0)]);
            sides.push([mesh.node(i, ny), mesh.node(i + 1, ny)]);
        }
        for j in 0..ny {
            sides.push([mesh.node(0, j), mesh.node(0, j + 1)]);
            sides.push([mesh.node(nx, j), mesh.node(nx, j + 1)]);
        }
        sides
    } else {
        // Every edge of one triangle, oriented as in it (the outline's, made once); the data
        // may run the other way.
        let sides = p.outline().edges.clone();
        for &[a, b] in &sides {
            if !known.contains_key(&(a, b)) {
                if let Some(v) = known.get(&(b, a)).copied() {
                    known.insert((a, b), [[v[0][1], v[0][0]], [v[1][1], v[1][0]]]);
                }
            }
        }
        sides
    };
    let edges = sides
        .into_iter()
        .map(|[a, b]| {
            let values = known.get(&(a, b)).copied();
            let comps = [0, 1].map(|k| {
                if constrained[2 * a + k] && constrained[2 * b + k] {
                    EdgeComponent::Free
                } else {
                    EdgeComponent::Known(values.map_or([0.0, 0.0], |v| v[k]))
                }
            });
            BoundaryEdge {
                nodes: [a, b],
                comps,
            }
        })
        .collect();
    Boundary { edges, constrained }
}
