//! A body's mesh and its matched refinement for a mortar run's estimates
//! ([`super::ProblemSettings::for_estimates`]): the user's mesh with nodes inserted on its
//! contact curve and nothing moved. Every node of the matched mesh is a node of the user's, or a
//! point of one of its boundary segments; every triangle lies in one of the user's. So a P1
//! field of the user's mesh is exactly the P1 field of the matched mesh with the interpolated
//! values at the inserted nodes ([`Transfer::interpolate`]), and an element sum over the
//! matched mesh is one over the user's ([`Transfer::parent`]).

use std::collections::HashMap;
use std::rc::Rc;

use super::curves::MeshedError;
use super::matched::point_key;
use super::BodyProblem;
use crate::fem::mesh::Mesh;
use crate::fem::wire::{Reader, Writer};
use crate::fem::Dofs;

/// Where a node of the matched mesh comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Source {
    /// The user's node.
    Node(usize),
    /// The point (1 − t) x_a + t x_b of the user's boundary segment [a, b].
    Segment { a: usize, b: usize, t: f64 },
}

/// The map from one body's mesh (the user's) to its matched refinement: whole, or a rank's
/// part of it ([`Transfer::restricted`]: the matched nodes and elements the rank reads).
#[derive(Clone, Debug)]
pub struct Transfer {
    /// The matched nodes' sources: all of them, or those of `nodes`.
    sources: Vec<Source>,
    /// The matched nodes `sources` are of, ascending (`None`: all).
    nodes: Option<Vec<u32>>,
    /// The user's triangle each matched triangle lies in: all of them, or those of `elements`.
    parents: Vec<usize>,
    /// The matched elements `parents` are of, ascending (`None`: all).
    elements: Option<Vec<u32>>,
    /// The number of the user's triangles.
    coarse_elements: usize,
}

/// Entry `i`'s place among `ids` (ascending; `None`: all), or a panic naming `what`: a phase
/// reads beyond the part of the transfer the rank was given.
fn place_of(ids: &Option<Vec<u32>>, i: usize, what: &str) -> usize {
    let Some(ids) = ids else { return i };
    match u32::try_from(i).ok().map(|i| ids.binary_search(&i)) {
        Some(Ok(k)) => k,
        _ => panic!("matched {what} {i} is not in this rank's part of the transfer"),
    }
}

/// Relative distance (to the segment's length) within which an inserted node lies on a
/// segment: round-off of the insertion's interpolation.
const ON_SEGMENT: f64 = 1e-9;

