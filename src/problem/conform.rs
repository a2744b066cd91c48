//! Contact curves meshed independently, made to match: every node of each curve gets a
//! partner on the other, so that Γc is a set of node pairs and the contact constraint, the
//! transfer of the Γc forces and the estimators' contact traction are those of matching
//! meshes (the contact patch test is passed exactly: a uniform pressure between flat sides
//! gives the exact linear fields, `tests/nonmatching.rs`).
//!
//! The partner of a node of body 2's curve is its projection onto body 1's curve along body
//! 1's normal field (the nodal normals, the mean of the two segments' outward normals,
//! interpolated linearly along each segment: the projection is unique and continuous, also
//! across the fan of a convex corner); the partner of a node of body 1's curve is where its
//! normal line meets body 2's curve. A partner that is not a node already is inserted into its
//! curve: the boundary segment is split there and so is the body's triangle on it (from the
//! opposite vertex); the segments of the Gmsh lines on it likewise. The shapes do not change.
//! A node that a partner would come within [`SNAP`] of a segment's length of is moved onto it
//! instead where its curve is straight (no sliver; the shape still does not change), or where
//! it is an end node of body 1's curve (moved along its one segment: the curve keeps its shape,
//! the boundary beyond it turns by O(d/h)).
//!
//! Γc is then where the curves overlap: nodes that project outside the other curve keep no
//! partner (they stay candidates, which the final penetration check covers).
//!
//! Without moving nodes ([`Snap::InsertOnly`], the matched meshes of a mortar run's
//! estimates), a node whose partner would land within [`NEAR`] of a node of the other curve
//! is paired with that node instead, off the normal line by that little.
//!
//! On matching meshes nothing is inserted or moved: the mesh is the user's.

use std::collections::HashMap;

use crate::fem::gmsh::GmshMesh;

use super::curves::{chain, node_normals};
pub use super::matched::{point_key, Matched};
use super::meshed::BODY_NAMES;
use super::polyline::{cross, lerp, project, ray, unit, Foot};

pub use super::polyline::COINCIDENT;
/// Relative distance (to the shorter segment at either node) under which a node on a straight
/// part of its curve is moved onto its partner's projection instead of a new node next to it,
/// which would cut a sliver, of relative area below about [`SNAP`], off the body's triangle.
pub const SNAP: f64 = 0.2;
/// Relative distance (to the segment's length) under which, in a mortar run's matched meshes
/// ([`Snap::InsertOnly`]: no node moves), a node's partner is the other curve's node next to
/// it, off its normal line by at most that, and no node is inserted on either curve
/// ([`Matched::near`]). An inserted node would cut a sliver of relative area about half of
/// it off the body's triangle, whose recovered stresses the equilibration cannot make
/// admissible: on Hertz level 4 meshed 1:1.5 (a node 2.7e−4 of its segment from the other's)
/// inserted nodes cut slivers of relative area 1.3e−4, whose stresses equilibrate to 7e−4
/// only, against 3e−9 with the nodes paired as they are (`tests/mortar.rs`).
pub const NEAR: f64 = 1e-2;

/// One body's contact curve: its nodes in order, with the body on their right.
struct Curve {
    nodes: Vec<usize>,
    /// Outward unit normal of each segment.
    segment_normals: Vec<[f64; 2]>,
}

/// The curve `name` of body `alpha` as a chain with its outward segment normals, oriented with
/// the body on the right; `None` where the curve is not a simple chain on the body's boundary
/// (the pairing names what is wrong).
fn curve(gmsh: &GmshMesh, alpha: usize, name: &str) -> Option<Curve> {
    let edges = gmsh.curve_edges(name)?;
    let body = gmsh.tag(2, BODY_NAMES[alpha - 1])?;
    let mut nodes = chain(&edges, name, "").ok()?;
    if nodes.len() < 2 {
        return None;
    }
    let mut opposite: HashMap<(usize, usize), Vec<usize>> = nodes
        .windows(2)
        .map(|w| ((w[0].min(w[1]), w[0].max(w[1])), Vec::new()))
        .collect();
    for (t, phys) in &gmsh.triangles {
        if !phys.contains(&body) {
            continue;
        }
        for i in 0..3 {
            let (a, b, c) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
            if let Some(list) = opposite.get_mut(&(a.min(b), a.max(b))) {
                list.push(c);
            }
        }
    }
    let pts = &gmsh.points;
    // Left normal of a→b and whether the body is on that side.
    let side = |a: usize, b: usize| -> Option<([f64; 2], bool)> {
        let [c] = opposite[&(a.min(b), a.max(b))][..] else {
            return None;
        };
        let n = [-(pts[b][1] - pts[a][1]), pts[b][0] - pts[a][0]];
        let n = unit(n);
        Some((
            n,
            n[0] * (pts[c][0] - pts[a][0]) + n[1] * (pts[c][1] - pts[a][1]) > 0.0,
        ))
    };
    if side(nodes[0], nodes[1])?.1 {
        nodes.reverse();
    }
    let mut segment_normals = Vec::with_capacity(nodes.len() - 1);
    for w in nodes.windows(2) {
        let (n, inside) = side(w[0], w[1])?;
        if inside {
            return None;
        }
        segment_normals.push(n);
    }
    Some(Curve {
        nodes,
        segment_normals,
    })
}

