//! P1 triangle meshes: structured ones of the benchmark blocks (docs/benchmarks.md,
//! "Meshes") and unstructured ones (Gmsh input, sub-meshes), `nx = ny = 0`.
//!
//! A structured body is an `nx × ny` grid of equal rectangles; the rectangle with corners a
//! (lower left), b (lower right), c (upper left), d (upper right) is split into the triangles
//! (a, b, d) and (a, d, c), elements 2 (j nx + i) and 2 (j nx + i) + 1 where a is node (i, j).
//! Node (i, j) has index `j (nx + 1) + i`; its dofs are `2 node` (x) and `2 node + 1` (y). Its
//! points and triangles are given by these formulas, not stored ([`Points`], [`Triangles`]).
use std::collections::HashMap;

use crate::fem::wire::{Reader, Writer};

mod store;
pub use store::{element_u32, PointIter, Points, TriangleIter, Triangles};

/// A triangle mesh: structured (`nx × ny` grid of the rectangle `origin + [0, size.0] ×
/// [0, size.1]`) or unstructured (`nx = ny = 0`, `origin` and `size` its bounding box).
#[derive(Clone, Debug)]
pub struct Mesh {
    pub nx: usize,
    pub ny: usize,
    pub origin: [f64; 2],
    pub size: [f64; 2],
    pub points: Points,
    pub triangles: Triangles,
}

