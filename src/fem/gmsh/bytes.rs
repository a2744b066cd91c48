//! A [`GmshMesh`] as bytes: what world rank 0 sends the other ranks after reading (or meshing)
//! the file once, instead of their parsing it again.

use std::collections::BTreeMap;

use super::{Cells, ElementTags, GmshMesh, Nesting};

impl GmshMesh {
    /// The mesh as bytes (little-endian: the path, the points, each kind of element's tag
    /// lists then its nodes in 4 bytes and its list's index, the element tags' runs, the
    /// names, the nesting): what world rank 0 sends the others, 16 bytes per triangle and per
    /// node.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(16 * self.points.len() + 16 * self.triangles.len());
        text(&mut b, &self.path);
        int(&mut b, self.points.len() as u64);
        for p in &self.points {
            b.extend_from_slice(&p[0].to_le_bytes());
            b.extend_from_slice(&p[1].to_le_bytes());
        }
        cells(&mut b, &self.triangles);
        let (runs, len) = self.triangle_tags.runs();
        int(&mut b, len as u64);
        int(&mut b, runs.len() as u64);
        for &(first, tag, step) in runs {
            int(&mut b, first as u64);
            int(&mut b, tag);
            b.push(step);
        }
        cells(&mut b, &self.lines);
        int(&mut b, self.names.len() as u64);
        for ((dim, tag), name) in &self.names {
            b.extend_from_slice(&dim.to_le_bytes());
            b.extend_from_slice(&tag.to_le_bytes());
            text(&mut b, name);
        }
        // (a mesh of its own: no children)
        int(&mut b, self.nesting.map_or(0, |n| n.children) as u64);
        b
    }

    /// The mesh [`GmshMesh::to_bytes`] wrote (`None` for bytes it did not write).
    pub fn from_bytes(bytes: &[u8]) -> Option<GmshMesh> {
        let mut r = Reader { bytes, at: 0 };
        let path = r.text()?;
        let points = (0..r.int()?)
            .map(|_| Some([r.f64()?, r.f64()?]))
            .collect::<Option<Vec<_>>>()?;
        let triangles = r.cells()?;
        let len = r.int()?;
        let runs = (0..r.int()?)
            .map(|_| Some((r.int()?, r.int()? as u64, r.take::<1>()?[0])))
            .collect::<Option<Vec<_>>>()?;
        let triangle_tags = ElementTags::from_runs(runs, len)?;
        let lines = r.cells()?;
        let names = (0..r.int()?)
            .map(|_| Some(((r.i32()?, r.i32()?), r.text()?)))
            .collect::<Option<BTreeMap<_, _>>>()?;
        let nesting = match r.int()? {
            0 => None,
            children => Some(Nesting { children }),
        };
        (r.at == bytes.len()).then_some(GmshMesh {
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

fn int(b: &mut Vec<u8>, v: u64) {
    b.extend_from_slice(&v.to_le_bytes());
}

fn text(b: &mut Vec<u8>, t: &str) {
    int(b, t.len() as u64);
    b.extend_from_slice(t.as_bytes());
}

/// Elements as bytes: the tag lists, the count, then each element's nodes and list index in 4
/// bytes each.
fn cells<const N: usize>(b: &mut Vec<u8>, c: &Cells<N>) {
    let (nodes, set, sets) = c.parts();
    int(b, sets.len() as u64);
    for tags in sets {
        int(b, tags.len() as u64);
        for &t in tags {
            b.extend_from_slice(&t.to_le_bytes());
        }
    }
    int(b, nodes.len() as u64);
    for (n, &s) in nodes.iter().zip(set) {
        for &v in n {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&s.to_le_bytes());
    }
}

/// Reads what [`GmshMesh::to_bytes`] wrote.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let b = self.bytes.get(self.at..self.at + N)?;
        self.at += N;
        b.try_into().ok()
    }
    fn int(&mut self) -> Option<usize> {
        usize::try_from(u64::from_le_bytes(self.take()?)).ok()
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_le_bytes(self.take()?))
    }
    fn i32(&mut self) -> Option<i32> {
        Some(i32::from_le_bytes(self.take()?))
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take()?))
    }
    fn tags(&mut self) -> Option<Vec<i32>> {
        (0..self.int()?).map(|_| self.i32()).collect()
    }
    /// What [`cells`] wrote.
    fn cells<const N: usize>(&mut self) -> Option<Cells<N>> {
        let sets = (0..self.int()?)
            .map(|_| self.tags())
            .collect::<Option<Vec<_>>>()?;
        let n = self.int()?;
        // (a count the bytes cannot hold is refused before anything is allocated for it)
        if n > (self.bytes.len() - self.at) / (4 * (N + 1)) {
            return None;
        }
        let mut nodes = Vec::with_capacity(n);
        let mut set = Vec::with_capacity(n);
        for _ in 0..n {
            let mut v = [0u32; N];
            for x in v.iter_mut() {
                *x = self.u32()?;
            }
            nodes.push(v);
            set.push(self.u32()?);
        }
        Cells::from_parts(nodes, set, sets)
    }
    fn text(&mut self) -> Option<String> {
        let n = self.int()?;
        let b = self.bytes.get(self.at..self.at + n)?;
        self.at += n;
        String::from_utf8(b.to_vec()).ok()
    }
}
