//! The Johnson–Mercier element, in the local frame of `fem::geometry::local_frame`: the
//! 30 × 27 local system and its least-squares operator (edge tractions → JM coefficients), the
//! operator cache per triangle shape, and the JM fields of all elements from the edge
//! tractions.

use super::fast_map::FastMap;

use super::eet::element_tractions;
use super::sizes::{MAX_SHAPES, NC, NONE, NT, SHAPE_QUANTUM};
use super::topology::Topology;
use crate::fem::geometry::{local_frame, unit};
use crate::fem::mesh::Mesh;

pub(super) fn traction(s: &[f64; 3], n: [f64; 2]) -> [f64; 2] {
    [s[0] * n[0] + s[2] * n[1], s[2] * n[0] + s[1] * n[1]]
}

/// Stress of sub-triangle a at local point ξ.
pub(super) fn eval(x: &[f64; NC], a: usize, xi: [f64; 2]) -> [f64; 3] {
    let o = 9 * a;
    [0, 1, 2].map(|r| x[o + 3 * r] + x[o + 3 * r + 1] * xi[0] + x[o + 3 * r + 2] * xi[1])
}

/// Edge midpoints of sub-triangle a = (0, q_a, q_{a+1}) (local frame).
/// σ̂ of the JM coefficients `x` at the 3 edge midpoints of each of the 3 sub-triangles (the
/// exact quadrature points of a quadratic integrand).
pub(super) fn midpoint_values(q: &[[f64; 2]; 3], x: &[f64; NC]) -> [[f64; 3]; 9] {
    let mut out = [[0.0; 3]; 9];
    for a in 0..3 {
        for (m, pt) in midpoints(q, a).into_iter().enumerate() {
            out[3 * a + m] = eval(x, a, pt);
        }
    }
    out
}

pub(super) fn midpoints(q: &[[f64; 2]; 3], a: usize) -> [[f64; 2]; 3] {
    let (p, r) = (q[a], q[(a + 1) % 3]);
    [
        [0.5 * p[0], 0.5 * p[1]],
        [0.5 * (p[0] + r[0]), 0.5 * (p[1] + r[1])],
        [0.5 * r[0], 0.5 * r[1]],
    ]
}

/// Row of the traction component k of sub-triangle a at point ξ with normal n.
fn traction_row(row: &mut [f64], a: usize, xi: [f64; 2], n: [f64; 2], k: usize, sign: f64) {
    let phi = [1.0, xi[0], xi[1]];
    let o = 9 * a;
    // (σn)_x = σxx n_x + σxy n_y; (σn)_y = σxy n_x + σyy n_y.
    let (ra, rb) = if k == 0 { (0, 2) } else { (2, 1) };
    for m in 0..3 {
        row[o + 3 * ra + m] += sign * phi[m] * n[0];
        row[o + 3 * rb + m] += sign * phi[m] * n[1];
    }
}

/// The 30 × 27 JM system of the normalised triangle q (row-major): rows 0..6 divergence,
/// 6..18 internal traction continuity, 18..30 external tractions (row 18 + 4 l + 2 end + k
/// equals the traction value of the same index).
fn jm_system(q: &[[f64; 2]; 3]) -> Vec<f64> {
    let mut m = vec![0.0; 30 * NC];
    for a in 0..3 {
        let o = 9 * a;
        // ∂σxx/∂ξ + ∂σxy/∂η, ∂σxy/∂ξ + ∂σyy/∂η.
        m[(2 * a) * NC + o + 1] = 1.0;
        m[(2 * a) * NC + o + 8] = 1.0;
        m[(2 * a + 1) * NC + o + 7] = 1.0;
        m[(2 * a + 1) * NC + o + 5] = 1.0;
        // Internal edge 0 → q_a between sub-triangles a − 1 and a.
        let n = unit([q[a][1], -q[a][0]]);
        for (ip, pt) in [[0.0, 0.0], q[a]].into_iter().enumerate() {
            for k in 0..2 {
                let row = 6 + 4 * a + 2 * ip + k;
                let r = &mut m[row * NC..(row + 1) * NC];
                traction_row(r, a, pt, n, k, 1.0);
                traction_row(r, (a + 2) % 3, pt, n, k, -1.0);
            }
        }
        // External edge q_a → q_{a+1}, outward normal.
        let b = (a + 1) % 3;
        let n = unit([q[b][1] - q[a][1], q[a][0] - q[b][0]]);
        for (ip, pt) in [q[a], q[b]].into_iter().enumerate() {
            for k in 0..2 {
                let row = 18 + 4 * a + 2 * ip + k;
                traction_row(&mut m[row * NC..(row + 1) * NC], a, pt, n, k, 1.0);
            }
        }
    }
    m
}

