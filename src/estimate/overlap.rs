//! Overlapping sub-meshes: a rank's own elements of a body mesh plus rings of neighbouring
//! elements, on which the equilibration (`equilibrate::equilibrate_restricted`) reproduces the
//! full-mesh recovered stress on the own elements (to round-off), so that the error
//! estimate of a body partitioned over several ranks does not depend on the partition.

use std::collections::HashSet;

use crate::estimate::equilibrate::{
    sweep_key, Boundary, BoundaryEdge, OperatorCache, Recovery, Restriction, Stars, SweepValues, NT,
};
use crate::fem::mesh::{element_u32, Mesh};
use crate::fem::wire::{Reader, Writer};
use crate::parallel::layout::Layout;

/// A rank's own elements of a body mesh plus `rings` rings of neighbouring elements (elements
/// sharing a vertex), as a sub-mesh whose elements keep increasing global order (so every
/// edge's "plus" element — the first element containing it — is the same as in the full
/// mesh) and whose nodes keep increasing global order (so every edge keeps its orientation
/// and every vertex its list of elements).
///
/// The sub-mesh is unstructured: `mesh.nx = mesh.ny = 0` (origin and size are the full
/// mesh's); only `points`, `triangles` and the functions built on them are meaningful (which
/// is all the equilibration uses).
#[derive(Clone, Debug)]
pub struct Overlap {
    pub mesh: Mesh,
    /// Global id of every sub-mesh element (increasing).
    pub elements: Vec<usize>,
    /// Global id of every sub-mesh node (increasing).
    pub nodes: Vec<usize>,
    /// Per sub-mesh element: one of the rank's own elements.
    pub owned: Vec<bool>,
    /// Per sub-mesh node: its sweep key (full-mesh colour, global index).
    pub vertex_key: Vec<u64>,
}

/// The exchanges of a body split over several ranks. A warm recovery
/// (`Recovery::Patch`) starts from the change δ of the previous recovery of the
/// same cache; on a sub-mesh, δ is exact on the own elements only. Before a warm recovery,
/// [`Halo::refresh`] gives every sub-mesh element that the rank does not own its owner's
/// values of δ, so the start is exact on the whole sub-mesh (up to the averaged-traction
/// field's last ring), however many recoveries the warm start has been carried through.
/// Between two sweeps [`Halo::exchange_sweep`] does the same with the traction values, so
/// the overlap needs the rings of one sweep ([`Overlap::rings_exchanged`]).
pub struct Halo {
    /// Over all ranks (a body estimated outside its group), else over its group.
    world: bool,
    /// Per rank: the sub-mesh indices of own elements that rank holds, in its order.
    send: Vec<Vec<usize>>,
    /// Per rank: the sub-mesh indices of the elements that rank owns and this one holds
    /// without owning them.
    recv: Vec<Vec<usize>>,
}

impl Halo {
    /// The exchange pattern of the sub-mesh `ov` (none: this rank holds none of the body's
    /// elements); `owner`: the rank estimating each of its elements, in the world (`world`)
    /// or in the body's group (read at the elements the rank does not own). Collective over
    /// that communicator.
    pub fn new(ov: Option<&Overlap>, owner: &[u32], world: bool, layout: &Layout) -> Halo {
        let size = if world {
            layout.size as usize
        } else {
            layout.group_size()
        };
        let (mut recv, mut ask) = (vec![Vec::new(); size], vec![Vec::new(); size]);
        if let Some(ov) = ov {
            for (l, &e) in ov.elements.iter().enumerate() {
                if !ov.owned[l] {
                    recv[owner[l] as usize].push(l);
                    ask[owner[l] as usize].push(e as u64);
                }
            }
        }
        let asked = layout.exchange(world, &ask);
        let send = asked
            .iter()
            .map(|ids| {
                ids.iter()
                    .map(|&e| {
                        ov.and_then(|ov| ov.elements.binary_search(&(e as usize)).ok())
                            .expect("only the owner is asked for an element")
                    })
                    .collect()
            })
            .collect();
        Halo { world, send, recv }
    }

    /// Give the elements this rank holds but does not own their owners' warm-start values
    /// (`OperatorCache::warm_values`); nothing where no warm start is held (the ranks make
    /// the same recoveries, so they hold one alike). Collective over its communicator.
    pub fn refresh(&self, layout: &Layout, cache: &mut OperatorCache) {
        let send = self
            .send
            .iter()
            .map(|l| cache.warm_values(l).map_or(Vec::new(), |v| v.concat()))
            .collect();
        for (l, v) in self.trade(layout, send) {
            if !l.is_empty() && v.len() == l.len() * NT {
                let values: Vec<[f64; NT]> = v.chunks_exact(NT).map(element_values).collect();
                cache.set_warm_values(l, &values);
            }
        }
    }