/// Whether node i of a curve is inside it with its two segments collinear (moving it along
/// them does not change the shape).
fn straight_at(normals: &[[f64; 2]], i: usize) -> bool {
    i > 0
        && i < normals.len()
        && cross(normals[i - 1], normals[i]).abs() <= 1e-12
        && normals[i - 1][0] * normals[i][0] + normals[i - 1][1] * normals[i][1] > 0.0
}

/// The curve's node nearest to `foot` when it is within `rel` of its segment's length.
fn near_node(foot: &Foot, rel: f64) -> Option<usize> {
    if foot.t <= rel {
        Some(foot.k)
    } else if foot.t >= 1.0 - rel {
        Some(foot.k + 1)
    } else {
        None
    }
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The end of the foot's segment nearer to the foot point `x`.
fn nearest_end(f: &Foot, p: &[[f64; 2]], x: [f64; 2]) -> usize {
    if distance(x, p[f.k]) <= distance(x, p[f.k + 1]) {
        f.k
    } else {
        f.k + 1
    }
}

/// The shorter of the segments on either side of node i of a curve of points `p`.
fn local_length(p: &[[f64; 2]], i: usize) -> f64 {
    let before = i.checked_sub(1).map(|h| distance(p[h], p[i]));
    let after = p.get(i + 1).map(|q| distance(p[i], *q));
    before
        .into_iter()
        .chain(after)
        .fold(f64::INFINITY, f64::min)
}

/// Whether making the curves match may move a node onto a partner's projection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Snap {
    /// Move a node next to a partner onto it (no sliver; the node-to-node discretisation).
    Move,
    /// Only insert: every node of the user's mesh stays where it is, so that a P1 field of the
    /// user's mesh is one of the matched mesh too (the mortar run's estimates,
    /// [`super::settings::ProblemSettings::for_estimates`]).
    InsertOnly,
}

/// Make the contact curves `contact` (body 1's, body 2's) of `gmsh` match (module doc). Where
/// a curve is missing or not a simple boundary chain, the mesh is returned as it is: the
/// pairing says what is wrong.
pub fn conform(gmsh: &GmshMesh, contact: &[String; 2]) -> (GmshMesh, Matched) {
    conform_with(gmsh, contact, Snap::Move)
}

