//! A rank's part of a vector that is indexed like the whole: the entries from index `first`
//! on (`first` = 0 and the whole length: the vector whole). What a rank keeps of an estimated
//! step for the output (its η maps on the elements it writes, its displacement on the dofs
//! they need) is held so, [`to_blocks`] sends values computed anywhere to the ranks that
//! hold them so, and [`from_blocks`] gathers nodal fields held so where a rank reads them.

use std::ops::Range;

use crate::parallel::layout::Layout;

/// Entry `i` of a vector held from index `first` on: 0 where it is not held.
pub fn value_at(held: &[f64], first: usize, i: usize) -> f64 {
    i.checked_sub(first)
        .and_then(|j| held.get(j))
        .copied()
        .unwrap_or(0.0)
}

/// The entries `keep` of a vector held from index `first` on (those of them it holds); the
/// part returned is held from index max(keep.start, first) on.
pub fn keep(held: &[f64], first: usize, keep: &Range<usize>) -> Vec<f64> {
    let start = keep.start.max(first);
    let hi = (keep.end.max(start) - first).min(held.len());
    held[(start - first).min(hi)..hi].to_vec()
}

/// `M` maps of the `len` items of body `alpha` (its elements), each item's values computed
/// on one rank (`items`, with `values[j][s]` item `items[s]`'s value of map j), sent to the
/// rank whose [`Layout::block`] holds the item: this rank's block of each map and the block's
/// first item. No rank holds a whole map. Collective over all ranks when `world` (items
/// computed outside the body's group), else over the body's group.
pub fn to_blocks<const M: usize>(
    layout: &Layout,
    alpha: usize,
    len: usize,
    items: &[u32],
    values: [&[f64]; M],
    world: bool,
) -> ([Vec<f64>; M], usize) {
    let (maps, first, count) = merge_into_blocks(layout, alpha, len, items, values, world);
    assert_eq!(count, maps[0].len(), "each item of the block from one rank");
    (maps, first)
}

/// [`to_blocks`] of values that several ranks contribute to an item (a coarse element's sum
/// over the fine elements in it): each item of the block holds the sum of what the ranks of
/// body `alpha`'s group sent for it (0 where none did). Collective over the group.
pub fn add_to_blocks<const M: usize>(
    layout: &Layout,
    alpha: usize,
    len: usize,
    items: &[u32],
    values: [&[f64]; M],
) -> ([Vec<f64>; M], usize) {
    let (maps, first, _) = merge_into_blocks(layout, alpha, len, items, values, false);
    (maps, first)
}

/// The values of `items` sent to their blocks' ranks and added there: this rank's block of
/// each map, its first item, and how many values it received.
fn merge_into_blocks<const M: usize>(
    layout: &Layout,
    alpha: usize,
    len: usize,
    items: &[u32],
    values: [&[f64]; M],
    world: bool,
) -> ([Vec<f64>; M], usize, usize) {
    let (first_rank, ranks) = match world {
        true => (0, layout.size as usize),
        false => (layout.group_ranks(alpha).start, layout.group_size()),
    };
    // (each item as M + 1 numbers: its index, exact in an f64, then its values)
    let mut send = vec![Vec::new(); ranks];
    for (s, &i) in items.iter().enumerate() {
        let to = &mut send[layout.block_owner(alpha, len, i as usize) - first_rank];
        to.push(i as f64);
        to.extend(values.iter().map(|v| v[s]));
    }
    let received = layout.exchange(world, &send);
    drop(send);
    let block = layout.block(alpha, len);
    let mut maps: [Vec<f64>; M] = std::array::from_fn(|_| vec![0.0; block.len()]);
    let mut count = 0;
    for item in received.iter().flat_map(|r| r.chunks_exact(M + 1)) {
        let i = item[0] as usize - block.start;
        for (m, &v) in maps.iter_mut().zip(&item[1..]) {
            m[i] += v;
        }
        count += 1;
    }
    (maps, block.start, count)
}

