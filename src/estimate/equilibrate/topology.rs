//! Mesh topology: edges (sorted node pairs) with their elements and geometry, vertex stars,
//! the vertex colouring and sweep keys of the multicolour order, and the owned elements and
//! vertices of a restriction.

use super::error::EquilibrationError;
use super::sizes::NONE;
use crate::fem::geometry::triangle_area;
use crate::fem::mesh::{element_u32, Mesh};

/// Sweep-order key of a vertex for `Recovery::PatchClassic`: colour in the high 32 bits, global
/// vertex index in the low ones.
pub fn sweep_key(colour: u8, global_index: usize) -> u64 {
    ((colour as u64) << 32) | global_index as u64
}

/// Vertex colouring for the multicolour order: two vertices of one element never share a
/// colour. Greedy colouring (every vertex the smallest colour its coloured neighbours do not
/// use):
/// - structured meshes ([`Mesh::structured`], six neighbours per interior vertex): in vertex
///   index order, 4 colours (for nx ≥ 2, ny ≥ 2). Smallest-last would find the lattice's 3,
///   but the published figures were made with these 4, and they change with the order;
/// - other meshes: in index order and in smallest-last order (Matula–Beck: repeatedly
///   remove a vertex of least remaining degree, colour in the reverse order), the one with
///   fewer colours kept (ties: index order). On the Gmsh meshes of `examples/hertz`
///   smallest-last saves one or two of index order's 6–7, and the overlap of a split body
///   grows with the colours (`Overlap::rings_for`).
///
/// Panics if a triangle refers to a missing node or if more than 255 colours are needed.
pub fn vertex_colours(mesh: &Mesh) -> Vec<u8> {
    let natural = index_order_colours(mesh);
    if mesh.is_structured() {
        return natural;
    }
    let neighbours = Neighbours::of(mesh);
    let order = smallest_last_order(&neighbours);
    let smallest_last = greedy_colours(&neighbours, order.iter().rev().map(|&i| i as usize));
    let count = |c: &[u8]| c.iter().max().map_or(0, |&m| m as usize + 1);
    if count(&smallest_last) < count(&natural) {
        smallest_last
    } else {
        natural
    }
}

/// Greedy colouring in vertex index order, straight from the vertex stars: on the
/// structured meshes, where it is the only colouring made, no neighbour lists are built.
/// The colouring is made on the whole body by every rank that estimates a part of it, for
/// the estimate's shares, while the bodies' factorisations are still held
/// (`share::Share::new`): its stars and lists are what a rank then holds beyond them.
fn index_order_colours(mesh: &Mesh) -> Vec<u8> {
    let nn = mesh.num_nodes();
    let (ptr, around) = vertex_stars(mesh, |e, _| element_u32(e));
    let mut colour = vec![0u8; nn];
    for i in 0..nn {
        let mut used = [0u64; 4];
        for &e in &around[ptr[i]..ptr[i + 1]] {
            for &v in &mesh.triangles.get(e as usize) {
                if v < i {
                    let c = colour[v] as usize;
                    used[c / 64] |= 1 << (c % 64);
                }
            }
        }
        let c = (0..255)
            .find(|&c| used[c / 64] & (1 << (c % 64)) == 0)
            .expect("vertex colouring: more than 255 colours");
        colour[i] = c as u8;
    }
    colour
}

/// The elements around every vertex of a mesh, in increasing order (12 bytes per element and
/// 8 per vertex): what growing many overlaps on one mesh reads (`overlap::Overlap::around`).
pub struct Stars {
    ptr: Vec<usize>,
    around: Vec<u32>,
}

impl Stars {
    pub fn of(mesh: &Mesh) -> Stars {
        let (ptr, around) = vertex_stars(mesh, |e, _| element_u32(e));
        Stars { ptr, around }
    }

    /// The elements around vertex `v`.
    pub fn at(&self, v: usize) -> &[u32] {
        &self.around[self.ptr[v]..self.ptr[v + 1]]
    }
}

/// The distinct neighbours (vertices sharing an element) of every vertex, sorted, as a
/// compressed list (8 bytes per vertex and 4 per neighbour).
struct Neighbours {
    ptr: Vec<usize>,
    adjacent: Vec<u32>,
}

impl Neighbours {
    fn of(mesh: &Mesh) -> Neighbours {
        let (stars, elements) = vertex_stars(mesh, |e, _| element_u32(e));
        let nn = mesh.num_nodes();
        let mut ptr = Vec::with_capacity(nn + 1);
        ptr.push(0);
        // (a vertex whose elements form one fan has at most one neighbour more than elements:
        // the list is allocated once)
        let mut adjacent = Vec::with_capacity(elements.len() + nn);
        let mut around = Vec::new();
        for i in 0..nn {
            around.clear();
            around.extend(
                (elements[stars[i]..stars[i + 1]].iter())
                    .flat_map(|&e| mesh.triangles.get(e as usize))
                    .filter(|&v| v != i)
                    .map(|v| v as u32),
            );
            around.sort_unstable();
            around.dedup();
            adjacent.extend_from_slice(&around);
            ptr.push(adjacent.len());
        }
        Neighbours { ptr, adjacent }
    }