/// The 27 × 12 map (row-major) from edge-traction values to JM coefficients of the
/// normalised triangle q, exact for self-equilibrated tractions (the only ones it is applied
/// to: every patch step and every final field keeps each element self-equilibrated). None if
/// the triangle is degenerate.
///
/// It is the reference triangle's operator mapped by the affine map q = A q̂ (the JM element
/// is affine-equivalent under the double Piola transform σ = A σ̂ Aᵀ / det A): a divergence-free
/// field with continuous internal tractions maps to one, and by Nanson's formula the traction
/// on an edge maps as t = A t̂ |ê| / |e|. A few thousand flops instead of a 30 × 27 QR, which
/// matters on unstructured meshes where every element has its own shape. Triangles that are
/// clockwise or nearly flat take the least-squares solution of their own system.
fn jm_operator(q: &[[f64; 2]; 3]) -> Option<[f64; NC * NT]> {
    let (qr, gr) = reference_operator();
    // A [q̂1 − q̂0, q̂2 − q̂0] = [q1 − q0, q2 − q0].
    let d = |v: &[[f64; 2]; 3], i: usize| [v[i][0] - v[0][0], v[i][1] - v[0][1]];
    let (e1, e2, r1, r2) = (d(q, 1), d(q, 2), d(qr, 1), d(qr, 2));
    let rdet = r1[0] * r2[1] - r2[0] * r1[1];
    let a = [
        [
            (e1[0] * r2[1] - e2[0] * r1[1]) / rdet,
            (e2[0] * r1[0] - e1[0] * r2[0]) / rdet,
        ],
        [
            (e1[1] * r2[1] - e2[1] * r1[1]) / rdet,
            (e2[1] * r1[0] - e1[1] * r2[0]) / rdet,
        ],
    ];
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    if det < 1e-6 {
        return jm_operator_lstsq(q);
    }
    let b = [
        [a[1][1] / det, -a[0][1] / det],
        [-a[1][0] / det, a[0][0] / det],
    ];
    // Tractions: t̂ = (|e|/|ê|) B t per edge end (B = A⁻¹), so X = G_ref T.
    let len = |v: &[[f64; 2]; 3], l: usize| {
        let m = (l + 1) % 3;
        (v[m][0] - v[l][0]).hypot(v[m][1] - v[l][1])
    };
    let mut x = [0.0; NC * NT];
    for l in 0..3 {
        let s = len(q, l) / len(qr, l);
        for end in 0..2 {
            let c = 4 * l + 2 * end;
            for i in 0..NC {
                let (g0, g1) = (gr[i * NT + c], gr[i * NT + c + 1]);
                x[i * NT + c] = s * (g0 * b[0][0] + g1 * b[1][0]);
                x[i * NT + c + 1] = s * (g0 * b[0][1] + g1 * b[1][1]);
            }
        }
    }
    // Coefficients: σ(ξ) = M σ̂(B ξ) with M the Voigt form (xx, yy, xy) of A · Aᵀ / det A; the
    // gradient coefficients of a linear function map by Bᵀ.
    let [[p, qq], [r, ss]] = a;
    let m = [
        [p * p, qq * qq, 2.0 * p * qq],
        [r * r, ss * ss, 2.0 * r * ss],
        [p * r, qq * ss, p * ss + qq * r],
    ]
    .map(|row| row.map(|v| v / det));
    let mut out = [0.0; NC * NT];
    for sub in 0..3 {
        let o = 9 * sub;
        for s in 0..3 {
            let row = |k: usize| &x[(o + 3 * s + k) * NT..(o + 3 * s + k + 1) * NT];
            let (c0, c1, c2) = (row(0), row(1), row(2));
            // (L X) rows of component s: constant, ξ and η coefficients.
            let mut lx = [[0.0; NT]; 3];
            for c in 0..NT {
                lx[0][c] = c0[c];
                lx[1][c] = b[0][0] * c1[c] + b[1][0] * c2[c];
                lx[2][c] = b[0][1] * c1[c] + b[1][1] * c2[c];
            }
            for rr in 0..3 {
                let w = m[rr][s];
                if w == 0.0 {
                    continue;
                }
                for k in 0..3 {
                    let dst = &mut out[(o + 3 * rr + k) * NT..(o + 3 * rr + k + 1) * NT];
                    for c in 0..NT {
                        dst[c] += w * lx[k][c];
                    }
                }
            }
        }
    }
    Some(out)
}

