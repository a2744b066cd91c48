//! Geometric checks of triangle meshes, for the mistakes a mesh generator's user makes:
//! flat or inverted triangles ([`quality`], [`MIN_QUALITY`]), folds ([`fold`]: two
//! triangles on the same side of their common edge), a body in several pieces ([`pieces`]),
//! and two bodies that overlap ([`overlap`]: a node or a triangle's centroid strictly inside
//! a triangle of the other body, or boundary edges that cross), found with a bucket grid in
//! O(N) for meshes of bounded grading.
//!
//! The predicates are plain floating point with tolerances relative to the local mesh size:
//! bodies that touch along a curve (coincident nodes, zero gap) do not overlap.

use crate::fem::mesh::{for_each_side, Mesh};

/// The smallest accepted relative area 2·area / (longest edge)² of a triangle (0.866 for an
/// equilateral triangle, 0.5 for half a square; it bounds the smallest angle from below by
/// about its value in radians). Below it a triangle is taken as degenerate.
pub const MIN_QUALITY: f64 = 1e-4;

/// The overlap tolerance: a point is strictly inside a triangle when it is farther than
/// `OVERLAP_TOL` × the triangle's longest edge from each of its sides; two segments cross when
/// each one's ends are farther than `OVERLAP_TOL` × the longer segment from the other's line.
pub const OVERLAP_TOL: f64 = 1e-6;

/// Whether a relative area ([`quality`]) is degenerate: below [`MIN_QUALITY`] in magnitude,
/// or NaN.
pub fn degenerate(q: f64) -> bool {
    q.abs() < MIN_QUALITY || q.is_nan()
}

/// Twice the signed area of (a, b, c): > 0 when counter-clockwise.
pub fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)
}

/// The relative area 2·area / (longest edge)² of a triangle, signed (> 0 counter-clockwise);
/// NaN for a triangle with a non-finite coordinate, 0 for three equal points.
pub fn quality(p: [[f64; 2]; 3]) -> f64 {
    let l2 = dist2(p[0], p[1])
        .max(dist2(p[1], p[2]))
        .max(dist2(p[2], p[0]));
    if l2 == 0.0 {
        return 0.0;
    }
    orient(p[0], p[1], p[2]) / l2
}

/// Whether `p` is strictly inside the triangle `t` (either orientation): farther than
/// `tol` × its longest edge from each of its sides.
pub fn strictly_inside(p: [f64; 2], t: [[f64; 2]; 3], tol: f64) -> bool {
    let a2 = orient(t[0], t[1], t[2]);
    let s = a2.signum();
    let l = dist2(t[0], t[1])
        .max(dist2(t[1], t[2]))
        .max(dist2(t[2], t[0]))
        .sqrt();
    (0..3).all(|i| {
        let (a, b) = (t[i], t[(i + 1) % 3]);
        // orient / |ab| is the distance of p from the line ab.
        s * orient(a, b, p) > tol * l * dist2(a, b).sqrt()
    })
}

/// Whether the segments p and q cross: each one's ends strictly on both sides of the other's
/// line, farther than `tol` × the longer segment from it (touching, collinear or shared ends
/// do not cross).
pub fn segments_cross(p: [[f64; 2]; 2], q: [[f64; 2]; 2], tol: f64) -> bool {
    let (lp, lq) = (dist2(p[0], p[1]).sqrt(), dist2(q[0], q[1]).sqrt());
    let eps = tol * lp.max(lq);
    let sides = |s: [[f64; 2]; 2], len: f64, o: [[f64; 2]; 2]| {
        let (a, b) = (
            orient(s[0], s[1], o[0]) / len,
            orient(s[0], s[1], o[1]) / len,
        );
        (a > eps && b < -eps) || (a < -eps && b > eps)
    };
    lp > 0.0 && lq > 0.0 && sides(p, lp, q) && sides(q, lq, p)
}