/// [`conform`], moving nodes or not as `snap` says.
pub fn conform_with(gmsh: &GmshMesh, contact: &[String; 2], snap: Snap) -> (GmshMesh, Matched) {
    let mut out = Matched::default();
    let mut conformed = gmsh.clone();
    let (Some(c1), Some(c2)) = (curve(gmsh, 1, &contact[0]), curve(gmsh, 2, &contact[1])) else {
        return (conformed, out);
    };
    let g = &mut conformed;
    let mut n1 = node_normals(&c1.segment_normals);
    let points = |g: &GmshMesh, c: &Curve| -> Vec<[f64; 2]> {
        c.nodes.iter().map(|&a| g.points[a]).collect()
    };

    // Snap: a node of a straight part of a curve that a partner would come near (closer than
    // SNAP times the segments on either side) is moved onto it.
    let mut moved = [vec![false; c1.nodes.len()], vec![false; c2.nodes.len()]];
    let mut source2 = vec![false; c2.nodes.len()];
    let movable = if snap == Snap::Move {
        c2.nodes.len()
    } else {
        0
    };
    for (j, &b) in c2.nodes.iter().enumerate().take(movable) {
        let (p1, p2) = (points(g, &c1), points(g, &c2));
        let Some(f) = project(g.points[b], &p1, &n1) else {
            continue;
        };
        let foot = lerp(p1[f.k], p1[f.k + 1], f.t);
        let i = nearest_end(&f, &p1, foot);
        let d = distance(foot, p1[i]);
        let local = local_length(&p1, i).min(local_length(&p2, j));
        if d <= COINCIDENT * local {
            source2[j] = true;
        } else if d < SNAP * local
            && (straight_at(&c1.segment_normals, i) || i == 0 || i + 1 == c1.nodes.len())
            && !moved[0][i]
        {
            // (an end node of body 1's curve moves along its one segment: the curve keeps
            // its shape, the boundary beyond turns by O(d/h); inserting the partner instead
            // would cut a sliver of relative size d/h off the end triangle). Its contact
            // direction is the normal it was projected along, so that its partner is exact.
            // Its contact direction is the normal it was projected along (the node's own on a
            // straight part, a blend of its neighbours' where one turns), so that its partner
            // is exact and finds it again below.
            g.points[c1.nodes[i]] = foot;
            out.made.insert(point_key(foot));
            n1[i] = f.normal;
            out.normals.insert(point_key(foot), f.normal);
            moved[0][i] = true;
            source2[j] = true;
        }
    }
    let movable = if snap == Snap::Move {
        c1.nodes.len()
    } else {
        0
    };
    for i in 0..movable {
        let (p1, p2) = (points(g, &c1), points(g, &c2));
        let Some(f) = ray(p1[i], n1[i], &p2) else {
            continue;
        };
        let foot = lerp(p2[f.k], p2[f.k + 1], f.t);
        let j = nearest_end(&f, &p2, foot);
        let d = distance(foot, p2[j]);
        let local = local_length(&p1, i).min(local_length(&p2, j));
        if d <= COINCIDENT * local || d >= SNAP * local || source2[j] {
            continue;
        }
        if straight_at(&c2.segment_normals, j) && !moved[1][j] {
            g.points[c2.nodes[j]] = foot;
            out.made.insert(point_key(foot));
            moved[1][j] = true;
            source2[j] = true;
            continue;
        }
        // Body 2's curve turns at its node: move body 1's node under it instead, or where
        // that cannot be (body 1's curve turns or ends there), body 2's node along its
        // segment (its curve loses O(d h κ) of its bulge).
        let under = project(p2[j], &p1, &n1)
            .map(|f| (lerp(p1[f.k], p1[f.k + 1], f.t), f.normal))
            .filter(|(to, _)| distance(*to, p1[i]) < SNAP * local);
        match under {
            Some((to, normal)) if straight_at(&c1.segment_normals, i) && !moved[0][i] => {
                g.points[c1.nodes[i]] = to;
                out.made.insert(point_key(to));
                n1[i] = normal;
                out.normals.insert(point_key(to), normal);
                moved[0][i] = true;
                source2[j] = true;
            }
            _ if !moved[1][j] => {
                g.points[c2.nodes[j]] = foot;
                out.made.insert(point_key(foot));
                moved[1][j] = true;
                source2[j] = true;
            }
            _ => {}
        }
    }
    out.moved = moved.map(|m| m.iter().filter(|&&x| x).count());

    // The partners that are not nodes: (segment, t) on each curve.
    let (p1, p2) = (points(g, &c1), points(g, &c2));
    if snap == Snap::InsertOnly {
        for (i, j) in near_pairs(&p1, &p2, &n1) {
            out.near.insert(point_key(p1[i]), point_key(p2[j]));
            source2[j] = true;
        }
    }
    let near1: std::collections::BTreeSet<[u64; 2]> = out.near.keys().copied().collect();
    let mut new1: Vec<(usize, f64, [f64; 2])> = Vec::new();
    // (a node that found its partner above has it: a projection again, along normals that
    // the move blended anew, would insert a node beside the partner)
    for (&b, _) in c2
        .nodes
        .iter()
        .zip(&source2)
        .filter(|(_, &partnered)| !partnered)
    {
        if let Some(f) = project(g.points[b], &p1, &n1) {
            if near_node(&f, COINCIDENT).is_none() {
                new1.push((f.k, f.t, f.normal));
            }
        }
    }
    let mut new2: Vec<(usize, f64, [f64; 2])> = Vec::new();
    for (i, &x) in p1.iter().enumerate() {
        if near1.contains(&point_key(x)) {
            continue;
        }
        if let Some(f) = ray(x, n1[i], &p2) {
            if near_node(&f, COINCIDENT).is_none() {
                new2.push((f.k, f.t, [0.0; 2]));
            }
        }
    }
    let body_tags = BODY_NAMES.map(|n| gmsh.tag(2, n).expect("the curves lie on the bodies"));
    for (alpha, (curve, new)) in [(&c1, new1), (&c2, new2)].into_iter().enumerate() {
        out.inserted[alpha] = new.len();
        let pts = if alpha == 0 { &p1 } else { &p2 };
        let made = insert(g, body_tags[alpha], &curve.nodes, pts, new);
        for &(p, n) in &made {
            out.made.insert(point_key(p));
            if alpha == 0 {
                out.normals.insert(point_key(p), n);
            }
        }
    }
    (conformed, out)
}

