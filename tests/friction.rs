//! Capability: friction at the contact (`-nndd_friction tresca|coulomb`, docs/method.md §9).
//! - The Tresca patch test: a block pressed on a foundation and pulled far beyond the
//!   threshold slides at every pair, its shear the threshold g at every node to 1e−10, on
//!   matching and non-matching meshes, NNDD and monolithic alike.
//! - μ = 0 gives the frictionless answer: to round-off from the monolithic solve, to the
//!   NNDD's tolerance from the NNDD.
//! - The NNDD with Coulomb friction equals the monolithic solve on 1, 2 and 3 ranks (the
//!   Hertz cylinder pushed sideways, the pin pushed sideways in its groove: curved, turning
//!   tangents), and records its Coulomb fixed points.
//! - Cattaneo–Mindlin at level 2: the stick zone and the peak shear against the formulas.
//! - The estimates with friction bound the error (e_ref, r = 4) at converged and unconverged
//!   iterates, Coulomb and Tresca, on 1, 2 and 3 ranks; an adaptive run with friction reaches
//!   its tolerance; a frictional run continues from its restart point.
//! - Bad input is refused in one line naming the option.

mod common;
use common::patch::*;
use common::*;

#[allow(dead_code)]
#[path = "../jobs/cattaneo_formula.rs"]
mod cattaneo_formula;

use std::path::{Path, PathBuf};

const HERTZ_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const HERTZ_FRICTION: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/hertz/hertz-friction.opts"
);
const HERTZ_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");
const PIN_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.geo");
const PIN_FRICTION: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/pin/pin-friction.opts"
);

/// The patch test's block pulled sideways by its lid (its left side free), Tresca `g`.
fn sliding_patch_args(msh: &Path, g: f64, pull: f64) -> Vec<String> {
    let mut args = patch_args(msh);
    // The block's left side is held in x by the patch test; here only its lid is.
    let at = args.iter().position(|a| a == "-nndd_bc_left2_ux").unwrap();
    args.drain(at..at + 2);
    args.extend([
        "-nndd_bc_lid_ux".into(),
        pull.to_string(),
        "-nndd_friction".into(),
        "tresca".into(),
        "-nndd_friction_threshold".into(),
        g.to_string(),
    ]);
    args
}

