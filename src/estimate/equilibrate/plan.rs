//! `Recovery::Patch`: the block Gauss–Seidel steps of `Recovery::PatchClassic` carried out in the
//! space of the edge-traction values, with everything that depends on the mesh only computed
//! once and kept from one recovery to the next.
//!
//! The complementary energy of an element is a quadratic form of its 12 traction values t_E
//! (the JM coefficients are G_E t_E, `johnson_mercier`):
//! ½ J_E(t_E) = ½ t_Eᵀ H_E t_E − r_Eᵀ t_E + const, H_E = h_E² Ĥ_shape, r_E = G_Eᵀ W_E σ̃_E,
//! so the gradient that a patch step needs is H_E t_E − r_E, read from the current edge
//! tractions: no JM coefficients are updated during the sweeps (they are built once at the
//! end), and nothing is located, hashed or allocated per step. A [`Plan`] holds, per
//! vertex in sweep order, its unknowns as flat traction indices 4 g + 2 end + k, its patch
//! operator and its elements' (traction index, unknown, sign) maps; per element, its gather
//! map (flat index and sign of each of its 12 values) and its Hessian. Each step is then
//! exactly `Relaxation::step` (the same minimisation over the same patch kernel, so the
//! same iterates to round-off), about ten times faster.
//!
//! Warm start ([`Warm`]): the change the sweeps make, δ = t_relaxed − t_EET, lies in the
//! patch kernel (it is zero on every prescribed component and keeps every element
//! self-equilibrated), which does not depend on the data. So t_EET(new data) + δ(previous
//! recovery) is admissible for the new data, and it is closer to the new minimum than
//! t_EET(new data) when the two data are close (the η^FE recovery after the η^glo one, the
//! next estimate's late in the NNDD). δ accumulates: the next δ is t_relaxed − t_EET of the
//! new data, so each warm recovery's sweeps add to the previous ones'.

use super::eet::{Bc, EdgeConditions};
use super::johnson_mercier::{midpoints, ShapeCache};
use super::relaxation::{PatchOp, Relaxation};
use super::sizes::{NC, NT};
use super::topology::Topology;
use crate::fem::geometry::{local_frame, triangle_area};
use crate::fem::mesh::{mix, Mesh};

/// The mesh-only data of the planned sweeps (see the module documentation).
pub(crate) struct Plan {
    /// Of the mesh, the boundary codes and the sweep order it was built for.
    fingerprint: u64,
    /// Per planned vertex (in sweep order): the range of its unknowns in `unk` and of its
    /// elements in `pel`.
    vptr: Vec<u32>,
    eptr: Vec<u32>,
    /// Flat traction index of every unknown.
    unk: Vec<u32>,
    /// Patch operator and 1/h_p² per planned vertex.
    vop: Vec<u32>,
    inv_hp2: Vec<f64>,
    /// Per patch element: the element and the range of its rows in `rows`.
    pel: Vec<u32>,
    rptr: Vec<u32>,
    /// (traction index in the element, unknown, negative sign).
    rows: Vec<(u8, u8, bool)>,
    /// Per planned vertex: the offset of its step coefficients a (`Plan::loads`).
    aptr: Vec<u32>,
    /// Per element: bit l (l < 3) the end of its edge l at its vertex l, bit 3 + l the
    /// edge's sign on it (1: negative); with the topology's edges, its 12 flat traction
    /// indices and signs ([`Plan::gather`]).
    orient: Vec<u8>,
    /// Distinct patch operators (for the statistics).
    pub(super) patterns: usize,
}

/// The change of the last planned recovery, for a warm start of the next one.
pub(crate) struct Warm {
    fingerprint: u64,
    delta: Vec<f64>,
}

