//! Gmsh input: MSH 4.1 files (ASCII or binary, parsed by the `mshio` crate) of a 2D mesh of
//! linear triangles, with physical groups naming its parts.
//!
//! [`read`] returns a [`GmshMesh`]: every node (x, y), every 3-node triangle with the physical
//! surfaces it belongs to, every 2-node line with its physical curves, and the physical names.
//! [`GmshMesh::body`] cuts out one named surface as a [`Mesh`] (its own node numbering,
//! counter-clockwise triangles) with its named curves as edge lists.
//!
//! MSH 4.1 stores only the elements of entities that belong to a physical group (unless the
//! file was saved with `Mesh.SaveAll`), and `mshio` skips the `$PhysicalNames` section, which
//! is read here (it is ASCII in binary files too).

use std::collections::BTreeMap;

use crate::fem::checks;
use crate::fem::mesh::Mesh;
use crate::fem::order::{self, ElementOrder};

mod bytes;
mod cells;
mod parse;
mod refine;

pub use bytes::{read_names, write_names};
pub use cells::{Cells, ElementTags};
pub use parse::{parse, read, MAX_FILE_BYTES};

/// The tag of the physical group `name` of dimension `dim` among a file's `names`.
pub fn tag_of(names: &BTreeMap<(i32, i32), String>, dim: i32, name: &str) -> Option<i32> {
    names
        .iter()
        .find(|((d, _), n)| *d == dim && n.as_str() == name)
        .map(|((_, t), _)| *t)
}

/// The names of the physical groups of dimension `dim` among a file's `names`, for messages
/// ("none" where there is none).
pub fn group_names(names: &BTreeMap<(i32, i32), String>, dim: i32) -> String {
    let v: Vec<&str> = names
        .iter()
        .filter(|((d, _), _)| *d == dim)
        .map(|(_, n)| n.as_str())
        .collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// What is wrong with a mesh file, in the words the user needs (the caller names the option).
#[derive(Debug, thiserror::Error)]
pub enum GmshError {
    #[error("cannot read {path}: {reason}")]
    Io { path: String, reason: String },
    #[error("cannot mesh {path}: {reason}")]
    Meshing { path: String, reason: String },
    #[error("{path} is not a Gmsh MSH 4.1 file ({reason}); write it with `gmsh -2 -format msh41`")]
    NotMsh { path: String, reason: String },
    #[error("{path}: {reason}")]
    Unsupported { path: String, reason: String },
    #[error("{path} has no physical surface named '{name}' (physical surfaces: {known})")]
    NoSurface {
        path: String,
        name: String,
        known: String,
    },
    #[error("{path}: {reason}")]
    Invalid { path: String, reason: String },
    #[error("{path}: '{}' has a degenerate triangle, {}: relative area 2·area/(longest edge)² = {:.3e}, below {:e}", .triangle.body, .triangle.element, .triangle.quality, checks::MIN_QUALITY)]
    Degenerate {
        path: String,
        triangle: Box<DegenerateTriangle>,
    },
}

/// A triangle whose relative area is below [`checks::MIN_QUALITY`] ([`GmshError::Degenerate`]).
#[derive(Debug)]
pub struct DegenerateTriangle {
    /// The physical surface.
    pub body: String,
    /// The Gmsh element and its corners, in words.
    pub element: String,
    pub corners: [[f64; 2]; 3],
    /// 2·area/(longest edge)².
    pub quality: f64,
}

/// A 2D triangle mesh as Gmsh wrote it (nodes numbered 0.. in the file's order).
#[derive(Clone, Debug, Default)]
pub struct GmshMesh {
    /// The file, for messages.
    pub path: String,
    pub points: Vec<[f64; 2]>,
    /// 3-node triangles and the physical surface tags of their entity.
    pub triangles: Cells<3>,
    /// The Gmsh element tag of each triangle (empty when not known: a mesh built in code).
    pub triangle_tags: ElementTags,
    /// 2-node lines and the physical curve tags of their entity.
    pub lines: Cells<2>,
    /// Physical names by (dimension, tag).
    pub names: BTreeMap<(i32, i32), String>,
    /// How a mesh made by [`GmshMesh::refined`] nests in the file's (`None`: the file's own).
    pub nesting: Option<Nesting>,
}

/// How a refined mesh nests in the mesh it was refined from: each of that mesh's triangles
/// became `children` consecutive ones. A body of either lists its triangles in the same order
/// of the coarse ones ([`GmshMesh::body`]), so that the refined body's triangles
/// r² t … r² (t + 1) − 1 lie in the coarse body's triangle t (the reference solution's
/// transfer relies on it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Nesting {
    pub children: usize,
}

