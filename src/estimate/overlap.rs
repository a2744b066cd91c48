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
mod tests;