    /// Sum `data` element-wise over the ranks that share the body's recovery (the halo's
    /// communicator; collective over it).
    pub fn sum(&self, layout: &Layout, data: &mut [f64]) {
        match self.world {
            true => layout.world_sum(data),
            false => layout.group_sum(data),
        }
    }

    /// Between two sweeps of a recovery on the sub-mesh: give the elements this rank holds
    /// but does not own their owners' current traction values (`values`: the recovery's;
    /// none on a rank that holds none of the body's elements, which only takes part).
    /// Collective over its communicator.
    pub fn exchange_sweep(&self, layout: &Layout, mut values: Option<&mut SweepValues>) {
        let send = self
            .send
            .iter()
            .map(|l| match &values {
                Some(v) => l.iter().flat_map(|&e| v.get(e)).collect(),
                None => Vec::new(),
            })
            .collect();
        for (l, v) in self.trade(layout, send) {
            if let Some(values) = values.as_mut() {
                for (&e, c) in l.iter().zip(v.chunks_exact(NT)) {
                    values.set(e, &element_values(c));
                }
            }
        }
    }

    /// Send each rank `send` (per rank, the 12 values of each element in its `send` list),
    /// and pair each list of elements held but not owned with the values its owner sent.
    fn trade<'h>(
        &'h self,
        layout: &Layout,
        send: Vec<Vec<f64>>,
    ) -> impl Iterator<Item = (&'h [usize], Vec<f64>)> {
        let got = layout.exchange(self.world, &send);
        self.recv.iter().map(Vec::as_slice).zip(got)
    }
}

/// The 12 values of one element from an exchanged buffer.
fn element_values(c: &[f64]) -> [f64; NT] {
    c.try_into().expect("NT values")
}

/// Number of colours of a colouring (`equilibrate::vertex_colours`).
pub fn colour_count(colours: &[u8]) -> usize {
    colours.iter().map(|&c| c as usize + 1).max().unwrap_or(0)
}

impl Overlap {
    /// The sub-mesh of the elements `own` (per global element) and `rings` rings around them
    /// (ring r + 1: the elements sharing a vertex with the rings ≤ r). The growth stops early
    /// when no element is added (`rings = usize::MAX`: the connected components of the own
    /// elements). `colours` is `equilibrate::vertex_colours` of the FULL mesh.
    ///
    /// Panics if `own` or `colours` do not match the mesh.
    pub fn new(mesh: &Mesh, own: &[bool], rings: usize, colours: &[u8]) -> Overlap {
        assert_eq!(
            own.len(),
            mesh.triangles.len(),
            "`own`: one entry per element"
        );
        let mine: Vec<u32> = (0..own.len())
            .filter(|&e| own[e])
            .map(element_u32)
            .collect();
        Overlap::around(mesh, &Stars::of(mesh), &mine, rings, colours)
    }