/// One body cut out of a [`GmshMesh`]: its mesh and its named boundary curves.
#[derive(Clone, Debug)]
pub struct GmshBody {
    pub mesh: Mesh,
    /// Each triangle's index in [`GmshMesh::triangles`].
    pub elements: Vec<usize>,
    /// Physical curve name → the body's edges on it (body node numbers).
    pub curves: BTreeMap<String, Vec<[usize; 2]>>,
}

impl GmshMesh {
    /// The physical tag of the group named `name` of dimension `dim`, if any.
    /// The line elements of the physical curve `name` (its nodes' pairs), if it exists.
    pub fn curve_edges(&self, name: &str) -> Option<Vec<[usize; 2]>> {
        let tag = self.tag(1, name)?;
        Some(
            self.lines
                .iter()
                .filter(|(_, phys)| phys.contains(&tag))
                .map(|(l, _)| l)
                .collect(),
        )
    }

    pub fn tag(&self, dim: i32, name: &str) -> Option<i32> {
        tag_of(&self.names, dim, name)
    }

    /// The Gmsh tag of triangle `i` (its number from 1 where the tags are not known).
    pub fn element_tag(&self, i: usize) -> u64 {
        match self.triangle_tags.is_empty() {
            true => i as u64 + 1,
            false => self.triangle_tags.get(i),
        }
    }

    /// Triangle `i` for a message: "element TAG (x, y), (x, y), (x, y)".
    pub fn describe(&self, i: usize) -> String {
        let p = self.triangles.nodes(i).map(|a| self.points[a]);
        format!(
            "element {} ({:.6e}, {:.6e}), ({:.6e}, {:.6e}), ({:.6e}, {:.6e})",
            self.element_tag(i),
            p[0][0],
            p[0][1],
            p[1][0],
            p[1][1],
            p[2][0],
            p[2][1]
        )
    }

    /// The names of the physical groups of dimension `dim`, comma separated.
    pub fn group_names(&self, dim: i32) -> String {
        group_names(&self.names, dim)
    }

    /// The number of nodes of the triangles of the physical surface `name` (0 if none).
    pub fn surface_node_count(&self, name: &str) -> usize {
        let Some(tag) = self.tag(2, name) else {
            return 0;
        };
        let mut seen = vec![false; self.points.len()];
        for (t, phys) in &self.triangles {
            if phys.contains(&tag) {
                t.iter().for_each(|&a| seen[a] = true);
            }
        }
        seen.iter().filter(|&&s| s).count()
    }

    /// The triangles of the physical surface `tag` in the `order` asked, as indices into
    /// [`GmshMesh::triangles`]: the file's, or bands ([`order::breadth_first`]); on a refined
    /// mesh the coarse triangles' children together, in the coarse triangles' order (the
    /// children of two coarse triangles share sides where those do: the same order as the
    /// coarse body's, [`Nesting`]).
    fn surface_triangles(&self, tag: i32, order: ElementOrder) -> Vec<usize> {
        let children = self.nesting.map_or(1, |n| n.children);
        let groups: Vec<usize> = (0..self.triangles.len() / children)
            .filter(|&g| self.triangles.tags(g * children).contains(&tag))
            .collect();
        let groups = match order {
            ElementOrder::File => groups,
            ElementOrder::Bands => {
                let sides: Vec<([usize; 2], u32)> = (groups.iter().enumerate())
                    .flat_map(|(j, &g)| {
                        (g * children..(g + 1) * children).flat_map(move |i| {
                            let t = self.triangles.nodes(i);
                            [0, 1, 2].map(|k| ([t[k], t[(k + 1) % 3]], j as u32))
                        })
                    })
                    .collect();
                (order::breadth_first(groups.len(), sides).into_iter())
                    .map(|j| groups[j])
                    .collect()
            }
        };
        (groups.into_iter())
            .flat_map(|g| g * children..(g + 1) * children)
            .collect()
    }