    fn len(&self) -> usize {
        self.ptr.len() - 1
    }

    /// The neighbours of vertex i.
    fn at(&self, i: usize) -> &[u32] {
        &self.adjacent[self.ptr[i]..self.ptr[i + 1]]
    }
}

/// Greedy colouring in `order` (each vertex once).
fn greedy_colours(neighbours: &Neighbours, order: impl Iterator<Item = usize>) -> Vec<u8> {
    const UNSET: u8 = u8::MAX;
    let mut colour = vec![UNSET; neighbours.len()];
    for i in order {
        let mut used = [0u64; 4];
        for &v in neighbours.at(i) {
            let c = colour[v as usize];
            if c != UNSET {
                used[c as usize / 64] |= 1 << (c % 64);
            }
        }
        let c = (0..255)
            .find(|&c| used[c / 64] & (1 << (c % 64)) == 0)
            .expect("vertex colouring: more than 255 colours");
        colour[i] = c as u8;
    }
    colour
}

/// The smallest-last removal order: each vertex removed has the least degree among the
/// vertices left (ties: the lowest index of the lowest bucket entry; deterministic).
fn smallest_last_order(neighbours: &Neighbours) -> Vec<u32> {
    let nn = neighbours.len();
    let mut degree: Vec<u32> = (0..nn).map(|i| neighbours.at(i).len() as u32).collect();
    let max = degree.iter().copied().max().unwrap_or(0) as usize;
    // Buckets by degree with stale entries skipped (a vertex is pushed again when its
    // degree drops).
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); max + 1];
    for i in (0..nn).rev() {
        buckets[degree[i] as usize].push(i as u32);
    }
    let mut removed = vec![false; nn];
    let mut order = Vec::with_capacity(nn);
    let mut low = 0;
    while order.len() < nn {
        let Some(i) = buckets[low].pop() else {
            low += 1;
            continue;
        };
        let i = i as usize;
        if removed[i] || degree[i] as usize != low {
            continue;
        }
        removed[i] = true;
        order.push(i as u32);
        for &v in neighbours.at(i) {
            let v = v as usize;
            if !removed[v] {
                degree[v] -= 1;
                buckets[degree[v] as usize].push(v as u32);
                low = low.min(degree[v] as usize);
            }
        }
    }
    order
}

/// The elements around every vertex in increasing element order, each as `entry(e, local
/// vertex)`, as a compressed list: vertex i has `entries[ptr[i]..ptr[i + 1]]` (8 bytes per
/// vertex and 4 per entry, six entries per vertex of a triangulation).
fn vertex_stars(mesh: &Mesh, entry: impl Fn(usize, usize) -> u32) -> (Vec<usize>, Vec<u32>) {
    let nn = mesh.num_nodes();
    let mut ptr = vec![0usize; nn + 1];
    for t in &mesh.triangles {
        for v in t {
            ptr[v + 1] += 1;
        }
    }
    for i in 0..nn {
        ptr[i + 1] += ptr[i];
    }
    let mut fill = ptr.clone();
    let mut entries = vec![0u32; 3 * mesh.triangles.len()];
    for (e, t) in mesh.triangles.iter().enumerate() {
        for (a, &v) in t.iter().enumerate() {
            entries[fill[v]] = entry(e, a);
            fill[v] += 1;
        }
    }
    (ptr, entries)
}

/// Element e is owned (no restriction: every element is).
pub(super) fn is_owned(owned: Option<&[bool]>, e: usize) -> bool {
    owned.is_none_or(|o| o[e])
}

/// Per vertex: it is a vertex of an owned element (None without restriction: all are).
pub(super) fn owned_vertices(mesh: &Mesh, owned: Option<&[bool]>) -> Option<Vec<bool>> {
    owned.map(|o| {
        let mut v = vec![false; mesh.num_nodes()];
        for (t, _) in mesh.triangles.iter().zip(o).filter(|(_, &own)| own) {
            for a in t {
                v[a] = true;
            }
        }
        v
    })
}

