//! Capability: bodies meshed on their own, node to node (`-nndd_contact_discretisation
//! node_to_node`; the default couples such curves by mortar, tests/mortar.rs). The contact
//! curves need not match: nndd inserts each curve's nodes into the other
//! (src/problem/conform.rs) and takes Γc where they overlap.
//! - The contact patch test: a block pressed flat on a foundation, the two sides meshed with
//!   ratios 1.7 and 3 in both orders, gives a uniform contact pressure and the exact linear
//!   displacements.
//! - Hertz (examples/hertz-nonmatching, the cylinder's mesh 1.7 times the block's) approaches
//!   Hertz's contact half-width and peak pressure over four levels; NNDD = monolithic on 1, 2
//!   and 4 ranks; η^glo bounds the error with exactly equilibrated stresses; and the punch with
//!   rounded corners (examples/punch-nonmatching, ratio 3) likewise.
//! - Penetration is never silent: a solution passing through the other body beyond Γc is an
//!   error; curves that cannot face each other are refused with one line naming them.

mod common;
use common::patch::*;
use common::*;

use std::path::{Path, PathBuf};

const PUNCH_GEO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/punch-nonmatching/punch-nonmatching.geo"
);
const PUNCH_OPTS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/punch-nonmatching/punch-nonmatching.opts"
);

