//! How a mesh holds its points and triangles: a structured grid's by their formula, none
//! stored ([`Mesh::structured`](super::Mesh::structured): a built-in body costs a rank that
//! holds it no memory per node or element), a rank's part of a listed mesh by their global
//! indices ([`Mesh::part`](super::Mesh::part): the entries the rank reads), any other's listed.
//! All hand out values, not references, by index or in order.

use crate::fem::wire::{Reader, Writer};

/// A mesh's triangles: those of a structured grid by their formula (none stored: 12 B per
/// element less on every rank that holds a body, 6 MiB per body at `paper` n = 512), the
/// others stored with their nodes as `u32` (half the memory of `usize`), all handed out as
/// `usize`. A body has fewer than 2³² nodes: the size check refuses meshes far smaller.
#[derive(Clone, Debug, Default)]
pub struct Triangles(Store);

#[derive(Clone, Debug)]
enum Store {
    /// Each triangle's nodes.
    Listed(Vec<[u32; 3]>),
    /// The `nx × ny` grid of [`Mesh::structured`](super::Mesh::structured): rectangle (i, j)
    /// is elements 2 (j nx + i), (a, b, d), and 2 (j nx + i) + 1, (a, d, c).
    Grid { nx: usize, ny: usize },
    /// A rank's part: some triangles of a listed mesh, by their global index.
    Part(Part<[u32; 3]>),
}

/// Some entries of a list of `len`, by their global indices: a rank's part of a listed mesh.
#[derive(Clone, Debug)]
struct Part<T> {
    len: usize,
    /// The entries' indices, ascending.
    ids: Vec<u32>,
    values: Vec<T>,
}

impl<T: Copy> Part<T> {
    /// The entries `ids` (ascending, each below `len`) of `all`.
    fn of(len: usize, ids: &[u32], all: impl Fn(usize) -> T) -> Part<T> {
        debug_assert!(ids.windows(2).all(|w| w[0] < w[1]), "ascending ids");
        assert!(
            ids.last().is_none_or(|&i| (i as usize) < len),
            "ids below {len}"
        );
        Part {
            len,
            ids: ids.to_vec(),
            values: ids.iter().map(|&i| all(i as usize)).collect(),
        }
    }

    /// Entry `i`: one held (a binary search), else a panic naming `what`: a phase reads
    /// beyond the part it was given.
    fn get(&self, i: usize, what: &str) -> T {
        let found = u32::try_from(i).ok().map(|i| self.ids.binary_search(&i));
        match found {
            Some(Ok(k)) => self.values[k],
            _ => panic!(
                "{what} {i} is not in this rank's part of the mesh ({} of {} held)",
                self.ids.len(),
                self.len
            ),
        }
    }

    /// The held entries with their global indices, ascending.
    fn held(&self) -> impl Iterator<Item = (usize, T)> + '_ {
        (self.ids.iter())
            .zip(&self.values)
            .map(|(&i, &v)| (i as usize, v))
    }
}

impl Default for Store {
    fn default() -> Store {
        Store::Listed(Vec::new())
    }
}

/// A triangle's nodes as stored.
fn narrow(t: [usize; 3]) -> [u32; 3] {
    t.map(|v| u32::try_from(v).expect("a mesh has fewer than 2^32 nodes"))
}

/// An element number in 4 bytes (compact per-element lists: the estimate's vertex stars and
/// slab order): a body has fewer than 2³² elements (PETSc's 32-bit indices refuse far smaller
/// ones).
pub fn element_u32(e: usize) -> u32 {
    u32::try_from(e).expect("a mesh has fewer than 2^32 elements")
}

impl Triangles {
    pub fn with_capacity(n: usize) -> Triangles {
        Triangles(Store::Listed(Vec::with_capacity(n)))
    }

