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

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use mshio::mshfile::ElementType;

use crate::fem::checks;
use crate::fem::mesh::Mesh;
use crate::fem::order::{self, ElementOrder};

mod bytes;
mod cells;
mod refine;

pub use bytes::{read_names, write_names};
pub use cells::{Cells, ElementTags};

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

/// The largest mesh file read: 4 GiB (tens of millions of nodes).
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// Read a Gmsh MSH 4.1 file: a regular file of at most [`MAX_FILE_BYTES`] (not a device or a
/// pipe, which may never end).
pub fn read(path: &Path) -> Result<GmshMesh, GmshError> {
    let name = path.display().to_string();
    let io = |reason: String| GmshError::Io {
        path: name.clone(),
        reason,
    };
    let meta = std::fs::metadata(path).map_err(|e| io(e.to_string()))?;
    if !meta.is_file() {
        return Err(io("it is not a regular file".into()));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(io(format!(
            "{} bytes, more than a mesh file may have ({} GiB)",
            meta.len(),
            MAX_FILE_BYTES >> 30
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| io(e.to_string()))?;
    parse(&bytes, &name)
}

/// Parse the bytes of an MSH 4.1 file (`path` only names it in messages).
pub fn parse(bytes: &[u8], path: &str) -> Result<GmshMesh, GmshError> {
    let not_msh = |reason: String| GmshError::NotMsh {
        path: path.to_string(),
        reason,
    };
    let unsupported = |reason: String| GmshError::Unsupported {
        path: path.to_string(),
        reason,
    };
    if !bytes.starts_with(b"$MeshFormat") {
        return Err(not_msh("no $MeshFormat header".into()));
    }
    // The second line is "version file-type data-size" (ASCII in binary files too).
    let version = bytes
        .split(|&b| b == b'\n')
        .nth(1)
        .map(|l| {
            String::from_utf8_lossy(l)
                .split_whitespace()
                .next()
                .unwrap_or("?")
                .to_string()
        })
        .unwrap_or_else(|| "?".into());
    if version != "4.1" {
        return Err(not_msh(format!("format version {version}, not 4.1")));
    }
    // The node tags and coordinates as the file gives them (mshio keeps no tags when they are
    // dense, and a tag given twice would be lost): non-finite coordinates and a tag given
    // twice at two places are refused here, naming the node.
    let scanned = scan_nodes(bytes);
    if let Some(list) = &scanned {
        let mut at: HashMap<u64, [f64; 3]> = HashMap::with_capacity(list.len());
        for &(tag, p) in list {
            if p.iter().any(|c| !c.is_finite()) {
                return Err(GmshError::Invalid {
                    path: path.to_string(),
                    reason: format!(
                        "node {tag} has a coordinate that is not a finite number ({}, {}, {})",
                        p[0], p[1], p[2]
                    ),
                });
            }
            if let Some(q) = at.insert(tag, p) {
                if q != p {
                    return Err(GmshError::Invalid {
                        path: path.to_string(),
                        reason: format!(
                            "node tag {tag} is given twice, at ({:e}, {:e}) and at ({:e}, {:e}); renumber the nodes (Gmsh: Coherence Mesh; or merge the files again)",
                            q[0], q[1], p[0], p[1]
                        ),
                    });
                }
            }
        }
    }

    let msh = mshio::parse_msh_bytes(bytes).map_err(|e| {
        let text = e.to_string();
        not_msh(text.lines().next().unwrap_or("parse error").to_string())
    })?;
    let entities = msh
        .data
        .entities
        .as_ref()
        .ok_or_else(|| not_msh("no $Entities section".into()))?;
    if !entities.volumes.is_empty() {
        return Err(unsupported(
            "a 3D mesh (it has volumes); nndd reads 2D meshes in the plane z = 0".into(),
        ));
    }
    let surface_tags: HashMap<i32, Vec<i32>> = entities
        .surfaces
        .iter()
        .map(|s| (s.tag, s.physical_tags.clone()))
        .collect();
    let curve_tags: HashMap<i32, Vec<i32>> = entities
        .curves
        .iter()
        .map(|c| (c.tag, c.physical_tags.clone()))
        .collect();

    // Nodes: compact numbering in the file's order.
    let nodes = msh
        .data
        .nodes
        .as_ref()
        .ok_or_else(|| not_msh("no $Nodes section".into()))?;
    // With dense tags (min..=max over the file) mshio keeps no tag map: the tags then run
    // consecutively from the smallest one, block after block.
    let mut index: HashMap<u64, usize> = HashMap::new();
    let mut points = Vec::new();
    let mut next_tag = nodes.min_node_tag;
    let total: usize = nodes.node_blocks.iter().map(|b| b.nodes.len()).sum();
    let file_tags = scanned.filter(|l| l.len() == total);
    for block in &nodes.node_blocks {
        if block.entity_dim == 3 {
            return Err(unsupported("a 3D mesh (nodes on volumes)".into()));
        }
        let mut tags = vec![0u64; block.nodes.len()];
        match (&file_tags, &block.node_tags) {
            (Some(list), _) => {
                for (k, t) in tags.iter_mut().enumerate() {
                    *t = list[points.len() + k].0;
                }
            }
            (None, Some(map)) => {
                for (&t, &k) in map {
                    tags[k] = t;
                }
            }
            (None, None) => {
                for t in tags.iter_mut() {
                    *t = next_tag;
                    next_tag += 1;
                }
            }
        }
        for (node, &tag) in block.nodes.iter().zip(&tags) {
            if !(node.x.is_finite() && node.y.is_finite() && node.z.is_finite()) {
                return Err(GmshError::Invalid {
                    path: path.to_string(),
                    reason: format!(
                        "node {tag} has a coordinate that is not a finite number ({}, {}, {})",
                        node.x, node.y, node.z
                    ),
                });
            }
            if node.z.abs() > 1e-12 * (1.0 + node.x.abs().max(node.y.abs())) {
                return Err(unsupported(format!(
                    "node {tag} has z = {:e}: nndd reads 2D meshes in the plane z = 0",
                    node.z
                )));
            }
            index.insert(tag, points.len());
            points.push([node.x, node.y]);
        }
    }

    // Elements: 3-node triangles on surfaces, 2-node lines on curves; points are ignored.
    let elements = msh
        .data
        .elements
        .as_ref()
        .ok_or_else(|| not_msh("no $Elements section".into()))?;
    let mut triangles = Cells::default();
    let mut triangle_tags = ElementTags::default();
    let mut lines = Cells::default();
    let lookup = |tag: &u64| {
        index.get(tag).copied().ok_or_else(|| GmshError::Invalid {
            path: path.to_string(),
            reason: format!("an element refers to node {tag}, which is not in $Nodes"),
        })
    };
    for block in &elements.element_blocks {
        match block.element_type {
            ElementType::Tri3 => {
                let phys = surface_tags
                    .get(&block.entity_tag)
                    .cloned()
                    .unwrap_or_default();
                for e in &block.elements {
                    let t = [
                        lookup(&e.nodes[0])?,
                        lookup(&e.nodes[1])?,
                        lookup(&e.nodes[2])?,
                    ];
                    triangles.push(t, &phys);
                    triangle_tags.push(e.element_tag);
                }
            }
            ElementType::Lin2 => {
                let phys = curve_tags
                    .get(&block.entity_tag)
                    .cloned()
                    .unwrap_or_default();
                for e in &block.elements {
                    lines.push([lookup(&e.nodes[0])?, lookup(&e.nodes[1])?], &phys);
                }
            }
            ElementType::Pnt => {}
            other => {
                let what = match other {
                    ElementType::Lin3 | ElementType::Tri6 | ElementType::Tri9 | ElementType::Tri10 => {
                        "quadratic or higher-order elements (nndd uses linear triangles: mesh with `Mesh.ElementOrder = 1`)"
                    }
                    ElementType::Qua4 | ElementType::Qua8 | ElementType::Qua9 => {
                        "quadrilaterals (nndd uses linear triangles: remove `Recombine`)"
                    }
                    _ => "3D or higher-order elements (nndd reads 2D meshes of linear triangles)",
                };
                return Err(unsupported(format!("{what}; found {other:?}")));
            }
        }
    }
    if triangles.is_empty() {
        return Err(unsupported(
            "no linear triangles (is the mesh 2D and in a physical surface?)".into(),
        ));
    }
    Ok(GmshMesh {
        path: path.to_string(),
        points,
        triangles,
        triangle_tags,
        lines,
        names: physical_names(bytes),
        nesting: None,
    })
}

/// The `$Nodes` section read directly: every node's tag and (x, y, z) in the file's order
/// (ASCII or binary MSH 4.1); `None` where the section is not as expected (parametric nodes,
/// a damaged file: mshio's parse then decides).
fn scan_nodes(bytes: &[u8]) -> Option<Vec<(u64, [f64; 3])>> {
    let header = bytes.split(|&b| b == b'\n').nth(1)?;
    let header = String::from_utf8_lossy(header);
    let mut h = header.split_whitespace().skip(1);
    let binary = h.next()? == "1";
    let size_t: usize = h.next()?.parse().ok()?;
    let start = find(bytes, b"\n$Nodes")? + "\n$Nodes".len();
    let mut at = start + bytes[start..].iter().position(|&b| b == b'\n')? + 1;
    let mut out = Vec::new();
    if binary {
        if size_t != 8 {
            return None;
        }
        let mut take = |n: usize| -> Option<&[u8]> {
            let b = bytes.get(at..at + n)?;
            at += n;
            Some(b)
        };
        let u = |b: &[u8]| u64::from_le_bytes(b.try_into().unwrap());
        let head = take(32)?;
        let blocks = u(&head[..8]);
        let count = u(&head[8..16]) as usize;
        out.reserve(count.min(bytes.len() / 32));
        for _ in 0..blocks {
            let b = take(20)?;
            let parametric = i32::from_le_bytes(b[8..12].try_into().unwrap());
            let n = u(&b[12..20]) as usize;
            if parametric != 0 {
                return None;
            }
            let tags = take(n.checked_mul(8)?)?.to_vec();
            let xyz = take(n.checked_mul(24)?)?;
            for k in 0..n {
                let c = |i: usize| {
                    f64::from_le_bytes(xyz[24 * k + 8 * i..24 * k + 8 * i + 8].try_into().unwrap())
                };
                out.push((u(&tags[8 * k..8 * k + 8]), [c(0), c(1), c(2)]));
            }
        }
    } else {
        let end = start + find(&bytes[start..], b"$EndNodes")?;
        let text = std::str::from_utf8(&bytes[at..end]).ok()?;
        let mut lines = text.lines();
        let nums = |l: &str| -> Option<Vec<u64>> {
            l.split_whitespace().map(|w| w.parse().ok()).collect()
        };
        let head = nums(lines.next()?)?;
        for _ in 0..*head.first()? {
            let b = nums(lines.next()?)?;
            if b.len() != 4 || b[2] != 0 {
                return None;
            }
            let n = b[3] as usize;
            let tags: Vec<u64> = (0..n)
                .map(|_| lines.next()?.trim().parse().ok())
                .collect::<Option<_>>()?;
            for tag in tags {
                let v: Vec<f64> = lines
                    .next()?
                    .split_whitespace()
                    .map(|w| w.parse().ok())
                    .collect::<Option<_>>()?;
                if v.len() != 3 {
                    return None;
                }
                out.push((tag, [v[0], v[1], v[2]]));
            }
        }
    }
    Some(out)
}

/// The `$PhysicalNames` section: (dimension, tag) → name.
fn physical_names(bytes: &[u8]) -> BTreeMap<(i32, i32), String> {
    let mut names = BTreeMap::new();
    let start = match find(bytes, b"$PhysicalNames") {
        Some(s) => s,
        None => return names,
    };
    let end = find(&bytes[start..], b"$EndPhysicalNames").map_or(bytes.len(), |e| start + e);
    let text = String::from_utf8_lossy(&bytes[start..end]);
    for line in text.lines().skip(2) {
        let mut it = line.splitn(3, char::is_whitespace);
        let (Some(dim), Some(tag), Some(name)) = (it.next(), it.next(), it.next()) else {
            continue;
        };
        if let (Ok(dim), Ok(tag)) = (dim.parse(), tag.parse()) {
            names.insert((dim, tag), name.trim().trim_matches('"').to_string());
        }
    }
    names
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
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
