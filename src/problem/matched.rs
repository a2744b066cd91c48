//! What [`super::conform`] did to make two contact curves meshed on their own match, as the
//! pairing of [`super::meshed`] reads it.

use std::collections::BTreeMap;

use crate::fem::wire::{Reader, Writer};

/// What was done to make the contact curves match.
#[derive(Clone, Debug, Default)]
pub struct Matched {
    /// Body 1's contact direction at the nodes inserted into its curve (the interpolated normal
    /// field there; by the node's coordinates), which the pairing uses instead of the mean of
    /// the (collinear) segments' normals.
    pub normals: BTreeMap<[u64; 2], [f64; 2]>,
    /// Nodes inserted into body 1's and body 2's curves.
    pub inserted: [usize; 2],
    /// Nodes moved onto a partner's projection, per body.
    pub moved: [usize; 2],
    /// The points of the nodes inserted or moved (by [`point_key`]), to tell a triangle nndd
    /// made from the user's in messages.
    pub made: std::collections::BTreeSet<[u64; 2]>,
    /// The pairs of nodes left as they are next to each other (within
    /// [`super::conform::NEAR`], by [`point_key`]): body 1's node and its partner, body 2's
    /// node off its normal line, which the pairing takes as it is.
    pub near: BTreeMap<[u64; 2], [u64; 2]>,
}

/// The key of a point in [`Matched::normals`].
pub fn point_key(p: [f64; 2]) -> [u64; 2] {
    [p[0].to_bits(), p[1].to_bits()]
}

impl Matched {
    /// What was done, as bytes (world rank 0 did it; `problem::settings` sends it).
    pub fn write(&self, w: &mut Writer) {
        w.int(self.normals.len());
        for (k, n) in &self.normals {
            k.iter().for_each(|&x| w.u64(x));
            w.f64(n[0]);
            w.f64(n[1]);
        }
        w.ints(&self.inserted);
        w.ints(&self.moved);
        w.int(self.made.len());
        for k in &self.made {
            k.iter().for_each(|&x| w.u64(x));
        }
        w.int(self.near.len());
        for (a, b) in &self.near {
            a.iter().chain(b).for_each(|&x| w.u64(x));
        }
    }

    /// What [`Matched::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Matched> {
        let normals = (0..r.count(32)?)
            .map(|_| Some(([r.u64()?, r.u64()?], [r.f64()?, r.f64()?])))
            .collect::<Option<BTreeMap<_, _>>>()?;
        let inserted = <[usize; 2]>::try_from(r.ints()?).ok()?;
        let moved = <[usize; 2]>::try_from(r.ints()?).ok()?;
        let made = (0..r.count(16)?)
            .map(|_| Some([r.u64()?, r.u64()?]))
            .collect::<Option<_>>()?;
        let near = (0..r.count(32)?)
            .map(|_| Some(([r.u64()?, r.u64()?], [r.u64()?, r.u64()?])))
            .collect::<Option<_>>()?;
        Some(Matched {
            normals,
            inserted,
            moved,
            made,
            near,
        })
    }
}
