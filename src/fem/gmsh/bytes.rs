//! A [`GmshMesh`] as bytes: what world rank 0 sends the other ranks after reading (or meshing)
//! the file once, instead of their parsing it again.

use std::collections::BTreeMap;

use super::{Cells, ElementTags, GmshMesh};

impl GmshMesh {
    /// The mesh as bytes (little-endian counts, coordinates, nodes and tags, then the names):
    /// what one rank sends the others instead of their parsing the file again.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(16 * self.points.len() + 40 * self.triangles.len());
        let int = |b: &mut Vec<u8>, v: u64| b.extend_from_slice(&v.to_le_bytes());
        let text = |b: &mut Vec<u8>, t: &str| {
            b.extend_from_slice(&(t.len() as u64).to_le_bytes());
            b.extend_from_slice(t.as_bytes());
        };
        text(&mut b, &self.path);
        int(&mut b, self.points.len() as u64);
        for p in &self.points {
            b.extend_from_slice(&p[0].to_le_bytes());
            b.extend_from_slice(&p[1].to_le_bytes());
        }
        let cells = |b: &mut Vec<u8>, nodes: &[usize], tags: &[i32]| {
            for &n in nodes {
                int(b, n as u64);
            }
            int(b, tags.len() as u64);
            for &t in tags {
                b.extend_from_slice(&t.to_le_bytes());
            }
        };
        int(&mut b, self.triangles.len() as u64);
        for (t, tags) in &self.triangles {
            cells(&mut b, &t, tags);
        }
        int(&mut b, self.triangle_tags.len() as u64);
        for t in self.triangle_tags.iter() {
            int(&mut b, t);
        }
        int(&mut b, self.lines.len() as u64);
        for (l, tags) in &self.lines {
            cells(&mut b, &l, tags);
        }
        int(&mut b, self.names.len() as u64);
        for ((dim, tag), name) in &self.names {
            b.extend_from_slice(&dim.to_le_bytes());
            b.extend_from_slice(&tag.to_le_bytes());
            text(&mut b, name);
        }
        b
    }

    /// The mesh [`GmshMesh::to_bytes`] wrote (`None` for bytes it did not write).
    pub fn from_bytes(bytes: &[u8]) -> Option<GmshMesh> {
        let mut r = Reader { bytes, at: 0 };
        let path = r.text()?;
        let points = (0..r.int()?)
            .map(|_| Some([r.f64()?, r.f64()?]))
            .collect::<Option<Vec<_>>>()?;
        let mut triangles = Cells::default();
        for _ in 0..r.int()? {
            triangles.push([r.int()?, r.int()?, r.int()?], &r.tags()?);
        }
        let triangle_tags = (0..r.int()?)
            .map(|_| Some(r.int()? as u64))
            .collect::<Option<ElementTags>>()?;
        let mut lines = Cells::default();
        for _ in 0..r.int()? {
            lines.push([r.int()?, r.int()?], &r.tags()?);
        }
        let names = (0..r.int()?)
            .map(|_| Some(((r.i32()?, r.i32()?), r.text()?)))
            .collect::<Option<BTreeMap<_, _>>>()?;
        (r.at == bytes.len()).then_some(GmshMesh {
            path,
            points,
            triangles,
            triangle_tags,
            lines,
            names,
        })
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
    fn tags(&mut self) -> Option<Vec<i32>> {
        (0..self.int()?).map(|_| self.i32()).collect()
    }
    fn text(&mut self) -> Option<String> {
        let n = self.int()?;
        let b = self.bytes.get(self.at..self.at + n)?;
        self.at += n;
        String::from_utf8(b.to_vec()).ok()
    }
}
