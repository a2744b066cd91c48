//! Capability: the Hertz benchmark (examples/hertz): a steel half-cylinder pressed onto an
//! aluminium block, meshed by Gmsh, with the initial gap g₀(x) = R − √(R² − x²) from the
//! geometry. The contact half-width, the peak pressure and the pressure profile approach
//! Hertz's as the mesh is refined (four levels); the NNDD equals the monolithic solve on 1, 2
//! and 4 ranks; the estimator's stresses stay exactly equilibrated on the curved contact side
//! and η^glo bounds the error against the reference solution on the nested mesh.

mod common;
use common::*;

use std::path::{Path, PathBuf};

const GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");

fn mesh(dir: &Path, level: u32) -> PathBuf {
    gmsh_level(GEO, dir, "hertz", level)
}

/// Solve examples/hertz/hertz.opts on `msh` (options after the file override it).
fn hertz(np: usize, msh: &Path, prefix: &Path, extra: &[&str]) -> serde_json::Value {
    solve_meshed(np, OPTS, msh, prefix, extra)
}

#[test]
fn hertz_approaches_the_analytical_contact_and_the_estimate_bounds_the_error() {
    let dir = scratch("hertz-levels");
    let mut fits = Vec::new();
    for level in [0, 1, 2, 3] {
        let msh = mesh(&dir, level);
        let prefix = dir.join(format!("level{level}"));
        // Every level: the estimate against the reference solution on the mesh split 4x
        // (level 0 also along the NNDD, θ fixed so that there are many iterates).
        let j = hertz(
            2,
            &msh,
            &prefix,
            &["-nndd_estimate", "-nndd_reference_factor", "4"],
        );
        let along = (level == 0).then(|| {
            let extra = ["-nndd_estimate_every", "2", "-nndd_theta", "0.25"];
            hertz(
                2,
                &msh,
                &dir.join("along"),
                &[&["-nndd_reference_factor", "4"][..], &extra].concat(),
            )
        });
        let h = hertz_fit_of(&prefix);
        let est = j["estimates"].as_array().expect("estimates");
        let last = est.last().expect("an estimate");
        println!(
            "level {level}: a {:.5} vs {:.5} ({:.2} %), p0 {:.4e} vs {:.4e} ({:.2} %), L2 {:.3}, eta_glo {:.4e}, e_ref {:.4e}",
            h.a_h,
            h.a,
            100.0 * h.a_err(),
            h.p0_h,
            h.p0,
            100.0 * h.p0_err(),
            h.l2,
            f(last, "eta_glo"),
            f(last, "e_ref")
        );
        // Γc is drawn on body 1's side, the block's top y = 0.
        let pts = points(&prefix, "contact");
        assert!(
            pts.chunks(2).all(|p| p[1].abs() < 1e-12),
            "contact grid off y = 0"
        );
        // The sum of the nodal forces is the summary's contact force.
        assert!((h.force - f(&j, "contact_force")).abs() < 1e-9 * h.force);
        // Exactly equilibrated stresses on the curved contact side too (the bound needs it).
        let res = &j["equilibrium_residuals"];
        for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
            assert!(f(res, key) < 1e-12, "{key}: {res}");
        }
        // The bound against the nested reference solution.
        assert!(
            f(last, "eta_glo") >= f(last, "e_ref"),
            "level {level}: {last}"
        );
        assert!(f(last, "effectivity") < 1.5, "level {level}: {last}");
        assert!(f(last, "eta_nndd") < 1e-4 * f(last, "eta_glo"), "{last}");
        if let Some(a) = along {
            // At every estimated iterate the bound holds, and η^NNDD → 0 as the NNDD converges.
            let est = a["estimates"].as_array().expect("estimates");
            assert!(est.len() >= 5, "{} estimates", est.len());
            for e in est {
                assert!(f(e, "eta_glo") >= f(e, "e_ref"), "iterate: {e}");
            }
            let (first, end) = (f(&est[0], "eta_nndd"), f(&est[est.len() - 1], "eta_nndd"));
            assert!(end < 1e-3 * first, "eta_NNDD {first} → {end}");
        }
        fits.push(h);
    }
    for w in fits.windows(2) {
        let (h1, h2) = (&w[0], &w[1]);
        assert!(h2.a_err() < h1.a_err(), "a: {h1:?} → {h2:?}");
        assert!(h2.p0_err() < h1.p0_err(), "p0: {h1:?} → {h2:?}");
        assert!(h2.l2 < h1.l2, "L2: {} → {}", h1.l2, h2.l2);
    }
    let finest = fits.last().expect("four levels");
    assert!(
        finest.a_err() < 0.03 && finest.p0_err() < 0.03,
        "finest: {finest:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn hertz_on_one_two_four_ranks_equals_the_monolithic_solve() {
    let dir = scratch("hertz-ranks");
    let msh = mesh(&dir, 1);
    // With the estimate of the final iterate: the bodies differ in size, so on 2 and 4 ranks
    // part of the larger body's element work goes to the other body's ranks
    // (`estimate::share`), and the estimates must still be the one-rank ones.
    let tight = ["-nndd_tol", "1e-11", "-nndd_estimate"];
    let mono = hertz(1, &msh, &dir.join("mono"), &["-nndd_solver", "monolithic"]);
    let em = f(&mono, "potential_energy");
    let mut one: Option<serde_json::Value> = None;
    for np in [1, 2, 4] {
        let j = hertz(np, &msh, &dir.join(format!("n{np}")), &tight);
        let last =
            |j: &serde_json::Value| j["estimates"].as_array().unwrap().last().unwrap().clone();
        if let Some(base) = &one {
            let (a, b) = (last(&j), last(base));
            for key in ["eta_glo", "eta_fe", "eta_nndd"] {
                let d = ((f(&a, key) - f(&b, key)) / f(&b, "eta_glo")).abs();
                assert!(
                    d < 1e-9,
                    "{np} ranks: {key} differs from one rank's by {d:e}"
                );
            }
            let r = &j["equilibrium_residuals"];
            for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
                assert!(f(r, key) < 1e-10, "{np} ranks: residual {key} = {}", r[key]);
            }
        } else {
            one = Some(j.clone());
        }
        let e = f(&j, "potential_energy");
        assert!(
            (e - em).abs() < 1e-9 * em.abs(),
            "{np} ranks: {e} vs monolithic {em}"
        );
        let it = f(&j, "iterations");
        // θ auto (hertz.opts names none): 17 iterations to 1e-11 on level 1 (θ = 0.25: 108).
        assert!((5.0..=40.0).contains(&it), "{np} ranks: {it} iterations");
        assert_eq!(j["contact_zone"], mono["contact_zone"], "{np} ranks");
        // The curves match: the matching leaves them as they are.
        let curves = &j["contact_curves"];
        assert_eq!(curves["inserted"], serde_json::json!([0, 0]), "{curves}");
        assert_eq!(curves["moved"], serde_json::json!([0, 0]), "{curves}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Contact beyond the named curves is an error: with both contact curves narrower than the
/// contact zone (half-width 0.06 against Hertz's 0.08) the cylinder passes into the block
/// beyond them, where no contact condition holds; every boundary node is checked, so the run
/// fails (exit 2, the node named, nothing written) on 1 and 3 ranks alike instead of reporting
/// `converged` with `max_penetration` 0. With the example's curves (0.16) nothing penetrates:
/// no warning, `max_penetration` 0.
#[test]
fn contact_beyond_the_contact_curves_is_an_error() {
    let dir = scratch("hertz-short-arc");
    let short = dir.join("c0.06.msh");
    gmsh(GEO, &[("level", "1"), ("c", "0.06")], &[], &short);
    for np in [1, 3] {
        let line = fails_with(
            np,
            &["-options_file", OPTS, "-nndd_mesh", short.to_str().unwrap()],
            Some(2),
            &[
                "-nndd_contact: body 2's node",
                "off the contact curve 'cylinder_arc'",
                "inside body 1",
                "no results are written",
            ],
        );
        // 0.4 mm deep: a few per cent of the displacements, far beyond round-off.
        let depth: f64 = line
            .split(" is ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(depth > 1e-4, "{line}");
    }
    let msh = dir.join("c0.16.msh");
    gmsh(GEO, &[("level", "1"), ("c", "0.16")], &[], &msh);
    let j = hertz(2, &msh, &dir.join("c0.16"), &[]);
    assert_eq!(j["warnings"], serde_json::json!([]), "{j}");
    let worst = &j["contact_curves"]["max_penetration"];
    assert!(worst["relative"].as_f64().unwrap() < 1e-12, "{worst}");
    std::fs::remove_dir_all(&dir).ok();
}