/// Two triangles that fold over each other: the first pair (e, f) of a mesh of
/// counter-clockwise triangles that go through a common side in the same direction, so that
/// they lie on the same side of it (consistent neighbours go through it in opposite
/// directions); also a side of three or more triangles, or a triangle given twice.
pub fn fold(mesh: &Mesh) -> Option<(usize, usize)> {
    let from = |s: u32| mesh.triangles.get(s as usize / 3)[s as usize % 3];
    let mut found = None;
    for_each_side(mesh, |run| {
        let bad = match run.len() {
            1 => false,
            2 => from(run[0].1) == from(run[1].1),
            _ => true,
        };
        if bad {
            found = Some((run[0].1 as usize / 3, run[1].1 as usize / 3));
        }
        bad
    });
    found
}

/// The pieces of a mesh: its triangles grouped by sides they share (two triangles that share
/// only a node are in different pieces: one can turn about it). The number of pieces and
/// each triangle's piece (numbered by their first triangle).
pub fn pieces(mesh: &Mesh) -> (usize, Vec<usize>) {
    let n = mesh.triangles.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut a: usize) -> usize {
        while parent[a] != a {
            parent[a] = parent[parent[a]];
            a = parent[a];
        }
        a
    }
    for_each_side(mesh, |run| {
        for w in run.windows(2) {
            let (a, b) = (
                root(&mut parent, w[0].1 as usize / 3),
                root(&mut parent, w[1].1 as usize / 3),
            );
            if a != b {
                parent[a.max(b)] = a.min(b);
            }
        }
        false
    });
    let mut number = vec![usize::MAX; n];
    let mut count = 0;
    let mut piece = vec![0; n];
    for (e, p) in piece.iter_mut().enumerate() {
        let r = root(&mut parent, e);
        if number[r] == usize::MAX {
            number[r] = count;
            count += 1;
        }
        *p = number[r];
    }
    (count, piece)
}

/// How two bodies overlap (body indices 0 and 1 of [`overlap`]'s pair).
#[derive(Clone, Debug, PartialEq)]
pub enum Overlap {
    /// Node `node` of body `body` is strictly inside triangle `element` of the other body.
    Node {
        body: usize,
        node: usize,
        element: usize,
    },
    /// The centroid of triangle `inner` of body `body` is strictly inside triangle `element`
    /// of the other body.
    Triangle {
        body: usize,
        inner: usize,
        element: usize,
    },
    /// Boundary edge `edges[0]` of body 0 crosses boundary edge `edges[1]` of body 1.
    Edges { edges: [[usize; 2]; 2] },
}

/// A uniform grid of square cells over a box, each cell listing the items whose bounding box
/// meets it (compressed rows).
pub(crate) struct Grid {
    lo: [f64; 2],
    cell: f64,
    dims: [usize; 2],
    start: Vec<u32>,
    items: Vec<u32>,
}

pub(crate) type BBox = [[f64; 2]; 2];

impl Grid {
    /// A grid over `area` with about `target` cells, holding `boxes` (id, bounding box).
    pub(crate) fn new(area: BBox, target: usize, boxes: &[(u32, BBox)]) -> Grid {
        let size = [area[1][0] - area[0][0], area[1][1] - area[0][1]];
        let cell = ((size[0] * size[1]) / target.max(1) as f64)
            .sqrt()
            .max(size[0].max(size[1]) / 4096.0)
            .max(f64::MIN_POSITIVE);
        let dims = [
            ((size[0] / cell).ceil() as usize).clamp(1, 4096),
            ((size[1] / cell).ceil() as usize).clamp(1, 4096),
        ];
        let mut g = Grid {
            lo: area[0],
            cell,
            dims,
            start: vec![0; dims[0] * dims[1] + 1],
            items: Vec::new(),
        };
        for (_, b) in boxes {
            for c in g.span(*b) {
                g.start[c + 1] += 1;
            }
        }
        for c in 0..dims[0] * dims[1] {
            g.start[c + 1] += g.start[c];
        }
        let mut fill = g.start.clone();
        g.items = vec![0; g.start[dims[0] * dims[1]] as usize];
        for (id, b) in boxes {
            for c in g.span(*b) {
                g.items[fill[c] as usize] = *id;
                fill[c] += 1;
            }
        }
        g
    }

