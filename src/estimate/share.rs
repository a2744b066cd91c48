//! Who estimates which elements. The element work of an estimate (the stress
//! recoveries and the element sums) is spread evenly over all ranks, whatever the sizes of the
//! two bodies: with one rank per body, a body twice the other's size would otherwise keep its
//! rank busy while the other waits (Hertz level 6: 25 s of 40). The Neumann re-solves stay on
//! each body's group; their fields go to the other ranks that estimate elements of the body
//! (`iteration::BodyFields`). Each rank recovers on its elements plus the overlap that makes the
//! recovery there exactly the one-rank one ([`Overlap`], its values exchanged between sweeps,
//! [`Halo::exchange_sweep`]), so the estimates do not depend on the assignment; the ranks
//! that share a body recover it in step.

use std::ops::Range;

use crate::estimate::equilibrate::{vertex_colours, Recovery};
use crate::estimate::overlap::{colour_count, Halo, Overlap};
use crate::estimate::view::View;
use crate::fem::mesh::{element_u32, Mesh};
use crate::parallel::layout::Layout;

/// The world rank estimating each element of body k + 1 (what a rank makes of a body it estimates:
/// the other's size is all it reads of the other body). Each body's elements in slabs along the
/// longer side of its bounding box (by barycentre, then index): the elements of body 1 then body 2
/// dealt in order into `ranks` shares of equal size, when no rank gets elements of both bodies (two
/// bodies of equal size on an even number of ranks: each body on its own ranks); else each body
/// dealt over all `ranks` in equal shares. The ranks that share a body recover it in step (their
/// overlaps exchange values between sweeps, `Halo::exchange_sweep`), so each must hold an equal
/// part of it: a rank with parts of two bodies would keep the others of one body waiting while it
/// recovers the other.
/// `sizes` are both bodies' element counts, `mesh` body k + 1's.
pub fn estimate_owner(sizes: [usize; 2], mesh: &Mesh, ranks: usize, k: usize) -> Vec<u32> {
    let own = dealt_ranks(sizes, ranks).is_some();
    let total = (sizes[0] + sizes[1]).max(1);
    // (body 2's elements are dealt after body 1's)
    let position = if k == 1 { sizes[0] } else { 0 };
    let order = slab_order(mesh);
    let len = order.len();
    let mut owner = vec![0u32; len];
    for (q, &e) in order.iter().enumerate() {
        owner[e as usize] = match own {
            true => (position + q) * ranks / total,
            false => q * ranks / len.max(1),
        } as u32;
    }
    owner
}

/// The world rank of each of body `alpha`'s `len` elements whose block of the output holds it
/// ([`Layout::block`]): who estimates the body where it is dealt over its group in index
/// blocks (`-nndd_partition blocks`) and estimated there alone.
pub fn block_owners(layout: &Layout, alpha: usize, len: usize) -> Vec<u32> {
    (0..len)
        .map(|e| layout.block_owner(alpha, len, e) as u32)
        .collect()
}

/// The world ranks that estimate elements of each body ([`estimate_owner`]), from the
/// bodies' element counts `sizes` alone: known before, and without, the owner of every
/// element.
pub fn estimating_ranks(sizes: [usize; 2], ranks: usize) -> [Range<usize>; 2] {
    dealt_ranks(sizes, ranks).unwrap_or([0..ranks, 0..ranks])
}

/// Whether some of each body's elements are estimated outside its group (then on every
/// rank: each makes the estimating rank of every element of the body, [`estimate_owner`]),
/// from the bodies' element counts `sizes`.
pub fn estimated_outside_group(sizes: [usize; 2], layout: &Layout) -> [bool; 2] {
    let ranks = estimating_ranks(sizes, layout.size as usize);
    [0, 1].map(|k| {
        let group = layout.group_ranks(k + 1);
        ranks[k].start < group.start || ranks[k].end > group.end
    })
}

/// The ranks of each body when the elements of body 1 then body 2 are dealt in order into
/// `ranks` equal shares (element q of all goes to rank q · ranks / total); `None` when a rank
/// would get elements of both.
fn dealt_ranks(sizes: [usize; 2], ranks: usize) -> Option<[Range<usize>; 2]> {
    let total = (sizes[0] + sizes[1]).max(1);
    let rank_of = |q: usize| q * ranks / total;
    let first = [0, sizes[0]];
    let ranges = [0, 1].map(|k| match sizes[k] {
        0 => 0..0,
        n => rank_of(first[k])..rank_of(first[k] + n - 1) + 1,
    });
    let both = !ranges[0].is_empty() && !ranges[1].is_empty() && ranges[0].end > ranges[1].start;
    (!both).then_some(ranges)
}