#[test]
fn the_contact_patch_test_is_passed_on_non_matching_meshes() {
    let dir = scratch("nm-patch");
    let p_exact = patch_pressure();
    for (n1, n2) in [(10u64, 17u64), (17, 10), (30, 10), (10, 30)] {
        let msh = dir.join(format!("patch-{n1}-{n2}.msh"));
        gmsh(
            PATCH,
            &[("n1", &n1.to_string()), ("n2", &n2.to_string())],
            &[],
            &msh,
        );
        // The discrete problem (the monolithic solve) to round-off; the NNDD to its tolerance.
        for (solver, limit) in [("monolithic", 1e-10), ("nndd", 1e-9)] {
            let prefix = dir.join(format!("{solver}-{n1}-{n2}"));
            let mut args = patch_args(&msh);
            args.extend(["-nndd_solver".into(), solver.into()]);
            args.extend(NODE_TO_NODE.map(String::from));
            let j = solve(2, &prefix, &strs(&args));
            let what = format!("{n1} and {n2} segments, {solver}");
            assert_eq!(j["converged"], true, "{what}");
            assert!(f(&j, "iterations") <= 40.0, "{what}: {}", j["iterations"]);
            let curves = &j["contact_curves"];
            // Every node of both curves is paired: at least the finer curve's nodes, at most
            // both curves' (their ends coincide).
            let pairs = curves["pairs"].as_u64().unwrap();
            assert!(pairs > n1.max(n2), "{what}: {curves}");
            assert!(pairs <= n1 + n2, "{what}: {curves}");
            assert_eq!(curves["nodes"], serde_json::json!([pairs, pairs]), "{what}");
            let (lo, hi) = assert_patch(&prefix, limit, &what);
            println!(
                "patch {n1}:{n2} {solver}: {} iterations, {} pairs (inserted {}, moved {}), pressure {:.12e} .. {:.12e} (exact {p_exact:.12e})",
                j["iterations"], pairs, curves["inserted"], curves["moved"], lo, hi
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

fn hertz_mesh(dir: &Path, level: u32) -> PathBuf {
    gmsh_level(HERTZ_NM_GEO, dir, "hertz-nm", level)
}

fn hertz(np: usize, msh: &Path, prefix: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = NODE_TO_NODE.to_vec();
    args.extend_from_slice(extra);
    solve_meshed(np, HERTZ_NM_OPTS, msh, prefix, &args)
}

/// The estimate of the final iterate bounds the error against the reference solution on the
/// nested mesh, with stresses equilibrated to round-off.
fn bounded(j: &serde_json::Value, what: &str) {
    let est = j["estimates"].as_array().expect("estimates");
    let last = est.last().expect("an estimate");
    assert!(
        f(last, "eta_glo") >= f(last, "e_ref"),
        "{what}: η^glo below e_ref: {last}"
    );
    assert!(f(last, "effectivity") < 1.6, "{what}: {last}");
    let res = &j["equilibrium_residuals"];
    for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
        assert!(f(res, key) < 1e-12, "{what}: {key}: {res}");
    }
}

#[test]
fn hertz_on_non_matching_meshes_approaches_the_analytical_contact() {
    let dir = scratch("nm-hertz-levels");
    let mut fits = Vec::new();
    for level in [1, 2, 3, 4] {
        let msh = hertz_mesh(&dir, level);
        let prefix = dir.join(format!("level{level}"));
        let extra: &[&str] = if level <= 2 {
            &["-nndd_estimate", "-nndd_reference_factor", "4"]
        } else {
            &[]
        };
        let j = hertz(2, &msh, &prefix, extra);
        let curves = &j["contact_curves"];
        assert!(
            curves["inserted"][1].as_u64().unwrap() > 0,
            "level {level}: the curves match already? {curves}"
        );
        let h = hertz_fit_of(&prefix);
        println!(
            "level {level}: {} pairs, a {:.5} vs {:.5} ({:.2} %), p0 {:.4e} vs {:.4e} ({:.2} %), {} iterations",
            curves["pairs"],
            h.a_h,
            h.a,
            100.0 * h.a_err(),
            h.p0_h,
            h.p0,
            100.0 * h.p0_err(),
            j["iterations"]
        );
        assert!((h.force - f(&j, "contact_force")).abs() < 1e-9 * h.force);
        if level <= 2 {
            bounded(&j, &format!("Hertz level {level}"));
        }
        fits.push(h);
    }
    // p0 and the profile converge; a_h is resolved to the pairs' spacing, which is irregular
    // (the block's nodes and the cylinder's, 1.7 times apart): within 5 % at every level.
    for w in fits.windows(2) {
        assert!(w[1].p0_err() < w[0].p0_err(), "p0: {:?} → {:?}", w[0], w[1]);
        assert!(w[1].l2 < w[0].l2, "L2: {:?} → {:?}", w[0], w[1]);
    }
    assert!(fits.iter().all(|h| h.a_err() < 0.05), "{fits:?}");
    let finest = fits.last().expect("four levels");
    assert!(
        finest.a_err() < 0.03 && finest.p0_err() < 0.03,
        "finest: {finest:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn non_matching_hertz_on_one_two_four_ranks_equals_the_monolithic_solve() {
    let dir = scratch("nm-hertz-ranks");
    let msh = hertz_mesh(&dir, 1);
    let mono = hertz(1, &msh, &dir.join("mono"), &["-nndd_solver", "monolithic"]);
    let em = f(&mono, "potential_energy");
    for np in [1, 2, 4] {
        let j = hertz(
            np,
            &msh,
            &dir.join(format!("n{np}")),
            &["-nndd_tol", "1e-11"],
        );
        let e = f(&j, "potential_energy");
        assert!(
            (e - em).abs() < 1e-9 * em.abs(),
            "{np} ranks: {e} vs monolithic {em}"
        );
        assert_eq!(j["contact_zone"], mono["contact_zone"], "{np} ranks");
        let (c, cm) = (&j["contact_curves"], &mono["contact_curves"]);
        for key in ["nodes", "pairs", "inserted", "moved"] {
            assert_eq!(c[key], cm[key], "{np} ranks: {key}");
        }
        assert!(f(&c["max_penetration"], "relative") < 1e-12, "{c}");
        let it = f(&j, "iterations");
        assert!((5.0..=40.0).contains(&it), "{np} ranks: {it} iterations");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_rounded_punch_on_non_matching_meshes_is_bounded_and_equals_the_monolithic_solve() {
    let dir = scratch("nm-punch");
    let msh = gmsh_level(PUNCH_GEO, &dir, "punch-nm", 1);
    let j = solve_meshed(
        2,
        PUNCH_OPTS,
        &msh,
        &dir.join("nndd"),
        &[
            "-nndd_estimate",
            "-nndd_reference_factor",
            "4",
            NODE_TO_NODE[0],
            NODE_TO_NODE[1],
        ],
    );
    bounded(&j, "punch");
    let curves = &j["contact_curves"];
    assert!(curves["inserted"][1].as_u64().unwrap() > 0, "{curves}");
    // The contact zone goes past the flat bottom (|x| ≤ 0.3) onto the rounded corners.
    let zone = &j["contact_zone"];
    assert!(zone[1].as_f64().unwrap() > 0.3, "{zone}");
    let mono = solve_meshed(
        3,
        PUNCH_OPTS,
        &msh,
        &dir.join("mono"),
        &[
            "-nndd_solver",
            "monolithic",
            NODE_TO_NODE[0],
            NODE_TO_NODE[1],
        ],
    );
    let (e, em) = (f(&j, "potential_energy"), f(&mono, "potential_energy"));
    assert!((e - em).abs() < 1e-8 * em.abs(), "{e} vs monolithic {em}");
    assert_eq!(j["contact_zone"], mono["contact_zone"]);
    std::fs::remove_dir_all(&dir).ok();
}

/// The cylinder's named arc (half-width 0.05) narrower than the contact zone (0.08) while the
/// block's curve is wide: the cylinder passes through the block's curve beyond Γc, an error
/// (exit 2, no results) naming the deepest node, the cylinder's beyond its arc; on 1 and 3
/// ranks alike.
#[test]
fn a_penetration_beyond_the_contact_curves_is_an_error() {
    let dir = scratch("nm-penetration");
    let msh = dir.join("short-arc.msh");
    gmsh(HERTZ_NM_GEO, &[("level", "1"), ("ca", "0.05")], &[], &msh);
    for np in [1, 3] {
        // (fails_with checks that nothing was written.)
        fails_with(
            np,
            &[
                "-options_file",
                HERTZ_NM_OPTS,
                "-nndd_mesh",
                msh.to_str().unwrap(),
                NODE_TO_NODE[0],
                NODE_TO_NODE[1],
            ],
            Some(2),
            &[
                "-nndd_contact: body 2's node",
                "off the contact curve 'cylinder_arc'",
                "inside body 1",
                "no results are written",
            ],
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Curves that cannot face each other: the block shifted sideways past the foundation's end,
/// so that no node of either curve projects onto the other.
#[test]
fn curves_that_cannot_face_each_other_are_refused() {
    let dir = scratch("nm-apart");
    let msh = dir.join("apart.msh");
    gmsh(PATCH, &[("dx", "2")], &[], &msh);
    for np in [1, 2] {
        let args = patch_args(&msh);
        refused_with_line(np, &strs(&args));
    }
    std::fs::remove_dir_all(&dir).ok();
}

fn refused_with_line(np: usize, args: &[&str]) {
    let err = fails_with(
        np,
        args,
        Some(1),
        &["-nndd_contact: the curves 'top1' and 'bottom2' cannot face each other"],
    );
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("nndd:")).collect();
    assert_eq!(lines.len(), 1, "{err}");
}