impl Transfer {
    /// The transfer from body `from`'s mesh to `to`'s, its matched refinement (the same body).
    pub fn new(from: &BodyProblem, to: &BodyProblem) -> Result<Transfer, MeshedError> {
        let (coarse, fine) = (from.mesh(), to.mesh());
        let invalid = |what: String| {
            MeshedError::Option {
            option: "-nndd_contact_discretisation mortar".into(),
            message: format!(
                "the estimates' matched mesh of body {} is not a refinement of the body's mesh: {what}",
                from.alpha
            ),
        }
        };
        let at: HashMap<[u64; 2], usize> = coarse
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| (point_key(p), i))
            .collect();
        let boundary = coarse.boundary_edges();
        let mut sources = Vec::with_capacity(fine.points.len());
        for p in &fine.points {
            if let Some(&i) = at.get(&point_key(p)) {
                sources.push(Source::Node(i));
                continue;
            }
            let (best, d, t) = boundary
                .iter()
                .map(|&[a, b]| {
                    let (t, d) = foot(coarse.points.get(a), coarse.points.get(b), p);
                    ([a, b], d, t)
                })
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .ok_or_else(|| invalid("no boundary".into()))?;
            let [a, b] = best;
            let len = dist(coarse.points.get(a), coarse.points.get(b));
            if d > ON_SEGMENT * len {
                return Err(invalid(format!(
                    "its node ({:.6e}, {:.6e}) is on no boundary segment",
                    p[0], p[1]
                )));
            }
            sources.push(Source::Segment { a, b, t });
        }
        let parents = parents(coarse, fine, &sources).map_err(invalid)?;
        Ok(Transfer {
            sources,
            nodes: None,
            parents,
            elements: None,
            coarse_elements: coarse.triangles.len(),
        })
    }

    /// This (whole) transfer's part at the matched `nodes` and `elements` (each ascending):
    /// what a rank reads of it.
    pub fn restricted(&self, nodes: &[u32], elements: &[u32]) -> Transfer {
        Transfer {
            sources: nodes.iter().map(|&n| self.sources[n as usize]).collect(),
            nodes: Some(nodes.to_vec()),
            parents: elements.iter().map(|&e| self.parents[e as usize]).collect(),
            elements: Some(elements.to_vec()),
            coarse_elements: self.coarse_elements,
        }
    }

    /// The P1 field `u` (x, y per node) of the user's mesh on the (whole) matched mesh.
    pub fn interpolate(&self, u: &[f64]) -> Vec<f64> {
        assert!(
            self.nodes.is_none(),
            "a part of a transfer interpolates at its nodes"
        );
        (0..self.sources.len())
            .flat_map(|n| self.value_at(u, n))
            .collect()
    }

    /// The user's nodes whose values make the matched `nodes`' ([`Transfer::interpolate_at`]
    /// reads them alone), ascending.
    pub fn stencil_nodes(&self, nodes: &[u32]) -> Vec<usize> {
        let mut coarse: Vec<usize> = (nodes.iter())
            .flat_map(|&n| match self.source(n as usize) {
                Source::Node(i) => [Some(i), None],
                Source::Segment { a, b, .. } => [Some(a), Some(b)],
            })
            .flatten()
            .collect();
        coarse.sort_unstable();
        coarse.dedup();
        coarse
    }

    /// The P1 field `u` of the user's mesh (held at least at [`Transfer::stencil_nodes`] of
    /// `nodes`) at the matched `nodes`: two values per node, in that order.
    pub fn interpolate_at(&self, u: &(impl Dofs + ?Sized), nodes: &[u32]) -> Vec<f64> {
        (nodes.iter())
            .flat_map(|&n| self.value_at(u, n as usize))
            .collect()
    }

    /// Matched node `n`'s source.
    fn source(&self, n: usize) -> Source {
        self.sources[place_of(&self.nodes, n, "node")]
    }

    /// Matched node `n`'s (x, y) of the P1 field `u` of the user's mesh.
    fn value_at(&self, u: &(impl Dofs + ?Sized), n: usize) -> [f64; 2] {
        let source = self.source(n);
        std::array::from_fn(|c| match source {
            Source::Node(i) => u[2 * i + c],
            Source::Segment { a, b, t } => (1.0 - t) * u[2 * a + c] + t * u[2 * b + c],
        })
    }

    /// The matched node of each of the user's nodes that is one (`None` for the others).
    pub fn fine_node_of(&self) -> HashMap<usize, usize> {
        assert!(self.nodes.is_none(), "a whole transfer");
        self.sources
            .iter()
            .enumerate()
            .filter_map(|(f, s)| match s {
                Source::Node(c) => Some((*c, f)),
                Source::Segment { .. } => None,
            })
            .collect()
    }

    /// The user's element that matched element `e` lies in.
    pub fn parent(&self, e: usize) -> usize {
        self.parents[place_of(&self.elements, e, "element")]
    }

    /// The transfer as bytes ([`Transfer::read`] reads them back).
    pub fn write(&self, w: &mut Writer) {
        w.list(&self.sources, |w, s| match *s {
            Source::Node(i) => {
                w.u8(0);
                w.int(i);
            }
            Source::Segment { a, b, t } => {
                w.u8(1);
                w.int(a);
                w.int(b);
                w.f64(t);
            }
        });
        let ids = |w: &mut Writer, ids: &Option<Vec<u32>>| match ids {
            None => w.u8(0),
            Some(ids) => {
                w.u8(1);
                w.u32s(ids);
            }
        };
        ids(w, &self.nodes);
        w.ints(&self.parents);
        ids(w, &self.elements);
        w.int(self.coarse_elements);
    }

    /// What [`Transfer::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Transfer> {
        let sources = r.list(9, |r| match r.u8()? {
            0 => Some(Source::Node(r.int()?)),
            1 => Some(Source::Segment {
                a: r.int()?,
                b: r.int()?,
                t: r.f64()?,
            }),
            _ => None,
        })?;
        let ids = |r: &mut Reader| match r.u8()? {
            0 => Some(None),
            1 => Some(Some(r.u32s()?)),
            _ => None,
        };
        let nodes = ids(r)?;
        let parents = r.ints()?;
        let elements = ids(r)?;
        let coarse_elements = r.int()?;
        let aligned = |ids: &Option<Vec<u32>>, n: usize| ids.as_ref().is_none_or(|i| i.len() == n);
        (aligned(&nodes, sources.len()) && aligned(&elements, parents.len())).then_some(Transfer {
            sources,
            nodes,
            parents,
            elements,
            coarse_elements,
        })
    }

    /// The number of the user's elements.
    pub fn coarse_elements(&self) -> usize {
        self.coarse_elements
    }
}