/// The elements of `mesh` in slab order: by the barycentre's coordinate along the longer side
/// of the bounding box, then by index (12 bytes per element of the body while it is sorted,
/// made on every rank that estimates the body).
fn slab_order(mesh: &Mesh) -> Vec<u32> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &mesh.points {
        for c in 0..2 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let axis = if hi[0] - lo[0] >= hi[1] - lo[1] { 0 } else { 1 };
    let centre: Vec<f64> = (0..mesh.triangles.len())
        .map(|e| {
            let p = mesh.triangle_points(e);
            (p[0][axis] + p[1][axis] + p[2][axis]) / 3.0
        })
        .collect();
    let mut order: Vec<u32> = (0..centre.len()).map(element_u32).collect();
    order.sort_unstable_by(|&a, &b| {
        (centre[a as usize].total_cmp(&centre[b as usize])).then(a.cmp(&b))
    });
    order
}

/// This rank's part in the estimates of one body.
pub enum Share {
    /// Every element of the body.
    Whole,
    /// Some elements (with their overlap), the others on other ranks.
    Part(Box<Overlap>, Halo),
    /// None, the body being split over other ranks: only the warm-start exchanges.
    Idle(Halo),
    /// None, the body being on one other rank.
    Elsewhere,
}

impl Share {
    /// This rank's share of the body `alpha` on `mesh` whose elements the world ranks `owner`
    /// estimate. When they are all in the body's group (`crosses` false), its halo exchanges
    /// run on the group and the other ranks have nothing to do with it; else on all ranks
    /// (which then all have the body's fields). Collective over that communicator when the
    /// body is split over several ranks. `owner` is not read on a rank that takes no part
    /// (outside the group, `crosses` false).
    pub fn new(
        alpha: usize,
        mesh: Option<&Mesh>,
        owner: &[u32],
        crosses: bool,
        recovery: Recovery,
        layout: &Layout,
    ) -> Share {
        let me = layout.rank as usize;
        let group = layout.group_ranks(alpha);
        if !crosses && !group.contains(&me) {
            return Share::Elsewhere;
        }
        let first = owner.first().copied().unwrap_or(0);
        let split = owner.iter().any(|&r| r != first);
        let mine = owner.contains(&(me as u32));
        // The halo's ranks: world ranks, or ranks in the group.
        let scoped: Vec<u32> = if crosses {
            owner.to_vec()
        } else {
            owner.iter().map(|&r| r - group.start as u32).collect()
        };
        match (split, mine) {
            (false, true) => Share::Whole,
            (false, false) => Share::Elsewhere,
            (true, false) => Share::Idle(Halo::new(None, &scoped, crosses, layout)),
            (true, true) => {
                let mesh = mesh.expect("a rank that estimates a body's elements holds its mesh");
                let colours = vertex_colours(mesh);
                let own: Vec<bool> = owner.iter().map(|&r| r as usize == me).collect();
                // The recovery exchanges the overlap's values between sweeps.
                let rings = Overlap::rings_exchanged(recovery, colour_count(&colours));
                let overlap = Overlap::new(mesh, &own, rings, &colours);
                let halo = Halo::new(Some(&overlap), &scoped, crosses, layout);
                Share::Part(Box::new(overlap), halo)
            }
        }
    }

    /// The elements of the body this rank's recoveries read: `None` for every one, else
    /// its overlap's (none where it recovers none).
    pub fn elements_read(&self) -> Option<Vec<u32>> {
        match self {
            Share::Whole => None,
            Share::Part(o, _) => Some(o.elements.iter().map(|&e| element_u32(e)).collect()),
            Share::Idle(_) | Share::Elsewhere => Some(Vec::new()),
        }
    }

