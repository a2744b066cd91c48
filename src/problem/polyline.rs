//! Points on a contact curve (a polyline with nodal normals): the projection along the
//! interpolated normal field and the crossing of a line, shared by the matching of curves meshed
//! on their own ([`super::conform`]) and the mortar operators ([`super::mortar`]).

/// Relative distance (to the segment's length) under which a point on a curve is its node: a
/// partner of the matching is the node itself, a projection's parameter t is taken in [0, 1].
pub const COINCIDENT: f64 = 1e-8;

pub(super) fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

pub(super) fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

pub(super) fn lerp(a: [f64; 2], b: [f64; 2], t: f64) -> [f64; 2] {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

pub(super) fn unit(v: [f64; 2]) -> [f64; 2] {
    let h = v[0].hypot(v[1]);
    [v[0] / h, v[1] / h]
}

/// Where a point lies on a curve: segment k at t ∈ [0, 1], at distance s along the direction
/// `normal` (the point is p(t) + s·normal).
#[derive(Clone, Copy, Debug)]
pub(super) struct Foot {
    pub k: usize,
    pub t: f64,
    pub s: f64,
    pub normal: [f64; 2],
}

/// The projection of `q` onto body 1's curve (points `p`, nodal normals `nn`) along the
/// interpolated normal field n(t) = (1 − t) n_k + t n_{k+1}: the root of
/// (q − p(t)) × n(t) = 0 in [0, 1] (a quadratic in t), the nearest if several.
pub(super) fn project(q: [f64; 2], p: &[[f64; 2]], nn: &[[f64; 2]]) -> Option<Foot> {
    let mut best: Option<Foot> = None;
    for k in 0..p.len() - 1 {
        let (a, b) = (p[k], p[k + 1]);
        let d = sub(b, a);
        let dn = sub(nn[k + 1], nn[k]);
        let e = sub(q, a);
        // c0 + c1 t + c2 t² = 0
        let c0 = cross(e, nn[k]);
        let c1 = cross(e, dn) - cross(d, nn[k]);
        let c2 = -cross(d, dn);
        let scale = d[0].hypot(d[1]).max(e[0].hypot(e[1]));
        let mut roots = Vec::with_capacity(2);
        if c2.abs() <= 1e-14 * scale {
            if c1 != 0.0 {
                roots.push(-c0 / c1);
            }
        } else {
            let disc = c1 * c1 - 4.0 * c2 * c0;
            if disc >= 0.0 {
                let r = disc.sqrt();
                // The stable pair of roots.
                let qq = -0.5 * (c1 + c1.signum() * r);
                if qq != 0.0 {
                    roots.push(c0 / qq);
                }
                roots.push(qq / c2);
            }
        }
        for t in roots {
            if !(-COINCIDENT..=1.0 + COINCIDENT).contains(&t) {
                continue;
            }
            let t = t.clamp(0.0, 1.0);
            let normal = unit(lerp(nn[k], nn[k + 1], t));
            let s = {
                let r = sub(q, lerp(a, b, t));
                r[0] * normal[0] + r[1] * normal[1]
            };
            if best.is_none_or(|f| s.abs() < f.s.abs()) {
                best = Some(Foot { k, t, s, normal });
            }
        }
    }
    best
}

/// Where the line x + s·n meets the curve of points `p`: the nearest crossing (smallest |s|).
pub(super) fn ray(x: [f64; 2], n: [f64; 2], p: &[[f64; 2]]) -> Option<Foot> {
    let mut best: Option<Foot> = None;
    for k in 0..p.len() - 1 {
        let w = sub(p[k + 1], p[k]);
        let r = sub(p[k], x);
        let det = cross(n, w);
        if det.abs() <= 1e-14 * w[0].hypot(w[1]) {
            continue; // parallel
        }
        let s = cross(r, w) / det;
        let t = cross(r, n) / det;
        if !(-COINCIDENT..=1.0 + COINCIDENT).contains(&t) {
            continue;
        }
        if best.is_none_or(|f| s.abs() < f.s.abs()) {
            best = Some(Foot {
                k,
                t: t.clamp(0.0, 1.0),
                s,
                normal: n,
            });
        }
    }
    best
}

/// Whether a contact curve ends or closes on itself (a pin's whole circle, a bore).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ends {
    Open,
    /// Given as a polyline whose last point repeats its first (with the same normal).
    Closed,
}

/// A node where the polyline turns by more than this (rad, 20°) is a corner of the curve, not a
/// sample of a smooth arc: [`Arcs`] takes no curvature from it.
pub const CORNER: f64 = 0.35;