/// The initial gap of a mortar run's estimates' continuous problem (docs/method.md §7, "The
/// estimates"): the mortar problem's nodal gaps g_j = D_jj⁻¹ g̃_j along its non-mortar chain,
/// linear on each of its segments, instead of the distance between the two polygons. The two
/// differ by the polygons' sagittas (h²/8R on a circle), which the weighted constraint averages
/// out and a pointwise one does not: against the polygons' distance the mortar solution
/// penetrates by that much at the matched pairs (the pin in its hole 2:3, level 1: a
/// correction ‖δ_n‖ as large as η^glo itself), against g₀* only by the displacement's own
/// O(h²u'').
#[derive(Clone, Debug)]
pub struct GapField {
    side: usize,
    points: Vec<[f64; 2]>,
    values: Vec<f64>,
}

impl GapField {
    /// The gap field of the mortar problem `mortar` (both bodies).
    pub fn new(mortar: [&BodyProblem; 2]) -> GapField {
        let side = super::pair_side(mortar);
        let nm = mortar[side];
        GapField {
            side,
            points: nm
                .contact_nodes
                .iter()
                .map(|&n| nm.mesh().points.get(n))
                .collect(),
            values: nm.gap.clone(),
        }
    }

    /// The gap field as bytes ([`GapField::read`] reads them back).
    pub fn write(&self, w: &mut Writer) {
        w.int(self.side);
        w.points(&self.points);
        w.f64s(&self.values);
    }

    /// What [`GapField::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<GapField> {
        let side = r.int().filter(|&s| s < 2)?;
        let (points, values) = (r.points()?, r.f64s()?);
        (points.len() == values.len()).then_some(GapField {
            side,
            points,
            values,
        })
    }

    /// g₀* at the point `x` of the non-mortar polygon (its nearest point there).
    pub fn at(&self, x: [f64; 2]) -> f64 {
        let (k, t) = place(&self.points, x);
        match self.values.get(k + 1) {
            Some(next) => (1.0 - t) * self.values[k] + t * next,
            None => self.values.get(k).copied().unwrap_or(0.0),
        }
    }

    /// Node-to-node `problems` on meshes matched to the mortar problem's (or refinements of
    /// them) with g₀* as the initial gap of each pair (at its non-mortar side's node).
    pub fn apply(&self, problems: [Rc<BodyProblem>; 2]) -> [Rc<BodyProblem>; 2] {
        let p = &problems[self.side];
        let gap: Vec<f64> = p
            .contact_nodes
            .iter()
            .map(|&n| self.at(p.mesh().points.get(n)))
            .collect();
        problems.map(|b| {
            Rc::new(BodyProblem {
                gap: gap.clone(),
                ..(*b).clone()
            })
        })
    }
}

