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

/// Contact beyond the named curves is said: with the paired arc narrower than the contact zone
/// (half-width 0.06 against Hertz's 0.08) the zone reaches the ends of Γc, where the block and
/// the cylinder go on side by side, and the run warns (exit 0, the line on stderr and in the
/// summary's `warnings`); with the example's arc (0.16) it does not.
#[test]
fn a_zone_that_reaches_the_end_of_the_contact_curves_is_said() {
    let dir = scratch("hertz-short-arc");
    let warned = |c: &str| {
        let msh = dir.join(format!("c{c}.msh"));
        gmsh(GEO, &[("level", "1"), ("c", c)], &[], &msh);
        let j = hertz(2, &msh, &dir.join(format!("c{c}")), &[]);
        let w: Vec<String> = j["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap().to_string())
            .collect();
        (j, w)
    };
    let (j, w) = warned("0.06");
    assert_eq!(j["contact_zone"], serde_json::json!([-0.06, 0.06]), "{j}");
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("reaches the end of the contact curves at (-6.000000e-2, 0.000000e0)"),
        "{w:?}"
    );
    let (_, w) = warned("0.16");
    assert!(w.is_empty(), "{w:?}");
    std::fs::remove_dir_all(&dir).ok();
}