/// Edges of the mesh (sorted node pairs), their elements and geometry, and vertex stars.
/// Indices are stored in 32 bits (half the memory); the accessors give `usize`.
pub(super) struct Topology {
    /// Nodes of each edge, n0 < n1.
    edge_nodes: Vec<[u32; 2]>,
    /// The plus element (the one the edge traction F̂_Γ acts on) and the minus element
    /// (`u32::MAX` on the boundary).
    edge_elems: Vec<[u32; 2]>,
    pub(super) edge_len: Vec<f64>,
    /// Whether the plus element runs along the edge from its first (lower) node to its
    /// second (its unit normal, outward of the plus element, is [`Topology::normal`]).
    plus_forward: Vec<bool>,
    /// Edge l of element e joins its local vertices l and l + 1.
    elem_edges: Vec<[u32; 3]>,
    pub(super) vert_ptr: Vec<usize>,
    /// 4 e + a (element, local vertex) for every vertex.
    vert_elems: Vec<u32>,
}

/// The elements (e, local vertex a) around a vertex ([`Topology::vertex_elements`]).
#[derive(Clone, Copy)]
pub(super) struct VertexElements<'a>(&'a [u32]);

impl VertexElements<'_> {
    pub(super) fn len(&self) -> usize {
        self.0.len()
    }

    pub(super) fn iter(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.0
            .iter()
            .map(|&p| ((p >> 2) as usize, (p & 3) as usize))
    }
}

fn wide(i: u32) -> usize {
    if i == u32::MAX {
        NONE
    } else {
        i as usize
    }
}

fn edge_key(a: usize, b: usize) -> u64 {
    let (a, b) = if a < b { (a, b) } else { (b, a) };
    ((a as u64) << 32) | b as u64
}

impl Topology {
    pub(super) fn new(mesh: &Mesh) -> Result<Topology, EquilibrationError> {
        let nt = mesh.triangles.len();
        let nn = mesh.num_nodes();
        let mut keys = Vec::with_capacity(3 * nt);
        for (e, t) in mesh.triangles.iter().enumerate() {
            if t.iter().any(|&v| v >= nn) || triangle_area(&mesh.triangle_points(e)) <= 0.0 {
                return Err(EquilibrationError::BadTriangle { element: e });
            }
            for l in 0..3 {
                keys.push(edge_key(t[l], t[(l + 1) % 3]));
            }
        }
        keys.sort_unstable();
        keys.dedup();
        let ne = keys.len();
        if ne >= u32::MAX as usize || nt >= (1 << 30) {
            return Err(EquilibrationError::TooLarge { elements: nt });
        }
        let edge_nodes: Vec<[u32; 2]> = keys
            .iter()
            .map(|&k| [(k >> 32) as u32, (k & 0xffff_ffff) as u32])
            .collect();
        let mut edge_elems = vec![[u32::MAX; 2]; ne];
        let mut edge_len = vec![0.0; ne];
        let mut plus_forward = vec![false; ne];
        let mut elem_edges = vec![[0u32; 3]; nt];
        for (e, t) in mesh.triangles.iter().enumerate() {
            for l in 0..3 {
                let (a, b) = (t[l], t[(l + 1) % 3]);
                let g = keys.binary_search(&edge_key(a, b)).unwrap();
                elem_edges[e][l] = g as u32;
                if edge_elems[g][0] == u32::MAX {
                    edge_elems[g][0] = e as u32;
                    let (pa, pb) = (mesh.points.get(a), mesh.points.get(b));
                    edge_len[g] = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
                    plus_forward[g] = a < b;
                } else if edge_elems[g][1] == u32::MAX {
                    edge_elems[g][1] = e as u32;
                } else {
                    return Err(EquilibrationError::NonManifoldEdge { a, b });
                }
            }
        }
        // (nt < 2³⁰ above: 4 e + a fits)
        let (vert_ptr, vert_elems) = vertex_stars(mesh, |e, a| (4 * e + a) as u32);
        Ok(Topology {
            edge_nodes,
            edge_elems,
            edge_len,
            plus_forward,
            elem_edges,
            vert_ptr,
            vert_elems,
        })
    }

