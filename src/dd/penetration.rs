//! The final check that the bodies do not pass through each other anywhere: Γc's pairs by
//! their gaps, every other boundary node of either body by the linearised gap along its outward
//! normal to the other body's boundary (a bucket search, O(N)). The contact conditions hold on
//! Γc's pairs only; this check finds where the bodies meet beyond them (contact curves named
//! shorter than the contact zone, a body pushed into a part of the other that no curve names).

use crate::dd::check::CONTACT_LIMIT;
use crate::dd::displacement::Displacement;
use crate::dd::iterate::Iterate;
use crate::fem::checks::{bbox, BBox, Grid};
use crate::parallel::layout::Layout;
use crate::problem::{BodyProblem, Outline};

/// Where the deepest penetration is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Site {
    /// Nothing penetrates.
    #[default]
    None,
    /// A Γc pair, whose gap the contact step keeps ≥ 0.
    GcPair,
    /// A node of a named contact curve beyond the part the other curve faces.
    ContactCurve,
    /// A boundary node on no contact curve.
    Boundary,
}

/// The largest penetration found over both bodies' boundaries ([`penetration`]).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Penetration {
    /// How far (m) the node is inside the other body, linearised: max(0, −g), g the gap along
    /// the node's normal after the displacements; 0 when nothing penetrates.
    pub depth: f64,
    /// The depth over the displacements' scale (the largest |u| on both bodies' boundaries).
    pub relative: f64,
    /// The node, in the reference configuration, and its body (0 when nothing penetrates).
    pub at: [f64; 2],
    pub body: usize,
    pub site: Site,
}

impl Penetration {
    /// The error of a penetration beyond round-off: where, how deep, what to do.
    pub fn failure(&self, curves: &[String; 2]) -> Option<String> {
        (self.relative.is_nan() || self.relative > CONTACT_LIMIT).then(|| {
            let (own, other) = (&curves[self.body - 1], &curves[2 - self.body]);
            let (place, remedy) = match self.site {
                Site::GcPair | Site::None => (format!("on the contact curve '{own}'"), "on Γc".to_string()),
                Site::ContactCurve => (
                    format!("on the contact curve '{own}'"),
                    format!("beyond the part of it that '{other}' faces: the bodies meet where the contact curves do not reach (name longer curves)"),
                ),
                Site::Boundary => (
                    format!("on its boundary off the contact curve '{own}'"),
                    "where no contact curve is named: the bodies meet beyond the contact curves (name curves that cover the contact zone, -nndd_contact)".to_string(),
                ),
            };
            format!(
                "body {}'s node ({:.6e}, {:.6e}) {place} is {:.3e} m inside body {} ({:.1e} of the displacements), {remedy}; no results are written",
                self.body,
                self.at[0],
                self.at[1],
                self.depth,
                3 - self.body,
                self.relative,
            )
        })
    }
}

/// A body's boundary: its edges (counter-clockwise, the body on the left), its nodes with
/// their outward unit normals (the mean of their two edges'), and the displacement of each
/// node shared from the body's owners.
struct Boundary<'a> {
    /// The body's outline: its boundary edges, nodes and their points.
    outline: &'a Outline,
    /// Per boundary node (in the outline's order).
    normals: Vec<[f64; 2]>,
    /// [ux, uy] per boundary node.
    u: Vec<f64>,
}

impl<'a> Boundary<'a> {
    /// Body `p`'s boundary, with its displacement `u` (empty off the body's ranks) shared
    /// with every rank (collective).
    fn of(layout: &Layout, p: &'a BodyProblem, u: &Displacement) -> Boundary<'a> {
        let outline = p.outline();
        let nodes = outline.nodes();
        let mut normals = vec![[0.0; 2]; nodes.len()];
        for &[a, b] in &outline.edges {
            let (pa, pb) = (outline.point(a), outline.point(b));
            let l = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
            let nu = [(pb[1] - pa[1]) / l, -(pb[0] - pa[0]) / l];
            for n in [a, b] {
                let v = &mut normals[outline
                    .index(n)
                    .expect("an edge's ends are on the boundary")];
                v[0] += nu[0];
                v[1] += nu[1];
            }
        }
        for v in &mut normals {
            let l = v[0].hypot(v[1]);
            if l > 0.0 {
                *v = [v[0] / l, v[1] / l];
            }
        }
        let mut values = vec![0.0; 2 * nodes.len()];
        if !u.is_empty() {
            for (k, &n) in nodes.iter().enumerate() {
                values[2 * k] = u[2 * n];
                values[2 * k + 1] = u[2 * n + 1];
            }
        }
        layout.share(p.alpha, &mut values);
        Boundary {
            outline,
            normals,
            u: values,
        }
    }

    fn disp(&self, node: usize) -> [f64; 2] {
        let i = self.outline.index(node).expect("a boundary node");
        [self.u[2 * i], self.u[2 * i + 1]]
    }

    /// The largest |u| on the boundary.
    fn scale(&self) -> f64 {
        self.u.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
    }
}

/// The boundary edges of a body in a bucket grid, for the rays of the other body's nodes.
struct EdgeGrid<'a> {
    boundary: &'a Boundary<'a>,
    grid: Grid,
}