    /// Cut out the physical surface `name` as a mesh of its own, its triangles in the `order`
    /// asked ([`GmshMesh::surface_triangles`]; bands: what a rank holds of the body is near its
    /// share) and counter-clockwise, its nodes numbered in the file's order or, in bands, as
    /// the triangles first meet them, with the physical curves whose lines lie on it.
    pub fn body(&self, name: &str, order: ElementOrder) -> Result<GmshBody, GmshError> {
        let tag = self.tag(2, name).ok_or_else(|| GmshError::NoSurface {
            path: self.path.clone(),
            name: name.to_string(),
            known: self.group_names(2),
        })?;
        let tris = self.surface_triangles(tag, order);
        if tris.is_empty() {
            return Err(GmshError::Invalid {
                path: self.path.clone(),
                reason: format!("the physical surface '{name}' has no triangles"),
            });
        }
        // The nodes as the triangles, in that order, first meet them (bands), or in the
        // file's order.
        const NONE: usize = usize::MAX;
        let mut local = vec![NONE; self.points.len()];
        let mut used: Vec<usize> = Vec::new();
        for a in tris.iter().flat_map(|&i| self.triangles.nodes(i)) {
            if local[a] == NONE {
                local[a] = 0;
                used.push(a);
            }
        }
        if order == ElementOrder::File {
            used.sort_unstable();
        }
        for (i, &a) in used.iter().enumerate() {
            local[a] = i;
        }
        let points: Vec<[f64; 2]> = used.iter().map(|&a| self.points[a]).collect();
        // Flat triangles are refused; the others are turned counter-clockwise (Gmsh writes a
        // surface's triangles in one orientation: those of the other one are inverted).
        let mut triangles = Vec::with_capacity(tris.len());
        let mut clockwise = Vec::with_capacity(tris.len());
        for &i in &tris {
            let t = self.triangles.nodes(i);
            let mut l = t.map(|a| local[a]);
            let q = checks::quality(l.map(|a| points[a]));
            if checks::degenerate(q) {
                return Err(GmshError::Degenerate {
                    path: self.path.clone(),
                    triangle: Box::new(DegenerateTriangle {
                        body: name.to_string(),
                        element: self.describe(i),
                        corners: t.map(|a| self.points[a]),
                        quality: q,
                    }),
                });
            }
            if q < 0.0 {
                l.swap(1, 2);
            }
            clockwise.push(q < 0.0);
            triangles.push(l);
        }
        let mesh = Mesh::unstructured(points, triangles);
        // Counter-clockwise neighbours go through their common side in opposite directions.
        if let Some((e, f)) = checks::fold(&mesh) {
            let (a, b) = (tris[e], tris[f]);
            let same = {
                let mut x = self.triangles.nodes(a);
                let mut y = self.triangles.nodes(b);
                x.sort_unstable();
                y.sort_unstable();
                x == y
            };
            let reason = if same {
                format!(
                    "'{name}' has the same triangle twice: {} and {}",
                    self.describe(a),
                    self.describe(b)
                )
            } else {
                // The inverted one: of the orientation fewer triangles of the surface have.
                let minority = 2 * clockwise.iter().filter(|&&c| c).count() < clockwise.len();
                let inverted = if clockwise[f] == minority { b } else { a };
                format!(
                    "'{name}' is folded: {} and {} lie on the same side of their common edge (inverted: element {})",
                    self.describe(a),
                    self.describe(b),
                    self.element_tag(inverted)
                )
            };
            return Err(GmshError::Invalid {
                path: self.path.clone(),
                reason,
            });
        }
        let mut curves: BTreeMap<String, Vec<[usize; 2]>> = BTreeMap::new();
        for (l, phys) in &self.lines {
            if local[l[0]] == NONE || local[l[1]] == NONE {
                continue;
            }
            for p in phys {
                if let Some(n) = self.names.get(&(1, *p)) {
                    curves
                        .entry(n.clone())
                        .or_default()
                        .push([local[l[0]], local[l[1]]]);
                }
            }
        }
        Ok(GmshBody {
            mesh,
            elements: tris,
            curves,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::parse::scan_nodes;
    use super::*;

    /// Two triangles of the unit square (surface `body1`), its bottom edge (curve `base`), with
    /// sparse node tags and clockwise triangles.
    const SQUARE: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n1 7 \"base\"\n2 3 \"body1\"\n$EndPhysicalNames\n$Entities\n0 1 1 0\n1 0 0 0 1 0 0 1 7 0\n1 0 0 0 1 1 0 1 3 0\n$EndEntities\n$Nodes\n1 4 10 40\n2 1 0 4\n10\n20\n30\n40\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n$EndNodes\n$Elements\n2 3 1 3\n1 1 1 1\n1 10 20\n2 1 2 2\n2 10 30 20\n3 10 40 30\n$EndElements\n";

    #[test]
    fn reads_nodes_triangles_curves_and_names() {
        let m = parse(SQUARE.as_bytes(), "square.msh").unwrap();
        assert_eq!(
            m.points,
            vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
        );
        assert_eq!(m.triangles.len(), 2);
        assert_eq!(m.lines, vec![([0, 1], vec![7])].into());
        assert_eq!(m.tag(2, "body1"), Some(3));
        assert_eq!(m.surface_node_count("body1"), 4);
        let b = m.body("body1", ElementOrder::File).unwrap();
        // Clockwise triangles are turned counter-clockwise.
        for e in 0..b.mesh.triangles.len() {
            let p = b.mesh.triangle_points(e);
            let a2 = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
            assert!((a2 - 1.0).abs() < 1e-15, "triangle {e}: 2 area {a2}");
        }
        let base: Vec<[[f64; 2]; 2]> = (b.curves["base"].iter())
            .map(|e| e.map(|a| b.mesh.points.get(a)))
            .collect();
        assert_eq!(base, vec![[[0.0, 0.0], [1.0, 0.0]]]);
        assert_eq!(b.mesh.boundary_edges().len(), 4);
    }

    #[test]
    fn bytes_give_the_same_mesh_and_refuse_anything_else() {
        let m = parse(SQUARE.as_bytes(), "square.msh").unwrap().refined(3);
        let b = m.to_bytes();
        let back = GmshMesh::from_bytes(&b).unwrap();
        assert_eq!(back.path, m.path);
        assert_eq!(back.points, m.points);
        assert_eq!(back.triangles, m.triangles);
        assert_eq!(back.lines, m.lines);
        assert_eq!(back.triangle_tags, m.triangle_tags);
        assert!(!m.triangle_tags.is_empty());
        assert_eq!(back.names, m.names);
        assert_eq!(
            (back.nesting, m.nesting.map(|n| n.children)),
            (m.nesting, Some(9))
        );
        // 16 bytes per node and per triangle, and a little for the tag lists and names.
        let size = 16 * (m.points.len() + m.triangles.len()) + 4 * 3 * m.lines.len();
        assert!(b.len() < size + 400, "{} bytes for {size}", b.len());
        assert!(GmshMesh::from_bytes(&b[..b.len() - 1]).is_none());
        let mut longer = b.clone();
        longer.push(0);
        assert!(GmshMesh::from_bytes(&longer).is_none());
    }

    #[test]
    fn refinement_is_nested_and_keeps_numbers_orientation_and_curves() {
        let m = parse(SQUARE.as_bytes(), "square.msh").unwrap();
        let r = 3;
        let f = m.refined(r);
        // 4 vertices + (r − 1) per edge (5 edges) + (r − 1)(r − 2)/2 per triangle.
        assert_eq!(f.points.len(), 4 + 5 * (r - 1) + 2 * (r - 1) * (r - 2) / 2);
        assert_eq!(&f.points[..4], &m.points[..]);
        assert_eq!(f.triangles.len(), 2 * r * r);
        assert_eq!(f.lines.len(), r);
        let area = |p: [[f64; 2]; 3]| {
            0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
        };
        let pts = |pts: &[[f64; 2]], t: [usize; 3]| t.map(|a| pts[a]);
        for (c, (t, _)) in m.triangles.iter().enumerate() {
            let a = area(pts(&m.points, t));
            let children = r * r * c..r * r * (c + 1);
            let sum: f64 = children
                .clone()
                .map(|s| area(pts(&f.points, f.triangles.nodes(s))))
                .sum();
            assert!((sum - a).abs() < 1e-14, "triangle {c}: areas {sum} vs {a}");
            for s in children {
                let b = area(pts(&f.points, f.triangles.nodes(s)));
                assert!((b - a / (r * r) as f64).abs() < 1e-14 && b * a > 0.0);
                assert_eq!(f.triangles.tags(s), m.triangles.tags(c));
            }
        }
        // The curve 'base' is the bottom edge split into r pieces, in order.
        let b = f.body("body1", ElementOrder::File).unwrap();
        let edges = &b.curves["base"];
        assert_eq!(edges.len(), r);
        for (k, e) in edges.iter().enumerate() {
            let (p, q) = (b.mesh.points.get(e[0]), b.mesh.points.get(e[1]));
            assert_eq!(e[1], edges.get(k + 1).map_or(e[1], |n| n[0]), "a chain");
            assert!((p[0] - k as f64 / r as f64).abs() < 1e-15 && p[1] == 0.0);
            assert!((q[0] - (k + 1) as f64 / r as f64).abs() < 1e-15 && q[1] == 0.0);
        }
        assert_eq!(b.mesh.boundary_edges().len(), 4 * r);
    }

    #[test]
    fn element_tags_nan_and_node_tags_given_twice() {
        let m = parse(SQUARE.as_bytes(), "x.msh").unwrap();
        assert_eq!(m.triangle_tags.iter().collect::<Vec<_>>(), vec![2, 3]);
        assert!(m
            .describe(1)
            .starts_with("element 3 (0.000000e0, 0.000000e0)"));
        let err = |text: &str| parse(text.as_bytes(), "x.msh").unwrap_err().to_string();
        let nan = SQUARE.replace("1 1 0\n0 1 0\n$EndNodes", "1 NaN 0\n0 1 0\n$EndNodes");
        let e = err(&nan);
        assert!(
            e.contains("node 30 has a coordinate that is not a finite number"),
            "{e}"
        );
        let inf = SQUARE.replace("1 1 0\n0 1 0\n$EndNodes", "1 1 0\n-inf 1 0\n$EndNodes");
        assert!(err(&inf).contains("node 40 has a coordinate"));
        // Node 40 given tag 10 (at another place): refused; at the same place: accepted.
        let twice = SQUARE.replace("30\n40\n", "30\n10\n");
        let e = err(&twice);
        assert!(e.contains("node tag 10 is given twice"), "{e}");
        let same = twice.replace("1 1 0\n0 1 0\n$EndNodes", "1 1 0\n0 0 0\n$EndNodes");
        assert!(
            parse(same.as_bytes(), "x.msh").is_err(),
            "element on the missing node 40"
        );
        assert!(scan_nodes(same.as_bytes()).is_some());
    }

    #[test]
    fn bodies_with_flat_or_folded_triangles_are_refused() {
        let m = parse(SQUARE.as_bytes(), "x.msh").unwrap();
        let mut flat = m.clone();
        // Node 40 = (0, 1) onto the diagonal from (0, 0) to (1, 1).
        flat.points[3] = [0.5, 0.5 + 1e-9];
        let e = flat
            .body("body1", ElementOrder::File)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("'body1' has a degenerate triangle, element 3"),
            "{e}"
        );
        let mut folded = m.clone();
        // Node 40 across the diagonal: both triangles below it.
        folded.points[3] = [0.9, 0.2];
        let e = folded
            .body("body1", ElementOrder::File)
            .unwrap_err()
            .to_string();
        assert!(e.contains("'body1' is folded: element "), "{e}");
        assert!(
            e.contains("element 2 (") && e.contains("element 3 ("),
            "{e}"
        );
        assert!(e.contains("(inverted: element"), "{e}");
    }

    #[test]
    fn refuses_what_it_cannot_read() {
        let err = |bytes: &[u8]| parse(bytes, "x.msh").unwrap_err().to_string();
        assert!(err(b"hello").contains("not a Gmsh MSH 4.1 file"));
        let v2 = SQUARE.replace("4.1 0 8", "2.2 0 8");
        assert!(err(v2.as_bytes()).contains("version 2.2"));
        let z = SQUARE.replace("1 1 0\n0 1 0\n$EndNodes", "1 1 0.5\n0 1 0\n$EndNodes");
        assert!(err(z.as_bytes()).contains("z = "));
        let m = parse(SQUARE.as_bytes(), "x.msh").unwrap();
        assert!(m
            .body("body2", ElementOrder::File)
            .unwrap_err()
            .to_string()
            .contains("body1"));
    }
}