/// A 64-bit mixing step (the multiply–xorshift of splitmix64): fingerprints that cost about
/// a nanosecond per entry.
pub fn mix(h: u64, x: u64) -> u64 {
    let mut z = (h ^ x).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Mesh {
    /// Fingerprint of the mesh: its triangles and the bits of its coordinates (the plans of
    /// the estimator and the checkpoints are checked against it).
    pub fn fingerprint(&self) -> u64 {
        let mut h = mix(self.triangles.len() as u64, self.points.len() as u64);
        for t in &self.triangles {
            h = mix(h, (t[0] as u64) | (t[1] as u64) << 21 | (t[2] as u64) << 42);
        }
        for p in &self.points {
            h = mix(mix(h, p[0].to_bits()), p[1].to_bits());
        }
        h
    }

    /// This mesh's part a rank reads: the triangles `elements` and the points of their
    /// nodes and of `nodes`, by their global indices (the rest handed out by no one: reading
    /// one panics). The counts, the numbering and the bounding box are the whole mesh's.
    pub fn part(&self, elements: &[u32], nodes: &[u32]) -> Mesh {
        let mut elements = elements.to_vec();
        elements.sort_unstable();
        elements.dedup();
        let corners = elements
            .iter()
            .flat_map(|&e| self.triangles.get(e as usize));
        let mut held: Vec<u32> = (corners.map(|v| v as u32))
            .chain(nodes.iter().copied())
            .collect();
        held.sort_unstable();
        held.dedup();
        Mesh {
            points: self.points.part(&held),
            triangles: self.triangles.part(&elements),
            ..*self
        }
    }

    /// The mesh as bytes ([`Writer`]): what a rank that built it sends another, a part as a
    /// part, a grid by its formula.
    pub fn write(&self, w: &mut Writer) {
        w.int(self.nx);
        w.int(self.ny);
        w.points(&[self.origin, self.size]);
        self.points.write(w);
        self.triangles.write(w);
    }

    /// What [`Mesh::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Mesh> {
        let (nx, ny) = (r.int()?, r.int()?);
        let [origin, size] = <[[f64; 2]; 2]>::try_from(r.points()?).ok()?;
        Some(Mesh {
            nx,
            ny,
            origin,
            size,
            points: Points::read(r)?,
            triangles: Triangles::read(r)?,
        })
    }

    pub fn structured(origin: [f64; 2], size: [f64; 2], nx: usize, ny: usize) -> Mesh {
        Mesh {
            nx,
            ny,
            origin,
            size,
            points: Points::grid(origin, size, nx, ny),
            triangles: Triangles::grid(nx, ny),
        }
    }

    /// An unstructured mesh (triangles counter-clockwise).
    pub fn unstructured(points: Vec<[f64; 2]>, triangles: Vec<[usize; 3]>) -> Mesh {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in &points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        Mesh {
            nx: 0,
            ny: 0,
            origin: lo,
            size: [hi[0] - lo[0], hi[1] - lo[1]],
            points: points.into(),
            triangles: triangles.into(),
        }
    }

    /// Whether the mesh is a structured grid (`node(i, j)` and the side lists apply).
    pub fn is_structured(&self) -> bool {
        self.nx > 0 && self.ny > 0
    }

    /// The boundary edges (edges of exactly one triangle), oriented as in their triangle
    /// (counter-clockwise: the body is on the left), in triangle order.
    pub fn boundary_edges(&self) -> Vec<[usize; 2]> {
        // A side met once is on the boundary (the sides grouped by their smaller node, a
        // counting sort: no hashing and no global sort, as this runs at every recovery and at
        // the final check of large meshes).
        let mut boundary = vec![false; 3 * self.triangles.len()];
        for_each_side(self, |run| {
            if let [(_, side)] = run {
                boundary[*side as usize] = true;
            }
            false
        });
        (0..boundary.len())
            .filter(|&s| boundary[s])
            .map(|s| {
                let t = self.triangles.get(s / 3);
                [t[s % 3], t[(s % 3 + 1) % 3]]
            })
            .collect()
    }

    pub fn node(&self, i: usize, j: usize) -> usize {
        j * (self.nx + 1) + i
    }

    pub fn num_nodes(&self) -> usize {
        self.points.len()
    }

    pub fn num_dofs(&self) -> usize {
        2 * self.points.len()
    }

    /// Nodes of the bottom edge, left to right.
    pub fn bottom_nodes(&self) -> Vec<usize> {
        (0..=self.nx).map(|i| self.node(i, 0)).collect()
    }

    /// Nodes of the top edge, left to right.
    pub fn top_nodes(&self) -> Vec<usize> {
        (0..=self.nx).map(|i| self.node(i, self.ny)).collect()
    }

    /// Edges of the right side x = origin.0 + size.0, bottom to top.
    pub fn right_edges(&self) -> Vec<[usize; 2]> {
        (0..self.ny)
            .map(|j| [self.node(self.nx, j), self.node(self.nx, j + 1)])
            .collect()
    }

    /// The vertex coordinates of triangle `e`.
    pub fn triangle_points(&self, e: usize) -> [[f64; 2]; 3] {
        let t = self.triangles.get(e);
        t.map(|v| self.points.get(v))
    }

    /// The element of each edge `(a, b)` of the chain `nodes` (segment k joins nodes k and
    /// k + 1), or `None` where no triangle has that edge: one scan of the triangles with a map
    /// of the chain's edges only (memory O(chain), not O(mesh)); on a rank's part
    /// ([`Mesh::part`]) the triangles it holds.
    pub fn chain_elements(&self, nodes: &[usize]) -> Vec<Option<usize>> {
        let key = |a: usize, b: usize| (a.min(b), a.max(b));
        let mut wanted: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
        for (k, w) in nodes.windows(2).enumerate() {
            wanted.entry(key(w[0], w[1])).or_default().push(k);
        }
        let mut out = vec![None; nodes.len().saturating_sub(1)];
        for (e, t) in self.triangles.held() {
            for k in 0..3 {
                if let Some(segs) = wanted.get(&key(t[k], t[(k + 1) % 3])) {
                    for &s in segs {
                        // The first triangle with the edge, as a whole-mesh edge map gives.
                        out[s].get_or_insert(e);
                    }
                }
            }
        }
        out
    }

    /// The sub-mesh of the triangles `elements` (in this order) and the mesh's node of each of
    /// its nodes (in increasing order, numbered 0.. in the sub-mesh); unstructured, its
    /// `origin` and `size` the whole mesh's.
    pub fn sub_mesh<I>(&self, elements: I) -> (Mesh, Vec<usize>)
    where
        I: IntoIterator<Item = usize> + Clone,
    {
        let (nodes, local) = self.sub_nodes(elements.clone());
        let sub = Mesh {
            nx: 0,
            ny: 0,
            origin: self.origin,
            size: self.size,
            points: nodes.iter().map(|&v| self.points.get(v)).collect(),
            triangles: (elements.into_iter())
                .map(|e| self.triangles.get(e).map(|v| local.of(&nodes, v)))
                .collect(),
        };
        (sub, nodes)
    }

    /// The nodes of the triangles `elements`, increasing, and their numbering 0.. ([`SubNodes`]):
    /// a map of the whole mesh's nodes where the triangles have at least one corner per 8 of
    /// them (4 B per node, no more than the sub-mesh's own points), else a search of the sorted
    /// nodes, so that a small sub-mesh of a large mesh (an overlap on one of many ranks) costs
    /// nothing of the mesh's size.
    fn sub_nodes<I: IntoIterator<Item = usize> + Clone>(
        &self,
        elements: I,
    ) -> (Vec<usize>, SubNodes) {
        let corners = 3 * elements.clone().into_iter().count();
        if 8 * corners < self.num_nodes() {
            let mut nodes: Vec<usize> = (elements.into_iter())
                .flat_map(|e| self.triangles.get(e))
                .collect();
            nodes.sort_unstable();
            nodes.dedup();
            return (nodes, SubNodes::Sorted);
        }
        const NONE: u32 = u32::MAX;
        let mut local = vec![NONE; self.num_nodes()];
        for e in elements {
            self.triangles.get(e).iter().for_each(|&v| local[v] = 0);
        }
        let nodes: Vec<usize> = (0..local.len()).filter(|&v| local[v] != NONE).collect();
        for (k, &v) in nodes.iter().enumerate() {
            local[v] = k as u32;
        }
        (nodes, SubNodes::Map(local))
    }

    /// Sorted node neighbourhoods (each node with itself), the sparsity pattern of P1.
    pub fn node_neighbours(&self) -> Vec<Vec<usize>> {
        let mut nb: Vec<Vec<usize>> = (0..self.num_nodes()).map(|i| vec![i]).collect();
        for t in &self.triangles {
            for a in t {
                for b in t {
                    if a != b {
                        nb[a].push(b);
                    }
                }
            }
        }
        for l in &mut nb {
            l.sort_unstable();
            l.dedup();
        }
        nb
    }
}