/// The normalised equilateral triangle and its operator (least squares), once per process.
fn reference_operator() -> &'static ([[f64; 2]; 3], [f64; NC * NT]) {
    static REFERENCE: std::sync::OnceLock<([[f64; 2]; 3], [f64; NC * NT])> =
        std::sync::OnceLock::new();
    REFERENCE.get_or_init(|| {
        let (_, _, q) = local_frame(&[[0.0, 0.0], [1.0, 0.0], [0.5, 0.75f64.sqrt()]]);
        let g = jm_operator_lstsq(&q).expect("the equilateral JM system has rank 27");
        (q, g)
    })
}

/// [`jm_operator`] by the least-squares solution of the triangle's own [`jm_system`] (exact
/// for self-equilibrated tractions). None if the system is rank deficient.
fn jm_operator_lstsq(q: &[[f64; 2]; 3]) -> Option<[f64; NC * NT]> {
    let m = jm_system(q);
    let rhs: Vec<usize> = (18..30).collect();
    let x = lstsq_operator(m, 30, NC, &rhs)?;
    let mut out = [0.0; NC * NT];
    out.copy_from_slice(&x);
    Some(out)
}

/// For the m × n matrix `a` (row-major, m ≥ n, full column rank), the n × rhs.len()
/// matrix whose column c is argmin_x ‖a x − e_{rhs[c]}‖ (Householder QR). None if a is
/// numerically rank deficient.
fn lstsq_operator(a: Vec<f64>, m: usize, n: usize, rhs: &[usize]) -> Option<Vec<f64>> {
    // Column-major copy (contiguous columns for the reflections).
    let mut ac = vec![0.0; m * n];
    for i in 0..m {
        for j in 0..n {
            ac[j * m + i] = a[i * n + j];
        }
    }
    let mut vs = vec![0.0; m * n];
    let mut betas = vec![0.0; n];
    let mut rdiag_max: f64 = 0.0;
    for j in 0..n {
        let norm = ac[j * m + j..(j + 1) * m]
            .iter()
            .map(|x| x * x)
            .sum::<f64>()
            .sqrt();
        let alpha = if ac[j * m + j] > 0.0 { -norm } else { norm };
        let v = &mut vs[j * m..(j + 1) * m];
        v[j..].copy_from_slice(&ac[j * m + j..(j + 1) * m]);
        v[j] -= alpha;
        let vn2: f64 = v[j..].iter().map(|x| x * x).sum();
        let beta = if vn2 > 0.0 { 2.0 / vn2 } else { 0.0 };
        betas[j] = beta;
        let v = &vs[j * m + j..(j + 1) * m];
        for c in j..n {
            let col = &mut ac[c * m + j..(c + 1) * m];
            let d: f64 = v.iter().zip(col.iter()).map(|(x, y)| x * y).sum();
            for (y, x) in col.iter_mut().zip(v) {
                *y -= beta * d * x;
            }
        }
        rdiag_max = rdiag_max.max(ac[j * m + j].abs());
    }
    if !(0..n).all(|j| ac[j * m + j].abs() > 1e-10 * rdiag_max) {
        return None;
    }
    let nr = rhs.len();
    let mut out = vec![0.0; n * nr];
    let mut y = vec![0.0; m];
    for (c, &row) in rhs.iter().enumerate() {
        y.iter_mut().for_each(|v| *v = 0.0);
        y[row] = 1.0;
        for j in 0..n {
            let v = &vs[j * m + j..(j + 1) * m];
            let d: f64 = v.iter().zip(&y[j..]).map(|(a, b)| a * b).sum();
            for (yi, vi) in y[j..].iter_mut().zip(v) {
                *yi -= betas[j] * d * vi;
            }
        }
        for j in (0..n).rev() {
            let s: f64 = y[j]
                - (j + 1..n)
                    .map(|k| ac[k * m + j] * out[k * nr + c])
                    .sum::<f64>();
            out[j * nr + c] = s / ac[j * m + j];
        }
    }
    Some(out)
}

pub(super) fn apply_operator(g: &[f64; NC * NT], t: &[f64; NT]) -> [f64; NC] {
    let mut x = [0.0; NC];
    for (i, xi) in x.iter_mut().enumerate() {
        let row = &g[i * NT..(i + 1) * NT];
        *xi = row.iter().zip(t).map(|(a, b)| a * b).sum();
    }
    x
}