    /// The view of the body's recoveries on this rank (none: nothing to do here).
    pub fn view<'a>(&'a self, layout: &'a Layout) -> Option<View<'a>> {
        match self {
            Share::Whole => Some(View::Whole),
            Share::Part(o, h) => Some(View::Overlap(o, h, layout)),
            Share::Idle(h) => Some(View::Idle(h, layout)),
            Share::Elsewhere => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn estimate_owners(meshes: [&Mesh; 2], ranks: usize) -> [Vec<u32>; 2] {
        let sizes = meshes.map(|m| m.triangles.len());
        [0, 1].map(|k| estimate_owner(sizes, meshes[k], ranks, k))
    }

    /// Slab order: by the barycentre along the longer side, ties by element index.
    #[test]
    fn slab_order_sorts_by_barycentre_then_index() {
        // 2 × 1 cells, longer along x: cell 0's triangles (0, 1) have barycentres x = 2/3 and
        // 1/3, cell 1's (2, 3) 5/3 and 4/3.
        let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.0], 2, 1);
        assert_eq!(slab_order(&mesh), vec![1, 0, 3, 2]);
        // 2 × 2 cells, still wider than tall: the rows' triangles share their barycentres'
        // x two by two, ties by index.
        let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.9], 2, 2);
        assert_eq!(slab_order(&mesh), vec![1, 5, 0, 4, 3, 7, 2, 6]);
        // Taller than wide: along y.
        let mesh = Mesh::structured([0.0, 0.0], [1.0, 2.0], 1, 2);
        assert_eq!(slab_order(&mesh), vec![0, 1, 2, 3]);
    }

    #[test]
    fn equal_bodies_get_ranks_of_their_own_else_every_body_is_dealt_over_all_ranks() {
        let a = Mesh::structured([0.0, 0.0], [1.0, 1.0], 8, 8);
        let b = Mesh::structured([0.0, 1.0], [1.0, 1.0], 8, 8);
        let [o1, o2] = estimate_owners([&a, &b], 2);
        assert!(o1.iter().all(|&r| r == 0) && o2.iter().all(|&r| r == 1));
        let [o1, o2] = estimate_owners([&a, &b], 1);
        assert!(o1.iter().chain(&o2).all(|&r| r == 0));
        // 4 ranks: two per body, in halves.
        let [o1, o2] = estimate_owners([&a, &b], 4);
        for (o, ranks) in [(&o1, [0, 1]), (&o2, [2, 3])] {
            for r in ranks {
                assert_eq!(o.iter().filter(|&&x| x == r).count(), o.len() / 2);
            }
        }
        // Body 1 three times body 2's size on 2 ranks: each body in halves, straight slabs
        // (by barycentre along x).
        let big = Mesh::structured([0.0, 0.0], [3.0, 1.0], 24, 8);
        let [o1, o2] = estimate_owners([&big, &b], 2);
        for o in [&o1, &o2] {
            assert_eq!(o.iter().filter(|&&r| r == 0).count(), o.len() / 2);
        }
        let x = |e: usize| big.triangle_points(e).iter().map(|p| p[0]).sum::<f64>() / 3.0;
        let cut0 = (0..o1.len())
            .filter(|&e| o1[e] == 0)
            .map(x)
            .fold(f64::MIN, f64::max);
        let cut1 = (0..o1.len())
            .filter(|&e| o1[e] == 1)
            .map(x)
            .fold(f64::MAX, f64::min);
        assert!(cut0 <= cut1, "{cut0} > {cut1}");
        // Any rank count: the ranks holding a body hold equal parts of it (to within one
        // element: they recover it in step), and a rank holds two bodies only when every body
        // is over all ranks (equal bodies on 3 ranks too: the middle rank would have both).
        for (m1, ranks) in [
            (&big, 3),
            (&big, 4),
            (&big, 6),
            (&big, 7),
            (&a, 3),
            (&a, 4),
            (&a, 1),
        ] {
            let owners = estimate_owners([m1, &b], ranks);
            let mut holds = vec![[0usize; 2]; ranks];
            for (k, o) in owners.iter().enumerate() {
                for &r in o.iter() {
                    holds[r as usize][k] += 1;
                }
                let counts: Vec<usize> = holds.iter().map(|h| h[k]).filter(|&c| c > 0).collect();
                let (lo, hi) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
                assert!(hi - lo <= 1, "{ranks} ranks, body {}: {counts:?}", k + 1);
            }
            // The ranks named from the sizes alone are those holding elements.
            let named = estimating_ranks([m1.triangles.len(), b.triangles.len()], ranks);
            for (k, range) in named.iter().enumerate() {
                let holding: Vec<usize> = (0..ranks).filter(|&r| holds[r][k] > 0).collect();
                assert_eq!(holding, range.clone().collect::<Vec<_>>(), "{ranks} ranks");
            }
            let both = holds.iter().any(|h| h[0] > 0 && h[1] > 0);
            let everywhere = holds.iter().all(|h| h[0] > 0 && h[1] > 0);
            assert!(!both || everywhere, "{ranks} ranks: {holds:?}");
        }
    }
}