/// Every side of every triangle as (larger node, 3 e + k) for side k (from node k to node
/// k + 1) of triangle e, grouped by the smaller node (compressed rows, a counting sort) and
/// sorted within each group: the runs of equal entries are the sides met more than once.
/// (A rank that holds a body's triangles only, not its points, still finds its sides: the
/// groups run over the nodes the triangles name.)
fn side_groups(mesh: &Mesh) -> (Vec<u32>, Vec<(u32, u32)>) {
    let n = mesh.triangles.iter().flatten().max().map_or(0, |m| m + 1);
    let mut start = vec![0u32; n + 1];
    for t in &mesh.triangles {
        for k in 0..3 {
            start[t[k].min(t[(k + 1) % 3]) + 1] += 1;
        }
    }
    for a in 0..n {
        start[a + 1] += start[a];
    }
    let mut fill = start.clone();
    let mut sides = vec![(0u32, 0u32); 3 * mesh.triangles.len()];
    for (e, t) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let lo = a.min(b);
            sides[fill[lo] as usize] = (a.max(b) as u32, (3 * e + k) as u32);
            fill[lo] += 1;
        }
    }
    for a in 0..n {
        sides[start[a] as usize..start[a + 1] as usize].sort_unstable();
    }
    (start, sides)
}

/// Calls `f` on each run of sides with the same two nodes (3 e + k of each, at least one).
pub(crate) fn for_each_side(mesh: &Mesh, mut f: impl FnMut(&[(u32, u32)]) -> bool) -> bool {
    let (start, sides) = side_groups(mesh);
    for a in 0..start.len() - 1 {
        let group = &sides[start[a] as usize..start[a + 1] as usize];
        let mut i = 0;
        while i < group.len() {
            let mut j = i + 1;
            while j < group.len() && group[j].0 == group[i].0 {
                j += 1;
            }
            if f(&group[i..j]) {
                return true;
            }
            i = j;
        }
    }
    false
}

/// How [`Mesh::sub_mesh`] numbers its nodes: the sub-mesh's number of each of the whole mesh's
/// nodes, or a binary search of the sub-mesh's sorted nodes.
enum SubNodes {
    Map(Vec<u32>),
    Sorted,
}

