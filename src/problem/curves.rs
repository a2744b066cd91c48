//! The contact curves of a Gmsh problem's bodies: a named curve as one chain of nodes, body 1's
//! side oriented with its outward normals and nodal contact directions (docs/method.md §5),
//! the check that two curves face each other, and Γc's pairs as [`super::meshed`] (node to
//! node) and [`super::coupled`] (mortar) find them; the errors of a meshed problem.

use super::mortar::Ends;
use std::collections::{BTreeMap, BTreeSet};

use crate::fem::gmsh::{GmshBody, GmshError};
use crate::fem::mesh::Points;

/// What is wrong with a meshed problem: one line, naming the option.
#[derive(Debug, thiserror::Error)]
pub enum MeshedError {
    #[error("-nndd_mesh: {0}")]
    Mesh(#[from] GmshError),
    #[error("{option}: {message}")]
    Option { option: String, message: String },
    /// A phase read the parsed file after it was let go (a defect: the run keeps it where a
    /// later phase reads it).
    #[error("-nndd_mesh {path}: the parsed mesh was released once the bodies were built, and a later phase reads it")]
    Released { path: String },
}

pub(super) fn opt_err(option: &str, message: String) -> MeshedError {
    MeshedError::Option {
        option: option.to_string(),
        message,
    }
}

/// The nodes of a curve as one chain from its first point to its last (the orientation of
/// its Gmsh line elements).
pub fn chain(edges: &[[usize; 2]], curve: &str, option: &str) -> Result<Vec<usize>, MeshedError> {
    let mut next: BTreeMap<usize, usize> = BTreeMap::new();
    let mut has_prev: BTreeSet<usize> = BTreeSet::new();
    for &[a, b] in edges {
        if next.insert(a, b).is_some() || !has_prev.insert(b) {
            return Err(opt_err(
                option,
                format!("the curve '{curve}' branches or is traversed twice (use one open curve)"),
            ));
        }
    }
    let starts: Vec<usize> = next
        .keys()
        .copied()
        .filter(|a| !has_prev.contains(a))
        .collect();
    if starts.len() != 1 {
        return Err(opt_err(
            option,
            format!(
                "the curve '{curve}' is closed or in several pieces ({} starts); use one open curve (closed contact curves are coupled by -nndd_contact_discretisation mortar)",
                starts.len()
            ),
        ));
    }
    let mut nodes = vec![starts[0]];
    while let Some(&b) = next.get(nodes.last().expect("non-empty")) {
        nodes.push(b);
    }
    if nodes.len() != edges.len() + 1 {
        return Err(opt_err(
            option,
            format!("the curve '{curve}' is not one chain"),
        ));
    }
    Ok(nodes)
}

/// A closed curve's nodes from its lowest node around and back to it; `None` unless the edges
/// form one loop (every node with one successor and one predecessor, all connected).
pub fn closed_loop(edges: &[[usize; 2]]) -> Option<Vec<usize>> {
    let mut next: BTreeMap<usize, usize> = BTreeMap::new();
    let mut prev: BTreeSet<usize> = BTreeSet::new();
    for &[a, b] in edges {
        if next.insert(a, b).is_some() || !prev.insert(b) {
            return None;
        }
    }
    if edges.len() < 3 || next.keys().any(|a| !prev.contains(a)) {
        return None;
    }
    let start = *next.keys().next()?;
    let mut nodes = vec![start];
    while let Some(&b) = next.get(nodes.last()?) {
        nodes.push(b);
        if b == start || nodes.len() > edges.len() + 1 {
            break;
        }
    }
    (nodes.len() == edges.len() + 1 && nodes.last() == Some(&start)).then_some(nodes)
}

/// Whether the physical curve `name` of `gmsh` closes on itself (one loop).
pub fn is_closed(gmsh: &crate::fem::gmsh::GmshMesh, name: &str) -> bool {
    gmsh.curve_edges(name)
        .is_some_and(|edges| closed_loop(&edges).is_some())
}

/// A contact curve as a chain: an open one from its first point to its last, a closed one
/// (a whole circle, a bore) from its lowest node around and back to it (that node repeated at
/// the end), with which it is.
pub fn contact_chain(
    edges: &[[usize; 2]],
    curve: &str,
    option: &str,
) -> Result<(Vec<usize>, Ends), MeshedError> {
    match closed_loop(edges) {
        Some(nodes) => Ok((nodes, Ends::Closed)),
        None => Ok((chain(edges, curve, option)?, Ends::Open)),
    }
}

/// [`node_normals`] of a chain that closes on itself where `ends` says so: its first node (the
/// same as its last) takes the mean of its two segments' normals, the last and the first.
pub(super) fn chain_normals(segments: &[[f64; 2]], ends: Ends) -> Vec<[f64; 2]> {
    let mut n = node_normals(segments);
    if ends == Ends::Closed && segments.len() > 1 {
        let (a, b) = (segments[0], segments[segments.len() - 1]);
        let mean = unit_or_up([a[0] + b[0], a[1] + b[1]]);
        let last = n.len() - 1;
        (n[0], n[last]) = (mean, mean);
    }
    n
}

/// Γc's pairs: both sides' nodes in pair order, and per pair g₀, the contact direction n
/// (body 1's outward normal) and the segment lengths of the pairs' side (node to node, as
/// [`super::meshed`] pairs them: body 1's). Under the mortar discretisation
/// ([`super::coupled`]) the pairs are the non-mortar body's nodes and the mortar body's side is
/// the nodes its rows use.
pub(super) struct Pairing {
    pub sides: [Vec<usize>; 2],
    /// Each body's node nearest each pair: the pair's own nodes node to node; under mortar
    /// the mortar body's heaviest in the pair's row.
    pub nearest: [Vec<usize>; 2],
    /// The whole contact curves (body 1's oriented as its side), with each body's outward
    /// normal at their nodes.
    pub candidates: [Vec<usize>; 2],
    pub candidate_normals: [Vec<[f64; 2]>; 2],
    pub gap: Vec<f64>,
    pub normals: Vec<[f64; 2]>,
    pub lengths: Vec<f64>,
}

/// The third vertex of the body's triangles on each segment of the chain `nodes` (by the
/// segment's (smaller, larger) node): one on a boundary segment.
fn third_vertices(body: &GmshBody, nodes: &[usize]) -> BTreeMap<(usize, usize), Vec<usize>> {
    let mut opposite: BTreeMap<(usize, usize), Vec<usize>> = nodes
        .windows(2)
        .map(|w| ((w[0].min(w[1]), w[0].max(w[1])), Vec::new()))
        .collect();
    for t in &body.mesh.triangles {
        for i in 0..3 {
            let (a, b, c) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
            if let Some(list) = opposite.get_mut(&(a.min(b), a.max(b))) {
                list.push(c);
            }
        }
    }
    opposite
}

/// A body's contact side in the orientation with the body on its right (for body 1 below a
/// horizontal side: by increasing x), with the outward unit normal of each of its segments
/// (its messages speak of body 1, whose side it orients node to node).
pub(super) fn oriented_side(
    body: &GmshBody,
    mut nodes: Vec<usize>,
    curve: &str,
) -> Result<(Vec<usize>, Vec<[f64; 2]>), MeshedError> {
    const OPT: &str = "-nndd_contact";
    let pts = &body.mesh.points;
    let opposite = third_vertices(body, &nodes);
    // Left normal of a→b; body 1 must be on the other side of every segment.
    let left = |a: usize, b: usize| {
        let (t0, t1) = (pts.get(b)[0] - pts.get(a)[0], pts.get(b)[1] - pts.get(a)[1]);
        let h = t0.hypot(t1);
        [-t1 / h, t0 / h]
    };
    let inside = |a: usize, b: usize| -> Result<f64, MeshedError> {
        match opposite[&(a.min(b), a.max(b))][..] {
            [c] => {
                let n = left(a, b);
                Ok(n[0] * (pts.get(c)[0] - pts.get(a)[0]) + n[1] * (pts.get(c)[1] - pts.get(a)[1]))
            }
            _ => Err(opt_err(
                OPT,
                format!(
                    "body 1's contact curve '{curve}' is not on its boundary at the segment from ({:.6e}, {:.6e}) to ({:.6e}, {:.6e})",
                    pts.get(a)[0], pts.get(a)[1], pts.get(b)[0], pts.get(b)[1]
                ),
            )),
        }
    };
    if inside(nodes[0], nodes[1])? > 0.0 {
        nodes.reverse();
    }
    let mut normals = Vec::with_capacity(nodes.len() - 1);
    for w in nodes.windows(2) {
        if inside(w[0], w[1])? > 0.0 {
            return Err(opt_err(
                OPT,
                format!("body 1 lies on both sides of its contact curve '{curve}'"),
            ));
        }
        normals.push(left(w[0], w[1]));
    }
    Ok((nodes, normals))
}

/// The contact direction at each node of a side (body 1's node to node, the non-mortar
/// body's under mortar): the mean of its segments' outward normals, normalised; (0, 1) exactly where that is (0, 1) to 1e−12 (no rotated frame).
pub(super) fn node_normals(segments: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let m = segments.len() + 1;
    (0..m)
        .map(|k| {
            let mut n = [0.0; 2];
            for s in [k.checked_sub(1), (k < m - 1).then_some(k)]
                .into_iter()
                .flatten()
            {
                n[0] += segments[s][0];
                n[1] += segments[s][1];
            }
            unit_or_up(n)
        })
        .collect()
}

/// The unit vector of n, exactly (0, 1) where it is that to 1e−12 (so that a straight
/// horizontal side keeps unrotated frames).
pub(super) fn unit_or_up(n: [f64; 2]) -> [f64; 2] {
    let h = n[0].hypot(n[1]);
    let n = [n[0] / h, n[1] / h];
    if n[0].abs() <= 1e-12 && n[1] > 0.0 {
        super::UP
    } else {
        n
    }
}

/// The contact curves must face each other (returns body 2's outward normals at its curve's
/// nodes): at every pair, body 2's outward normal at its
/// node (the mean of its curve's segments' normals there) must not point the way body 1's
/// does (n¹ · n² ≤ 0); else body 2 is reached from its inside and the contact condition holds
/// nothing back (a curve on the far side of body 2, for instance).
pub(super) fn facing(
    contact: &[String; 2],
    body2: &GmshBody,
    chain2: &[usize],
    side1: &[[f64; 2]],
    s2: &[usize],
    normals: &[[f64; 2]],
    p2: &Points,
) -> Result<Vec<[f64; 2]>, MeshedError> {
    const OPT: &str = "-nndd_contact";
    let curve = &contact[1];
    let pts = &body2.mesh.points;
    let opposite = third_vertices(body2, chain2);
    // The outward unit normal of each segment of body 2's curve.
    let mut segments = Vec::with_capacity(chain2.len() - 1);
    for w in chain2.windows(2) {
        let (a, b) = (w[0], w[1]);
        let [c] = opposite[&(a.min(b), a.max(b))][..] else {
            return Err(opt_err(
                OPT,
                format!(
                    "body 2's contact curve '{curve}' is not on its boundary at the segment from ({:.6e}, {:.6e}) to ({:.6e}, {:.6e})",
                    pts.get(a)[0], pts.get(a)[1], pts.get(b)[0], pts.get(b)[1]
                ),
            ));
        };
        let (t0, t1) = (pts.get(b)[0] - pts.get(a)[0], pts.get(b)[1] - pts.get(a)[1]);
        let h = t0.hypot(t1);
        let n = [-t1 / h, t0 / h];
        let inward =
            n[0] * (pts.get(c)[0] - pts.get(a)[0]) + n[1] * (pts.get(c)[1] - pts.get(a)[1]) > 0.0;
        segments.push(if inward { [-n[0], -n[1]] } else { n });
    }
    let node_normal: BTreeMap<usize, [f64; 2]> = chain2
        .iter()
        .copied()
        .zip(node_normals(&segments))
        .collect();
    for (k, &b) in s2.iter().enumerate() {
        let (n1, n2) = (normals[k], node_normal[&b]);
        let dot = n1[0] * n2[0] + n1[1] * n2[1];
        if dot > 0.0 {
            return Err(opt_err(
                OPT,
                format!(
                    "the curves '{}' and '{curve}' do not face each other: at body 1's node ({:.6e}, {:.6e}) and its partner ({:.6e}, {:.6e}) the outward normals ({:.4}, {:.4}) and ({:.4}, {:.4}) point the same way (n1·n2 = {dot:.3}); name the curve of body 2 that faces body 1's",
                    contact[0],
                    side1[k][0], side1[k][1], p2.get(b)[0], p2.get(b)[1], n1[0], n1[1], n2[0], n2[1]
                ),
            ));
        }
    }
    Ok(chain2.iter().map(|b| node_normal[b]).collect())
}
