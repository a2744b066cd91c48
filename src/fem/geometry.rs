//! Triangle geometry: signed area, barycentric coordinates, the local frame (barycentre,
//! diameter, normalised vertices) and unit vectors.

/// Signed area of the triangle p (positive when counter-clockwise).
pub fn triangle_area(p: &[[f64; 2]; 3]) -> f64 {
    0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
}

/// Barycentric coordinates of the point x in the triangle p.
pub fn barycentric(p: &[[f64; 2]; 3], x: [f64; 2]) -> [f64; 3] {
    let a2 = 2.0 * triangle_area(p);
    let mut lam = [0.0; 3];
    for a in 0..3 {
        let (j, k) = (p[(a + 1) % 3], p[(a + 2) % 3]);
        lam[a] = ((j[0] - x[0]) * (k[1] - x[1]) - (k[0] - x[0]) * (j[1] - x[1])) / a2;
    }
    lam
}

/// Barycentre c, diameter h and the normalised vertices q_a = (p_a − c)/h.
pub fn local_frame(p: &[[f64; 2]; 3]) -> ([f64; 2], f64, [[f64; 2]; 3]) {
    let c = [
        (p[0][0] + p[1][0] + p[2][0]) / 3.0,
        (p[0][1] + p[1][1] + p[2][1]) / 3.0,
    ];
    let mut h: f64 = 0.0;
    for a in 0..3 {
        let b = (a + 1) % 3;
        let (dx, dy) = (p[b][0] - p[a][0], p[b][1] - p[a][1]);
        h = h.max((dx * dx + dy * dy).sqrt());
    }
    let q = [0, 1, 2].map(|a| [(p[a][0] - c[0]) / h, (p[a][1] - c[1]) / h]);
    (c, h, q)
}

/// The unit vector along v.
pub fn unit(v: [f64; 2]) -> [f64; 2] {
    let l = v[0].hypot(v[1]);
    [v[0] / l, v[1] / l]
}