/// The smooth curve through a polyline's nodes, which the mortar gap is measured to
/// (`-nndd_mortar_gap curves`): on each segment the circular arc through its two nodes whose
/// curvature is the mean of those of the circles through each end node and its two neighbours.
/// On the polygon of a circle (at any spacing) that is the circle itself, to round-off; on a
/// smooth curve it is O(h³) from it where the chord is O(h²). A corner ([`CORNER`]) or an open
/// curve's end node gives no curvature; a segment with none from either end is its chord.
pub(super) struct Arcs<'a> {
    points: &'a [[f64; 2]],
    /// Signed curvature per segment (> 0: the curve turns left, its centre on the left).
    kappa: Vec<f64>,
}

impl<'a> Arcs<'a> {
    pub fn new(points: &'a [[f64; 2]], ends: Ends) -> Arcs<'a> {
        let n = points.len();
        // The curvature of the circle through each node and its neighbours, where it has two
        // and does not turn a corner.
        let node: Vec<Option<f64>> = (0..n)
            .map(|i| {
                let (a, c) = match ends {
                    _ if n < 3 => return None,
                    _ if i > 0 && i < n - 1 => (points[i - 1], points[i + 1]),
                    // The first node is the last: its neighbours are the last but one and the
                    // second.
                    Ends::Closed => (points[n - 2], points[1]),
                    Ends::Open => return None,
                };
                let b = points[i];
                let (u, v, w) = (sub(b, a), sub(c, b), sub(c, a));
                let turn = cross(u, v).atan2(u[0] * v[0] + u[1] * v[1]);
                let lengths = u[0].hypot(u[1]) * v[0].hypot(v[1]) * w[0].hypot(w[1]);
                (turn.abs() <= CORNER && lengths > 0.0).then(|| 2.0 * cross(u, v) / lengths)
            })
            .collect();
        let kappa = (0..n.saturating_sub(1))
            .map(|k| match (node[k], node[k + 1]) {
                (Some(a), Some(b)) => 0.5 * (a + b),
                (Some(a), None) | (None, Some(a)) => a,
                (None, None) => 0.0,
            })
            .collect();
        Arcs { points, kappa }
    }

    /// The distance s along the unit direction `n` from `x` to the curve (x + s·n on it), the
    /// crossing nearest `x`, looked for first near the nodes `hint` (then everywhere); `None`
    /// where the line misses it.
    pub fn ray(&self, x: [f64; 2], n: [f64; 2], hint: std::ops::Range<usize>) -> Option<f64> {
        // The chords' crossing says where to look: the arcs of that segment and its neighbours.
        let (lo, hi) = (
            hint.start.saturating_sub(2),
            (hint.end + 2).min(self.points.len()),
        );
        let near = match (lo + 1 < hi)
            .then(|| ray(x, n, &self.points[lo..hi]))
            .flatten()
        {
            Some(f) => f.k + lo,
            None => ray(x, n, self.points)?.k,
        };
        (near.saturating_sub(1)..(near + 2).min(self.kappa.len()))
            .filter_map(|k| self.ray_on(k, x, n))
            .min_by(|a, b| a.abs().total_cmp(&b.abs()))
    }

    /// Where the line x + s·n meets segment k's arc (between its nodes).
    fn ray_on(&self, k: usize, x: [f64; 2], n: [f64; 2]) -> Option<f64> {
        let (a, b) = (self.points[k], self.points[k + 1]);
        let d = sub(b, a);
        let len = d[0].hypot(d[1]);
        let kappa = self.kappa[k];
        let half = 0.5 * len * kappa.abs();
        if !(1e-12..1.0).contains(&half) {
            let f = ray(x, n, &self.points[k..k + 2])?;
            return Some(f.s);
        }
        // The centre: on the side the curve turns to, R cos(half-angle) from the chord's middle.
        let r = 1.0 / kappa.abs();
        let side = kappa.signum();
        let left = [-d[1] / len, d[0] / len];
        let depth = r * (1.0 - half * half).sqrt();
        let mid = lerp(a, b, 0.5);
        let centre = [
            mid[0] + side * depth * left[0],
            mid[1] + side * depth * left[1],
        ];
        // |x + s n − c|² = r²: s² + 2 s (x − c)·n + |x − c|² − r² = 0.
        let e = sub(x, centre);
        let bq = e[0] * n[0] + e[1] * n[1];
        let dist = e[0].hypot(e[1]);
        let cq = (dist - r) * (dist + r);
        let disc = bq * bq - cq;
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = -(bq + bq.signum() * root);
        let mut roots = vec![q];
        if q != 0.0 {
            roots.push(cq / q);
        }
        // The arc: the circle's points over the chord, on the side away from the centre.
        roots
            .into_iter()
            .filter(|&s| {
                let p = [x[0] + s * n[0], x[1] + s * n[1]];
                let rel = sub(p, a);
                let t = (rel[0] * d[0] + rel[1] * d[1]) / (len * len);
                let off = sub(p, mid);
                (-COINCIDENT..=1.0 + COINCIDENT).contains(&t)
                    && side * (off[0] * left[0] + off[1] * left[1]) <= COINCIDENT * len
            })
            .min_by(|a, b| a.abs().total_cmp(&b.abs()))
    }
}