/// The nodes (i of body 1's curve `p1`, j of body 2's `p2`) that a mortar run's matched
/// meshes pair as they are ([`NEAR`]): j's projection along body 1's normal field `n1` lies
/// within `NEAR` of its segment's length from node i, but not within [`COINCIDENT`], and node
/// i's normal line meets body 2's curve as near node j.
fn near_pairs(p1: &[[f64; 2]], p2: &[[f64; 2]], n1: &[[f64; 2]]) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for (j, &b) in p2.iter().enumerate() {
        let Some(f) = project(b, p1, n1) else {
            continue;
        };
        let (None, Some(i)) = (near_node(&f, COINCIDENT), near_node(&f, NEAR)) else {
            continue;
        };
        let back = ray(p1[i], n1[i], p2);
        if back
            .is_some_and(|r| near_node(&r, COINCIDENT).is_none() && near_node(&r, NEAR) == Some(j))
        {
            pairs.push((i, j));
        }
    }
    pairs
}

/// Insert the points (segment k of `nodes`, t, normal) into body `tag`'s boundary: each splits
/// its segment, the body's triangle on it and the Gmsh lines on it. Returns the new points
/// with their normals.
fn insert(
    g: &mut GmshMesh,
    tag: i32,
    nodes: &[usize],
    pts: &[[f64; 2]],
    mut new: Vec<(usize, f64, [f64; 2])>,
) -> Vec<([f64; 2], [f64; 2])> {
    new.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    new.dedup_by(|x, y| x.0 == y.0 && (x.1 - y.1).abs() <= COINCIDENT);
    let key = |a: usize, b: usize| (a.min(b), a.max(b));
    let mut tri: HashMap<(usize, usize), usize> = HashMap::new();
    let on_curve: HashMap<(usize, usize), ()> =
        nodes.windows(2).map(|w| (key(w[0], w[1]), ())).collect();
    for (i, (t, phys)) in g.triangles.iter().enumerate() {
        if phys.contains(&tag) {
            for e in 0..3 {
                let k = key(t[e], t[(e + 1) % 3]);
                if on_curve.contains_key(&k) {
                    tri.insert(k, i);
                }
            }
        }
    }
    let mut lines: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (i, (l, _)) in g.lines.iter().enumerate() {
        let k = key(l[0], l[1]);
        if on_curve.contains_key(&k) {
            lines.entry(k).or_default().push(i);
        }
    }
    let mut made = Vec::with_capacity(new.len());
    // Points on one segment in increasing t: each splits the part from the previous one to
    // the segment's end.
    let mut from = usize::MAX;
    let mut last_k = usize::MAX;
    for (k, t, normal) in new {
        if k != last_k {
            from = nodes[k];
            last_k = k;
        }
        let to = nodes[k + 1];
        let p = lerp(pts[k], pts[k + 1], t);
        g.points.push(p);
        let c = g.points.len() - 1;
        made.push((p, normal));
        // The triangle on (from, to): [x, y, z] with {x, y} = {from, to} → [x, c, z], [c, y, z].
        let i = tri.remove(&key(from, to)).expect("a boundary triangle");
        let t3 = g.triangles.nodes(i);
        let e = (0..3)
            .find(|&e| key(t3[e], t3[(e + 1) % 3]) == key(from, to))
            .expect("the edge is the triangle's");
        let (x, y, z) = (t3[e], t3[(e + 1) % 3], t3[(e + 2) % 3]);
        g.triangles.set_nodes(i, [x, c, z]);
        g.triangles.push_like([c, y, z], i);
        if !g.triangle_tags.is_empty() {
            let tag = g.triangle_tags.get(i);
            g.triangle_tags.push(tag);
        }
        let j = g.triangles.len() - 1;
        let (i_from, i_to) = if x == from { (i, j) } else { (j, i) };
        tri.insert(key(from, c), i_from);
        tri.insert(key(c, to), i_to);
        // The lines on (from, to), each kept in its direction.
        let mut kept = Vec::new();
        for l in lines.remove(&key(from, to)).unwrap_or_default() {
            let [a, b] = g.lines.nodes(l);
            g.lines.set_nodes(l, [a, c]);
            g.lines.push_like([c, b], l);
            let m = g.lines.len() - 1;
            let (l_from, l_to) = if a == from { (l, m) } else { (m, l) };
            lines.entry(key(from, c)).or_default().push(l_from);
            kept.push(l_to);
        }
        lines.insert(key(c, to), kept);
        from = c;
    }
    made
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::polyline::sub;

    /// Body 1 the square [0, 1] × [−1, 0] with its top nodes at `top1` (x, y = 0), body 2 the
    /// square [0, 1] × [0, 1] with its bottom nodes at `bottom2`; each a fan of triangles from
    /// its far corner, both counter-clockwise; the contact curves `top1`, `bottom2`.
    fn two_squares(top1: &[f64], bottom2: &[f64]) -> GmshMesh {
        let mut g = GmshMesh {
            path: "two squares".into(),
            names: [
                ((2, 1), "body1"),
                ((2, 2), "body2"),
                ((1, 3), "top1"),
                ((1, 4), "bottom2"),
            ]
            .into_iter()
            .map(|(k, n)| (k, n.to_string()))
            .collect(),
            ..Default::default()
        };
        // Body 1: (0, −1), then the top from x = 1 down to 0, then (1, −1) closes via corner.
        g.points.push([0.0, -1.0]);
        g.points.push([1.0, -1.0]);
        let top: Vec<usize> = top1
            .iter()
            .rev()
            .map(|&x| {
                g.points.push([x, 0.0]);
                g.points.len() - 1
            })
            .collect();
        g.triangles.push([0, 1, top[0]], &[1]);
        for w in top.windows(2) {
            g.triangles.push([0, w[0], w[1]], &[1]);
        }
        for w in top.windows(2) {
            g.lines.push([w[0], w[1]], &[3]);
        }
        // Body 2: (0, 1) with the bottom from x = 0 to 1, then (1, 1).
        let apex = g.points.len();
        g.points.push([0.0, 1.0]);
        let bottom: Vec<usize> = bottom2
            .iter()
            .map(|&x| {
                g.points.push([x, 0.0]);
                g.points.len() - 1
            })
            .collect();
        g.points.push([1.0, 1.0]);
        let corner = g.points.len() - 1;
        for w in bottom.windows(2) {
            g.triangles.push([apex, w[0], w[1]], &[2]);
            g.lines.push([w[0], w[1]], &[4]);
        }
        g.triangles
            .push([apex, *bottom.last().unwrap(), corner], &[2]);
        g
    }

    fn contact() -> [String; 2] {
        ["top1".into(), "bottom2".into()]
    }

    /// Signed area of each body's triangles.
    fn areas(g: &GmshMesh, tag: i32) -> Vec<f64> {
        g.triangles
            .iter()
            .filter(|(_, p)| p.contains(&tag))
            .map(|(t, _)| {
                let [a, b, c] = t.map(|i| g.points[i]);
                0.5 * cross(sub(b, a), sub(c, a))
            })
            .collect()
    }

    fn curve_x(g: &GmshMesh, tag: i32) -> Vec<f64> {
        let mut x: Vec<f64> = g
            .lines
            .iter()
            .filter(|(_, p)| p.contains(&tag))
            .flat_map(|(l, _)| l.map(|i| g.points[i][0]))
            .collect();
        x.sort_by(f64::total_cmp);
        x.dedup();
        x
    }

    #[test]
    fn each_curves_nodes_are_inserted_into_the_other() {
        let g = two_squares(&[0.0, 0.3, 1.0], &[0.0, 0.6, 1.0]);
        let (c, m) = conform(&g, &contact());
        assert_eq!((m.inserted, m.moved), ([1, 1], [0, 0]));
        assert_eq!(curve_x(&c, 3), vec![0.0, 0.3, 0.6, 1.0]);
        assert_eq!(curve_x(&c, 4), vec![0.0, 0.3, 0.6, 1.0]);
        for tag in [1, 2] {
            let (before, after) = (areas(&g, tag), areas(&c, tag));
            assert_eq!(after.len(), before.len() + 1, "one triangle split");
            assert!(
                after.iter().all(|&a| a > 0.0),
                "orientation kept: {after:?}"
            );
            let (s0, s1): (f64, f64) = (before.iter().sum(), after.iter().sum());
            assert!((s0 - s1).abs() < 1e-15, "area {s0} → {s1}");
        }
        // The normal of the node inserted into body 1's (flat) curve is its normal.
        assert_eq!(m.normals.values().collect::<Vec<_>>(), vec![&[0.0, 1.0]]);
    }

    #[test]
    fn matching_curves_are_left_as_they_are() {
        let g = two_squares(&[0.0, 0.25, 0.5, 1.0], &[0.0, 0.25, 0.5, 1.0]);
        let (c, m) = conform(&g, &contact());
        assert_eq!((m.inserted, m.moved), ([0, 0], [0, 0]));
        assert_eq!(c.points, g.points);
        assert_eq!(c.triangles, g.triangles);
    }

    #[test]
    fn a_node_next_to_a_partner_on_a_straight_curve_is_moved_onto_it() {
        // Body 2's node at 0.52 projects 0.02 from body 1's node at 0.5 (< SNAP of 0.48).
        let g = two_squares(&[0.0, 0.5, 1.0], &[0.0, 0.52, 1.0]);
        let (c, m) = conform(&g, &contact());
        assert_eq!((m.inserted, m.moved), ([0, 0], [1, 0]));
        assert_eq!(curve_x(&c, 3), vec![0.0, 0.52, 1.0]);
        assert!(areas(&c, 1).iter().all(|&a| a > 0.0));
    }

    #[test]
    fn insert_only_keeps_every_node_where_it_is() {
        // The same meshes: the partners are inserted next to the nodes instead.
        let g = two_squares(&[0.0, 0.5, 1.0], &[0.0, 0.52, 1.0]);
        let (c, m) = conform_with(&g, &contact(), Snap::InsertOnly);
        assert_eq!((m.inserted, m.moved), ([1, 1], [0, 0]));
        assert_eq!(curve_x(&c, 3), vec![0.0, 0.5, 0.52, 1.0]);
        assert_eq!(curve_x(&c, 4), vec![0.0, 0.5, 0.52, 1.0]);
        assert_eq!(&c.points[..g.points.len()], &g.points[..]);
        assert!(areas(&c, 1).iter().all(|&a| a > 0.0));
    }

    #[test]
    fn insert_only_pairs_a_node_next_to_a_partner_as_it_is() {
        // Body 2's node at 0.502 projects 0.002 (0.4 % of the segment) from body 1's node at
        // 0.5: paired as they are, nothing inserted (a node at 0.502 would cut a sliver of
        // relative area 0.004 off body 1's triangle, one at 0.5 another off body 2's).
        let g = two_squares(&[0.0, 0.5, 1.0], &[0.0, 0.502, 1.0]);
        let (c, m) = conform_with(&g, &contact(), Snap::InsertOnly);
        assert_eq!((m.inserted, m.moved), ([0, 0], [0, 0]));
        assert_eq!(curve_x(&c, 3), vec![0.0, 0.5, 1.0]);
        assert_eq!(curve_x(&c, 4), vec![0.0, 0.502, 1.0]);
        let near: Vec<_> = m.near.iter().collect();
        assert_eq!(
            near,
            vec![(&point_key([0.5, 0.0]), &point_key([0.502, 0.0]))],
            "{near:?}"
        );
        // Moving nodes (node to node), the same node is moved onto its partner instead.
        let (_, m) = conform(&g, &contact());
        assert_eq!((m.moved, m.near.len()), ([1, 0], 0));
    }

    #[test]
    fn the_projection_follows_the_normal_field_across_a_convex_corner() {
        // A corner at (0, 0) between a flat part and a 45° slope down: (0.1, 1) is in the fan
        // of the corner, where no segment's own normal line passes.
        let p = [[-1.0, 0.0], [0.0, 0.0], [1.0, -1.0]];
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let nn = node_normals(&[[0.0, 1.0], [s, s]]);
        let q = [0.1, 1.0];
        let f = project(q, &p, &nn).expect("a projection in the fan");
        let foot = lerp(p[f.k], p[f.k + 1], f.t);
        let r = sub(q, foot);
        assert!(cross(r, f.normal).abs() < 1e-14, "{f:?}");
        assert!(f.s > 0.0 && (r[0].hypot(r[1]) - f.s).abs() < 1e-14);
        assert!(
            f.normal[0] > 0.0 && f.normal[1] > s,
            "between the two normals: {f:?}"
        );
    }
}
