//! Who estimates which elements. The element work of an estimate (the stress
//! recoveries and the element sums) is spread evenly over all ranks, whatever the sizes of the
//! two bodies: with one rank per body, a body twice the other's size would otherwise keep its
//! rank busy while the other waits (Hertz level 6: 25 s of 40). The Neumann re-solves stay on
//! each body's group; their fields go to the other ranks that estimate elements of the body
//! (`iteration::BodyFields`). Each rank recovers on its elements plus the overlap that makes the
//! recovery there exactly the one-rank one ([`Overlap`], its values exchanged between sweeps,
//! [`Halo::exchange_sweep`]), so the estimates do not depend on the assignment; the ranks
//! that share a body recover it in step.

use std::cell::OnceCell;
use std::ops::Range;

use crate::estimate::equilibrate::{vertex_colours, Recovery, Stars};
use crate::estimate::overlap::{colour_count, Halo, Overlap};
use crate::estimate::view::View;
use crate::fem::mesh::{element_u32, Mesh};
use crate::fem::wire::{Reader, Writer};
use crate::parallel::layout::Layout;
use crate::parallel::partition::Partitioner;

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

/// Who estimates a body's elements ([`estimate_owner`], or [`block_owners`] for a body dealt
/// in index blocks and estimated on its group alone): what every rank's share of its estimates
/// is made from ([`SharePlan::seed`]). Made on each rank that takes part in the body's
/// estimates from its whole mesh, or under `-nndd_mesh_input root` on world rank 0 for every
/// rank (`app::input`).
pub struct SharePlan<'m> {
    alpha: usize,
    mesh: Option<&'m Mesh>,
    /// The world rank estimating each element (empty without the mesh).
    owner: Vec<u32>,
    /// Whether several ranks estimate the body's elements.
    split: bool,
    crosses: bool,
    recovery: Recovery,
    /// Made where a rank's overlap is first made: the mesh's colouring, its vertices' stars
    /// and each rank's elements.
    colours: OnceCell<Vec<u8>>,
    stars: OnceCell<Stars>,
    by_rank: OnceCell<ByRank>,
}

/// The elements each world rank estimates, increasing (a compressed list: rank q's are
/// `elements[start[q]..start[q + 1]]`).
struct ByRank {
    start: Vec<usize>,
    elements: Vec<u32>,
}

impl ByRank {
    fn of(owner: &[u32]) -> ByRank {
        let ranks = owner.iter().map(|&r| r as usize + 1).max().unwrap_or(0);
        let mut start = vec![0usize; ranks + 1];
        owner.iter().for_each(|&r| start[r as usize + 1] += 1);
        for q in 0..ranks {
            start[q + 1] += start[q];
        }
        let mut fill = start.clone();
        let mut elements = vec![0u32; owner.len()];
        for (e, &r) in owner.iter().enumerate() {
            elements[fill[r as usize]] = element_u32(e);
            fill[r as usize] += 1;
        }
        ByRank { start, elements }
    }

    fn of_rank(&self, q: usize) -> &[u32] {
        match self.start.get(q..q + 2) {
            Some(&[a, b]) => &self.elements[a..b],
            _ => &[],
        }
    }
}

impl<'m> SharePlan<'m> {
    /// The plan of body `alpha` on `mesh` (none: the rank takes no part in its estimates),
    /// the bodies' element counts being `sizes`, estimated outside its group (`crosses`,
    /// [`estimated_outside_group`]) or not, dealt over its group by `how`.
    pub fn new(
        alpha: usize,
        mesh: Option<&'m Mesh>,
        sizes: [usize; 2],
        layout: &Layout,
        how: Partitioner,
        crosses: bool,
        recovery: Recovery,
    ) -> SharePlan<'m> {
        let k = alpha - 1;
        let in_blocks = how == Partitioner::IndexBlocks && !crosses;
        let owner = match mesh {
            Some(_) if in_blocks => block_owners(layout, alpha, sizes[k]),
            Some(m) => estimate_owner(sizes, m, layout.size as usize, k),
            None => Vec::new(),
        };
        let first = owner.first().copied().unwrap_or(0);
        SharePlan {
            alpha,
            mesh,
            split: owner.iter().any(|&r| r != first),
            owner,
            crosses,
            recovery,
            colours: OnceCell::new(),
            stars: OnceCell::new(),
            by_rank: OnceCell::new(),
        }
    }

    /// Whether some of the body's elements are estimated outside its group.
    pub fn crosses(&self) -> bool {
        self.crosses
    }

    /// World rank `rank`'s share of the body's estimates, to be made a [`Share`] there
    /// ([`Seed::share`]). The plan's mesh is read where the rank estimates some of the body's
    /// elements and others estimate the rest: its overlap is grown through the mesh's vertex
    /// stars, made once ([`Overlap::around`]: O(N) to clear its marks, O(overlap) beyond).
    pub fn seed(&self, rank: usize, layout: &Layout) -> Seed {
        let group = layout.group_ranks(self.alpha);
        if !self.crosses && !group.contains(&rank) {
            return Seed::Elsewhere;
        }
        if !self.split {
            return match self.owner.first() {
                Some(&r) if r as usize == rank => Seed::Whole,
                _ => Seed::Elsewhere,
            };
        }
        let mine = (self.by_rank.get_or_init(|| ByRank::of(&self.owner))).of_rank(rank);
        if mine.is_empty() {
            return Seed::Idle;
        }
        let mesh = self
            .mesh
            .expect("a rank that estimates a body's elements holds its mesh");
        let colours = self.colours.get_or_init(|| vertex_colours(mesh));
        let stars = self.stars.get_or_init(|| Stars::of(mesh));
        // The recovery exchanges the overlap's values between sweeps.
        let rings = Overlap::rings_exchanged(self.recovery, colour_count(colours));
        let overlap = Overlap::around(mesh, stars, mine, rings, colours);
        // (the halo's ranks: world ranks, or ranks in the group)
        let base = if self.crosses { 0 } else { group.start as u32 };
        let owner = (overlap.elements.iter())
            .map(|&e| self.owner[e] - base)
            .collect();
        Seed::Part(Box::new(overlap), owner)
    }
}

