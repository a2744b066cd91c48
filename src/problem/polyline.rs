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
