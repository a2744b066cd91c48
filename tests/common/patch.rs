//! The contact patch test (tests/nonmatching/patch.geo): a block [0, 1] × [0, 0.5] (body 2)
//! pressed by its lid onto a foundation [0, 1] × [−1, 0] (body 1), the foundation's top meshed
//! with n1 segments and the block's bottom with n2. A uniform pressure between flat sides is
//! exact for P1: σ_yy = −p, σ_xx = 0 in both bodies.

use std::path::Path;

use super::{field, points};

pub const PATCH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/nonmatching/patch.geo");

/// The patch test's materials and the lid's displacement.
pub const PATCH_E: [f64; 2] = [1e9, 3e9];
pub const PATCH_NU: [f64; 2] = [0.3, 0.25];
pub const PATCH_PRESS: f64 = -1e-3;

/// The options of the patch test on the mesh `msh`.
pub fn patch_args(msh: &Path) -> Vec<String> {
    let mut a: Vec<String> = [
        "-nndd_mesh",
        msh.to_str().unwrap(),
        "-nndd_contact",
        "top1,bottom2",
        "-nndd_bc_base_uy",
        "0",
        "-nndd_bc_left1_ux",
        "0",
        "-nndd_bc_left2_ux",
        "0",
        "-nndd_tol",
        "1e-12",
        "-nndd_bc_lid_uy",
    ]
    .map(String::from)
    .to_vec();
    a.push(PATCH_PRESS.to_string());
    for k in 0..2 {
        a.extend([
            format!("-nndd_body{}_E", k + 1),
            PATCH_E[k].to_string(),
            format!("-nndd_body{}_nu", k + 1),
            PATCH_NU[k].to_string(),
        ]);
    }
    a
}

pub fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// The exact contact pressure: the lid's displacement δ = (1 − ν₁²)p/E₁ · 1 + (1 − ν₂²)p/E₂ · 0.5
/// gives p.
pub fn patch_pressure() -> f64 {
    let flex = |k: usize, h: f64| (1.0 - PATCH_NU[k] * PATCH_NU[k]) / PATCH_E[k] * h;
    -PATCH_PRESS / (flex(0, 1.0) + flex(1, 0.5))
}

/// A uniform pressure p between the flat sides, plane strain: σ_yy = −p, σ_xx = 0 in both
/// bodies, so ε_xx = ν(1 + ν)p/E and ε_yy = −(1 − ν²)p/E; the foundation's base is at y = −1
/// (u_y = 0), both bodies' left sides at x = 0 (u_x = 0), the lid at y = 0.5.
pub fn exact(alpha: usize, p: f64, x: [f64; 2]) -> [f64; 2] {
    let exx = |k: usize| PATCH_NU[k] * (1.0 + PATCH_NU[k]) * p / PATCH_E[k];
    let eyy = |k: usize| -(1.0 - PATCH_NU[k] * PATCH_NU[k]) * p / PATCH_E[k];
    match alpha {
        1 => [exx(0) * x[0], eyy(0) * (x[1] + 1.0)],
        _ => [exx(1) * x[0], eyy(0) + eyy(1) * x[1]],
    }
}

/// The run at `prefix` passes the patch test to `limit`: the contact pressure uniform and
/// the exact one, both bodies' displacements the exact fields (relative to the lid's).
/// Returns the pressure's range.
pub fn assert_patch(prefix: &Path, limit: f64, what: &str) -> (f64, f64) {
    let p_exact = patch_pressure();
    let pressure = field(prefix, "contact", "pressure");
    let (lo, hi) = pressure
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &x| (a.min(x), b.max(x)));
    assert!((hi - lo) / hi < limit, "{what}: pressure {lo} .. {hi}");
    assert!(
        (hi - p_exact).abs() < limit * p_exact,
        "{what}: {hi} vs {p_exact}"
    );
    for alpha in [1, 2] {
        let body = format!("body{alpha}");
        let pts = points(prefix, &body);
        let u = field(prefix, &body, "displacement");
        let mut worst = 0.0_f64;
        for (x, u) in pts.chunks(2).zip(u.chunks(3)) {
            let e = exact(alpha, p_exact, [x[0], x[1]]);
            worst = worst.max((u[0] - e[0]).abs()).max((u[1] - e[1]).abs());
        }
        assert!(
            worst < limit * PATCH_PRESS.abs(),
            "{what}: body {alpha}'s displacement off the exact field by {worst:e}"
        );
    }
    (lo, hi)
}