    /// The triangles of the `nx × ny` grid of [`Mesh::structured`](super::Mesh::structured),
    /// none stored.
    pub(super) fn grid(nx: usize, ny: usize) -> Triangles {
        // (its node numbers fit in 4 bytes, as a stored mesh's: the per-node lists rely on it)
        let nodes = (nx + 1) * (ny + 1);
        assert!(
            u32::try_from(nodes).is_ok(),
            "a mesh has fewer than 2^32 nodes"
        );
        Triangles(Store::Grid { nx, ny })
    }

    pub fn len(&self) -> usize {
        match &self.0 {
            Store::Listed(t) => t.len(),
            Store::Grid { nx, ny } => 2 * nx * ny,
            Store::Part(p) => p.len,
        }
    }

    /// The triangles this store can hand out: all of a listed or grid mesh, a part's own.
    pub fn held_len(&self) -> usize {
        match &self.0 {
            Store::Part(p) => p.ids.len(),
            _ => self.len(),
        }
    }

    /// The triangles this store can hand out, with their indices, ascending: all of a listed
    /// or grid mesh, a part's own.
    pub fn held(&self) -> Box<dyn Iterator<Item = (usize, [usize; 3])> + '_> {
        let wide = |t: [u32; 3]| t.map(|v| v as usize);
        match &self.0 {
            Store::Part(p) => Box::new(p.held().map(move |(e, t)| (e, wide(t)))),
            _ => Box::new(self.iter().enumerate()),
        }
    }

    /// The triangles `ids` (ascending) of these, as a part: what a rank reads of a mesh.
    pub(super) fn part(&self, ids: &[u32]) -> Triangles {
        Triangles(Store::Part(Part::of(self.len(), ids, |e| {
            narrow(self.get(e))
        })))
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The nodes of triangle `e`.
    pub fn get(&self, e: usize) -> [usize; 3] {
        match &self.0 {
            Store::Listed(t) => t[e].map(|v| v as usize),
            &Store::Grid { nx, ny } => {
                assert!(e < 2 * nx * ny, "triangle {e} of a grid of {}", 2 * nx * ny);
                let (i, j) = ((e / 2) % nx, e / 2 / nx);
                let a = j * (nx + 1) + i;
                let (b, c) = (a + 1, a + nx + 1);
                match e % 2 {
                    0 => [a, b, c + 1],
                    _ => [a, c + 1, c],
                }
            }
            Store::Part(p) => p.get(e, "triangle").map(|v| v as usize),
        }
    }

    /// Appends triangle `t` (a grid's triangles are listed first; a part is not extended).
    pub fn push(&mut self, t: [usize; 3]) {
        match &mut self.0 {
            Store::Grid { .. } => {
                self.0 = Store::Listed(self.iter().map(narrow).collect());
                self.push(t);
            }
            Store::Listed(v) => v.push(narrow(t)),
            Store::Part(_) => panic!("a rank's part of a mesh is not extended"),
        }
    }

    /// The triangles' nodes, in order.
    pub fn iter(&self) -> TriangleIter<'_> {
        ByIndex {
            store: self,
            range: 0..self.len(),
        }
    }
}

impl PartialEq for Triangles {
    /// The same triangles, listed or by their grid's formula.
    fn eq(&self, other: &Triangles) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

impl Eq for Triangles {}

impl<'a> IntoIterator for &'a Triangles {
    type Item = [usize; 3];
    type IntoIter = TriangleIter<'a>;
    fn into_iter(self) -> TriangleIter<'a> {
        self.iter()
    }
}

impl FromIterator<[usize; 3]> for Triangles {
    fn from_iter<I: IntoIterator<Item = [usize; 3]>>(it: I) -> Triangles {
        Triangles(Store::Listed(it.into_iter().map(narrow).collect()))
    }
}

impl From<Vec<[usize; 3]>> for Triangles {
    fn from(v: Vec<[usize; 3]>) -> Triangles {
        v.into_iter().collect()
    }
}

