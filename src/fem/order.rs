//! An order of a mesh's triangles in which consecutive ones lie together
//! ([`breadth_first`]: Cuthill–McKee's, from a pseudo-peripheral triangle of each connected
//! part). A block of consecutive triangles is then a band across the body, and nodes numbered
//! as the triangles first meet them make a block of nodes the band's: what a rank holds of a
//! body, its block of the elements and of the nodes and their neighbours, is close to its
//! share (docs/scaling.md, "Memory per rank"). Gmsh writes a surface's triangles in the order
//! its mesher made them, in which a block of them touches nodes all over the surface. The
//! order depends on the triangles' sides and their order alone, not on where they are: a mesh
//! turned or moved is ordered alike (and so estimated alike).

/// The order of a Gmsh body's triangles and nodes (`-nndd_mesh_order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ElementOrder {
    /// The mesh file's: the triangles as Gmsh wrote them, the nodes in the order of their
    /// tags.
    #[default]
    File,
    /// Bands across the body ([`breadth_first`]), the nodes numbered as the triangles first
    /// meet them.
    Bands,
}

/// Cells (triangles, or groups of them) numbered 0..`cells`, met in breadth-first searches
/// (Cuthill–McKee), each from a pseudo-peripheral cell of its connected part (the last one a
/// search from the part's first cell meets), the parts in the order of their first cells.
/// `sides` are the cells' sides as (side, cell), a side its two nodes (in either order); two
/// cells are neighbours where they share a side, and a cell's neighbours are met in
/// increasing order.
pub fn breadth_first(cells: usize, sides: Vec<([usize; 2], u32)>) -> Vec<usize> {
    let neighbours = Neighbours::of(cells, sides);
    let mut stamp = vec![0u32; cells];
    let mut order = Vec::with_capacity(cells);
    let mut search = 0;
    for first in 0..cells {
        if stamp[first] != 0 {
            continue;
        }
        // (a search from `first` that keeps nothing, then the one that numbers the part)
        search += 1;
        let start = neighbours.search(first, search, &mut stamp, &mut Vec::new());
        search += 1;
        neighbours.search(start, search, &mut stamp, &mut order);
    }
    order
}

/// The cells' neighbours (compressed rows, each ascending).
struct Neighbours {
    first: Vec<usize>,
    cells: Vec<u32>,
}

impl Neighbours {
    fn of(cells: usize, mut sides: Vec<([usize; 2], u32)>) -> Neighbours {
        for (s, _) in sides.iter_mut() {
            s.sort_unstable();
        }
        sides.sort_unstable();
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for run in sides.chunk_by(|a, b| a.0 == b.0) {
            for (i, a) in run.iter().enumerate() {
                for b in &run[i + 1..] {
                    if a.1 != b.1 {
                        pairs.extend([(a.1, b.1), (b.1, a.1)]);
                    }
                }
            }
        }
        drop(sides);
        pairs.sort_unstable();
        pairs.dedup();
        let mut first = vec![0; cells + 1];
        for &(a, _) in &pairs {
            first[a as usize + 1] += 1;
        }
        for c in 0..cells {
            first[c + 1] += first[c];
        }
        Neighbours {
            first,
            cells: pairs.into_iter().map(|(_, b)| b).collect(),
        }
    }

    /// A breadth-first search from `start` over the cells not stamped `search` (marking them
    /// so), appending them to `order` in the order met; returns the last one met.
    fn search(
        &self,
        start: usize,
        search: u32,
        stamp: &mut [u32],
        order: &mut Vec<usize>,
    ) -> usize {
        let mut queue = std::collections::VecDeque::from([start]);
        stamp[start] = search;
        let mut last = start;
        while let Some(c) = queue.pop_front() {
            order.push(c);
            last = c;
            for &n in &self.cells[self.first[c]..self.first[c + 1]] {
                let n = n as usize;
                if stamp[n] != search {
                    stamp[n] = search;
                    queue.push_back(n);
                }
            }
        }
        last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sides of an `n × n` grid of squares, each cell numbered by `number`.
    fn grid(n: usize, number: impl Fn(usize) -> usize) -> Vec<([usize; 2], u32)> {
        let node = |i: usize, j: usize| j * (n + 1) + i;
        let mut sides = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let c = number(j * n + i) as u32;
                let [a, b, d, e] = [
                    node(i, j),
                    node(i + 1, j),
                    node(i + 1, j + 1),
                    node(i, j + 1),
                ];
                sides.extend([([a, b], c), ([b, d], c), ([e, d], c), ([a, e], c)]);
            }
        }
        sides
    }

    #[test]
    fn a_scrambled_grid_is_met_in_bands_each_cell_once() {
        // A 32 × 32 grid of squares numbered in a scrambled order: every cell once, and a
        // block of an eighth of them spans at most 1/4 + 1/8 of the grid's anti-diagonals
        // (bands from a corner, the pseudo-peripheral cell).
        let n = 32;
        let scramble = |c: usize| (c * 389 + 7) % (n * n);
        let mut position = vec![0; n * n];
        for c in 0..n * n {
            position[scramble(c)] = c;
        }
        let order = breadth_first(n * n, grid(n, scramble));
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..n * n).collect::<Vec<_>>());
        let diagonal = |c: usize| (position[c] % n + position[c] / n) as i64;
        for block in order.chunks(n * n / 8) {
            let (lo, hi) = block.iter().fold((i64::MAX, i64::MIN), |(lo, hi), &c| {
                (lo.min(diagonal(c)), hi.max(diagonal(c)))
            });
            assert!(hi - lo <= (2 * n as i64) * 3 / 8, "{lo}..{hi}");
        }
    }

    #[test]
    fn disconnected_parts_follow_one_another_and_groups_are_their_cells() {
        // Two grids without a common side, the second's cells after the first's: each part's
        // cells together. A group of cells sharing sides among themselves is one cell.
        let mut sides = grid(3, |c| c);
        sides.extend(
            grid(3, |c| c + 9)
                .into_iter()
                .map(|([a, b], c)| ([a + 100, b + 100], c)),
        );
        let order = breadth_first(18, sides);
        assert!(order[..9].iter().all(|&c| c < 9), "{order:?}");
        assert!(order[9..].iter().all(|&c| c >= 9), "{order:?}");
        // The 3 × 3 grid's cells grouped by rows: a path of three groups, met from an end.
        let rows = breadth_first(3, grid(3, |c| c / 3));
        assert!(rows == [0, 1, 2] || rows == [2, 1, 0], "{rows:?}");
    }
}
