//! Who estimates which elements (issue 11). The element work of an estimate (the stress
//! recoveries and the element sums) is spread evenly over all ranks, whatever the sizes of the
//! two bodies: with one rank per body, a body twice the other's size would otherwise keep its
//! rank busy while the other waits (Hertz level 6: 25 s of 40). The Neumann re-solves stay on
//! each body's group; their fields go to the other ranks that estimate elements of the body
//! (`cre::BodyFields`). Each rank recovers on its elements plus the overlap that makes the
//! recovery there exactly the one-rank one ([`Overlap`]), so the estimates do not depend on
//! the assignment.

use crate::estimate::cre::View;
use crate::estimate::equilibrate::{vertex_colours, StarChoice};
use crate::estimate::overlap::{colour_count, Halo, Overlap};
use crate::fem::mesh::Mesh;
use crate::parallel::layout::Layout;

/// The world rank estimating each element of each body: the elements of body 1 then body 2,
/// each body's in slabs along the longer side of its bounding box (by barycentre, then index),
/// dealt in order into `ranks` shares of equal size. Two bodies of equal size on two ranks
/// get one rank each; a larger body spills over into the other body's ranks.
pub fn estimate_owners(meshes: [&Mesh; 2], ranks: usize) -> [Vec<u32>; 2] {
    let total: usize = meshes.iter().map(|m| m.triangles.len()).sum();
    let mut position = 0;
    meshes.map(|mesh| {
        let nt = mesh.triangles.len();
        let centre = |e: usize| {
            let p = mesh.triangle_points(e);
            [0, 1].map(|c| (p[0][c] + p[1][c] + p[2][c]) / 3.0)
        };
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &mesh.points {
            for c in 0..2 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let axis = if hi[0] - lo[0] >= hi[1] - lo[1] { 0 } else { 1 };
        let mut order: Vec<(f64, usize)> = (0..nt).map(|e| (centre(e)[axis], e)).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut owner = vec![0u32; nt];
        for (q, &(_, e)) in order.iter().enumerate() {
            owner[e] = ((position + q) * ranks / total.max(1)) as u32;
        }
        position += nt;
        owner
    })
}

/// This rank's part in the estimates of one body.
pub enum Share {
    /// Every element of the body.
    Whole,
    /// Some elements (with their overlap), the others on other ranks.
    Part(Overlap, Halo),
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
    /// body is split over several ranks.
    pub fn new(
        alpha: usize,
        mesh: &Mesh,
        owner: &[u32],
        crosses: bool,
        recovery: StarChoice,
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
                let colours = vertex_colours(mesh);
                let own: Vec<bool> = owner.iter().map(|&r| r as usize == me).collect();
                let rings = Overlap::rings_for(recovery, colour_count(&colours));
                let overlap = Overlap::new(mesh, &own, rings, &colours);
                let halo = Halo::new(Some(&overlap), &scoped, crosses, layout);
                Share::Part(overlap, halo)
            }
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

    #[test]
    fn equal_bodies_get_a_rank_each_and_a_larger_one_spills_over() {
        let a = Mesh::structured([0.0, 0.0], [1.0, 1.0], 8, 8);
        let b = Mesh::structured([0.0, 1.0], [1.0, 1.0], 8, 8);
        let [o1, o2] = estimate_owners([&a, &b], 2);
        assert!(o1.iter().all(|&r| r == 0) && o2.iter().all(|&r| r == 1));
        let [o1, o2] = estimate_owners([&a, &b], 1);
        assert!(o1.iter().chain(&o2).all(|&r| r == 0));
        // Body 1 three times body 2's size on 2 ranks: rank 0 gets 2/3 of body 1, rank 1 the
        // rest and body 2; the cut is a straight slab (by barycentre along x).
        let big = Mesh::structured([0.0, 0.0], [3.0, 1.0], 24, 8);
        let [o1, o2] = estimate_owners([&big, &b], 2);
        let on0 = o1.iter().filter(|&&r| r == 0).count();
        assert_eq!(on0, (big.triangles.len() + b.triangles.len()) / 2);
        assert!(o2.iter().all(|&r| r == 1));
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
        // Any rank count: every rank gets its share to within one element.
        for ranks in [3, 4, 6, 7] {
            let [o1, o2] = estimate_owners([&big, &b], ranks);
            let mut count = vec![0usize; ranks];
            for &r in o1.iter().chain(&o2) {
                count[r as usize] += 1;
            }
            let (lo, hi) = (count.iter().min().unwrap(), count.iter().max().unwrap());
            assert!(hi - lo <= 1, "{ranks} ranks: {count:?}");
        }
    }
}