/// A mesh's points: a structured grid's by their formula (none stored: 16 B per node less
/// on every rank that holds a body), the others listed.
#[derive(Clone, Debug, Default)]
pub struct Points(PointStore);

#[derive(Clone, Debug)]
enum PointStore {
    /// Each point.
    Listed(Vec<[f64; 2]>),
    /// Node j (nx + 1) + i of the grid of [`Mesh::structured`](super::Mesh::structured), at
    /// origin + (i hx, j hy), hx = size.0 / nx, hy = size.1 / ny (as it stored them).
    Grid {
        origin: [f64; 2],
        h: [f64; 2],
        nx: usize,
        ny: usize,
    },
    /// A rank's part: some points of a listed mesh, by their global index.
    Part(Part<[f64; 2]>),
}

impl Default for PointStore {
    fn default() -> PointStore {
        PointStore::Listed(Vec::new())
    }
}

impl Points {
    /// The points of the `nx × ny` grid of the rectangle `origin + [0, size.0] × [0, size.1]`,
    /// none stored.
    pub(super) fn grid(origin: [f64; 2], size: [f64; 2], nx: usize, ny: usize) -> Points {
        let h = [size[0] / nx as f64, size[1] / ny as f64];
        Points(PointStore::Grid { origin, h, nx, ny })
    }

    pub fn len(&self) -> usize {
        match &self.0 {
            PointStore::Listed(p) => p.len(),
            PointStore::Grid { nx, ny, .. } => (nx + 1) * (ny + 1),
            PointStore::Part(p) => p.len,
        }
    }

    /// The points `ids` (ascending) of these, as a part: what a rank reads of a mesh.
    pub(super) fn part(&self, ids: &[u32]) -> Points {
        Points(PointStore::Part(Part::of(self.len(), ids, |i| self.get(i))))
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point `i`.
    pub fn get(&self, i: usize) -> [f64; 2] {
        match &self.0 {
            PointStore::Listed(p) => p[i],
            &PointStore::Grid { origin, h, nx, ny } => {
                assert!(
                    i < (nx + 1) * (ny + 1),
                    "point {i} of a grid of {}",
                    (nx + 1) * (ny + 1)
                );
                let (a, b) = (i % (nx + 1), i / (nx + 1));
                [origin[0] + a as f64 * h[0], origin[1] + b as f64 * h[1]]
            }
            PointStore::Part(p) => p.get(i, "point"),
        }
    }

    /// Appends point `p` (a grid's points are listed first).
    pub fn push(&mut self, p: [f64; 2]) {
        self.listed().push(p);
    }

    /// Moves point `i` to `p` (a grid's points are listed first).
    pub fn set(&mut self, i: usize, p: [f64; 2]) {
        self.listed()[i] = p;
    }

    /// The points as a list, a grid's listed first (a part is not changed).
    fn listed(&mut self) -> &mut Vec<[f64; 2]> {
        if let PointStore::Grid { .. } = self.0 {
            self.0 = PointStore::Listed(self.iter().collect());
        }
        match &mut self.0 {
            PointStore::Listed(v) => v,
            PointStore::Grid { .. } => unreachable!("listed above"),
            PointStore::Part(_) => panic!("a rank's part of a mesh is not changed"),
        }
    }

    /// The points, in order.
    pub fn iter(&self) -> PointIter<'_> {
        ByIndex {
            store: self,
            range: 0..self.len(),
        }
    }

    /// The points listed (a copy).
    pub fn to_vec(&self) -> Vec<[f64; 2]> {
        self.iter().collect()
    }
}

impl PartialEq for Points {
    /// The same points, listed or by their grid's formula.
    fn eq(&self, other: &Points) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

impl<'a> IntoIterator for &'a Points {
    type Item = [f64; 2];
    type IntoIter = PointIter<'a>;
    fn into_iter(self) -> PointIter<'a> {
        self.iter()
    }
}