/// The place of `x` on the polyline `pts`: its nearest segment k and the fraction t on it.
pub fn place(pts: &[[f64; 2]], x: [f64; 2]) -> (usize, f64) {
    let mut best = (0, 0.0, f64::INFINITY);
    for k in 0..pts.len().saturating_sub(1) {
        let (t, d) = foot(pts[k], pts[k + 1], x);
        if d < best.2 {
            best = (k, t, d);
        }
    }
    (best.0, best.1)
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

/// The foot of `p` on the segment [a, b]: its fraction t ∈ [0, 1] and distance.
fn foot(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> (f64, f64) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (t, dist([a[0] + t * dx, a[1] + t * dy], p))
}

/// The user's triangle each matched triangle lies in: the one around its centroid among the
/// triangles at its vertices' sources (a matched triangle has a vertex of the user's, the one
/// opposite the split boundary segment).
fn parents(coarse: &Mesh, fine: &Mesh, sources: &[Source]) -> Result<Vec<usize>, String> {
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); coarse.points.len()];
    for (e, t) in coarse.triangles.iter().enumerate() {
        for a in t {
            around[a].push(e);
        }
    }
    let mut out = Vec::with_capacity(fine.triangles.len());
    for (f, t) in fine.triangles.iter().enumerate() {
        let p = fine.triangle_points(f);
        let c = [
            (p[0][0] + p[1][0] + p[2][0]) / 3.0,
            (p[0][1] + p[1][1] + p[2][1]) / 3.0,
        ];
        let mut best: Option<(usize, f64)> = None;
        for v in t {
            let near: &[usize] = match sources[v] {
                Source::Node(i) => &around[i],
                Source::Segment { a, .. } => &around[a],
            };
            for &e in near {
                let inside = least_barycentric(coarse.triangle_points(e), c);
                if best.is_none_or(|(_, b)| inside > b) {
                    best = Some((e, inside));
                }
            }
        }
        match best {
            Some((e, inside)) if inside > -1e-9 => out.push(e),
            _ => {
                return Err(format!(
                    "its triangle at ({:.6e}, {:.6e}) lies in none of the body's",
                    c[0], c[1]
                ))
            }
        }
    }
    Ok(out)
}

/// The least barycentric coordinate of `x` in the triangle `p` (≥ 0 inside).
fn least_barycentric(p: [[f64; 2]; 3], x: [f64; 2]) -> f64 {
    let area = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let total = area(p[0], p[1], p[2]);
    [
        area(x, p[1], p[2]),
        area(p[0], x, p[2]),
        area(p[0], p[1], x),
    ]
    .iter()
    .map(|a| a / total)
    .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_split_triangle_carries_p1_fields_and_sums_exactly() {
        // One triangle, its bottom edge split at x = 0.3.
        let coarse = Mesh::unstructured(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], vec![[0, 1, 2]]);
        let fine = Mesh::unstructured(
            vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.3, 0.0]],
            vec![[0, 3, 2], [3, 1, 2]],
        );
        let body = |mesh: Mesh| BodyProblem {
            alpha: 1,
            mesh: super::super::BodyMesh::Whole(mesh),
            outline: Default::default(),
            fingerprint: Default::default(),
            material: crate::fem::Material {
                young: 1.0,
                poisson: 0.3,
            },
            dirichlet: vec![],
            neumann: vec![],
            contact_nodes: vec![],
            trace: super::super::GcTrace::Nodes,
            gap: vec![],
            contact_normals: vec![],
            contact_lengths: vec![],
            contact_candidates: vec![],
            candidate_normals: vec![],
            support: super::super::Support::Conditions,
        };
        let t = Transfer::new(&body(coarse), &body(fine)).unwrap();
        assert_eq!(t.parents, vec![0, 0]);
        // u = (x + 2y, 3x − y) is P1: exact at the new node.
        let u = [0.0, 0.0, 1.0, 3.0, 2.0, -1.0];
        let v = t.interpolate(&u);
        assert!(
            (v[6] - 0.3).abs() < 1e-15 && (v[7] - 0.9).abs() < 1e-15,
            "{v:?}"
        );
        assert_eq!((t.parent(0), t.parent(1), t.coarse_elements()), (0, 0, 1));
        assert_eq!(t.fine_node_of().len(), 3);
        // At the new node alone: from the split edge's ends, the same values.
        assert_eq!(t.stencil_nodes(&[3]), vec![0, 1]);
        assert_eq!(
            t.interpolate_at(&u[..], &[3, 2]),
            [&v[6..8], &v[4..6]].concat()
        );
        // A rank's part (matched nodes 2 and 3, element 1), sent as bytes: the same values and
        // parent there; a node outside it is refused.
        let mut w = Writer::default();
        t.restricted(&[2, 3], &[1]).write(&mut w);
        let mut r = Reader::new(&w.0);
        let part = Transfer::read(&mut r).filter(|_| r.is_done()).unwrap();
        assert_eq!(
            part.interpolate_at(&u[..], &[3, 2]),
            t.interpolate_at(&u[..], &[3, 2])
        );
        assert_eq!((part.parent(1), part.stencil_nodes(&[3])), (0, vec![0, 1]));
        let outside = std::panic::catch_unwind(|| part.interpolate_at(&u[..], &[1]));
        assert!(outside.is_err());
    }
}