#[test]
fn a_block_pulled_beyond_the_tresca_threshold_slides_at_the_threshold_everywhere() {
    let dir = scratch("fr-patch");
    let g = 0.1 * patch_pressure();
    for (n1, n2) in [(10u64, 10u64), (10, 17), (30, 10)] {
        let msh = dir.join(format!("patch-{n1}-{n2}.msh"));
        gmsh(
            PATCH,
            &[("n1", &n1.to_string()), ("n2", &n2.to_string())],
            &[],
            &msh,
        );
        let mut energies = Vec::new();
        for solver in ["monolithic", "nndd"] {
            let prefix = dir.join(format!("{solver}-{n1}-{n2}"));
            let mut args = sliding_patch_args(&msh, g, 1e-2);
            args.extend(["-nndd_solver".into(), solver.into()]);
            let j = solve(2, &prefix, &strs(&args));
            let what = format!("{n1}:{n2} {solver}");
            assert_eq!(j["converged"], true, "{what}");
            let c = &j["contact"];
            let pairs = j["contact_curves"]["pairs"].as_u64().unwrap();
            assert_eq!(c["friction"], "tresca", "{what}");
            assert_eq!(c["stick_nodes"], 0, "{what}: {c}");
            // Every pair slips (an end pair the block's tilt opens aside).
            let slipping = c["slip_nodes"].as_u64().unwrap();
            assert!(slipping + 1 >= pairs, "{what}: {c}");
            // Body 2 is dragged back (−x) by the foundation: shear −g at every slipping node.
            let state = field(&prefix, "contact", "contact_state");
            let shear = field(&prefix, "contact", "shear");
            let worst = shear
                .iter()
                .zip(&state)
                .filter(|(_, &s)| s == 2.0)
                .map(|(t, _)| (t + g).abs() / g)
                .fold(0.0_f64, f64::max);
            assert!(
                worst < 1e-10,
                "{what}: shear off -g by {worst:e} (relative)"
            );
            // Body 1 slips back (−x) relative to the block: w_t = u¹_t − u²_t < 0.
            let slip = field(&prefix, "contact", "slip");
            assert!(slip.iter().all(|&s| s < 0.0), "{what}: slip {slip:?}");
            energies.push(f(&j, "potential_energy"));
            println!(
                "tresca patch {n1}:{n2} {solver}: {slipping} of {pairs} pairs slipping, shear = -g to {worst:.1e}, {} iterations",
                j["iterations"]
            );
        }
        let rel = (energies[0] - energies[1]).abs() / energies[0].abs();
        assert!(rel < 1e-9, "{n1}:{n2}: energies {energies:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

fn hertz_mesh(dir: &Path, level: u32) -> PathBuf {
    gmsh_level(HERTZ_GEO, dir, "hertz", level)
}

#[test]
fn a_zero_friction_coefficient_gives_the_frictionless_answer() {
    let dir = scratch("fr-zero");
    let msh = hertz_mesh(&dir, 1);
    // The frictional machinery (2m interface rows, the frictional QP) with μ = 0 against the
    // frictionless run: the monolithic solves to round-off, the NNDD to its tolerance.
    for (solver, limit) in [("monolithic", 1e-12), ("nndd", 1e-8)] {
        let run = |name: &str, extra: &[&str]| {
            let prefix = dir.join(format!("{solver}-{name}"));
            let mut args = vec!["-nndd_solver", solver, "-nndd_tol", "1e-10"];
            args.extend_from_slice(extra);
            let j = solve_meshed(2, HERTZ_OPTS, &msh, &prefix, &args);
            (j, prefix)
        };
        let (a, pa) = run("none", &[]);
        let (b, pb) = run(
            "mu0",
            &[
                "-nndd_friction",
                "coulomb",
                "-nndd_friction_coefficient",
                "0",
            ],
        );
        let energy = (f(&a, "potential_energy") - f(&b, "potential_energy")).abs()
            / f(&a, "potential_energy").abs();
        let pressure = rel_max_diff(
            &field(&pa, "contact", "pressure"),
            &field(&pb, "contact", "pressure"),
        );
        let lambda = rel_max_diff(
            &field(&pa, "contact", "lambda"),
            &field(&pb, "contact", "lambda"),
        );
        println!("mu = 0, {solver}: energy {energy:.1e}, pressure {pressure:.1e}, lambda {lambda:.1e} (relative)");
        assert!(energy < limit, "{solver}: energy {energy:e}");
        assert!(pressure < limit * 100.0, "{solver}: pressure {pressure:e}");
        assert!(lambda < limit * 100.0, "{solver}: lambda {lambda:e}");
        let c = &b["contact"];
        assert_eq!(
            c["stick_nodes"], 0,
            "{solver}: nothing sticks at mu = 0: {c}"
        );
        assert_eq!(f(c, "tangential_force"), 0.0, "{solver}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The NNDD on 1, 2 and 3 ranks and the monolithic solve agree with friction: energy and
/// the Γc tractions; the Coulomb fixed points are in the history.
fn ranks_agree(dir: &Path, name: &str, opts: &str, msh: &Path, extra: &[&str]) {
    let mut args = vec!["-nndd_tol", "1e-11", "-nndd_force_tol", "1e-11"];
    args.extend_from_slice(extra);
    let reference = dir.join(format!("{name}-monolithic"));
    let mut m_args = args.clone();
    m_args.extend(["-nndd_solver", "monolithic"]);
    let m = solve_meshed(2, opts, msh, &reference, &m_args);
    let c = &m["contact"];
    assert!(
        f(c, "stick_nodes") > 0.0 && f(c, "slip_nodes") > 0.0,
        "{name}: partial slip: {c}"
    );
    let shear_m = field(&reference, "contact", "shear");
    let pressure_m = field(&reference, "contact", "pressure");
    for np in [1, 2, 3] {
        let prefix = dir.join(format!("{name}-nndd-{np}"));
        let j = solve_meshed(np, opts, msh, &prefix, &args);
        assert_eq!(j["converged"], true, "{name} on {np}");
        let energy = (f(&j, "potential_energy") - f(&m, "potential_energy")).abs()
            / f(&m, "potential_energy").abs();
        let shear = rel_max_diff(&field(&prefix, "contact", "shear"), &shear_m);
        let pressure = rel_max_diff(&field(&prefix, "contact", "pressure"), &pressure_m);
        let coulomb: Vec<u64> = j["history"]
            .as_array()
            .unwrap()
            .iter()
            .map(|h| h["coulomb_iterations"].as_u64().unwrap_or(0))
            .collect();
        println!(
            "{name} on {np} rank(s): {} iterations, energy {energy:.1e}, shear {shear:.1e}, pressure {pressure:.1e} off the monolithic; Coulomb solves per contact step {:?}",
            j["iterations"],
            &coulomb[..coulomb.len().min(12)]
        );
        assert!(energy < 1e-9, "{name} on {np}: energy {energy:e}");
        assert!(shear < 1e-7, "{name} on {np}: shear {shear:e}");
        assert!(pressure < 1e-7, "{name} on {np}: pressure {pressure:e}");
        assert!(coulomb.iter().all(|&k| k >= 1), "{name}: {coulomb:?}");
        assert_eq!(
            j["contact"]["stick_nodes"], c["stick_nodes"],
            "{name} on {np}"
        );
    }
}

#[test]
fn the_nndd_with_friction_equals_the_monolithic_solve_on_1_2_and_3_ranks() {
    let dir = scratch("fr-ranks");
    let hertz = hertz_mesh(&dir, 1);
    ranks_agree(&dir, "hertz", HERTZ_FRICTION, &hertz, &[]);
    let pin = gmsh_level(PIN_GEO, &dir, "pin", 1);
    ranks_agree(&dir, "pin", PIN_FRICTION, &pin, &[]);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn cattaneo_mindlin_partial_slip_at_level_2() {
    let dir = scratch("fr-cattaneo");
    let msh = hertz_mesh(&dir, 2);
    let prefix = dir.join("cattaneo");
    let j = solve_meshed(2, HERTZ_FRICTION, &msh, &prefix, &[]);
    let c = &j["contact"];
    let (p, q) = (f(c, "normal_force"), f(c, "tangential_force"));
    let formula = cattaneo_formula::cattaneo(p, q, 0.3, 1.0, 2.1e11, 0.3);
    let pts = points(&prefix, "contact");
    let x: Vec<f64> = pts.chunks(2).map(|p| p[0]).collect();
    let got = cattaneo_formula::measure(
        &x,
        &field(&prefix, "contact", "contact_state"),
        &field(&prefix, "contact", "shear"),
    );
    let ratio = q.abs() / (0.3 * p);
    let err = |a: f64, b: f64| (a - b).abs() / b;
    println!(
        "Cattaneo level 2, Q/(mu P) = {ratio:.3}: a {:.5} (formula {:.5}), c {:.5} (formula {:.5}), peak shear {:.4e} (formula {:.4e}), stick zone centred at {:.2e}",
        got.a, formula.a, got.c, formula.c, got.peak_shear, formula.peak_shear, got.stick_centre
    );
    assert!((0.3..0.8).contains(&ratio), "partial slip: {ratio}");
    assert!(err(got.a, formula.a) < 0.05, "a");
    assert!(err(got.c, formula.c) < 0.05, "c");
    assert!(err(got.peak_shear, formula.peak_shear) < 0.15, "peak shear");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_friction_input_is_refused_in_one_line() {
    let dir = scratch("fr-bad");
    let msh = hertz_mesh(&dir, 1);
    let m = msh.to_str().unwrap();
    let base = ["-options_file", HERTZ_FRICTION, "-nndd_mesh", m];
    let with = |extra: &[&'static str]| {
        let mut a: Vec<&str> = base.to_vec();
        a.extend_from_slice(extra);
        a
    };
    refused(
        2,
        &with(&["-nndd_friction_coefficient", "-0.1"]),
        "-nndd_friction_coefficient",
    );
    refused(
        2,
        &with(&["-nndd_friction", "tresca", "-nndd_friction_threshold", "-5"]),
        "-nndd_friction_threshold",
    );
    refused(
        2,
        &with(&["-nndd_friction_threshold", "1e6"]),
        "-nndd_friction_threshold",
    );
    refused(
        2,
        &with(&[
            "-nndd_friction",
            "tresca",
            "-nndd_friction_coefficient",
            "0.3",
        ]),
        "-nndd_friction_coefficient",
    );
    refused(
        2,
        &[
            "-nndd_mesh",
            m,
            "-nndd_contact",
            "block_top,cylinder_arc",
            "-nndd_bc_base_uy",
            "0",
            "-nndd_bc_base_ux",
            "0",
            "-nndd_bc_lid_uy",
            "-1e-3",
            "-nndd_bc_lid_ux",
            "0",
            "-nndd_friction",
            "coulomb",
        ],
        "-nndd_friction coulomb",
    );
    refused(
        2,
        &with(&["-nndd_estimate", "-nndd_stop", "balanced"]),
        "-nndd_stop balanced",
    );
    // The estimates with friction on a curved Γc (the pin's groove).
    let pin = gmsh_level(PIN_GEO, &dir, "pin", 1);
    refused(
        2,
        &[
            "-options_file",
            PIN_FRICTION,
            "-nndd_mesh",
            pin.to_str().unwrap(),
            "-nndd_estimate",
        ],
        "-nndd_estimate",
    );
    refused(2, &with(&["-nndd_friction", "sticky"]), "-nndd_friction");
    refused(
        2,
        &with(&["-nndd_contact_discretisation", "mortar"]),
        "-nndd_contact_discretisation mortar",
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_frictional_run_continues_from_its_restart_point() {
    let dir = scratch("fr-restart");
    let msh = hertz_mesh(&dir, 1);
    let straight = solve_meshed(2, HERTZ_FRICTION, &msh, &dir.join("straight"), &[]);
    let first = dir.join("first");
    let out = mpirun(
        2,
        &[
            "-options_file",
            HERTZ_FRICTION,
            "-nndd_mesh",
            msh.to_str().unwrap(),
            "-nndd_output",
            first.to_str().unwrap(),
            "-nndd_checkpoint_every",
            "5",
            "-nndd_max_it",
            "8",
        ],
    );
    // (the iteration limit reached: exit 3, a restart point after iteration 5)
    assert_eq!(out.status.code(), Some(3));
    let point = format!("{}.checkpoint.json", first.display());
    let resumed = solve_meshed(
        2,
        HERTZ_FRICTION,
        &msh,
        &dir.join("resumed"),
        &["-nndd_restart", &point],
    );
    assert_eq!(resumed["converged"], true);
    assert_eq!(resumed["iterations"], straight["iterations"]);
    let de = (f(&resumed, "potential_energy") - f(&straight, "potential_energy")).abs()
        / f(&straight, "potential_energy").abs();
    assert!(de < 1e-12, "energy {de:e}");
    assert_eq!(
        resumed["contact"]["stick_nodes"],
        straight["contact"]["stick_nodes"]
    );
    // Another coefficient is another problem.
    let m = msh.to_str().unwrap();
    let line = fails_with(
        2,
        &[
            "-options_file",
            HERTZ_FRICTION,
            "-nndd_mesh",
            m,
            "-nndd_friction_coefficient",
            "0.2",
            "-nndd_restart",
            &point,
        ],
        Some(1),
        &[
            "-nndd_restart",
            "friction is coulomb 0.3, this run's coulomb 0.2",
        ],
    );
    println!("{line}");
    std::fs::remove_dir_all(&dir).ok();
}

/// η^glo bounds the error of frictional iterates, converged and not, Coulomb and Tresca,
/// with exactly equilibrated stresses; its split is consistent; every rank count agrees.
#[test]
fn the_estimates_bound_the_error_with_friction() {
    let dir = scratch("fr-estimates");
    let msh = hertz_mesh(&dir, 1);
    let tresca = [
        "-nndd_bc_lid_ux",
        "3e-3",
        "-nndd_friction",
        "tresca",
        "-nndd_friction_threshold",
        "3e8",
    ];
    let cases: [(&str, &str, &[&str]); 4] = [
        (
            "coulomb, iteration 2",
            HERTZ_FRICTION,
            &["-nndd_stop", "none", "-nndd_max_it", "2"],
        ),
        (
            "coulomb, iteration 4",
            HERTZ_FRICTION,
            &["-nndd_stop", "none", "-nndd_max_it", "4"],
        ),
        ("coulomb, converged", HERTZ_FRICTION, &[]),
        ("tresca, converged", HERTZ_OPTS, &tresca),
    ];
    for (what, opts, extra) in cases {
        let mut etas = Vec::new();
        for np in [1, 2, 3] {
            let prefix = dir.join(format!("{}-{np}", what.replace([',', ' '], "_")));
            let mut args = vec!["-nndd_estimate", "-nndd_reference_factor", "4"];
            args.extend_from_slice(extra);
            let p = prefix.to_str().unwrap();
            let mut all = vec![
                "-options_file",
                opts,
                "-nndd_mesh",
                msh.to_str().unwrap(),
                "-nndd_output",
                p,
            ];
            all.extend_from_slice(&args);
            let run = mpirun(np, &all);
            // (a fixed iteration count ends with exit 0: asked for)
            assert!(
                run.status.success(),
                "{what} on {np}: {}",
                String::from_utf8_lossy(&run.stderr)
            );
            let j = json(&prefix);
            let e = j["estimates"].as_array().unwrap().last().unwrap().clone();
            let (glo, fe, nndd) = (f(&e, "eta_glo"), f(&e, "eta_fe"), f(&e, "eta_nndd"));
            let e_ref = f(&e, "e_ref");
            let gamma = glo / e_ref;
            println!("{what} on {np}: eta_glo {glo:.6e} eta_FE {fe:.6e} eta_NNDD {nndd:.3e} e_ref {e_ref:.6e} effectivity {gamma:.4}");
            assert!(gamma >= 1.0, "{what}: the bound fails: {gamma}");
            assert!(gamma <= 1.3, "{what}: effectivity {gamma}");
            let ratio = (fe * fe + nndd * nndd) / (glo * glo);
            assert!((0.9..1.1).contains(&ratio), "{what}: split {ratio}");
            let res = &j["equilibrium_residuals"];
            for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
                assert!(f(res, key) < 1e-11, "{what}: {key} {}", res[key]);
            }
            etas.push(glo);
        }
        let spread = etas
            .iter()
            .fold(0.0_f64, |m, e| m.max((e - etas[0]).abs() / etas[0]));
        assert!(spread < 1e-8, "{what}: ranks disagree: {etas:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Adaptive meshes with friction: the Hertz cylinder pushed sideways (Coulomb) remeshed until
/// η^glo ≤ 5 % of ‖u_h‖_E, its λ (normal and tangential halves) carried to each new Γc, the
/// bound holding at every cycle.
#[test]
fn an_adaptive_run_with_friction_reaches_its_tolerance() {
    let dir = scratch("fr-adapt");
    let prefix = dir.join("hertz");
    let j = solve_meshed(
        2,
        HERTZ_FRICTION,
        Path::new(HERTZ_GEO),
        &prefix,
        &["-nndd_adapt_tol", "0.05", "-nndd_reference_factor", "2"],
    );
    let cycles = j["cycles"].as_array().unwrap();
    assert!(cycles.len() >= 2, "{cycles:?}");
    let rel: Vec<f64> = cycles.iter().map(|c| f(c, "relative_error")).collect();
    assert!(rel.windows(2).all(|w| w[1] < w[0]), "{rel:?}");
    assert!(*rel.last().unwrap() <= 0.05, "{rel:?}");
    for c in cycles {
        let gamma = f(c, "effectivity");
        assert!((1.0..1.3).contains(&gamma), "effectivity {gamma}");
    }
    let c = &j["contact"];
    assert!(f(c, "stick_nodes") > 0.0 && f(c, "slip_nodes") > 0.0, "{c}");
    println!(
        "adaptive Hertz with Coulomb friction: {rel:?}, effectivities {:?}",
        cycles
            .iter()
            .map(|c| f(c, "effectivity"))
            .collect::<Vec<_>>()
    );
    std::fs::remove_dir_all(&dir).ok();
}