/// Fingerprint of what a plan depends on: the mesh ([`Mesh::fingerprint`]), the boundary
/// codes and the sweep keys of a restriction (none: the mesh's own colouring).
pub(super) fn fingerprint(mesh: u64, bc: &EdgeConditions, keys: Option<&[u64]>) -> u64 {
    let mut h = mesh;
    for b in bc.iter() {
        let code = |c: &Bc| match c {
            Bc::Interior => 0,
            Bc::Known(_) => 1,
            Bc::Free => 2,
        };
        h = mix(h, code(&b[0]) | code(&b[1]) << 2);
    }
    for &k in keys.unwrap_or(&[]) {
        h = mix(h, k);
    }
    mix(h, keys.is_some() as u64)
}

impl Plan {
    /// The plan of `relax`'s mesh for the vertices in `order` (sweep order), building the
    /// missing patch operators (all of them, past the cache capacity too) and Hessians.
    pub(super) fn new(
        relax: &mut Relaxation,
        cache: &mut ShapeCache,
        order: &[usize],
        fingerprint: u64,
    ) -> Plan {
        let (mesh, topo) = (relax.mesh, relax.topo);
        let nt = mesh.triangles.len();
        let mut plan = Plan {
            fingerprint,
            vptr: vec![0],
            eptr: vec![0],
            unk: Vec::new(),
            vop: Vec::new(),
            inv_hp2: Vec::new(),
            pel: Vec::new(),
            rptr: vec![0],
            rows: Vec::new(),
            aptr: vec![0],
            orient: Vec::with_capacity(nt),
            patterns: 0,
        };
        for &i in order {
            let lay = relax.layout(i);
            if lay.unknowns.is_empty() {
                continue;
            }
            let o = relax
                .operator_for(cache, i, &lay, true)
                .expect("always built");
            if relax.ops[o].dim() == 0 {
                continue;
            }
            plan.vop.push(o as u32);
            plan.aptr
                .push(plan.aptr.last().copied().unwrap_or(0) + relax.ops[o].dim() as u32);
            plan.inv_hp2.push(1.0 / (lay.hp * lay.hp));
            plan.unk.extend(
                lay.unknowns
                    .iter()
                    .map(|&(g, end, k)| (4 * g + 2 * end + k) as u32),
            );
            for ((e, _), list) in topo.vertex_elements(i).iter().zip(&lay.smap) {
                plan.pel.push(e as u32);
                plan.rows
                    .extend(list.iter().map(|&(ti, u, s)| (ti as u8, u as u8, s < 0.0)));
                plan.rptr.push(plan.rows.len() as u32);
            }
            plan.vptr.push(plan.unk.len() as u32);
            plan.eptr.push(plan.pel.len() as u32);
        }
        for e in 0..nt {
            let t = mesh.triangles.get(e);
            let mut o = 0u8;
            for (l, g) in topo.edges_of(e).into_iter().enumerate() {
                o |= (topo.end_of(g, t[l]) as u8) << l;
                if topo.sign(e, g) < 0.0 {
                    o |= 1 << (3 + l);
                }
            }
            plan.orient.push(o);
        }
        plan.patterns = relax.ops.len();
        plan.shrink();
        plan
    }

    /// Release the growth slack of the vectors (up to half of them).
    fn shrink(&mut self) {
        for v in [&mut self.vptr, &mut self.eptr, &mut self.unk, &mut self.vop] {
            v.shrink_to_fit();
        }
        for v in [&mut self.pel, &mut self.rptr, &mut self.aptr] {
            v.shrink_to_fit();
        }
        self.inv_hp2.shrink_to_fit();
        self.rows.shrink_to_fit();
    }

    pub(super) fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// The 12 flat traction indices 4 g + 2 end + k of element e (value j = 4 l + 2 pos + k:
    /// edge l, its end at the element's vertex l + pos, component k) and the bit mask of the
    /// values whose sign is negative on e.
    #[inline]
    fn gather(&self, topo: &Topology, e: usize) -> ([u32; NT], u16) {
        let (g, o) = (topo.edges_of(e), self.orient[e]);
        let mut idx = [0u32; NT];
        let mut neg = 0u16;
        for l in 0..3 {
            let first = ((o >> l) & 1) as usize;
            let negative = (o >> (3 + l)) & 1 != 0;
            for pos in 0..2 {
                for k in 0..2 {
                    let j = 4 * l + 2 * pos + k;
                    idx[j] = (4 * g[l] + 2 * (first ^ pos) + k) as u32;
                    if negative {
                        neg |= 1 << j;
                    }
                }
            }
        }
        (idx, neg)
    }