impl<'a> EdgeGrid<'a> {
    fn new(boundary: &'a Boundary<'a>, reach: f64) -> EdgeGrid<'a> {
        let outline = boundary.outline;
        let pts = |ns: &[usize]| ns.iter().map(|&n| outline.point(n)).collect::<Vec<_>>();
        let boxes: Vec<(u32, BBox)> = (outline.edges.iter())
            .enumerate()
            .map(|(e, ends)| (e as u32, bbox(pts(ends))))
            .collect();
        let mut area = bbox(pts(outline.nodes()));
        let [lo, hi] = &mut area;
        for (l, h) in lo.iter_mut().zip(hi.iter_mut()) {
            *l -= reach;
            *h += reach;
        }
        EdgeGrid {
            boundary,
            grid: Grid::new(area, boxes.len(), &boxes),
        }
    }

    /// The first point ahead (distance s ∈ [0, reach]) where the ray x + sν meets the
    /// boundary, with the boundary's displacement there.
    fn hit(&self, x: [f64; 2], nu: [f64; 2], reach: f64) -> Option<(f64, [f64; 2])> {
        let outline = self.boundary.outline;
        let end = [x[0] + reach * nu[0], x[1] + reach * nu[1]];
        let mut best: Option<(f64, [f64; 2])> = None;
        self.grid.query(bbox([x, end]), |e| {
            let [ea, eb] = outline.edges[e as usize];
            let (pa, pb) = (outline.point(ea), outline.point(eb));
            let w = [pb[0] - pa[0], pb[1] - pa[1]];
            let r = [pa[0] - x[0], pa[1] - x[1]];
            let det = nu[0] * w[1] - nu[1] * w[0];
            if det == 0.0 {
                return false;
            }
            let s = (r[0] * w[1] - r[1] * w[0]) / det;
            let t = (r[0] * nu[1] - r[1] * nu[0]) / det;
            if (0.0..=1.0).contains(&t)
                && (0.0..=reach).contains(&s)
                && best.is_none_or(|(h, _)| s < h)
            {
                let (ua, ub) = (self.boundary.disp(ea), self.boundary.disp(eb));
                best = Some((
                    s,
                    [ua[0] + t * (ub[0] - ua[0]), ua[1] + t * (ub[1] - ua[1])],
                ));
            }
            false
        });
        best
    }
}

/// The largest penetration over both bodies (collective; every rank finds the same). On Γc
/// it is the pairs' gap g₀ + u²_n − u¹_n; at every other boundary node x of either body, the
/// gap along its outward normal ν to the first point q ahead on the other body's boundary,
/// linearised as the contact conditions are: s + (u_other(q) − u(x))·ν, x + sν = q. Only
/// points within twice the largest boundary displacement can give a negative gap, so the
/// bucket search looks that far.
pub fn penetration(layout: &Layout, problems: [&BodyProblem; 2], it: &Iterate) -> Penetration {
    let boundaries = [0, 1].map(|k| Boundary::of(layout, problems[k], &it.u[k]));
    let scale = boundaries[0].scale().max(boundaries[1].scale());
    let mut worst = Penetration::default();
    let mut consider = |depth: f64, body: usize, node: usize, site: Site| {
        if depth > worst.depth || depth.is_nan() {
            let at = problems[body - 1].boundary_point(node);
            worst = Penetration {
                depth,
                relative: 0.0,
                at,
                body,
                site,
            };
        }
    };
    // Γc: the pairs (at the nodes of its pair side; under mortar, the weighted gaps).
    let side = crate::problem::pair_side(problems);
    let ps = problems[side];
    for k in 0..it.lambda.len() {
        let gap = it.trace2[k] - (it.lambda[k] - ps.gap[k]);
        consider(-gap, side + 1, ps.contact_nodes[k], Site::GcPair);
    }
    // Every other boundary node against the other body's boundary.
    let reach = 2.0 * scale * (1.0 + 1e-6);
    if reach > 0.0 {
        for a in 0..2 {
            let (p, own) = (problems[a], &boundaries[a]);
            let other = EdgeGrid::new(&boundaries[1 - a], reach);
            let on_gc: std::collections::HashSet<usize> = p.contact_nodes.iter().copied().collect();
            let on_curve: std::collections::HashSet<usize> =
                p.contact_candidates.iter().copied().collect();
            for (k, &node) in own.outline.nodes().iter().enumerate() {
                if on_gc.contains(&node) {
                    continue;
                }
                let (x, nu) = (own.outline.point(node), own.normals[k]);
                if let Some((s, uq)) = other.hit(x, nu, reach) {
                    let ux = own.disp(node);
                    let gap = s + (uq[0] - ux[0]) * nu[0] + (uq[1] - ux[1]) * nu[1];
                    let site = if on_curve.contains(&node) {
                        Site::ContactCurve
                    } else {
                        Site::Boundary
                    };
                    consider(-gap, a + 1, node, site);
                }
            }
        }
    }
    worst.relative = if scale > 0.0 {
        worst.depth / scale
    } else {
        worst.depth
    };
    worst
}