/// The inverse of [`to_blocks`] for nodal fields: fields of body `alpha` (two values per node
/// of its `len` nodes), each held on the body's ranks as their [`Layout::block`] of the nodes
/// (`blocks[j]`: field j's values at this rank's block, two per node; empty outside the
/// group; as many fields on every rank), gathered on every rank at its `nodes` alone: field
/// j's two values per node of `nodes`, in that order. No rank sends or holds a whole field.
/// Collective over all ranks.
pub fn from_blocks(
    layout: &Layout,
    alpha: usize,
    len: usize,
    blocks: &[&[f64]],
    nodes: &[usize],
) -> Vec<Vec<f64>> {
    let ranks = layout.size as usize;
    let mut asks = vec![Vec::<u64>::new(); ranks];
    for &n in nodes {
        asks[layout.block_owner(alpha, len, n)].push(n as u64);
    }
    let asked = layout.exchange(true, &asks);
    let block = layout.block(alpha, len);
    // (to each rank, its nodes' values field by field)
    let replies: Vec<Vec<f64>> = (asked.iter())
        .map(|nodes| {
            (blocks.iter())
                .flat_map(|b| {
                    nodes.iter().flat_map(move |&n| {
                        let i = 2 * (n as usize - block.start);
                        [b[i], b[i + 1]]
                    })
                })
                .collect()
        })
        .collect();
    drop(asked);
    let replied = layout.exchange(true, &replies);
    drop(replies);
    // Each node's values from its owner's reply, in the order this rank asked.
    let mut out: Vec<Vec<f64>> = (blocks.iter())
        .map(|_| Vec::with_capacity(2 * nodes.len()))
        .collect();
    let mut next = vec![0; ranks];
    for &n in nodes {
        let r = layout.block_owner(alpha, len, n);
        let count = asks[r].len();
        for (j, field) in out.iter_mut().enumerate() {
            let at = 2 * (j * count + next[r]);
            field.extend_from_slice(&replied[r][at..at + 2]);
        }
        next[r] += 1;
    }
    out
}

/// A map of `len` items of body `alpha` held as blocks ([`to_blocks`]: this rank's `block`
/// from item `first` on), whole on world rank 0 alone (empty elsewhere; collective over all
/// ranks).
pub fn whole_on_root(
    layout: &Layout,
    alpha: usize,
    len: usize,
    block: &[f64],
    first: usize,
) -> Vec<f64> {
    let mut send = vec![Vec::new(); layout.size as usize];
    if layout.owns(alpha) && !block.is_empty() {
        send[0] = std::iter::once(first as f64)
            .chain(block.iter().copied())
            .collect();
    }
    let received = layout.exchange(true, &send);
    if !layout.is_root() {
        return Vec::new();
    }
    let mut whole = vec![0.0; len];
    for part in received.iter().filter(|p| !p.is_empty()) {
        let first = part[0] as usize;
        whole[first..first + part.len() - 1].copy_from_slice(&part[1..]);
    }
    whole
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_part_has_the_values_of_its_entries() {
        let whole: Vec<f64> = (0..10).map(|e| e as f64 + 0.5).collect();
        let part = keep(&whole, 0, &(3..7));
        assert_eq!(part, vec![3.5, 4.5, 5.5, 6.5]);
        for e in 0..10 {
            let want = if (3..7).contains(&e) { whole[e] } else { 0.0 };
            assert_eq!(value_at(&part, 3, e), want, "entry {e}");
            assert_eq!(value_at(&whole, 0, e), whole[e]);
        }
        // Kept again (the same part, or a wider one): unchanged; a narrower one: its entries.
        assert_eq!(keep(&part, 3, &(3..7)), part);
        assert_eq!(keep(&part, 3, &(0..10)), part);
        assert_eq!(keep(&part, 3, &(5..6)), vec![5.5]);
        // An empty range keeps nothing.
        assert!(keep(&whole, 0, &(0..0)).is_empty());
    }
}