impl FromIterator<[f64; 2]> for Points {
    fn from_iter<I: IntoIterator<Item = [f64; 2]>>(it: I) -> Points {
        Points(PointStore::Listed(it.into_iter().collect()))
    }
}

impl From<Vec<[f64; 2]>> for Points {
    fn from(v: Vec<[f64; 2]>) -> Points {
        Points(PointStore::Listed(v))
    }
}

/// Bytes of the stores ([`Triangles::write`], [`Points::write`]): a tag, then a listed store's
/// entries, a grid's dimensions, a part's length, indices and entries.
const LISTED: u8 = 0;
const GRID: u8 = 1;
const PART: u8 = 2;

impl Triangles {
    /// These triangles as bytes (a grid's by its dimensions).
    pub fn write(&self, w: &mut Writer) {
        let nodes = |w: &mut Writer, t: &[u32; 3]| t.iter().for_each(|&v| w.u32(v));
        match &self.0 {
            Store::Listed(t) => {
                w.u8(LISTED);
                w.list(t, nodes);
            }
            &Store::Grid { nx, ny } => {
                w.u8(GRID);
                w.int(nx);
                w.int(ny);
            }
            Store::Part(p) => {
                w.u8(PART);
                w.int(p.len);
                w.u32s(&p.ids);
                w.list(&p.values, nodes);
            }
        }
    }

    /// What [`Triangles::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Triangles> {
        let nodes = |r: &mut Reader| Some([r.u32()?, r.u32()?, r.u32()?]);
        Some(Triangles(match r.u8()? {
            LISTED => Store::Listed(r.list(12, nodes)?),
            GRID => Store::Grid {
                nx: r.int()?,
                ny: r.int()?,
            },
            PART => Store::Part(Part::read(r, 12, nodes)?),
            _ => return None,
        }))
    }
}

impl Points {
    /// These points as bytes (a grid's by its formula's constants).
    pub fn write(&self, w: &mut Writer) {
        match &self.0 {
            PointStore::Listed(p) => {
                w.u8(LISTED);
                w.points(p);
            }
            &PointStore::Grid { origin, h, nx, ny } => {
                w.u8(GRID);
                w.points(&[origin, h]);
                w.int(nx);
                w.int(ny);
            }
            PointStore::Part(p) => {
                w.u8(PART);
                w.int(p.len);
                w.u32s(&p.ids);
                w.points(&p.values);
            }
        }
    }

    /// What [`Points::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Points> {
        let point = |r: &mut Reader| Some([r.f64()?, r.f64()?]);
        Some(Points(match r.u8()? {
            LISTED => PointStore::Listed(r.points()?),
            GRID => {
                let [origin, h] = <[[f64; 2]; 2]>::try_from(r.points()?).ok()?;
                PointStore::Grid {
                    origin,
                    h,
                    nx: r.int()?,
                    ny: r.int()?,
                }
            }
            PART => PointStore::Part(Part::read(r, 16, point)?),
            _ => return None,
        }))
    }
}

impl<T> Part<T> {
    /// A part's length, ascending indices below it, and as many entries, each of at least
    /// `entry` bytes read by `each`.
    fn read(
        r: &mut Reader,
        entry: usize,
        each: impl FnMut(&mut Reader) -> Option<T>,
    ) -> Option<Part<T>> {
        let len = r.int()?;
        let ids = r.u32s()?;
        let values = r.list(entry, each)?;
        let sound = ids.windows(2).all(|w| w[0] < w[1])
            && ids.last().is_none_or(|&i| (i as usize) < len)
            && values.len() == ids.len();
        sound.then_some(Part { len, ids, values })
    }
}

/// What [`ByIndex`] hands out: a mesh's points or triangles by index.
pub trait Indexed {
    type Item;
    fn at(&self, i: usize) -> Self::Item;
}

impl Indexed for Triangles {
    type Item = [usize; 3];
    fn at(&self, e: usize) -> [usize; 3] {
        self.get(e)
    }
}