/// A rank's share of one body's estimates before its halo is made ([`Seed::share`]): what
/// [`SharePlan::seed`] makes of it, where the rank is or on world rank 0.
pub enum Seed {
    Whole,
    /// Some elements: the overlap, and the rank estimating each of its elements (world ranks
    /// where the body is estimated outside its group, else ranks in the group).
    Part(Box<Overlap>, Vec<u32>),
    Idle,
    Elsewhere,
}

impl Seed {
    /// This rank's share (collective over the body's group, or every rank where the body is
    /// estimated outside it, `crosses`: the halos' exchange patterns).
    pub fn share(self, crosses: bool, layout: &Layout) -> Share {
        match self {
            Seed::Whole => Share::Whole,
            Seed::Elsewhere => Share::Elsewhere,
            Seed::Idle => Share::Idle(Halo::new(None, &[], crosses, layout)),
            Seed::Part(overlap, owner) => {
                let halo = Halo::new(Some(&overlap), &owner, crosses, layout);
                Share::Part(overlap, halo)
            }
        }
    }

    /// The elements of the body this rank's recoveries read ([`Share::elements_read`]).
    pub fn elements_read(&self) -> Option<Vec<u32>> {
        match self {
            Seed::Whole => None,
            Seed::Part(o, _) => Some(overlap_elements(o)),
            Seed::Idle | Seed::Elsewhere => Some(Vec::new()),
        }
    }

    /// The seed as bytes ([`Writer`]).
    pub fn write(&self, w: &mut Writer) {
        match self {
            Seed::Whole => w.u8(0),
            Seed::Elsewhere => w.u8(1),
            Seed::Idle => w.u8(2),
            Seed::Part(overlap, owner) => {
                w.u8(3);
                overlap.write(w);
                w.u32s(owner);
            }
        }
    }

    /// What [`Seed::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Seed> {
        match r.u8()? {
            0 => Some(Seed::Whole),
            1 => Some(Seed::Elsewhere),
            2 => Some(Seed::Idle),
            3 => {
                let overlap = Overlap::read(r)?;
                let owner = r.u32s()?;
                (owner.len() == overlap.elements.len())
                    .then(|| Seed::Part(Box::new(overlap), owner))
            }
            _ => None,
        }
    }
}

/// The body elements of an overlap, by their global indices.
fn overlap_elements(o: &Overlap) -> Vec<u32> {
    o.elements.iter().map(|&e| element_u32(e)).collect()
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
    /// This rank's share of the body whose estimates `plan` deals out ([`SharePlan::seed`],
    /// [`Seed::share`]). Collective over the body's group, or every
    /// rank where the body is estimated outside it.
    pub fn new(plan: &SharePlan, layout: &Layout) -> Share {
        plan.seed(layout.rank as usize, layout)
            .share(plan.crosses, layout)
    }

    /// The elements of the body this rank's recoveries read: `None` for every one, else
    /// its overlap's (none where it recovers none).
    pub fn elements_read(&self) -> Option<Vec<u32>> {
        match self {
            Share::Whole => None,
            Share::Part(o, _) => Some(overlap_elements(o)),
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

    /// A seed reads back as written (what world rank 0 sends a rank under
    /// `-nndd_mesh_input root`); a part's owners must match its overlap.
    #[test]
    fn seeds_read_back_as_written() {
        let mesh = Mesh::structured([0.0, 0.0], [2.0, 1.0], 8, 6);
        let colours = vertex_colours(&mesh);
        let own: Vec<bool> = (0..mesh.triangles.len()).map(|e| e < 40).collect();
        let overlap = Overlap::new(&mesh, &own, 3, &colours);
        let owner: Vec<u32> = overlap.owned.iter().map(|&o| (!o) as u32).collect();
        let bytes = |s: &Seed| {
            let mut w = Writer::default();
            s.write(&mut w);
            w.0
        };
        for seed in [Seed::Whole, Seed::Idle, Seed::Elsewhere] {
            let back = Seed::read(&mut Reader::new(&bytes(&seed))).unwrap();
            assert_eq!(back.elements_read(), seed.elements_read());
        }
        let part = Seed::Part(Box::new(overlap.clone()), owner.clone());
        let written = bytes(&part);
        let Some(Seed::Part(o, back)) = Seed::read(&mut Reader::new(&written)) else {
            panic!("a part reads back as a part");
        };
        assert_eq!(
            (o.elements, back),
            (overlap.elements.clone(), owner.clone())
        );
        let short = Seed::Part(Box::new(overlap), owner[1..].to_vec());
        assert!(Seed::read(&mut Reader::new(&bytes(&short))).is_none());
        assert!(Seed::read(&mut Reader::new(&[7])).is_none());
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
