//! Capability: the Hertz benchmark (examples/hertz): a steel half-cylinder pressed onto an
//! aluminium block, meshed by Gmsh, with the initial gap g₀(x) = R − √(R² − x²) from the
//! geometry. The contact half-width, the peak pressure and the pressure profile approach
//! Hertz's as the mesh is refined; the NNDD equals the monolithic solve on 1, 2 and 4 ranks;
//! the estimator's stresses stay exactly equilibrated on the curved contact side.

mod common;
use common::*;

#[path = "../jobs/hertz_fit.rs"]
mod hertz_fit;

use std::path::{Path, PathBuf};
use std::process::Command;

const GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");
const MATERIALS: [(f64, f64); 2] = [(7e10, 0.33), (2.1e11, 0.3)];

fn mesh(dir: &Path, level: u32) -> PathBuf {
    let out = dir.join(format!("hertz-{level}.msh"));
    let st = Command::new("gmsh")
        .args(["-2", "-format", "msh41", "-v", "1", "-setnumber", "level"])
        .arg(level.to_string())
        .arg(GEO)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("gmsh runs (jobs/setup installs it)");
    assert!(
        st.status.success(),
        "gmsh: {}",
        String::from_utf8_lossy(&st.stderr)
    );
    out
}

/// Solve examples/hertz/hertz.opts on `msh` (options after the file override it).
fn hertz(np: usize, msh: &Path, prefix: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "-options_file",
        OPTS,
        "-nndd_mesh",
        msh.to_str().unwrap(),
        "-nndd_output",
        prefix.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let out = mpirun(np, &args);
    assert!(
        out.status.success(),
        "nndd {args:?}:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    json(prefix)
}

fn fit(prefix: &Path) -> hertz_fit::HertzFit {
    let pts = h5(prefix, "/grids/contact/points");
    let x: Vec<f64> = pts.chunks(2).map(|p| p[0]).collect();
    let active: Vec<bool> = h5(prefix, "/steps/0/contact/active")
        .iter()
        .map(|&a| a > 0.5)
        .collect();
    hertz_fit::fit(
        &x,
        &h5(prefix, "/steps/0/contact/normal_force"),
        &h5(prefix, "/steps/0/contact/pressure"),
        &active,
        1.0,
        MATERIALS,
    )
}

#[test]
fn hertz_approaches_the_analytical_contact() {
    let dir = scratch("hertz-levels");
    let mut fits = Vec::new();
    for level in [1, 2] {
        let msh = mesh(&dir, level);
        let prefix = dir.join(format!("level{level}"));
        let j = hertz(2, &msh, &prefix, &["-nndd_estimate"]);
        let h = fit(&prefix);
        println!(
            "level {level}: a {:.5} vs {:.5} ({:.2} %), p0 {:.4e} vs {:.4e} ({:.2} %), L2 {:.3}",
            h.a_h,
            h.a,
            100.0 * h.a_err(),
            h.p0_h,
            h.p0,
            100.0 * h.p0_err(),
            h.l2
        );
        // The sum of the nodal forces is the summary's contact force.
        assert!((h.force - f(&j, "contact_force")).abs() < 1e-9 * h.force);
        // Exactly equilibrated stresses on the curved contact side too (the bound needs it).
        let res = &j["equilibrium_residuals"];
        for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
            assert!(f(res, key) < 1e-12, "{key}: {res}");
        }
        let est = &j["estimates"][0];
        assert!(f(est, "eta_nndd") < 1e-4 * f(est, "eta_glo"), "{est}");
        fits.push(h);
    }
    let (h1, h2) = (&fits[0], &fits[1]);
    assert!(
        h2.a_err() < h1.a_err() && h2.a_err() < 0.05,
        "a: {h1:?} → {h2:?}"
    );
    assert!(
        h2.p0_err() < h1.p0_err() && h2.p0_err() < 0.05,
        "p0: {h1:?} → {h2:?}"
    );
    assert!(h2.l2 < h1.l2, "L2: {} → {}", h1.l2, h2.l2);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn hertz_on_one_two_four_ranks_equals_the_monolithic_solve() {
    let dir = scratch("hertz-ranks");
    let msh = mesh(&dir, 1);
    let tight = ["-nndd_tol", "1e-11"];
    let mono = hertz(1, &msh, &dir.join("mono"), &["-nndd_solver", "monolithic"]);
    let em = f(&mono, "potential_energy");
    for np in [1, 2, 4] {
        let j = hertz(np, &msh, &dir.join(format!("n{np}")), &tight);
        let e = f(&j, "potential_energy");
        assert!(
            (e - em).abs() < 1e-9 * em.abs(),
            "{np} ranks: {e} vs monolithic {em}"
        );
        let it = f(&j, "iterations");
        // θ auto (hertz.opts names none): 17 iterations to 1e-11 on level 1 (θ = 0.25: 108).
        assert!((5.0..=40.0).contains(&it), "{np} ranks: {it} iterations");
        assert_eq!(j["contact_zone"], mono["contact_zone"], "{np} ranks");
    }
    std::fs::remove_dir_all(&dir).ok();
}