impl Indexed for Points {
    type Item = [f64; 2];
    fn at(&self, i: usize) -> [f64; 2] {
        self.get(i)
    }
}

/// The iterator of [`Triangles::iter`] and [`Points::iter`]: each by index, in order.
#[derive(Clone, Debug)]
pub struct ByIndex<'a, S> {
    store: &'a S,
    range: std::ops::Range<usize>,
}

/// The iterator of [`Triangles::iter`].
pub type TriangleIter<'a> = ByIndex<'a, Triangles>;

/// The iterator of [`Points::iter`].
pub type PointIter<'a> = ByIndex<'a, Points>;

impl<S: Indexed> Iterator for ByIndex<'_, S> {
    type Item = S::Item;
    fn next(&mut self) -> Option<S::Item> {
        self.range.next().map(|i| self.store.at(i))
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        self.range.size_hint()
    }
    fn nth(&mut self, n: usize) -> Option<S::Item> {
        self.range.nth(n).map(|i| self.store.at(i))
    }
}

impl<S: Indexed> DoubleEndedIterator for ByIndex<'_, S> {
    fn next_back(&mut self) -> Option<S::Item> {
        self.range.next_back().map(|i| self.store.at(i))
    }
}

impl<S: Indexed> ExactSizeIterator for ByIndex<'_, S> {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::mesh::Mesh;

    #[test]
    fn triangles_hand_back_their_nodes_from_four_bytes_each() {
        let v = vec![[0, 1, 5], [0, 5, 4], [1, 2, 6]];
        let t = Triangles::from(v.clone());
        assert_eq!(t.iter().collect::<Vec<_>>(), v);
        assert_eq!(t.get(1), [0, 5, 4]);
        match &t.0 {
            Store::Listed(l) => assert_eq!(std::mem::size_of_val(&l[..]), 3 * 12),
            _ => panic!("listed triangles stored otherwise"),
        }
        let top = [0, 1, u32::MAX as usize];
        assert_eq!(Triangles::from(vec![top]).get(0), top);
    }

    #[test]
    fn a_grid_s_triangles_are_its_rectangles_split_along_a_d_and_none_are_stored() {
        let (nx, ny) = (3, 2);
        let m = Mesh::structured([0.0, 0.0], [1.0, 1.0], nx, ny);
        assert!(matches!(m.triangles.0, Store::Grid { .. }));
        // The rectangles listed row by row, as docs/benchmarks.md draws them.
        let mut listed = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let (a, c) = (m.node(i, j), m.node(i, j + 1));
                listed.push([a, a + 1, c + 1]);
                listed.push([a, c + 1, c]);
            }
        }
        assert_eq!(m.triangles.iter().collect::<Vec<_>>(), listed);
        assert_eq!(m.triangles.iter().rev().nth(2), Some(listed[9]));
        assert_eq!(m.triangles.iter().len(), 12);
        assert_eq!(m.triangles, Triangles::from(listed.clone()));
        // Every triangle counter-clockwise, and the grid's area covered once.
        let areas: Vec<f64> = (m.triangles.iter())
            .map(|t| crate::fem::geometry::triangle_area(&t.map(|v| m.points.get(v))))
            .collect();
        assert!(areas.iter().all(|&a| a > 0.0), "{areas:?}");
        let area: f64 = areas.iter().sum();
        assert!((area - 1.0).abs() < 1e-14, "area {area}");
        // A triangle appended to a grid lists the grid's before it.
        let mut grown = m.triangles.clone();
        grown.push([0, 1, 2]);
        listed.push([0, 1, 2]);
        assert_eq!(grown.iter().collect::<Vec<_>>(), listed);
        assert!(matches!(grown.0, Store::Listed(_)));
    }

    #[test]
    #[should_panic(expected = "fewer than 2^32 nodes")]
    fn a_node_beyond_u32_is_refused() {
        let _ = Triangles::from(vec![[0, 1, 1 << 32]]);
    }

    #[test]
    fn a_grid_s_points_are_the_ones_it_listed_bit_for_bit() {
        let (origin, size, nx, ny) = ([0.1, 0.9], [1.0 / 3.0, 0.7], 7, 5);
        let m = Mesh::structured(origin, size, nx, ny);
        assert!(matches!(m.points.0, PointStore::Grid { .. }));
        // What the grid used to list, in node order j (nx + 1) + i.
        let (hx, hy) = (size[0] / nx as f64, size[1] / ny as f64);
        let mut listed = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                listed.push([origin[0] + i as f64 * hx, origin[1] + j as f64 * hy]);
            }
        }
        let bits =
            |p: &[[f64; 2]]| -> Vec<[u64; 2]> { p.iter().map(|q| q.map(f64::to_bits)).collect() };
        assert_eq!(bits(&m.points.to_vec()), bits(&listed));
        assert_eq!(m.points.len(), 48);
        assert_eq!(m.points.iter().rev().nth(8), Some(listed[39]));
        assert_eq!(m.points, Points::from(listed.clone()));
        assert_eq!(m.points.get(m.node(3, 2)), listed[2 * 8 + 3]);
        let mut grown = m.points.clone();
        grown.push([9.0, 9.0]);
        listed.push([9.0, 9.0]);
        assert_eq!(grown.to_vec(), listed);
        assert!(matches!(grown.0, PointStore::Listed(_)));
        let mut moved = m.points.clone();
        moved.set(5, [-1.0, 2.0]);
        assert_eq!(moved.get(5), [-1.0, 2.0]);
        assert_eq!(moved.get(6), listed[6]);
    }

    #[test]
    fn a_part_hands_out_its_entries_as_the_whole_mesh_does_and_holds_no_others() {
        let whole = Mesh::unstructured(
            Mesh::structured([0.0, 0.0], [1.0, 1.0], 4, 3)
                .points
                .to_vec(),
            Mesh::structured([0.0, 0.0], [1.0, 1.0], 4, 3)
                .triangles
                .iter()
                .collect(),
        );
        let part = whole.part(&[7, 2, 7, 20], &[19]);
        // The counts and the numbering are the whole mesh's.
        assert_eq!((part.triangles.len(), part.num_nodes()), (24, 20));
        assert_eq!(part.triangles.held_len(), 3);
        let held: Vec<(usize, [usize; 3])> = part.triangles.held().collect();
        let expected: Vec<(usize, [usize; 3])> =
            [2, 7, 20].map(|e| (e, whole.triangles.get(e))).to_vec();
        assert_eq!(held, expected);
        for (_, t) in &held {
            for &v in t {
                assert_eq!(part.points.get(v), whole.points.get(v));
            }
        }
        assert_eq!(part.points.get(19), whole.points.get(19));
        // (a triangle's chain edge found among the triangles held)
        let t = whole.triangles.get(20);
        assert_eq!(part.chain_elements(&[t[0], t[1]]), vec![Some(20)]);
        match &part.points.0 {
            PointStore::Part(p) => assert_eq!(p.ids, [1, 2, 3, 7, 8, 9, 12, 13, 18, 19]),
            _ => panic!("a part's points stored otherwise"),
        }
    }

    #[test]
    #[should_panic(expected = "triangle 3 is not in this rank's part of the mesh (1 of 24 held)")]
    fn a_triangle_beyond_the_part_is_refused() {
        let whole = Mesh::structured([0.0, 0.0], [1.0, 1.0], 4, 3);
        let _ = whole.part(&[2], &[]).triangles.get(3);
    }

    #[test]
    #[should_panic(expected = "point 12 of a grid of 12")]
    fn a_point_beyond_the_grid_is_refused() {
        let _ = Mesh::structured([0.0, 0.0], [1.0, 1.0], 3, 2)
            .points
            .get(12);
    }
}