impl SubNodes {
    /// The sub-mesh's number of the whole mesh's node `v`, one of `nodes` (sorted).
    fn of(&self, nodes: &[usize], v: usize) -> usize {
        match self {
            SubNodes::Map(local) => local[v] as usize,
            SubNodes::Sorted => nodes.binary_search(&v).expect("a node of the sub-mesh"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_elements_are_the_first_triangles_with_each_edge() {
        let m = Mesh::structured([0.0, 1.0], [1.0, 1.0], 5, 4);
        // The top side, a diagonal-crossing chain and an edge that no triangle has.
        for chain in [
            m.top_nodes(),
            vec![m.node(0, 0), m.node(1, 1), m.node(1, 2)],
        ] {
            let got = m.chain_elements(&chain);
            for (k, w) in chain.windows(2).enumerate() {
                let first = m.triangles.iter().position(|t| {
                    (0..3).any(|i| {
                        let (a, b) = (t[i], t[(i + 1) % 3]);
                        (a, b) == (w[0], w[1]) || (b, a) == (w[0], w[1])
                    })
                });
                assert_eq!(got[k], first, "segment {k} of {chain:?}");
                assert!(first.is_some());
            }
        }
        let apart = m.chain_elements(&[m.node(0, 0), m.node(2, 0)]);
        assert_eq!(apart, vec![None]);
    }

    /// A grid, a listed mesh and a part read back as written: the same points and triangles
    /// (a part's own, and its refusal of the rest), and truncated bytes refused.
    #[test]
    fn a_mesh_written_as_bytes_reads_back_the_same() {
        let grid = Mesh::structured([0.5, 1.0], [2.0, 1.5], 4, 3);
        let mut listed = grid.clone();
        listed.points.set(3, [0.25, 1.125]);
        let part = listed.part(&[2, 7, 11], &[19]);
        let round = |m: &Mesh| {
            let mut w = Writer::default();
            m.write(&mut w);
            let mut r = Reader::new(&w.0);
            let back = Mesh::read(&mut r).expect("read back");
            assert!(r.is_done());
            for cut in [1, w.0.len() / 2, w.0.len() - 1] {
                assert!(Mesh::read(&mut Reader::new(&w.0[..cut])).is_none());
            }
            back
        };
        for m in [&grid, &listed] {
            let back = round(m);
            assert_eq!(
                (back.nx, back.ny, back.origin, back.size),
                (m.nx, m.ny, m.origin, m.size)
            );
            assert_eq!(back.fingerprint(), m.fingerprint());
            assert!(back.points == m.points && back.triangles == m.triangles);
        }
        let back = round(&part);
        assert_eq!(back.triangles.len(), listed.triangles.len());
        let held: Vec<_> = back.triangles.held().collect();
        assert_eq!(held, part.triangles.held().collect::<Vec<_>>());
        assert_eq!(held.len(), 3);
        for (_, t) in held {
            for v in t {
                assert_eq!(back.points.get(v), listed.points.get(v));
            }
        }
        assert_eq!(back.points.get(19), listed.points.get(19));
        assert!(std::panic::catch_unwind(|| back.points.get(0)).is_err());
    }

    #[test]
    fn counts_area_and_diagonal() {
        let m = Mesh::structured([0.0, 1.0], [1.0, 1.0], 4, 3);
        assert_eq!(m.num_nodes(), 20);
        assert_eq!(m.triangles.len(), 24);
        let mut area = 0.0;
        for e in 0..m.triangles.len() {
            let p = m.triangle_points(e);
            let a = 0.5
                * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                    - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]));
            assert!(a > 0.0, "triangle {e} is not counter-clockwise");
            area += a;
        }
        assert!((area - 1.0).abs() < 1e-14);
        // The diagonal of the first rectangle goes from a = (0,1) to d = (0.25, 1 + 1/3).
        assert_eq!(m.triangles.get(0), [0, 1, 6]);
        assert_eq!(m.triangles.get(1), [0, 6, 5]);
        assert_eq!(m.top_nodes(), vec![15, 16, 17, 18, 19]);
        assert_eq!(m.right_edges()[0], [4, 9]);
    }

    /// A sub-mesh is numbered the same whether its nodes come from a map of the whole mesh's
    /// (many elements) or a search of its sorted nodes (few): its nodes increasing, each
    /// triangle's corners theirs.
    #[test]
    fn a_sub_mesh_is_numbered_alike_by_map_and_by_search() {
        let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], 20, 20);
        for (elements, sorted) in [(vec![5, 47, 46, 300], true), ((0..400).collect(), false)] {
            let (_, how) = mesh.sub_nodes(elements.iter().copied());
            assert_eq!(matches!(how, SubNodes::Sorted), sorted);
            let (sub, nodes) = mesh.sub_mesh(elements.iter().copied());
            let mut expected: Vec<usize> = (elements.iter())
                .flat_map(|&e| mesh.triangles.get(e))
                .collect();
            expected.sort_unstable();
            expected.dedup();
            assert_eq!(nodes, expected);
            for (k, &e) in elements.iter().enumerate() {
                let corners = sub.triangles.get(k).map(|v| nodes[v]);
                assert_eq!(corners, mesh.triangles.get(e));
            }
            for (k, &v) in nodes.iter().enumerate() {
                assert_eq!(sub.points.get(k), mesh.points.get(v));
            }
        }
    }
}