/// JM operators per triangle shape (normalised vertices, quantised key), at most `capacity`
/// of them (the recovery's, `sizes::capacities`).
pub(crate) struct ShapeCache {
    map: FastMap<[i64; 4], usize>,
    pub(super) ops: Vec<[f64; NC * NT]>,
    scratch: Option<Box<[f64; NC * NT]>>,
    capacity: usize,
}

impl Default for ShapeCache {
    fn default() -> ShapeCache {
        ShapeCache {
            map: Default::default(),
            ops: Vec::new(),
            scratch: None,
            capacity: MAX_SHAPES,
        }
    }
}

impl ShapeCache {
    fn key(q: &[[f64; 2]; 3]) -> [i64; 4] {
        [q[0][0], q[0][1], q[1][0], q[1][1]].map(|v| (v / SHAPE_QUANTUM).round() as i64)
    }

    /// Index of the cached operator of shape q (NONE past the capacity: no caching), or
    /// None if the local problem is singular.
    pub(super) fn index(&mut self, q: &[[f64; 2]; 3]) -> Option<usize> {
        let key = Self::key(q);
        if let Some(&i) = self.map.get(&key) {
            return Some(i);
        }
        let op = jm_operator(q)?;
        if self.ops.len() >= self.capacity {
            return Some(NONE);
        }
        self.ops.push(op);
        self.map.insert(key, self.ops.len() - 1);
        Some(self.ops.len() - 1)
    }

    /// At most `capacity` operators from now on (those held beyond it are kept).
    pub(super) fn set_capacity(&mut self, capacity: usize) {
        self.capacity = capacity;
    }

    /// The operator of index i (recomputed for shape q if i is NONE).
    pub(super) fn operator(&mut self, i: usize, q: &[[f64; 2]; 3]) -> &[f64; NC * NT] {
        if i != NONE {
            return &self.ops[i];
        }
        // Shapes past the capacity were checked non-singular in `index`.
        let op = jm_operator(q).unwrap_or([0.0; NC * NT]);
        self.scratch = Some(Box::new(op));
        self.scratch.as_ref().unwrap()
    }
}