    /// The 12 values of element `e` in the flat traction vector `flat`, each with the
    /// element's own orientation (the traction on its boundary, at its vertices in its own
    /// order): the same numbers on every sub-mesh that holds the element.
    pub(super) fn element_values(&self, topo: &Topology, flat: &[f64], e: usize) -> [f64; NT] {
        let (idx, neg) = self.gather(topo, e);
        std::array::from_fn(|j| {
            let t = flat[idx[j] as usize];
            if neg & (1 << j) != 0 {
                -t
            } else {
                t
            }
        })
    }

    /// Write the values of element `e` ([`Plan::element_values`]) into `flat`.
    pub(super) fn set_element_values(
        &self,
        topo: &Topology,
        flat: &mut [f64],
        e: usize,
        v: &[f64; NT],
    ) {
        let (idx, neg) = self.gather(topo, e);
        for j in 0..NT {
            flat[idx[j] as usize] = if neg & (1 << j) != 0 { -v[j] } else { v[j] };
        }
    }

    /// The step coefficients a_v = Hinv Nᵀ Σ_E S_Eᵀ r_E / h_p² of every planned vertex
    /// (`PatchOp::step`), from the element loads r_E = G_Eᵀ W_E σ̃_E (σ̃_E constant; the
    /// midpoint rule of the sub-triangles is exact for the quadratic integrand).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn loads(
        &self,
        mesh: &Mesh,
        cache: &mut ShapeCache,
        shape_of: &[usize],
        sig: &[[f64; 3]],
        cm: &[[f64; 3]; 3],
        ops: &[PatchOp],
    ) -> Vec<f64> {
        let r: Vec<[f64; NT]> = (0..mesh.triangles.len())
            .map(|e| {
                let pts = mesh.triangle_points(e);
                let (_, _, q) = local_frame(&pts);
                let w = triangle_area(&pts) / 9.0;
                let cs: [f64; 3] =
                    [0, 1, 2].map(|r| w * (0..3).map(|c| cm[r][c] * sig[e][c]).sum::<f64>());
                let mut m = [0.0; NC];
                for a in 0..3 {
                    for pt in midpoints(&q, a) {
                        let phi = [1.0, pt[0], pt[1]];
                        for r in 0..3 {
                            for k in 0..3 {
                                m[9 * a + 3 * r + k] += phi[k] * cs[r];
                            }
                        }
                    }
                }
                let g = cache.operator(shape_of[e], &q);
                let mut r = [0.0; NT];
                for (c, &mc) in m.iter().enumerate() {
                    for (ti, rt) in r.iter_mut().enumerate() {
                        *rt += g[c * NT + ti] * mc;
                    }
                }
                r
            })
            .collect();
        let mut a = Vec::with_capacity(*self.aptr.last().unwrap_or(&0) as usize);
        let mut g = Vec::new();
        for v in 0..self.vop.len() {
            g.clear();
            g.resize((self.vptr[v + 1] - self.vptr[v]) as usize, 0.0);
            for p in self.eptr[v] as usize..self.eptr[v + 1] as usize {
                let e = self.pel[p] as usize;
                for &(ti, u, negative) in
                    &self.rows[self.rptr[p] as usize..self.rptr[p + 1] as usize]
                {
                    let x = r[e][ti as usize];
                    g[u as usize] += if negative { -x } else { x };
                }
            }
            ops[self.vop[v] as usize].load_coefficients(&g, self.inv_hp2[v], &mut a);
        }
        a
    }

    /// `sweeps` symmetric Gauss–Seidel sweeps (forward in the even ones, backward in the
    /// odd ones) on the flat edge tractions `trac` (4 g + 2 end + k), with the step
    /// coefficients `a` ([`Plan::loads`]) and the patch operators `ops`; every change is
    /// also added to `change` (a warm start's δ, [`Warm`]) unless it is empty. `between`
    /// is called between two sweeps ([`super::Restriction::between_sweeps`]).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn sweep(
        &self,
        topo: &Topology,
        ops: &[PatchOp],
        a: &[f64],
        trac: &mut [f64],
        change: &mut [f64],
        sweeps: usize,
        between: Option<&dyn Fn(&mut SweepValues)>,
    ) {
        let track = !change.is_empty();
        let nv = self.vop.len();
        let mut te: Vec<[f64; NT]> = Vec::with_capacity(16);
        for s in 0..sweeps {
            if let (true, Some(f)) = (s > 0, between) {
                f(&mut SweepValues {
                    plan: self,
                    topo,
                    trac: &mut *trac,
                    change: &mut *change,
                });
            }
            for v in 0..nv {
                let v = if s % 2 == 0 { v } else { nv - 1 - v };
                te.clear();
                for &e in &self.pel[self.eptr[v] as usize..self.eptr[v + 1] as usize] {
                    let (idx, neg) = self.gather(topo, e as usize);
                    te.push(std::array::from_fn(|j| {
                        let t = trac[idx[j] as usize];
                        if neg & (1 << j) != 0 {
                            -t
                        } else {
                            t
                        }
                    }));
                }
                let unk = &self.unk[self.vptr[v] as usize..self.vptr[v + 1] as usize];
                let av = &a[self.aptr[v] as usize..self.aptr[v + 1] as usize];
                ops[self.vop[v] as usize].step(av, &te, |u, d| {
                    trac[unk[u] as usize] += d;
                    if track {
                        change[unk[u] as usize] += d;
                    }
                });
            }
        }
    }
}

