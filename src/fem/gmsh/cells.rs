//! A Gmsh mesh's elements of one kind (triangles, lines) with the physical tags of their
//! entity ([`Cells`]) and the triangles' element tags ([`ElementTags`]), held compactly: nodes
//! in 4 bytes, and each element's tags as an index into the mesh's few distinct tag lists (an
//! element's own list would cost a heap block each: about 80 bytes per triangle where this
//! costs 16, on every rank that holds the mesh).

/// Elements of `N` nodes, each with the physical tags of its entity.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Cells<const N: usize> {
    nodes: Vec<[u32; N]>,
    /// Each element's tags: an index into `sets`.
    set: Vec<u32>,
    sets: Vec<Vec<i32>>,
}

impl<const N: usize> Cells<N> {
    pub fn with_capacity(n: usize) -> Cells<N> {
        Cells {
            nodes: Vec::with_capacity(n),
            set: Vec::with_capacity(n),
            sets: Vec::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Add an element: its nodes (fewer than 2³²: a Gmsh mesh nndd reads is far smaller) and
    /// its tags.
    pub fn push(&mut self, nodes: [usize; N], tags: &[i32]) {
        let set = match self.set.last() {
            // (elements come entity by entity: the last element's tags, most often)
            Some(&s) if self.sets[s as usize] == tags => s,
            _ => match self.sets.iter().position(|t| t == tags) {
                Some(s) => s as u32,
                None => {
                    self.sets.push(tags.to_vec());
                    (self.sets.len() - 1) as u32
                }
            },
        };
        self.nodes.push(narrow(nodes));
        self.set.push(set);
    }

    /// A new element of nodes `nodes` with the tags of element `like`.
    pub fn push_like(&mut self, nodes: [usize; N], like: usize) {
        let set = self.set[like];
        self.nodes.push(narrow(nodes));
        self.set.push(set);
    }

    /// Element `i`'s nodes set to `nodes`.
    pub fn set_nodes(&mut self, i: usize, nodes: [usize; N]) {
        self.nodes[i] = narrow(nodes);
    }

    /// The nodes of element `i`.
    pub fn nodes(&self, i: usize) -> [usize; N] {
        self.nodes[i].map(|v| v as usize)
    }

    /// The physical tags of element `i`.
    pub fn tags(&self, i: usize) -> &[i32] {
        &self.sets[self.set[i] as usize]
    }

    /// What a [`Cells`] is made of: each element's nodes and index into the tag lists, and
    /// the lists (for [`super::GmshMesh::to_bytes`]).
    pub(super) fn parts(&self) -> (&[[u32; N]], &[u32], &[Vec<i32>]) {
        (&self.nodes, &self.set, &self.sets)
    }

    /// The [`Cells`] of those parts, if they make one.
    pub(super) fn from_parts(
        nodes: Vec<[u32; N]>,
        set: Vec<u32>,
        sets: Vec<Vec<i32>>,
    ) -> Option<Cells<N>> {
        let fits = nodes.len() == set.len() && set.iter().all(|&s| (s as usize) < sets.len());
        fits.then_some(Cells { nodes, set, sets })
    }

    /// Each element's nodes and tags, in order.
    pub fn iter(&self) -> CellIter<'_, N> {
        CellIter { cells: self, i: 0 }
    }
}

/// The iterator of [`Cells::iter`].
pub struct CellIter<'a, const N: usize> {
    cells: &'a Cells<N>,
    i: usize,
}

impl<'a, const N: usize> Iterator for CellIter<'a, N> {
    type Item = ([usize; N], &'a [i32]);
    fn next(&mut self) -> Option<Self::Item> {
        let i = self.i;
        (i < self.cells.len()).then(|| {
            self.i += 1;
            (self.cells.nodes(i), self.cells.tags(i))
        })
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.cells.len() - self.i;
        (left, Some(left))
    }
}

/// An element's nodes as stored.
fn narrow<const N: usize>(nodes: [usize; N]) -> [u32; N] {
    nodes.map(|v| u32::try_from(v).expect("a Gmsh mesh has fewer than 2^32 nodes"))
}

impl<'a, const N: usize> IntoIterator for &'a Cells<N> {
    type Item = ([usize; N], &'a [i32]);
    type IntoIter = CellIter<'a, N>;
    fn into_iter(self) -> CellIter<'a, N> {
        self.iter()
    }
}

impl<const N: usize> From<Vec<([usize; N], Vec<i32>)>> for Cells<N> {
    fn from(v: Vec<([usize; N], Vec<i32>)>) -> Cells<N> {
        let mut c = Cells::with_capacity(v.len());
        for (nodes, tags) in v {
            c.push(nodes, &tags);
        }
        c
    }
}

/// The Gmsh element tag of each triangle, held as runs (Gmsh numbers a block's elements
/// consecutively, and a refined triangle's r² children share its tag): a few runs where a tag
/// per element would cost 8 bytes each on every rank.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ElementTags {
    /// (first element, its tag, the step from one element to the next: 0, 1, or [`OPEN`]
    /// while the run has one element).
    runs: Vec<(usize, u64, u8)>,
    len: usize,
}