    /// The cells that the box `b` meets.
    fn span(&self, b: BBox) -> impl Iterator<Item = usize> {
        let at = |x: f64, k: usize| {
            (((x - self.lo[k]) / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1)
        };
        let (x0, x1, y0, y1) = (
            at(b[0][0], 0),
            at(b[1][0], 0),
            at(b[0][1], 1),
            at(b[1][1], 1),
        );
        let nx = self.dims[0];
        (y0..=y1).flat_map(move |j| (x0..=x1).map(move |i| j * nx + i))
    }

    /// Calls `f` on the items listed in the cells that `b` meets (an item may come more than
    /// once) until it returns true; whether it did.
    pub(crate) fn query(&self, b: BBox, mut f: impl FnMut(u32) -> bool) -> bool {
        self.span(b).any(|c| {
            self.items[self.start[c] as usize..self.start[c + 1] as usize]
                .iter()
                .any(|&id| f(id))
        })
    }
}

pub(crate) fn bbox<P: std::borrow::Borrow<[f64; 2]>>(points: impl IntoIterator<Item = P>) -> BBox {
    let mut b = [[f64::INFINITY; 2], [f64::NEG_INFINITY; 2]];
    for p in points {
        let p = p.borrow();
        for k in 0..2 {
            b[0][k] = b[0][k].min(p[k]);
            b[1][k] = b[1][k].max(p[k]);
        }
    }
    b
}

fn meets(a: BBox, b: BBox) -> bool {
    a[0][0] <= b[1][0] && b[0][0] <= a[1][0] && a[0][1] <= b[1][1] && b[0][1] <= a[1][1]
}

fn contains(b: BBox, p: [f64; 2]) -> bool {
    meets(b, [p, p])
}

/// Where two bodies overlap, if they do: a node or a triangle's centroid of one strictly
/// inside a triangle of the other, or boundary edges of the two that cross (tolerance
/// [`OVERLAP_TOL`]). Only the common part of the bodies' bounding boxes is searched, with a
/// bucket grid of about one cell per triangle there.
pub fn overlap(meshes: [&Mesh; 2]) -> Option<Overlap> {
    let boxes = meshes.map(|m| bbox(&m.points));
    let common = [
        [
            boxes[0][0][0].max(boxes[1][0][0]),
            boxes[0][0][1].max(boxes[1][0][1]),
        ],
        [
            boxes[0][1][0].min(boxes[1][1][0]),
            boxes[0][1][1].min(boxes[1][1][1]),
        ],
    ];
    if !(common[0][0] <= common[1][0] && common[0][1] <= common[1][1]) {
        return None;
    }
    let tri_box = |m: &Mesh, e: usize| bbox(m.triangle_points(e));
    // Points of body `a` in triangles of body `b`: the nodes both ways, then the centroids.
    // The triangles that meet the common box, with their boxes.
    let near: Vec<Vec<(u32, BBox)>> = meshes
        .iter()
        .map(|m| {
            (0..m.triangles.len())
                .map(|e| (e as u32, tri_box(m, e)))
                .filter(|(_, bx)| meets(*bx, common))
                .collect()
        })
        .collect();
    let grids: Vec<Option<Grid>> = near
        .iter()
        .map(|items| (!items.is_empty()).then(|| Grid::new(common, items.len(), items)))
        .collect();
    let inside = |p: [f64; 2], b: usize| -> Option<usize> {
        let grid = grids[b].as_ref()?;
        if !contains(common, p) {
            return None;
        }
        let mut hit = None;
        grid.query([p, p], |e| {
            let inside = strictly_inside(p, meshes[b].triangle_points(e as usize), OVERLAP_TOL);
            if inside {
                hit = Some(e as usize);
            }
            inside
        });
        hit
    };
    for (a, mesh) in meshes.iter().enumerate() {
        for (node, p) in mesh.points.iter().enumerate() {
            if let Some(element) = inside(p, 1 - a) {
                return Some(Overlap::Node {
                    body: a,
                    node,
                    element,
                });
            }
        }
    }
    for (a, mesh) in meshes.iter().enumerate() {
        for inner in near[a].iter().map(|&(e, _)| e as usize) {
            let t = mesh.triangle_points(inner);
            let c = [
                (t[0][0] + t[1][0] + t[2][0]) / 3.0,
                (t[0][1] + t[1][1] + t[2][1]) / 3.0,
            ];
            if let Some(element) = inside(c, 1 - a) {
                return Some(Overlap::Triangle {
                    body: a,
                    inner,
                    element,
                });
            }
        }
    }
    // Boundary edges that cross.
    // (An edge that meets the common box is on the boundary of the body exactly when it is on
    // the boundary of the triangles that meet the box: its triangles' boxes contain its own.)
    let edges = [0, 1].map(|k| {
        let m = meshes[k];
        let part = Mesh {
            triangles: near[k]
                .iter()
                .map(|&(e, _)| m.triangles.get(e as usize))
                .collect(),
            points: Default::default(),
            ..*m
        };
        part.boundary_edges()
            .into_iter()
            .filter(|e| meets(bbox([m.points.get(e[0]), m.points.get(e[1])]), common))
            .collect::<Vec<_>>()
    });
    if edges[0].is_empty() || edges[1].is_empty() {
        return None;
    }
    let seg = |k: usize, e: [usize; 2]| [meshes[k].points.get(e[0]), meshes[k].points.get(e[1])];
    let items: Vec<(u32, BBox)> = edges[0]
        .iter()
        .enumerate()
        .map(|(i, &e)| (i as u32, bbox(seg(0, e))))
        .collect();
    let grid = Grid::new(common, items.len(), &items);
    for &f in &edges[1] {
        let q = seg(1, f);
        let mut hit = None;
        grid.query(bbox(q), |i| {
            let e = edges[0][i as usize];
            let cross = segments_cross(seg(0, e), q, OVERLAP_TOL);
            if cross {
                hit = Some(e);
            }
            cross
        });
        if let Some(e) = hit {
            return Some(Overlap::Edges { edges: [e, f] });
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quality_of_hand_triangles() {
        let eq = [[0.0, 0.0], [1.0, 0.0], [0.5, 3f64.sqrt() / 2.0]];
        assert!((quality(eq) - 3f64.sqrt() / 2.0).abs() < 1e-15);
        assert_eq!(quality([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), 0.5);
        // Clockwise: negative.
        assert_eq!(quality([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0]]), -0.5);
        // A node on the opposite side: zero; near it: its height over the side.
        assert_eq!(quality([[0.0, 0.0], [2.0, 0.0], [1.0, 0.0]]), 0.0);
        assert!((quality([[0.0, 0.0], [2.0, 0.0], [1.0, 1e-6]]) - 0.5e-6).abs() < 1e-20);
        assert_eq!(quality([[1.0, 1.0]; 3]), 0.0);
        assert!(quality([[f64::NAN, 0.0], [1.0, 0.0], [0.0, 1.0]]).is_nan());
    }

    #[test]
    fn point_in_triangle_by_hand() {
        let t = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let mut r = t;
        r.swap(1, 2);
        for tri in [t, r] {
            assert!(strictly_inside([0.25, 0.25], tri, 1e-6));
            // On a side, at a vertex, outside: not strictly inside.
            assert!(!strictly_inside([0.5, 0.0], tri, 1e-6));
            assert!(!strictly_inside([0.5, 0.5], tri, 1e-6));
            assert!(!strictly_inside([0.0, 0.0], tri, 1e-6));
            assert!(!strictly_inside([0.6, 0.6], tri, 1e-6));
            // Within the tolerance of a side: not inside; just beyond it: inside.
            assert!(!strictly_inside([0.5, 1e-7], tri, 1e-6));
            assert!(strictly_inside([0.5, 1e-5], tri, 1e-6));
        }
    }

    #[test]
    fn segment_crossings_by_hand() {
        let p = [[0.0, 0.0], [1.0, 1.0]];
        assert!(segments_cross(p, [[0.0, 1.0], [1.0, 0.0]], 1e-6));
        // Sharing an end, touching at an end, collinear overlapping, apart, parallel.
        assert!(!segments_cross(p, [[1.0, 1.0], [2.0, 0.0]], 1e-6));
        assert!(!segments_cross(p, [[0.5, 0.5], [1.0, 0.0]], 1e-6));
        assert!(!segments_cross(p, [[0.5, 0.5], [2.0, 2.0]], 1e-6));
        assert!(!segments_cross(p, [[2.0, 0.0], [3.0, 1.0]], 1e-6));
        assert!(!segments_cross(p, [[0.0, 1.0], [1.0, 2.0]], 1e-6));
        // The lines cross but not the segments.
        assert!(!segments_cross(p, [[3.0, 0.0], [0.0, 3.0]], 1e-6));
    }

    #[test]
    fn orientation_consistency_between_neighbours() {
        // The unit square in two counter-clockwise triangles: consistent.
        let pts = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let good = Mesh::unstructured(pts.clone(), vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(fold(&good), None);
        assert_eq!(pieces(&good), (1, vec![0, 0]));
        // Node 3 moved to (2, 0.5), across the diagonal 0–2: the triangle (0, 2, 3) turned
        // counter-clockwise again (as the reader does) goes through 0 → 2 like (0, 1, 2).
        let mut moved = pts.clone();
        moved[3] = [2.0, 0.5];
        assert!(orient(moved[0], moved[2], moved[3]) < 0.0);
        let folded = Mesh::unstructured(moved, vec![[0, 1, 2], [0, 3, 2]]);
        assert_eq!(fold(&folded), Some((0, 1)));
        // A triangle given twice; three triangles on one side.
        let twice = Mesh::unstructured(pts.clone(), vec![[0, 1, 2], [0, 2, 3], [1, 2, 0]]);
        assert!(fold(&twice).is_some());
        // Two triangles sharing only node 2: two pieces.
        let bow = Mesh::unstructured(
            vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [2.0, 1.0], [2.0, 2.0]],
            vec![[0, 1, 2], [2, 3, 4]],
        );
        assert_eq!(fold(&bow), None);
        assert_eq!(pieces(&bow), (2, vec![0, 1]));
    }

    #[test]
    fn overlapping_and_touching_bodies() {
        let square = |x: f64, y: f64, s: f64| {
            Mesh::unstructured(
                vec![[x, y], [x + s, y], [x + s, y + s], [x, y + s]],
                vec![[0, 1, 2], [0, 2, 3]],
            )
        };
        let below = Mesh::structured([0.0, 0.0], [1.0, 1.0], 4, 4);
        // Touching along y = 1 with coincident nodes, and with other nodes: no overlap.
        let above = Mesh::structured([0.0, 1.0], [1.0, 1.0], 4, 4);
        assert_eq!(overlap([&below, &above]), None);
        let above3 = Mesh::structured([0.0, 1.0], [1.0, 1.0], 3, 5);
        assert_eq!(overlap([&below, &above3]), None);
        // Apart.
        assert_eq!(overlap([&below, &square(3.0, 3.0, 1.0)]), None);
        // A small square inside a triangle of body 0: its nodes are inside.
        match overlap([&below, &square(0.3, 0.05, 0.01)]) {
            Some(Overlap::Node { body: 1, .. }) => {}
            o => panic!("{o:?}"),
        }
        // Body 1 pushed 0.1 into body 0 (and 0.1 to the right): its bottom nodes are inside
        // body 0's triangles.
        let pushed = Mesh::structured([0.1, 0.9], [1.0, 1.0], 4, 4);
        assert!(matches!(
            overlap([&below, &pushed]),
            Some(Overlap::Node { .. })
        ));
        // The same triangles in both bodies (other node numbers): centroids inside.
        let same = square(0.0, 0.0, 1.0);
        let copy = Mesh::unstructured(
            vec![[1.0, 1.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            vec![[1, 2, 0], [1, 0, 3]],
        );
        assert!(matches!(
            overlap([&same, &copy]),
            Some(Overlap::Triangle { .. })
        ));
        // A cross: no node or centroid of one inside the other, but the edges cross.
        let bar = |p: [[f64; 2]; 4]| Mesh::unstructured(p.to_vec(), vec![[0, 1, 2], [0, 2, 3]]);
        let h = bar([[-2.0, -0.1], [2.0, -0.1], [2.0, 0.1], [-2.0, 0.1]]);
        let v = bar([[-0.1, -2.0], [0.1, -2.0], [0.1, 2.0], [-0.1, 2.0]]);
        assert!(matches!(overlap([&h, &v]), Some(Overlap::Edges { .. })));
    }
}