impl Warm {
    /// δ = 0 for the plan `fingerprint` and `len` traction values (a cold start; the sweeps
    /// add their changes to it, [`Plan::sweep`]).
    pub(super) fn zero(fingerprint: u64, len: usize) -> Warm {
        Warm {
            fingerprint,
            delta: vec![0.0; len],
        }
    }

    /// δ, for the sweeps to add their changes to.
    pub(super) fn delta_mut(&mut self) -> &mut [f64] {
        &mut self.delta
    }

    /// The plan fingerprint δ was made with, and δ itself (flat traction indices).
    pub(super) fn parts_mut(&mut self) -> (u64, &mut [f64]) {
        (self.fingerprint, &mut self.delta)
    }

    /// Add δ to `trac` if it was made with the plan `fingerprint` (the same mesh, boundary
    /// codes and order); returns whether it was.
    pub(super) fn apply(&self, fingerprint: u64, trac: &mut [f64]) -> bool {
        if self.fingerprint != fingerprint || self.delta.len() != trac.len() {
            return false;
        }
        for (t, d) in trac.iter_mut().zip(&self.delta) {
            *t += d;
        }
        true
    }
}

/// The traction values of a `Recovery::Patch` recovery between two sweeps, element by element
/// (the 12 values of a sub-mesh element in its own orientation, as the plan gathers them):
/// what [`Restriction::between_sweeps`] reads and overwrites. Writing an element's values
/// moves the warm start's change δ with them (t − δ, the start, is kept).
pub struct SweepValues<'a> {
    plan: &'a Plan,
    topo: &'a Topology,
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

#[cfg(test)]
mod tests {
    use super::super::testutil::*;
    use super::super::{
        equilibrate_restricted, equilibrate_with, EquilibratedStress, OperatorCache, Recovery,
    };
    use crate::fem::mesh::Mesh;

    /// max over elements of |a − b| / max |b|.
    fn max_diff(mesh: &Mesh, a: &EquilibratedStress, b: &EquilibratedStress) -> f64 {
        let scale = (0..mesh.triangles.len())
            .flat_map(|e| b.coefficients(e).to_vec())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        (0..mesh.triangles.len())
            .flat_map(|e| {
                a.coefficients(e)
                    .iter()
                    .zip(b.coefficients(e))
                    .map(|(x, y)| (x - y).abs())
                    .collect::<Vec<_>>()
            })
            .fold(0.0f64, f64::max)
            / scale
    }