    /// [`Overlap::new`] of the own elements `own` (increasing), its rings grown through the
    /// mesh's `stars`: O(N) to clear the marks and O(overlap) beyond, so that world rank 0
    /// makes every rank's overlap from one [`Stars`] (`share::SharePlan`).
    ///
    /// Panics if `own` or `colours` do not match the mesh.
    pub fn around(
        mesh: &Mesh,
        stars: &Stars,
        own: &[u32],
        rings: usize,
        colours: &[u8],
    ) -> Overlap {
        let (nt, nn) = (mesh.triangles.len(), mesh.num_nodes());
        assert_eq!(colours.len(), nn, "`colours`: one entry per node");
        let mut inside = vec![false; nt];
        let mut marked = vec![false; nn];
        own.iter().for_each(|&e| inside[e as usize] = true);
        let mut elements: Vec<u32> = own.to_vec();
        // Ring r + 1: the elements around the vertices of ring r (those of the rings before
        // were marked then).
        let mut ring = elements.clone();
        for _ in 0..rings {
            let mut next = Vec::new();
            for &e in &ring {
                for v in mesh.triangles.get(e as usize) {
                    if !std::mem::replace(&mut marked[v], true) {
                        for &f in stars.at(v) {
                            if !std::mem::replace(&mut inside[f as usize], true) {
                                next.push(f);
                            }
                        }
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            elements.extend_from_slice(&next);
            ring = next;
        }
        elements.sort_unstable();
        let elements: Vec<usize> = elements.into_iter().map(|e| e as usize).collect();
        let (sub, nodes) = mesh.sub_mesh(elements.iter().copied());
        let is_own = |e: usize| own.binary_search(&element_u32(e)).is_ok();
        Overlap {
            mesh: sub,
            owned: elements.iter().map(|&e| is_own(e)).collect(),
            vertex_key: nodes.iter().map(|&v| sweep_key(colours[v], v)).collect(),
            elements,
            nodes,
        }
    }

    /// The overlap as bytes ([`Writer`]): what world rank 0 makes of a rank's share and sends
    /// it under `-nndd_mesh_input root` (`share::Seed`).
    pub fn write(&self, w: &mut Writer) {
        self.mesh.write(w);
        w.ints(&self.elements);
        w.ints(&self.nodes);
        w.list(&self.owned, |w, &o| w.u8(o as u8));
        w.list(&self.vertex_key, |w, &k| w.u64(k));
    }

    /// What [`Overlap::write`] wrote (`None`: bytes that do not read back as one, the counts
    /// disagreeing with the sub-mesh's included).
    pub fn read(r: &mut Reader) -> Option<Overlap> {
        let ov = Overlap {
            mesh: Mesh::read(r)?,
            elements: r.ints()?,
            nodes: r.ints()?,
            owned: r.list(1, |r| r.u8().map(|o| o != 0))?,
            vertex_key: r.list(8, |r| r.u64())?,
        };
        let elements = ov.mesh.triangles.len();
        let nodes = ov.mesh.num_nodes();
        let agree = ov.elements.len() == elements
            && ov.owned.len() == elements
            && ov.nodes.len() == nodes
            && ov.vertex_key.len() == nodes;
        agree.then_some(ov)
    }

    /// Rings of overlap for which `equilibrate_restricted` on the sub-mesh is exact on the
    /// own elements, with `colours` colours (`colour_count`): `2 + sweeps × colours` for
    /// `Recovery::PatchClassic`, `2 + (sweeps + warm_sweeps) × colours` for `Recovery::Patch` (a warm
    /// recovery after a cold one of the same cache: see below), 2 for `Recovery::Eet`,
    /// `usize::MAX` for `Recovery::Star` (a global solve: no overlap short of the whole mesh
    /// is exact, and `equilibrate_restricted` refuses it).
    ///
    /// The dependency argument. Let O be the own elements, E_r the elements within r rings of
    /// O (E_0 = O) and E_L the sub-mesh. Every element datum (FE stress, nodal forces) is
    /// exact on the sub-mesh. A vertex sees its true star (all its elements, in the same
    /// order, and the true boundary status of the edges through it) iff all its elements are
    /// in the sub-mesh, which holds for the vertices of E_{L−1}.
    /// - Star problems: the star at vertex i fixes the edge moments at the end i of the edges
    ///   through i from the elements around i; the averaged-traction field of an element
    ///   depends on the stars at its three vertices, so it is exact on E_{L−1}: one ring.
    /// - Patch steps (`Relaxation::step`): a step at vertex v reads only the fields of the
    ///   elements around v and writes only the tractions of the edges through v and the
    ///   fields of the elements around v. If the fields (and the tractions of their edges)
    ///   are exact on a set X ⊇ E_r before a colour step, the steps at vertices whose star
    ///   lies in X are exact, and only the elements around the other vertices of the colour
    ///   can be spoilt: every element of E_{r−1} has all its vertices' stars in E_r ⊆ X, so
    ///   the exact set still contains E_{r−1}. Each colour step costs one ring; a sweep has
    ///   `colours` of them, and the final rebuild of the fields from the edge tractions keeps
    ///   the exact set. Hence the own elements are exact if L − 1 − sweeps × colours ≥ 0.
    ///
    /// - Warm start (`Recovery::Patch` after another recovery with the same cache on the same
    ///   sub-mesh): the change δ = (t_relaxed − t_EET)(previous) is exact on the own
    ///   elements, and [`Halo::refresh`] gives every other sub-mesh element its owner's δ
    ///   (without the exchange δ would only be exact on E_{L−1−sweeps × colours}, and
    ///   the exact set would shrink with every warm recovery). The start t_EET(new) + δ is
    ///   then exact on E_{L−1}, so after `warm_sweeps` sweeps the own elements are exact if
    ///   L − 1 − warm_sweeps × colours ≥ 0.
    ///
    /// So the own elements' fields are exact from 1 ring (averaged) and
    /// 1 + max(sweeps, warm_sweeps) × colours rings (patch relaxation) on. One more ring makes them exact on E_1 too, i.e. also on
    /// every element across an edge of an own element: then the equilibrium check of
    /// `residuals_restricted` (which measures the traction jumps across the edges between
    /// an own element and any neighbour, the partition interface included) compares exact
    /// fields; with one ring less it reports the spurious jumps against the inexact
    /// neighbours (measured: 2e-2 to 7e-2 on the test partitions) although the own fields
    /// are exact.
    /// Hence the count returned, 2 and 2 + sweeps × colours. (The argument is not tight: the
    /// two passes over one colour where a forward and a backward sweep meet cost one ring,
    /// not two, and within a sweep information only travels along increasing colours.)
    pub fn rings_for(choice: Recovery, colours: usize) -> usize {
        // A warm start's δ is refreshed from the owners (`Halo`): it needs no more rings than
        // a cold start.
        choice
            .most_sweeps()
            .map_or(usize::MAX, |sweeps| 2 + sweeps * colours)
    }

    /// Rings of overlap for which the recovery is exact on the own elements when the
    /// elements held but not owned take their owners' traction values between two sweeps
    /// ([`Halo::exchange_sweep`]): `2 + colours` for `Recovery::Patch` (the argument of
    /// [`Overlap::rings_for`] for one sweep: after each exchange the whole sub-mesh is exact
    /// again, but for the star problems' outer ring), as `rings_for` otherwise (no
    /// exchanges).
    pub fn rings_exchanged(choice: Recovery, colours: usize) -> usize {
        if choice.exchanges_between_sweeps() {
            2 + colours
        } else {
            Self::rings_for(choice, colours)
        }
    }

    /// Sub-mesh index of the global node g.
    fn local_node(&self, g: usize) -> Option<usize> {
        self.nodes.binary_search(&g).ok()
    }

    /// The sub-mesh dofs (2 node + k) of a full-mesh dof vector.
    pub fn restrict_dofs<U: crate::fem::Dofs + ?Sized>(&self, u: &U) -> Vec<f64> {
        self.per_dof(u)
    }

    /// The sub-mesh entries of any per-dof vector of the full mesh.
    fn per_dof<T: Copy, V: std::ops::Index<usize, Output = T> + ?Sized>(&self, v: &V) -> Vec<T> {
        self.nodes
            .iter()
            .flat_map(|&g| [v[2 * g], v[2 * g + 1]])
            .collect()
    }

    /// The boundary data of the sub-mesh: the full mesh's (real) boundary edges whose two
    /// nodes are in the sub-mesh and that are edges of sub-mesh elements, renumbered, and the
    /// `constrained` flags of the sub-mesh dofs. The artificial boundary of the sub-mesh is
    /// not listed (the equilibration treats it as traction free: only the results beyond
    /// the overlap see it).
    pub fn restrict_boundary(&self, b: &Boundary) -> Boundary {
        let sorted = |a: usize, c: usize| if a < c { [a, c] } else { [c, a] };
        let edges: HashSet<[usize; 2]> = self
            .mesh
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |l| sorted(t[l], t[(l + 1) % 3])))
            .collect();
        Boundary {
            edges: b
                .edges
                .iter()
                .filter_map(|be| {
                    let nodes = [self.local_node(be.nodes[0])?, self.local_node(be.nodes[1])?];
                    edges
                        .contains(&sorted(nodes[0], nodes[1]))
                        .then_some(BoundaryEdge {
                            nodes,
                            comps: be.comps,
                        })
                })
                .collect(),
            constrained: self.per_dof(&b.constrained),
        }
    }

    /// The restriction to pass to `equilibrate_restricted`.
    pub fn restriction(&self) -> Restriction<'_> {
        self.restriction_with(None)
    }