    pub(super) fn vertex_elements(&self, i: usize) -> VertexElements<'_> {
        VertexElements(&self.vert_elems[self.vert_ptr[i]..self.vert_ptr[i + 1]])
    }

    pub(super) fn num_edges(&self) -> usize {
        self.edge_nodes.len()
    }

    /// The nodes of edge g, sorted.
    pub(super) fn nodes(&self, g: usize) -> [usize; 2] {
        self.edge_nodes[g].map(|v| v as usize)
    }

    /// The unit normal of edge g, outward of its plus element.
    pub(super) fn normal(&self, mesh: &Mesh, g: usize) -> [f64; 2] {
        let [lo, hi] = self.nodes(g);
        let (a, b) = if self.plus_forward[g] {
            (lo, hi)
        } else {
            (hi, lo)
        };
        let (pa, pb) = (mesh.points.get(a), mesh.points.get(b));
        let tv = [pb[0] - pa[0], pb[1] - pa[1]];
        let len = self.edge_len[g];
        [tv[1] / len, -tv[0] / len]
    }

    /// The plus and minus elements of edge g (NONE on the boundary).
    pub(super) fn elems(&self, g: usize) -> [usize; 2] {
        self.edge_elems[g].map(wide)
    }

    /// The edges of element e (edge l joins its local vertices l and l + 1).
    pub(super) fn edges_of(&self, e: usize) -> [usize; 3] {
        self.elem_edges[e].map(|g| g as usize)
    }

    pub(super) fn edge_id(&self, a: usize, b: usize) -> Option<usize> {
        let (a, b) = if a < b { (a, b) } else { (b, a) };
        let k = [a as u32, b as u32];
        self.edge_nodes.binary_search(&k).ok()
    }

    /// +1 if F̂_Γ acts on e (the plus element), −1 otherwise.
    pub(super) fn sign(&self, e: usize, g: usize) -> f64 {
        if self.edge_elems[g][0] as usize == e {
            1.0
        } else {
            -1.0
        }
    }

    /// Position (0 or 1) of node i in edge g.
    pub(super) fn end_of(&self, g: usize, i: usize) -> usize {
        if self.edge_nodes[g][0] as usize == i {
            0
        } else {
            1
        }
    }

    pub(super) fn local_edge(&self, e: usize, g: usize) -> usize {
        self.elem_edges[e]
            .iter()
            .position(|&x| x as usize == g)
            .unwrap()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The compressed stars and neighbour lists hold what the triangles say: each vertex's
    /// elements in increasing order, and its distinct neighbours sorted.
    #[test]
    fn stars_and_neighbours_are_the_triangles() {
        let mesh = Mesh::unstructured(
            vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.5, 1.0], [1.5, 1.0]],
            vec![[0, 1, 3], [1, 4, 3], [1, 2, 4]],
        );
        let (ptr, packed) = vertex_stars(&mesh, |e, a| (4 * e + a) as u32);
        let star = |i: usize| packed[ptr[i]..ptr[i + 1]].to_vec();
        assert_eq!(star(1), vec![1, 4, 8]); // (0, 1), (1, 0), (2, 0)
        assert_eq!(star(3), vec![2, 6]); // (0, 2), (1, 2)
        assert_eq!(star(2), vec![9]);
        let neighbours = Neighbours::of(&mesh);
        assert_eq!(neighbours.len(), 5);
        assert_eq!(neighbours.at(1), &[0, 2, 3, 4]);
        assert_eq!(neighbours.at(0), &[1, 3]);
        assert_eq!(neighbours.at(4), &[1, 2, 3]);
    }

    #[test]
    fn vertex_colouring_is_proper() {
        for (nx, ny) in [(1, 1), (2, 2), (5, 3), (16, 12), (64, 48)] {
            let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], nx, ny);
            let colours = vertex_colours(&mesh);
            for t in &mesh.triangles {
                let c = t.map(|v| colours[v]);
                assert!(c[0] != c[1] && c[1] != c[2] && c[2] != c[0], "{t:?}: {c:?}");
            }
            let count = colours.iter().map(|&c| c as usize + 1).max().unwrap();
            println!("{nx} x {ny}: {count} colours");
            assert_eq!(count, if nx >= 2 && ny >= 2 { 4 } else { 3 });
        }
    }

    #[test]
    fn smallest_last_colours_an_unstructured_mesh_with_fewer_colours() {
        // A structured mesh with its node numbering shuffled (and no longer marked
        // structured): index order then needs more than 4 colours, smallest-last finds the
        // lattice's 3, and the colouring is proper.
        let mut mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], 40, 40);
        let nn = mesh.num_nodes();
        let mut perm: Vec<usize> = (0..nn).collect();
        let mut seed = 11u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as usize
        };
        for i in (1..nn).rev() {
            perm.swap(i, next() % (i + 1));
        }
        let mut points = vec![[0.0; 2]; nn];
        for (i, p) in mesh.points.iter().enumerate() {
            points[perm[i]] = p;
        }
        mesh.points = points.into();
        (mesh.nx, mesh.ny) = (0, 0);
        mesh.triangles = mesh.triangles.iter().map(|t| t.map(|v| perm[v])).collect();
        let neighbours = Neighbours::of(&mesh);
        let count = |c: &[u8]| c.iter().max().map_or(0, |&m| m as usize + 1);
        let natural = count(&index_order_colours(&mesh));
        assert_eq!(
            index_order_colours(&mesh),
            greedy_colours(&neighbours, 0..nn)
        );
        let colours = vertex_colours(&mesh);
        for t in &mesh.triangles {
            let c = t.map(|v| colours[v]);
            assert!(c[0] != c[1] && c[1] != c[2] && c[2] != c[0], "{t:?}: {c:?}");
        }
        println!("index order: {natural} colours, kept: {}", count(&colours));
        assert!(natural > 4, "index order: {natural} colours");
        assert_eq!(count(&colours), 3);
    }
}
