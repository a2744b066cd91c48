//! A [`GmshMesh`] as bytes: what world rank 0 sends the other ranks after reading (or meshing)
//! the file once, instead of their parsing it again.

use std::collections::BTreeMap;

use super::{Cells, ElementTags, GmshMesh, Nesting};
use crate::fem::wire::{Reader, Writer};

impl GmshMesh {
    /// The mesh as bytes (little-endian: the path, the points, each kind of element's tag
    /// lists then its nodes in 4 bytes and its list's index, the element tags' runs, the
    /// names, the nesting): what world rank 0 sends the others, 16 bytes per triangle and per
    /// node.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::with_capacity(16 * self.points.len() + 16 * self.triangles.len());
        w.text(&self.path);
        w.points(&self.points);
        cells(&mut w, &self.triangles);
        let (runs, len) = self.triangle_tags.runs();
        w.int(len);
        w.list(runs, |w, &(first, tag, step)| {
            w.int(first);
            w.u64(tag);
            w.u8(step);
        });
        cells(&mut w, &self.lines);
        write_names(&mut w, &self.names);
        // (a mesh of its own: no children)
        w.int(self.nesting.map_or(0, |n| n.children));
        w.0
    }

    /// The mesh [`GmshMesh::to_bytes`] wrote (`None` for bytes it did not write).
    pub fn from_bytes(bytes: &[u8]) -> Option<GmshMesh> {
        let mut r = Reader::new(bytes);
        let path = r.text()?;
        let points = r.points()?;
        let triangles = read_cells(&mut r)?;
        let len = r.int()?;
        let runs = r.list(17, |r| Some((r.int()?, r.u64()?, r.u8()?)))?;
        let triangle_tags = ElementTags::from_runs(runs, len)?;
        let lines = read_cells(&mut r)?;
        let names = read_names(&mut r)?;
        let nesting = match r.int()? {
            0 => None,
            children => Some(Nesting { children }),
        };
        r.is_done().then_some(GmshMesh {
            path,
            points,
            triangles,
            triangle_tags,
            lines,
            names,
            nesting,
        })
    }
}

/// Elements as bytes: the tag lists, the count, then each element's nodes and list index in 4
/// bytes each.
fn cells<const N: usize>(w: &mut Writer, c: &Cells<N>) {
    let (nodes, set, sets) = c.parts();
    w.list(sets, |w, tags| w.list(tags, |w, &t| w.i32(t)));
    w.int(nodes.len());
    for (n, &s) in nodes.iter().zip(set) {
        for &v in n {
            w.u32(v);
        }
        w.u32(s);
    }
}

/// What [`cells`] wrote.
fn read_cells<const N: usize>(r: &mut Reader) -> Option<Cells<N>> {
    let sets = r.list(8, |r| r.list(4, Reader::i32))?;
    let n = r.count(4 * (N + 1))?;
    let mut nodes = Vec::with_capacity(n);
    let mut set = Vec::with_capacity(n);
    for _ in 0..n {
        let mut v = [0u32; N];
        for x in v.iter_mut() {
            *x = r.u32()?;
        }
        nodes.push(v);
        set.push(r.u32()?);
    }
    Cells::from_parts(nodes, set, sets)
}

/// A file's physical names, by (dimension, tag), as bytes.
pub fn write_names(w: &mut Writer, names: &BTreeMap<(i32, i32), String>) {
    w.int(names.len());
    for ((dim, tag), name) in names {
        w.i32(*dim);
        w.i32(*tag);
        w.text(name);
    }
}

/// What [`write_names`] wrote.
pub fn read_names(r: &mut Reader) -> Option<BTreeMap<(i32, i32), String>> {
    (0..r.count(16)?)
        .map(|_| Some(((r.i32()?, r.i32()?), r.text()?)))
        .collect()
}