    /// [`Overlap::restriction`] with a halo exchange between sweeps
    /// ([`Restriction::between_sweeps`]; the overlap then needs
    /// [`Overlap::rings_exchanged`] rings only).
    pub fn restriction_with<'a>(
        &'a self,
        between_sweeps: Option<&'a dyn Fn(&mut SweepValues)>,
    ) -> Restriction<'a> {
        Restriction {
            vertex_key: &self.vertex_key,
            owned: &self.owned,
            between_sweeps,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::equilibrate::tests::{block_rect, fe_solve, STEEL};
    use crate::estimate::equilibrate::{
        equilibrate_restricted, equilibrate_with, vertex_colours, EquilibratedStress,
        EquilibrationError,
    };
    use crate::testutil::Lcg;

    const PATCH3: Recovery = Recovery::PatchClassic { sweeps: 3 };

    /// Largest differences of a partitioned equilibration from the full-mesh one.
    #[derive(Debug, Default)]
    struct Diff {
        /// |cre² − cre²_full| / cre²_full over the owned elements.
        cre: f64,
        /// max |coefficient difference| / max |coefficient| per owned element.
        coef: f64,
        /// Relative |Σ_parts Σ_owned cre² − Σ cre²| (and the same for `energy_final`).
        sum: f64,
        /// Largest restricted residual and FE-equilibrium defect of the parts.
        residual: f64,
        /// Largest sub-mesh, as a fraction of the mesh.
        coverage: f64,
    }

    /// Equilibrate every part (`part[e]`: part of element e) on its overlap of `rings` rings
    /// and compare its owned elements with the full-mesh equilibration `full` (of `choice`).
    fn partitioned(
        mesh: &Mesh,
        bd: &Boundary,
        u: &[f64],
        full: &EquilibratedStress,
        part: &[usize],
        choice: Recovery,
        rings: usize,
    ) -> Diff {
        let nt = mesh.triangles.len();
        let colours = vertex_colours(mesh);
        let full_cre = full.cre_map(mesh, &STEEL, u);
        let mut d = Diff::default();
        let mut times_owned = vec![0; nt];
        let (mut total, mut energy) = (0.0, 0.0);
        for p in 0..=*part.iter().max().unwrap() {
            let own: Vec<bool> = part.iter().map(|&q| q == p).collect();
            let ov = Overlap::new(mesh, &own, rings, &colours);
            let (us, bs) = (ov.restrict_dofs(u), ov.restrict_boundary(bd));
            let eq = equilibrate_restricted(
                &ov.mesh,
                &STEEL,
                &us,
                &bs,
                choice,
                Some(&ov.restriction()),
                None,
                None,
            )
            .unwrap();
            let cre = eq.cre_map(&ov.mesh, &STEEL, &us);
            for (le, &ge) in ov
                .elements
                .iter()
                .enumerate()
                .filter(|&(le, _)| ov.owned[le])
            {
                times_owned[ge] += 1;
                total += cre[le];
                d.cre = d.cre.max((cre[le] - full_cre[ge]).abs() / full_cre[ge]);
                let (a, b) = (eq.coefficients(le), full.coefficients(ge));
                let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let diff = a
                    .iter()
                    .zip(b)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                d.coef = d.coef.max(diff / scale);
            }
            energy += eq.stats().energy_final;
            let r = eq.residuals_restricted(&ov.mesh, &bs, Some(&ov.owned));
            d.residual = d.residual.max(r.max()).max(eq.stats().fe_equilibrium);
            d.coverage = d.coverage.max(ov.elements.len() as f64 / nt as f64);
        }
        assert!(times_owned.iter().all(|&k| k == 1), "not a partition");
        let full_total: f64 = full_cre.iter().sum();
        let full_energy = full.stats().energy_final;
        d.sum = ((total - full_total).abs() / full_total)
            .max((energy - full_energy).abs() / full_energy);
        d
    }

    fn barycentre(mesh: &Mesh, e: usize) -> [f64; 2] {
        let p = mesh.triangle_points(e);
        [0, 1].map(|c| (p[0][c] + p[1][c] + p[2][c]) / 3.0)
    }

    /// Three slabs with wavy interfaces (by the barycentre).
    fn slabs(mesh: &Mesh) -> Vec<usize> {
        (0..mesh.triangles.len())
            .map(|e| {
                let [x, y] = barycentre(mesh, e);
                if x < 0.3 + 0.08 * (7.0 * y).sin() {
                    0
                } else if x < 0.62 + 0.05 * (5.0 * y).cos() {
                    1
                } else {
                    2
                }
            })
            .collect()
    }

    /// A checkerboard of blocks of `b` × `b` cells dealt to three parts.
    fn checkerboard(mesh: &Mesh, b: usize) -> Vec<usize> {
        (0..mesh.triangles.len())
            .map(|e| {
                let (i, j) = ((e / 2) % mesh.nx, (e / 2) / mesh.nx);
                (i / b + j / b) % 3
            })
            .collect()
    }

    fn assert_exact(d: &Diff, what: &str) {
        assert!(d.cre < 1e-10 && d.coef < 1e-10, "{what}: {d:?}");
        assert!(d.sum < 1e-12, "{what}: {d:?}");
        assert!(d.residual < 1e-10, "{what}: {d:?}");
        assert!(
            d.coverage < 1.0,
            "{what}: the overlaps cover the mesh, the test proves nothing"
        );
    }

    /// Exact, with round-off residuals, at `rings_for`; one ring less: the owned fields are
    /// still exact (but not their neighbours, so the residual check is not meaningful);
    /// measurably different with too few rings.
    fn check_partition(mesh: &Mesh, bd: &Boundary, part: &[usize], sweeps: usize, name: &str) {
        let u = fe_solve(mesh, bd);
        let c = colour_count(&vertex_colours(mesh));
        let patch = Recovery::PatchClassic { sweeps };
        for (choice, too_few) in [(Recovery::Eet, 0), (patch, 1)] {
            let full = equilibrate_with(mesh, &STEEL, &u, bd, choice).unwrap();
            let rings = Overlap::rings_for(choice, c);
            let d = partitioned(mesh, bd, &u, &full, part, choice, rings);
            println!("{name} {choice:?}, {rings} rings: {d:?}");
            assert_exact(&d, &format!("{name} {choice:?}, {rings} rings"));
            let d = partitioned(mesh, bd, &u, &full, part, choice, rings - 1);
            println!("{name} {choice:?}, {} rings: {d:?}", rings - 1);
            assert!(d.cre < 1e-10 && d.coef < 1e-10 && d.sum < 1e-12, "{d:?}");
            let d = partitioned(mesh, bd, &u, &full, part, choice, too_few);
            println!("{name} {choice:?}, {too_few} rings (too few): {d:?}");
            assert!(
                d.coef > 1e-6 && d.cre > 1e-6,
                "{name} {choice:?}, {too_few} rings: {d:?}"
            );
        }
    }

    #[test]
    fn slab_partition_is_exact() {
        let (mesh, bd) = block_rect(96, 64);
        check_partition(&mesh, &bd, &slabs(&mesh), 3, "slabs");
    }

    #[test]
    fn checkerboard_partition_is_exact() {
        let (mesh, bd) = block_rect(96, 64);
        // Blocks of 24 × 24 cells (4 × 3, the top row partial): 4 disconnected blocks per
        // part, touching only at corners; corners where 4 blocks of 3 parts meet.
        check_partition(&mesh, &bd, &checkerboard(&mesh, 24), 3, "checkerboard");
    }

    #[test]
    fn distorted_mesh_partition_is_exact() {
        // Every triangle a different shape: no cache sharing between congruent triangles.
        let (mut mesh, bd) = block_rect(40, 32);
        let mut rng = Lcg(11);
        for j in 1..mesh.ny {
            for i in 1..mesh.nx {
                let n = mesh.node(i, j);
                let p = mesh.points.get(n);
                let q = [
                    p[0] + 0.2 / 40.0 * rng.next(),
                    p[1] + 0.2 / 32.0 * rng.next(),
                ];
                mesh.points.set(n, q);
            }
        }
        check_partition(&mesh, &bd, &slabs(&mesh), 2, "distorted slabs");
    }

    /// A chain of `Recovery::Patch` recoveries, one cold then two warm (an estimate's η^glo
    /// and η^FE recoveries, then the next estimate's η^glo one), each part on its overlap of
    /// `rings_for` rings with its own cache and the warm starts refreshed from the owners
    /// before each warm recovery ([`Halo::refresh`], emulated here), equals the same chain
    /// on the whole mesh on the own elements; without the refresh it does not.
    #[test]
    fn warm_started_recovery_partition_is_exact() {
        let (mesh, bd) = block_rect(48, 32);
        let u = fe_solve(&mesh, &bd);
        let scaled = |a: f64, m: usize| -> Vec<f64> {
            u.iter()
                .enumerate()
                .map(|(i, x)| x * (1.0 + a * ((i / 7) % m) as f64))
                .collect()
        };
        let data = [u.clone(), scaled(0.05, 3), scaled(0.03, 5)];
        let colours = vertex_colours(&mesh);
        let c = colour_count(&colours);
        let choice = Recovery::Patch {
            sweeps: 2,
            warm_sweeps: 1,
        };
        let mut full_ops = OperatorCache::default();
        let full: Vec<_> = data
            .iter()
            .map(|d| {
                equilibrate_restricted(
                    &mesh,
                    &STEEL,
                    d,
                    &bd,
                    choice,
                    None,
                    Some(&mut full_ops),
                    None,
                )
                .unwrap()
            })
            .collect();
        let part = slabs(&mesh);
        let parts = *part.iter().max().unwrap() + 1;
        let rings = Overlap::rings_for(choice, c);
        assert_eq!(rings, 2 + 2 * c, "the rings of the cold recovery");
        for refresh in [true, false] {
            let ovs: Vec<Overlap> = (0..parts)
                .map(|p| {
                    let own: Vec<bool> = part.iter().map(|&q| q == p).collect();
                    Overlap::new(&mesh, &own, rings, &colours)
                })
                .collect();
            let mut ops: Vec<OperatorCache> = (0..parts).map(|_| Default::default()).collect();
            let mut worst: f64 = 0.0;
            for (step, d) in data.iter().enumerate() {
                if refresh && step > 0 {
                    // Every element's δ from its owner's cache (what `Halo::refresh` sends).
                    let mut owner_values = vec![[0.0; NT]; mesh.triangles.len()];
                    for (ov, cache) in ovs.iter().zip(&mut ops) {
                        let own: Vec<usize> =
                            (0..ov.elements.len()).filter(|&l| ov.owned[l]).collect();
                        for (&l, v) in own.iter().zip(cache.warm_values(&own).unwrap()) {
                            owner_values[ov.elements[l]] = v;
                        }
                    }
                    for (ov, cache) in ovs.iter().zip(&mut ops) {
                        let other: Vec<usize> =
                            (0..ov.elements.len()).filter(|&l| !ov.owned[l]).collect();
                        let values: Vec<[f64; NT]> = other
                            .iter()
                            .map(|&l| owner_values[ov.elements[l]])
                            .collect();
                        assert!(cache.set_warm_values(&other, &values));
                    }
                }
                for (ov, cache) in ovs.iter().zip(&mut ops) {
                    let bs = ov.restrict_boundary(&bd);
                    let r = ov.restriction();
                    let eq = equilibrate_restricted(
                        &ov.mesh,
                        &STEEL,
                        &ov.restrict_dofs(d),
                        &bs,
                        choice,
                        Some(&r),
                        Some(cache),
                        None,
                    )
                    .unwrap();
                    for (le, &ge) in ov.elements.iter().enumerate().filter(|&(l, _)| ov.owned[l]) {
                        let b = full[step].coefficients(ge);
                        let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                        for (x, y) in eq.coefficients(le).iter().zip(b) {
                            worst = worst.max((x - y).abs() / scale);
                        }
                    }
                }
            }
            println!("warm chain, {rings} rings, refresh {refresh}: max coefficient difference {worst:.1e}");
            if refresh {
                assert!(worst < 1e-10, "{rings} rings: {worst:e}");
            } else {
                assert!(worst > 1e-6, "{rings} rings, no refresh: {worst:e}");
            }
        }
    }

    /// Where exactness sets in: the differences against the ring count (3 sweeps, slabs).
    #[test]
    fn exactness_against_rings() {
        let (mesh, bd) = block_rect(96, 64);
        let u = fe_solve(&mesh, &bd);
        let part = slabs(&mesh);
        let c = colour_count(&vertex_colours(&mesh));
        println!("colours {c}; rings: max relative difference of cre², of the coefficients");
        let rings = Overlap::rings_for(PATCH3, c);
        let full = equilibrate_with(&mesh, &STEEL, &u, &bd, PATCH3).unwrap();
        for r in 0..=rings {
            let d = partitioned(&mesh, &bd, &u, &full, &part, PATCH3, r);
            println!("{r:3}  {:.2e}  {:.2e}", d.cre, d.coef);
        }
    }

    #[test]
    fn overlap_reads_back_as_written_and_damaged_bytes_are_refused() {
        let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.0], 8, 6);
        let colours = vertex_colours(&mesh);
        let own: Vec<bool> = (0..mesh.triangles.len()).map(|e| e % 3 == 0).collect();
        let ov = Overlap::new(&mesh, &own, 2, &colours);
        let mut w = Writer::default();
        ov.write(&mut w);
        let back = Overlap::read(&mut Reader::new(&w.0)).unwrap();
        assert_eq!(
            (&back.elements, &back.nodes, &back.owned, &back.vertex_key),
            (&ov.elements, &ov.nodes, &ov.owned, &ov.vertex_key)
        );
        assert_eq!(back.mesh.fingerprint(), ov.mesh.fingerprint());
        assert!(Overlap::read(&mut Reader::new(&w.0[..w.0.len() - 1])).is_none());
        // (one owned flag short of the sub-mesh's elements)
        let mut short = ov.clone();
        short.owned.pop();
        let mut w = Writer::default();
        short.write(&mut w);
        assert!(Overlap::read(&mut Reader::new(&w.0)).is_none());
    }

    /// The rings grown through the vertex stars are those of sweeps over the whole mesh
    /// (ring r + 1: every element with a vertex of an element of the rings ≤ r), up to the
    /// connected component (`usize::MAX`).
    #[test]
    fn rings_grown_through_the_stars_are_the_whole_mesh_sweeps() {
        let mesh = Mesh::structured([0.0, 0.0], [3.0, 1.0], 12, 5);
        let colours = vertex_colours(&mesh);
        let mut rng = Lcg(11);
        let own: Vec<bool> = (0..mesh.triangles.len())
            .map(|_| rng.next() > 0.93)
            .collect();
        for rings in [0, 1, 2, 3, 5, usize::MAX] {
            let mut inside = own.clone();
            for _ in 0..rings.min(100) {
                let mut marked = vec![false; mesh.num_nodes()];
                for (t, _) in mesh.triangles.iter().zip(&inside).filter(|(_, &i)| i) {
                    t.iter().for_each(|&v| marked[v] = true);
                }
                for (t, i) in mesh.triangles.iter().zip(inside.iter_mut()) {
                    *i |= t.iter().any(|&v| marked[v]);
                }
            }
            let swept: Vec<usize> = (0..inside.len()).filter(|&e| inside[e]).collect();
            let ov = Overlap::new(&mesh, &own, rings, &colours);
            assert_eq!(ov.elements, swept, "{rings} rings");
            let owned: Vec<bool> = swept.iter().map(|&e| own[e]).collect();
            assert_eq!(ov.owned, owned, "{rings} rings");
        }
    }

    #[test]
    fn overlap_structure() {
        let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.0], 8, 6);
        let (nt, nn) = (mesh.triangles.len(), mesh.num_nodes());
        let colours = vertex_colours(&mesh);
        assert_eq!(colour_count(&colours), 4);
        let mut rng = Lcg(5);
        let own: Vec<bool> = (0..nt).map(|_| rng.next() > 0.7).collect();
        let ov = Overlap::new(&mesh, &own, 1, &colours);
        assert!(ov.elements.windows(2).all(|w| w[0] < w[1]));
        assert!(ov.nodes.windows(2).all(|w| w[0] < w[1]));
        // Own elements plus exactly those sharing a vertex with one.
        let mut touched = vec![false; nn];
        for (t, _) in mesh.triangles.iter().zip(&own).filter(|(_, &o)| o) {
            t.iter().for_each(|&v| touched[v] = true);
        }
        let expected: Vec<usize> = (0..nt)
            .filter(|&e| mesh.triangles.get(e).iter().any(|&v| touched[v]))
            .collect();
        assert_eq!(ov.elements, expected);
        for (le, &ge) in ov.elements.iter().enumerate() {
            assert_eq!(ov.owned[le], own[ge]);
            assert_eq!(
                ov.mesh.triangles.get(le).map(|v| ov.nodes[v]),
                mesh.triangles.get(ge)
            );
        }
        for (k, &g) in ov.nodes.iter().enumerate() {
            assert_eq!(ov.mesh.points.get(k), mesh.points.get(g));
            assert_eq!(
                ov.vertex_key[k],
                crate::estimate::equilibrate::sweep_key(colours[g], g)
            );
        }
        let u: Vec<f64> = (0..mesh.num_dofs()).map(|d| d as f64).collect();
        let us = ov.restrict_dofs(&u);
        assert_eq!(us.len(), ov.mesh.num_dofs());
        assert!(ov
            .nodes
            .iter()
            .enumerate()
            .all(|(k, &g)| us[2 * k + 1] == (2 * g + 1) as f64));
        // Real boundary edges only: every listed edge is on the full mesh's boundary.
        let (_, bd) = block_rect(8, 6);
        let bs = ov.restrict_boundary(&bd);
        assert!(!bs.edges.is_empty() && bs.edges.len() < bd.edges.len());
        for be in &bs.edges {
            let g = be.nodes.map(|v| ov.nodes[v]);
            assert!(bd.edges.iter().any(|b| b.nodes == g && b.comps == be.comps));
        }
        assert!(ov
            .nodes
            .iter()
            .enumerate()
            .all(|(k, &g)| bs.constrained[2 * k] == bd.constrained[2 * g]));
        // Unbounded rings: the whole (connected) mesh; Recovery::Star asks for that and is
        // refused anyway.
        let rings = Overlap::rings_for(Recovery::star(), 4);
        let all = Overlap::new(&mesh, &own, rings, &colours);
        assert_eq!(all.elements.len(), nt);
        let (_, bd) = block_rect(8, 6);
        let err = equilibrate_restricted(
            &all.mesh,
            &STEEL,
            &all.restrict_dofs(&u),
            &all.restrict_boundary(&bd),
            Recovery::star(),
            Some(&all.restriction()),
            None,
            None,
        );
        assert!(matches!(
            err,
            Err(EquilibrationError::RestrictedMinimumEnergy)
        ));
    }
}
