//! Reading an MSH 4.1 file's bytes into a [`GmshMesh`]: the header, the nodes (their tags as
//! the file gives them, [`scan_nodes`]), the triangles and lines with their entities' physical
//! tags (through `mshio`), and the physical names (`$PhysicalNames`, which `mshio` skips).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use mshio::mshfile::ElementType;

use super::{Cells, ElementTags, GmshError, GmshMesh};

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
    let e = Errors(path);
    check_version(bytes, &e)?;
    // The node tags and coordinates as the file gives them (mshio keeps no tags when they are
    // dense, and a tag given twice would be lost): non-finite coordinates and a tag given
    // twice at two places are refused here, naming the node.
    let scanned = scan_nodes(bytes);
    if let Some(list) = &scanned {
        check_scanned(list, &e)?;
    }
    let msh = mshio::parse_msh_bytes(bytes).map_err(|err| {
        let text = err.to_string();
        e.not_msh(text.lines().next().unwrap_or("parse error").to_string())
    })?;
    let (index, points) = read_points(&msh, scanned, &e)?;
    let (triangles, triangle_tags, lines) = read_elements(&msh, &index, &e)?;
    if triangles.is_empty() {
        return Err(e.unsupported(
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

/// The errors of the file `.0`, by kind.
struct Errors<'a>(&'a str);

impl Errors<'_> {
    fn not_msh(&self, reason: String) -> GmshError {
        GmshError::NotMsh {
            path: self.0.to_string(),
            reason,
        }
    }

    fn unsupported(&self, reason: String) -> GmshError {
        GmshError::Unsupported {
            path: self.0.to_string(),
            reason,
        }
    }

    fn invalid(&self, reason: String) -> GmshError {
        GmshError::Invalid {
            path: self.0.to_string(),
            reason,
        }
    }
}

/// The `$MeshFormat` header, of version 4.1.
fn check_version(bytes: &[u8], e: &Errors) -> Result<(), GmshError> {
    if !bytes.starts_with(b"$MeshFormat") {
        return Err(e.not_msh("no $MeshFormat header".into()));
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
        return Err(e.not_msh(format!("format version {version}, not 4.1")));
    }
    Ok(())
}

/// The file's nodes as [`scan_nodes`] read them: finite coordinates, and a tag given twice
/// only at one place.
fn check_scanned(list: &[(u64, [f64; 3])], e: &Errors) -> Result<(), GmshError> {
    let mut at: HashMap<u64, [f64; 3]> = HashMap::with_capacity(list.len());
    for &(tag, p) in list {
        if p.iter().any(|c| !c.is_finite()) {
            return Err(e.invalid(format!(
                "node {tag} has a coordinate that is not a finite number ({}, {}, {})",
                p[0], p[1], p[2]
            )));
        }
        if let Some(q) = at.insert(tag, p) {
            if q != p {
                return Err(e.invalid(format!(
                    "node tag {tag} is given twice, at ({:e}, {:e}) and at ({:e}, {:e}); renumber the nodes (Gmsh: Coherence Mesh; or merge the files again)",
                    q[0], q[1], p[0], p[1]
                )));
            }
        }
    }
    Ok(())
}

/// Each node tag's index among the points.
type NodeIndex = HashMap<u64, usize>;

/// The nodes, numbered compactly in the file's order: each node tag's index, and the points.
fn read_points(
    msh: &mshio::MshFile<u64, i32, f64>,
    scanned: Option<Vec<(u64, [f64; 3])>>,
    e: &Errors,
) -> Result<(NodeIndex, Vec<[f64; 2]>), GmshError> {
    let nodes = msh
        .data
        .nodes
        .as_ref()
        .ok_or_else(|| e.not_msh("no $Nodes section".into()))?;
    // With dense tags (min..=max over the file) mshio keeps no tag map: the tags then run
    // consecutively from the smallest one, block after block.
    let mut index: NodeIndex = HashMap::new();
    let mut points = Vec::new();
    let mut next_tag = nodes.min_node_tag;
    let total: usize = nodes.node_blocks.iter().map(|b| b.nodes.len()).sum();
    let file_tags = scanned.filter(|l| l.len() == total);
    for block in &nodes.node_blocks {
        if block.entity_dim == 3 {
            return Err(e.unsupported("a 3D mesh (nodes on volumes)".into()));
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
                return Err(e.invalid(format!(
                    "node {tag} has a coordinate that is not a finite number ({}, {}, {})",
                    node.x, node.y, node.z
                )));
            }
            if node.z.abs() > 1e-12 * (1.0 + node.x.abs().max(node.y.abs())) {
                return Err(e.unsupported(format!(
                    "node {tag} has z = {:e}: nndd reads 2D meshes in the plane z = 0",
                    node.z
                )));
            }
            index.insert(tag, points.len());
            points.push([node.x, node.y]);
        }
    }
    Ok((index, points))
}

/// The 3-node triangles on surfaces (with their Gmsh element tags) and the 2-node lines on
/// curves, each with its entity's physical tags; points are ignored, anything else refused.
fn read_elements(
    msh: &mshio::MshFile<u64, i32, f64>,
    index: &NodeIndex,
    e: &Errors,
) -> Result<(Cells<3>, ElementTags, Cells<2>), GmshError> {
    let entities = msh
        .data
        .entities
        .as_ref()
        .ok_or_else(|| e.not_msh("no $Entities section".into()))?;
    if !entities.volumes.is_empty() {
        return Err(e.unsupported(
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
    let elements = msh
        .data
        .elements
        .as_ref()
        .ok_or_else(|| e.not_msh("no $Elements section".into()))?;
    let mut triangles = Cells::default();
    let mut triangle_tags = ElementTags::default();
    let mut lines = Cells::default();
    let lookup = |tag: &u64| {
        index.get(tag).copied().ok_or_else(|| {
            e.invalid(format!(
                "an element refers to node {tag}, which is not in $Nodes"
            ))
        })
    };
    for block in &elements.element_blocks {
        match block.element_type {
            ElementType::Tri3 => {
                let phys = surface_tags
                    .get(&block.entity_tag)
                    .cloned()
                    .unwrap_or_default();
                for el in &block.elements {
                    let t = [
                        lookup(&el.nodes[0])?,
                        lookup(&el.nodes[1])?,
                        lookup(&el.nodes[2])?,
                    ];
                    triangles.push(t, &phys);
                    triangle_tags.push(el.element_tag);
                }
            }
            ElementType::Lin2 => {
                let phys = curve_tags
                    .get(&block.entity_tag)
                    .cloned()
                    .unwrap_or_default();
                for el in &block.elements {
                    lines.push([lookup(&el.nodes[0])?, lookup(&el.nodes[1])?], &phys);
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
                return Err(e.unsupported(format!("{what}; found {other:?}")));
            }
        }
    }
    Ok((triangles, triangle_tags, lines))
}

/// The `$Nodes` section read directly: every node's tag and (x, y, z) in the file's order
/// (ASCII or binary MSH 4.1); `None` where the section is not as expected (parametric nodes,
/// a damaged file: mshio's parse then decides).
pub(super) fn scan_nodes(bytes: &[u8]) -> Option<Vec<(u64, [f64; 3])>> {
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