/// The step of a run of one element, which the next element decides.
const OPEN: u8 = 2;

impl ElementTags {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The next element's tag.
    pub fn push(&mut self, tag: u64) {
        let i = self.len;
        self.len += 1;
        if let Some((first, start, step)) = self.runs.last_mut() {
            let at = (i - *first) as u64;
            let joins = match *step {
                OPEN if tag == *start || tag == *start + 1 => {
                    *step = (tag - *start) as u8;
                    true
                }
                OPEN => false,
                s => tag == *start + s as u64 * at,
            };
            if joins {
                return;
            }
        }
        self.runs.push((i, tag, OPEN));
    }

    /// Element `i`'s tag.
    pub fn get(&self, i: usize) -> u64 {
        assert!(i < self.len, "element {i} of {}", self.len);
        let r = self.runs.partition_point(|&(first, _, _)| first <= i) - 1;
        let (first, start, step) = self.runs[r];
        start + (step % OPEN) as u64 * (i - first) as u64
    }

    /// The runs (first element, its tag, step) and the element count (for
    /// [`super::GmshMesh::to_bytes`]).
    pub(super) fn runs(&self) -> (&[(usize, u64, u8)], usize) {
        (&self.runs, self.len)
    }

    /// The [`ElementTags`] of those runs, if they make one.
    pub(super) fn from_runs(runs: Vec<(usize, u64, u8)>, len: usize) -> Option<ElementTags> {
        let ordered = runs.windows(2).all(|w| w[0].0 < w[1].0)
            && runs.first().is_none_or(|r| r.0 == 0)
            && runs.last().is_none_or(|r| r.0 < len)
            && runs.iter().all(|r| r.2 <= OPEN);
        (ordered && (len == 0) == runs.is_empty()).then_some(ElementTags { runs, len })
    }

    /// Every element's tag, in order.
    pub fn iter(&self) -> impl Iterator<Item = u64> + '_ {
        (0..self.len).map(|i| self.get(i))
    }
}

impl FromIterator<u64> for ElementTags {
    fn from_iter<I: IntoIterator<Item = u64>>(it: I) -> ElementTags {
        let mut t = ElementTags::default();
        it.into_iter().for_each(|v| t.push(v));
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_element_keeps_its_nodes_and_tags_with_one_list_per_distinct_tags() {
        let given = vec![
            ([0, 1, 2], vec![1]),
            ([2, 1, 3], vec![1]),
            ([3, 4, 5], vec![2, 7]),
            ([5, 4, 6], vec![]),
            ([6, 7, 8], vec![1]),
        ];
        let c = Cells::from(given.clone());
        assert_eq!(c.len(), 5);
        let back: Vec<([usize; 3], Vec<i32>)> = c.iter().map(|(n, t)| (n, t.to_vec())).collect();
        assert_eq!(back, given);
        assert_eq!(c.sets.len(), 3, "{:?}", c.sets);
    }

    #[test]
    fn element_tags_come_back_as_given_in_few_runs() {
        // A block numbered 1.., a refined mesh's repeated tags, a lone tag, a block again.
        let given: Vec<u64> = (1..=50)
            .chain([7, 7, 7, 7, 9, 9, 9, 9])
            .chain([1000])
            .chain(200..260)
            .collect();
        let t: ElementTags = given.iter().copied().collect();
        assert_eq!(t.len(), given.len());
        assert_eq!(t.iter().collect::<Vec<_>>(), given);
        assert_eq!(t.runs.len(), 5, "{:?}", t.runs);
    }
}