    /// A distorted 6 × 6 block (no two patches alike) and its FE solution.
    fn distorted() -> (Mesh, super::super::Boundary, Vec<f64>) {
        let (mesh, bd) = distorted_block(6, 3);
        let u = fe_solve(&mesh, &bd);
        (mesh, bd, u)
    }

    /// The planned steps are the classic ones: the same σ̂ after 1, 2 and 5 sweeps (to
    /// round-off), on a structured and on a distorted mesh.
    #[test]
    fn planned_sweeps_equal_the_classic_ones() {
        let (mesh, bd) = block(6);
        let u = fe_solve(&mesh, &bd);
        for (name, (mesh, bd, u)) in [("block", (mesh, bd, u)), ("distorted", distorted())] {
            for sweeps in [1, 2, 5] {
                let classic =
                    equilibrate_with(&mesh, &STEEL, &u, &bd, Recovery::PatchClassic { sweeps })
                        .unwrap();
                let planned = equilibrate_with(
                    &mesh,
                    &STEEL,
                    &u,
                    &bd,
                    Recovery::Patch {
                        sweeps,
                        warm_sweeps: 0,
                    },
                )
                .unwrap();
                let d = max_diff(&mesh, &planned, &classic);
                println!("{name}, {sweeps} sweeps: max coefficient difference {d:.1e}");
                assert!(d < 1e-11, "{name}, {sweeps} sweeps: {d:e}");
                let (a, b) = (planned.stats().energy_final, classic.stats().energy_final);
                assert!((a - b).abs() < 1e-11 * b, "{a} vs {b}");
                assert_admissible(&planned.residuals(&mesh, &bd), 1e-10);
            }
        }
    }

    /// A warm start (after a recovery of nearby data with the same cache) stays exactly
    /// admissible, and one warm sweep lowers the energy below three cold ones; after
    /// `forget_warm_start`, the recovery is the cold one, bit for bit.
    #[test]
    fn warm_start_is_admissible_and_closer_to_the_minimum() {
        let (mesh, bd, u) = distorted();
        // Nearby data: the same problem, the displacement perturbed by 2 % (still
        // FE-equilibrated: the loads scale with it).
        let (mut bd2, v) = (bd.clone(), u.iter().map(|x| 1.02 * x).collect::<Vec<_>>());
        for edge in &mut bd2.edges {
            for c in &mut edge.comps {
                if let super::super::EdgeComponent::Known(t) = c {
                    *t = [1.02 * t[0], 1.02 * t[1]];
                }
            }
        }
        let choice = Recovery::Patch {
            sweeps: 3,
            warm_sweeps: 1,
        };
        let mut ops = OperatorCache::default();
        let run = |w: &[f64], b, ops: &mut OperatorCache| {
            equilibrate_restricted(&mesh, &STEEL, w, b, choice, None, Some(ops), None).unwrap()
        };
        run(&u, &bd, &mut ops);
        let warm = run(&v, &bd2, &mut ops);
        assert_admissible(&warm.residuals(&mesh, &bd2), 1e-10);
        let cold = |sweeps| {
            equilibrate_with(
                &mesh,
                &STEEL,
                &v,
                &bd2,
                Recovery::Patch {
                    sweeps,
                    warm_sweeps: 0,
                },
            )
            .unwrap()
            .stats()
            .energy_final
        };
        let (e_warm, e3, e_min) = (warm.stats().energy_final, cold(3), cold(400));
        println!("energies: warm (3 + 1 sweeps) {e_warm:e}, cold 3 {e3:e}, cold 400 {e_min:e}");
        assert!(e_warm < e3 && e_warm >= e_min * (1.0 - 1e-12));
        ops.forget_warm_start();
        let again = run(&v, &bd2, &mut ops);
        let fresh = equilibrate_with(&mesh, &STEEL, &v, &bd2, choice).unwrap();
        for e in 0..mesh.triangles.len() {
            assert_eq!(again.coefficients(e), fresh.coefficients(e));
        }
    }
}