/// The JM coefficients of every element from the edge tractions.
pub(super) fn jm_fields(
    mesh: &Mesh,
    topo: &Topology,
    trac: &[[[f64; 2]; 2]],
    cache: &mut ShapeCache,
    shape_of: &[usize],
    coef: &mut [[f64; NC]],
) {
    for (e, c) in coef.iter_mut().enumerate() {
        let (_, _, qv) = local_frame(&mesh.triangle_points(e));
        let t = element_tractions(topo, trac, mesh, e);
        *c = apply_operator(cache.operator(shape_of[e], &qv), &t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::equilibrate::energy::{dotv, norm};
    use crate::estimate::equilibrate::relaxation::equilibrium_constraints;
    use crate::fem::geometry::triangle_area;
    use crate::qp::dense::SymMatrix;
    use crate::testutil::Lcg;

    #[test]
    fn jm_local_solve_reproduces_equilibrated_tractions() {
        let p = [[0.1, 0.2], [1.3, 0.5], [0.4, 1.4]];
        let (_, _, q) = local_frame(&p);
        let g = jm_operator(&q).expect("rank 27");
        let cons = equilibrium_constraints(&q);
        let mut rng = Lcg(2024);
        for trial in 0..20 {
            let mut t = [0.0; NT];
            t.iter_mut().for_each(|v| *v = 1e7 * rng.next());
            // Project onto the self-equilibrated subspace: t − Cᵀ (C Cᵀ)⁻¹ C t.
            let mut cct = SymMatrix::new(3);
            for i in 0..3 {
                for j in 0..3 {
                    cct.set(i, j, dotv(&cons[i], &cons[j]));
                }
            }
            let mut y: Vec<f64> = (0..3).map(|i| dotv(&cons[i], &t)).collect();
            let unbalanced = norm(&y);
            cct.cholesky().unwrap().solve_in_place(&mut y);
            if trial % 2 == 0 {
                for i in 0..NT {
                    t[i] -= (0..3).map(|r| cons[r][i] * y[r]).sum::<f64>();
                }
            }
            let tmax = t.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let x = apply_operator(&g, &t);
            let mut worst_t: f64 = 0.0;
            let (mut worst_div, mut worst_jump): (f64, f64) = (0.0, 0.0);
            for a in 0..3 {
                let b = (a + 1) % 3;
                let n = unit([q[b][1] - q[a][1], q[a][0] - q[b][0]]);
                for (end, pt) in [q[a], q[b]].into_iter().enumerate() {
                    let tr = traction(&eval(&x, a, pt), n);
                    for k in 0..2 {
                        worst_t = worst_t.max((tr[k] - t[4 * a + 2 * end + k]).abs() / tmax);
                    }
                }
                let o = 9 * a;
                worst_div = worst_div.max((x[o + 1] + x[o + 8]).abs() / tmax);
                worst_div = worst_div.max((x[o + 7] + x[o + 5]).abs() / tmax);
                let n = unit([q[a][1], -q[a][0]]);
                for pt in [[0.0, 0.0], q[a]] {
                    let t1 = traction(&eval(&x, a, pt), n);
                    let t0 = traction(&eval(&x, (a + 2) % 3, pt), n);
                    worst_jump =
                        worst_jump.max((t1[0] - t0[0]).abs().max((t1[1] - t0[1]).abs()) / tmax);
                }
            }
            if trial % 2 == 0 {
                assert!(worst_t < 1e-12, "traction misfit {worst_t:e}");
                assert!(
                    worst_div < 1e-12 && worst_jump < 1e-12,
                    "{worst_div:e} {worst_jump:e}"
                );
            } else {
                // Unbalanced data cannot be matched by a divergence-free field.
                assert!(unbalanced > 1e5 && worst_t.max(worst_div).max(worst_jump) > 1e-3);
            }
        }
        // Divergence-free JM fields with zero traction vanish (rank 27, 9-dim kernel map).
        assert!(jm_operator(&q).is_some());
    }

    /// max over the 30 rows of |M x − (0, t)| / ‖x‖: the JM system's residual.
    fn misfit(q: &[[f64; 2]; 3], x: &[f64; NC], t: &[f64; NT]) -> f64 {
        let m = jm_system(q);
        let mut w: f64 = 0.0;
        for row in 0..30 {
            let rhs = if row >= 18 { t[row - 18] } else { 0.0 };
            let v: f64 = (0..NC).map(|c| m[row * NC + c] * x[c]).sum::<f64>() - rhs;
            w = w.max(v.abs());
        }
        w / norm(x)
    }

    /// The mapped operator solves each triangle's own JM system to round-off for
    /// self-equilibrated tractions (the JM element is affine-equivalent), for well-shaped,
    /// obtuse and slivery triangles, as the least-squares operator does; the two agree to the
    /// system's conditioning. A clockwise triangle takes the least squares itself.
    #[test]
    fn mapped_operator_equals_the_least_squares_one() {
        let mut rng = Lcg(7);
        let (mut worst, mut worst_residual): (f64, f64) = (0.0, 0.0);
        for trial in 0..200 {
            let stretch = [1.0, 0.2, 0.02][trial % 3];
            let p = [
                [rng.next(), stretch * rng.next()],
                [1.0 + rng.next(), stretch * rng.next()],
                [rng.next(), stretch * (1.0 + rng.next())],
            ];
            let (_, _, q) = local_frame(&p);
            if triangle_area(&q) <= 0.0 {
                continue;
            }
            let (g, gl) = (jm_operator(&q).unwrap(), jm_operator_lstsq(&q).unwrap());
            let cons = equilibrium_constraints(&q);
            // A basis of the self-equilibrated tractions: project unit vectors.
            let mut cct = SymMatrix::new(3);
            for i in 0..3 {
                for j in 0..3 {
                    cct.set(i, j, dotv(&cons[i], &cons[j]));
                }
            }
            let chol = cct.cholesky().unwrap();
            for unit_index in 0..NT {
                let mut t = [0.0; NT];
                t[unit_index] = 1.0;
                let mut y: Vec<f64> = (0..3).map(|i| dotv(&cons[i], &t)).collect();
                chol.solve_in_place(&mut y);
                for i in 0..NT {
                    t[i] -= (0..3).map(|r| cons[r][i] * y[r]).sum::<f64>();
                }
                let (x, xl) = (apply_operator(&g, &t), apply_operator(&gl, &t));
                let scale = norm(&xl).max(1.0);
                let diff: Vec<f64> = x.iter().zip(&xl).map(|(a, b)| a - b).collect();
                worst = worst.max(norm(&diff) / scale);
                worst_residual = worst_residual.max(misfit(&q, &x, &t));
                assert!(misfit(&q, &xl, &t) < 1e-14);
            }
        }
        assert!(
            worst_residual < 1e-14,
            "JM residual of the mapped operator: {worst_residual:e}"
        );
        assert!(worst < 1e-7, "mapped vs least squares: {worst:e}");
        let cw = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]];
        let (_, _, q) = local_frame(&cw);
        assert_eq!(jm_operator(&q), jm_operator_lstsq(&q));
    }
}
