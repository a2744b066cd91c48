//! Capability: the contact step's QP by the primal–dual active-set method (the default),
//! warm-started from the previous contact set, gives Clarabel's solution: the same interface
//! position λ, contact set and energy to 1e−10 on `paper` at stiffness ratios 1000 … 0.001,
//! on Hertz and on the pin; once the contact set has settled it certifies in one step; where
//! it does not certify (here: one step allowed from a cold start) Clarabel solves the QP and
//! the history says so.

mod common;
use common::*;

use std::path::Path;

const HERTZ_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const HERTZ_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");
const PIN_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.geo");
const PIN_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.opts");

/// Clarabel at every contact step, from scratch (no warm start).
const CLARABEL: [&str; 4] = ["-nndd_qp_solver", "clarabel", "-nndd_qp_warm_start", "0"];

fn solvers(j: &serde_json::Value) -> Vec<(String, u64)> {
    j["history"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| {
            (
                h["qp_solver"].as_str().unwrap().to_string(),
                h["qp_iterations"].as_u64().unwrap(),
            )
        })
        .collect()
}

/// The run at `a` (the active-set method) and at `b` (Clarabel) end at the same λ, contact set
/// and energy.
fn same_solution(a: &Path, ja: &serde_json::Value, b: &Path, jb: &serde_json::Value, what: &str) {
    let (la, lb) = (field(a, "contact", "lambda"), field(b, "contact", "lambda"));
    let d = rel_max_diff(&la, &lb);
    assert!(d < 1e-10, "{what}: λ differs by {d:e}");
    assert_eq!(
        field(a, "contact", "active"),
        field(b, "contact", "active"),
        "{what}: contact sets"
    );
    let (ea, eb) = (f(ja, "potential_energy"), f(jb, "potential_energy"));
    assert!(
        ((ea - eb) / eb).abs() < 1e-10,
        "{what}: energy {ea} vs {eb}"
    );
    assert_eq!(ja["iterations"], jb["iterations"], "{what}: iterations");
    for j in [ja, jb] {
        assert!(f(j, "qp_kkt_residual") < 1e-12, "{what}: KKT residual");
    }
    // Every step of the active-set run certified, without Clarabel; every step of the other
    // was Clarabel's.
    let sa = solvers(ja);
    assert!(sa.iter().all(|(s, _)| s == "active_set"), "{what}: {sa:?}");
    assert!(solvers(jb).iter().all(|(s, _)| s == "clarabel"), "{what}");
    // The warm start: one step wherever the contact set did not change, and most steps.
    let ones = sa.iter().filter(|(_, k)| *k == 1).count();
    assert!(
        ones * 2 > sa.len(),
        "{what}: warm start rarely certified: {sa:?}"
    );
    assert!(sa.iter().all(|(_, k)| *k <= 10), "{what}: {sa:?}");
}

fn compare(dir: &Path, name: &str, np: usize, args: &[&str]) {
    let (a, b) = (
        dir.join(format!("{name}-as")),
        dir.join(format!("{name}-cl")),
    );
    let run = |prefix: &Path, extra: &[&str]| {
        let mut all = args.to_vec();
        all.extend(["-nndd_output", prefix.to_str().unwrap()]);
        all.extend(extra);
        let out = mpirun(np, &all);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        json(prefix)
    };
    let ja = run(&a, &[]);
    let jb = run(&b, &CLARABEL);
    same_solution(&a, &ja, &b, &jb, name);
}

#[test]
fn active_set_equals_clarabel_on_paper_at_every_stiffness_ratio() {
    let dir = scratch("qp-paper");
    // E¹/E² = 1000, 1, 0.001 (body 2 keeps E = 2.1e11).
    for (tag, e1) in [("1000", "2.1e14"), ("1", "2.1e11"), ("0.001", "2.1e8")] {
        let mut args = PAPER_16_TIGHT.to_vec();
        args.extend(["-nndd_body1_E", e1]);
        compare(&dir, &format!("ratio{tag}"), 2, &args);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn active_set_equals_clarabel_on_hertz_and_the_pin() {
    let dir = scratch("qp-curved");
    for (name, geo, opts, np) in [
        ("hertz", HERTZ_GEO, HERTZ_OPTS, 2),
        ("pin", PIN_GEO, PIN_OPTS, 3),
    ] {
        let msh = gmsh_level(geo, &dir, name, 2);
        let args = [
            "-options_file",
            opts,
            "-nndd_mesh",
            msh.to_str().unwrap(),
            "-nndd_tol",
            "1e-11",
        ];
        compare(&dir, name, np, &args);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// One active-set step from the unconstrained solution's contact set does not certify on
/// `paper`: Clarabel then solves every contact step, the history and the monitor say so, and
/// the answer is the same.
#[test]
fn a_step_that_does_not_certify_falls_back_to_clarabel() {
    let dir = scratch("qp-fallback");
    let base = PAPER_16_TIGHT;
    let (a, b) = (dir.join("default"), dir.join("fallback"));
    let ja = solve(2, &a, &base);
    let mut args = base.to_vec();
    args.extend(["-nndd_qp_max_it", "1", "-nndd_qp_warm_start", "0"]);
    args.extend(["-nndd_monitor", "-nndd_output", b.to_str().unwrap()]);
    let out = mpirun(2, &args);
    assert!(out.status.success());
    let jb = json(&b);
    let sb = solvers(&jb);
    assert!(
        sb.iter().all(|(s, k)| s == "clarabel" && *k > 0),
        "every step fell back: {sb:?}"
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines = stdout
        .lines()
        .filter(|l| l.contains(" NNDD dlambda"))
        .count();
    let marked = stdout.lines().filter(|l| l.contains("(clarabel)")).count();
    assert_eq!(
        marked, lines,
        "the monitor marks Clarabel's steps:\n{stdout}"
    );
    let d = rel_max_diff(
        &field(&a, "contact", "lambda"),
        &field(&b, "contact", "lambda"),
    );
    assert!(d < 1e-10, "λ differs by {d:e}");
    assert_eq!(ja["iterations"], jb["iterations"]);
    std::fs::remove_dir_all(&dir).ok();
}
