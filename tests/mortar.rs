//! Capability: the mortar discretisation of contact curves meshed on their own
//! (`-nndd_contact_discretisation mortar`, src/problem/mortar.rs, src/problem/coupled.rs): the
//! curves as meshed, no node inserted, the coarser curve's nodes carrying the constraints and
//! the other body meeting them at points of its curve.
//! - The contact patch test at size ratios 1:1.7, 3:1, 1:10 and 10:1, either curve the coarser:
//!   the pressure uniform and the displacements the exact linear fields, monolithic solve and
//!   NNDD.
//! - On matching curves mortar is node to node: the same energy and pressures.
//! - Hertz with the cylinder 10 times coarser than the block and the block 10 times coarser:
//!   the peak pressure within 3 % of Hertz's, θ auto in ≤ 20 iterations, NNDD = monolithic, on
//!   1, 2 and 3 ranks alike, each rank holding the mesh of its group's body alone.
//! - The pin in its hole meshed 2:3: no open pair inside the contact arc, NNDD = monolithic;
//!   the pressure smooth (its largest second difference along Γc ≤ 5 % of the peak), where
//!   the gap measured between the polygons (`-nndd_mortar_gap polygons`) leaves a ripple of
//!   twice that.
//! - The estimates (src/estimate/mortar.rs): on the patch test η^glo, η^FE, η^NNDD and e_ref
//!   vanish to 1e−6 of ‖u‖_E (the answer is exact); on Hertz 1:1.5 and the pin in its hole 2:3 η^glo bounds e_ref at
//!   two reference factors, η^NNDD vanishes at convergence, and 1, 2 and 3 ranks agree; with
//!   estimates during the loop each estimated step's η^glo_E and η^FE_E in the result file
//!   (on the run's own meshes, each rank keeping its rows) sum to that step's η^glo and η^FE on
//!   1 and 4 ranks; finer (Hertz 1:1.5, level 4), where the curves' nodes come within 3e−4 of
//!   a segment of each other, the matched meshes pair them as they are, the estimate's
//!   stresses equilibrated to 1e−8 and η^glo ≥ e_ref; on 3 and 4 ranks no rank holds a whole field (the iterate carried to the
//!   matched meshes on each rank's part), and η^glo, η^FE and e_ref are the one rank's to
//!   1e−10.
//! - Closed contact curves (tests/mortar/bore.geo, a pin in its bore, whole circles meshed 2:3):
//!   the same answer as on the circles' lower arcs, NNDD = monolithic, 1, 2 and 3 ranks alike;
//!   node to node and the estimates on them refused in a line.
//! - `-nndd_contact_discretisation auto` (the default) couples curves that do not match by
//!   mortar and matching ones node to node (tests/floating.rs: node to node where a body is
//!   held only by contact).
//! - What mortar does not do yet is refused with one line: a Dirichlet step on the mortar
//!   body, a built-in problem.

mod common;
use common::patch::*;
use common::*;

use std::path::{Path, PathBuf};

const MORTAR: [&str; 2] = ["-nndd_contact_discretisation", "mortar"];

fn patch_mesh(dir: &Path, n1: u64, n2: u64) -> PathBuf {
    let msh = dir.join(format!("patch-{n1}-{n2}.msh"));
    gmsh(
        PATCH,
        &[("n1", &n1.to_string()), ("n2", &n2.to_string())],
        &[],
        &msh,
    );
    msh
}

#[test]
fn the_contact_patch_test_with_mortar_at_four_size_ratios() {
    let dir = scratch("mortar-patch");
    let p_exact = patch_pressure();
    for (n1, n2) in [(10u64, 17u64), (30, 10), (10, 100), (100, 10)] {
        let msh = patch_mesh(&dir, n1, n2);
        for (solver, limit) in [("monolithic", 1e-10), ("nndd", 1e-9)] {
            let prefix = dir.join(format!("{solver}-{n1}-{n2}"));
            let mut args = patch_args(&msh);
            args.extend(MORTAR.map(String::from));
            args.extend(["-nndd_solver".into(), solver.into()]);
            let j = solve(2, &prefix, &strs(&args));
            let what = format!("{n1} and {n2} segments, mortar, {solver}");
            assert_eq!(j["converged"], true, "{what}");
            assert!(f(&j, "iterations") <= 5.0, "{what}: {}", j["iterations"]);
            // Nothing inserted; the coarser curve's nodes carry the pairs.
            let curves = &j["contact_curves"];
            assert_eq!(curves["discretisation"], "mortar", "{what}");
            assert_eq!(curves["inserted"], serde_json::json!([0, 0]), "{what}");
            assert!(curves["coupling_seconds"].as_f64().is_some(), "{what}");
            let coarser = if n1 <= n2 { 1 } else { 2 };
            assert_eq!(curves["non_mortar"], coarser, "{what}: {curves}");
            assert_eq!(curves["pairs"], n1.min(n2) + 1, "{what}");
            assert_eq!(
                curves["nodes"],
                serde_json::json!([n1 + 1, n2 + 1]),
                "{what}"
            );
            let (lo, hi) = assert_patch(&prefix, limit, &what);
            println!(
                "patch {n1}:{n2} mortar {solver}: {} iterations, {} pairs on body {coarser}, pressure {lo:.12e} .. {hi:.12e} (exact {p_exact:.12e})",
                j["iterations"], curves["pairs"]
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn on_matching_curves_mortar_is_node_to_node() {
    let dir = scratch("mortar-matching");
    // Matching flat sides with an uneven pressure: the lid sheared sideways tilts the block.
    let msh = patch_mesh(&dir, 20, 20);
    let mut runs = Vec::new();
    for disc in ["node_to_node", "mortar"] {
        let prefix = dir.join(disc);
        let mut args = patch_args(&msh);
        args.extend(
            [
                "-nndd_bc_lid_traction",
                "2e5,0",
                "-nndd_contact_discretisation",
                disc,
            ]
            .map(String::from),
        );
        let j = solve(2, &prefix, &strs(&args));
        assert_eq!(j["converged"], true, "{disc}");
        runs.push((
            f(&j, "potential_energy"),
            field(&prefix, "contact", "pressure"),
        ));
    }
    let (e, p) = (&runs[0], &runs[1]);
    let de = (e.0 - p.0).abs() / e.0.abs();
    let dp = rel_max_diff(&e.1, &p.1);
    println!("matching 20:20: energy {:.12e} and {:.12e} (rel. diff {de:.1e}), pressures differ by {dp:.1e}", e.0, p.0);
    assert!(de < 1e-12, "energy {} vs {}", e.0, p.0);
    assert!(dp < 1e-9, "pressures differ by {dp:e}");
    std::fs::remove_dir_all(&dir).ok();
}

fn hertz_mesh(dir: &Path, ratio: &str, level: &str) -> PathBuf {
    let msh = dir.join(format!("hertz-{ratio}-{level}.msh"));
    gmsh(
        HERTZ_NM_GEO,
        &[("level", level), ("ratio", ratio)],
        &[],
        &msh,
    );
    msh
}

fn hertz_run(np: usize, msh: &Path, prefix: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = MORTAR.to_vec();
    args.extend_from_slice(extra);
    solve_meshed(np, HERTZ_NM_OPTS, msh, prefix, &args)
}

#[test]
fn hertz_with_mortar_on_curves_meshed_1_to_10_either_way() {
    let dir = scratch("mortar-hertz");
    for ratio in ["10", "0.1"] {
        let msh = hertz_mesh(&dir, ratio, "2");
        let mono = hertz_run(
            2,
            &msh,
            &dir.join(format!("mono-{ratio}")),
            &["-nndd_solver", "monolithic"],
        );
        let mut energies = Vec::new();
        // (both bodies' elements, which the one rank holds)
        let mut both = 0;
        for np in [1, 2, 3] {
            let prefix = dir.join(format!("nndd-{ratio}-{np}"));
            let j = hertz_run(np, &msh, &prefix, &[]);
            let what = format!("hertz ratio {ratio} on {np} rank(s)");
            assert_eq!(j["converged"], true, "{what}");
            assert!(
                f(&j, "iterations") <= 20.0,
                "{what}: {} iterations",
                j["iterations"]
            );
            let h = hertz_fit_of(&prefix);
            println!(
                "{what}: {} iterations, {} pairs, p0 {:.4e} vs Hertz {:.4e} ({:.2} %), energy {:.10e} (monolithic {:.10e})",
                j["iterations"],
                j["contact_curves"]["pairs"],
                h.p0_h,
                h.p0,
                100.0 * h.p0_err(),
                f(&j, "potential_energy"),
                f(&mono, "potential_energy")
            );
            assert!(h.p0_err() < 0.03, "{what}: p0 {} vs {}", h.p0_h, h.p0);
            let e = f(&j, "potential_energy");
            let em = f(&mono, "potential_energy");
            assert!((e - em).abs() < 1e-8 * em.abs(), "{what}: {e} vs {em}");
            energies.push(e);
            // Without estimates a rank holds the mesh of its group's body alone.
            let held: Vec<usize> =
                serde_json::from_value(j["held_mesh_elements_per_rank"].clone()).unwrap();
            let groups: Vec<usize> = serde_json::from_value(j["body_ranks"].clone()).unwrap();
            match np {
                1 => both = held[0],
                _ => {
                    let (b1, b2) = (held[0], held[np - 1]);
                    assert!(b1 + b2 == both && b1 < both, "{what}: {held:?} of {both}");
                    assert!(
                        held[..groups[0]].iter().all(|&h| h == b1),
                        "{what}: {held:?}"
                    );
                    assert!(
                        held[groups[0]..].iter().all(|&h| h == b2),
                        "{what}: {held:?}"
                    );
                }
            }
        }
        for e in &energies {
            assert!(
                (e - energies[0]).abs() < 1e-10 * energies[0].abs(),
                "{energies:?}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_pin_in_its_hole_meshed_2_to_3_has_no_open_pair_inside_the_arc() {
    let dir = scratch("mortar-pin");
    let msh = dir.join("pin.msh");
    gmsh(PIN_HOLE_GEO, &[("level", "2"), ("ratio", "1.5")], &[], &msh);
    let mut energies = Vec::new();
    let mut ripples = Vec::new();
    for (solver, gap) in [
        ("nndd", "curves"),
        ("monolithic", "curves"),
        ("nndd", "polygons"),
    ] {
        let prefix = dir.join(format!("{solver}-{gap}"));
        let mut args = vec!["-nndd_solver", solver, "-nndd_mortar_gap", gap];
        args.extend(MORTAR);
        let j = solve_meshed(2, PIN_HOLE_OPTS, &msh, &prefix, &args);
        assert_eq!(j["converged"], true, "{solver}");
        let active: Vec<bool> = field(&prefix, "contact", "active")
            .iter()
            .map(|&a| a > 0.5)
            .collect();
        let first = active.iter().position(|&a| a).expect("contact");
        let last = active.iter().rposition(|&a| a).expect("contact");
        let open = active[first..=last].iter().filter(|&&a| !a).count();
        // The largest |p_k − (p_k−1 + p_k+1)/2| inside the arc over the peak.
        let p = field(&prefix, "contact", "pressure");
        let peak = p.iter().fold(0.0_f64, |m, &v| m.max(v));
        let ripple = (first + 1..last)
            .map(|k| (p[k] - 0.5 * (p[k - 1] + p[k + 1])).abs() / peak)
            .fold(0.0_f64, f64::max);
        println!(
            "pin 2:3 mortar {solver}, gap to the {gap}: {} pairs, {} in contact, {open} open inside the arc, energy {:.10e}, largest second difference {:.2} % of the peak",
            active.len(),
            last + 1 - first - open,
            f(&j, "potential_energy"),
            100.0 * ripple
        );
        assert_eq!(open, 0, "{solver} {gap}: open pairs inside the arc");
        energies.push(f(&j, "potential_energy"));
        ripples.push(ripple);
    }
    assert!(
        (energies[0] - energies[1]).abs() < 1e-8 * energies[1].abs(),
        "{energies:?}"
    );
    assert!(ripples[0] <= 0.05, "the pressure's ripple {ripples:?}");
    assert!(ripples[2] > 2.0 * ripples[0], "{ripples:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn auto_couples_curves_that_do_not_match_by_mortar() {
    let dir = scratch("mortar-auto");
    for (n1, n2, want) in [(10u64, 17u64, "mortar"), (20, 20, "node_to_node")] {
        let msh = patch_mesh(&dir, n1, n2);
        let prefix = dir.join(format!("auto-{n1}-{n2}"));
        let args = patch_args(&msh);
        let j = solve(2, &prefix, &strs(&args));
        let curves = &j["contact_curves"];
        println!("patch {n1}:{n2}, -nndd_contact_discretisation auto: {curves}");
        assert_eq!(curves["discretisation"], want, "{n1}:{n2}: {curves}");
        assert_eq!(curves["inserted"], serde_json::json!([0, 0]), "{curves}");
        assert_patch(&prefix, 1e-9, &format!("auto {n1}:{n2}"));
    }
    // The pin in its hole meshed alike: only the arcs' end nodes are moved onto their
    // partners, nothing inserted: node to node.
    let msh = dir.join("pin.msh");
    gmsh(PIN_HOLE_GEO, &[("level", "1")], &[], &msh);
    let j = solve_meshed(1, PIN_HOLE_OPTS, &msh, &dir.join("pin"), &[]);
    assert_eq!(j["contact_curves"]["discretisation"], "node_to_node");
    std::fs::remove_dir_all(&dir).ok();
}

/// |a − b| / |b|.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

const BORE_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/mortar/bore.geo");

/// The options of tests/mortar/bore.geo (the pin pushed 50 µm down in its bore), but the
/// materials ([`ALUMINIUM_ON_STEEL`]).
const BORE: [&str; 10] = [
    "-nndd_bc_outer_ux",
    "0",
    "-nndd_bc_outer_uy",
    "0",
    "-nndd_bc_bore_ux",
    "0",
    "-nndd_bc_bore_uy",
    "-5e-5",
    "-nndd_tol",
    "1e-9",
];

#[test]
fn a_pin_in_its_bore_with_whole_circles_for_contact_curves() {
    let dir = scratch("mortar-bore");
    let msh = dir.join("bore.msh");
    gmsh(BORE_GEO, &[("level", "1"), ("ratio", "1.5")], &[], &msh);
    let m = msh.to_str().unwrap();
    let run = |np: usize, name: &str, extra: &[&str]| {
        let mut args = BORE.to_vec();
        args.extend(ALUMINIUM_ON_STEEL);
        args.extend(["-nndd_mesh", m]);
        args.extend_from_slice(extra);
        let j = solve(np, &dir.join(name), &args);
        assert_eq!(j["converged"], true, "{name}: {}", j["status"]);
        assert_eq!(j["contact_curves"]["discretisation"], "mortar", "{name}");
        j
    };
    // The whole circles (auto couples closed curves by mortar), on 1, 2 and 3 ranks and by
    // the monolithic solve; the lower arcs of ±120° of the same mesh.
    let mut whole = Vec::new();
    for np in [1, 2, 3] {
        whole.push(run(
            np,
            &format!("whole-{np}"),
            &["-nndd_contact", "hole,pin"],
        ));
    }
    let mono = run(
        2,
        "mono",
        &["-nndd_contact", "hole,pin", "-nndd_solver", "monolithic"],
    );
    let arcs = run(
        2,
        "arcs",
        &[
            "-nndd_contact",
            "hole_low,pin_low",
            "-nndd_contact_discretisation",
            "mortar",
        ],
    );
    let e = |j: &serde_json::Value| f(j, "potential_energy");
    let force = |j: &serde_json::Value| f(j, "contact_force");
    println!(
        "pin in its bore, whole circles: {} pairs, energy {:.12e}, force {:.9e}, {} iterations; lower arcs: {} pairs, energy {:.12e}, force {:.9e}; monolithic {:.12e}",
        whole[1]["contact_curves"]["pairs"],
        e(&whole[1]),
        force(&whole[1]),
        whole[1]["iterations"],
        arcs["contact_curves"]["pairs"],
        e(&arcs),
        force(&arcs),
        e(&mono)
    );
    // Every node of the hole's circle (64 segments, the coarser) is a pair.
    assert_eq!(whole[1]["contact_curves"]["pairs"], 64);
    for j in &whole {
        assert!(
            rel(e(j), e(&whole[0])) < 1e-10,
            "{} vs {}",
            e(j),
            e(&whole[0])
        );
    }
    assert!(
        rel(e(&whole[1]), e(&mono)) < 1e-8,
        "{} vs {}",
        e(&whole[1]),
        e(&mono)
    );
    // The contact arc (about ±55°) lies inside the lower arcs: the same answer.
    assert!(
        rel(e(&whole[1]), e(&arcs)) < 1e-9,
        "{} vs {}",
        e(&whole[1]),
        e(&arcs)
    );
    assert!(rel(force(&whole[1]), force(&arcs)) < 1e-8);
    // Γc's pairs run from a cut (the constraints span it): the pressure at each of the hole's
    // nodes is the arcs' run's, and the pairs in contact are one stretch of the circle.
    let at = |name: &str| -> Vec<([f64; 2], f64, bool)> {
        let pts = points(&dir.join(name), "contact");
        let p = field(&dir.join(name), "contact", "pressure");
        let a = field(&dir.join(name), "contact", "active");
        (0..p.len())
            .map(|k| ([pts[2 * k], pts[2 * k + 1]], p[k], a[k] > 0.5))
            .collect()
    };
    let (round, low) = (at("whole-2"), at("arcs"));
    // ParaView draws the closed Γc all round: its segments are the pairs' and the closing one.
    let segments = cells(&dir.join("whole-2"), "contact");
    assert_eq!(segments.len(), 2 * round.len());
    assert_eq!(segments[segments.len() - 2..], [round.len() as i64 - 1, 0]);
    assert_eq!(
        cells(&dir.join("arcs"), "contact").len(),
        2 * (low.len() - 1)
    );
    let peak = low.iter().map(|x| x.1).fold(0.0, f64::max);
    for (x, p, _) in &low {
        let (_, q, _) = round
            .iter()
            .find(|(y, _, _)| (y[0] - x[0]).hypot(y[1] - x[1]) < 1e-12)
            .expect("the arc's pair on the circle");
        assert!((p - q).abs() < 1e-7 * peak, "at {x:?}: {p} vs {q}");
    }
    let changes = (0..round.len())
        .filter(|&k| round[k].2 != round[(k + 1) % round.len()].2)
        .count();
    assert_eq!(changes, 2, "one stretch in contact");
    // What closed curves do not have yet: node to node and the estimates, refused in a line.
    let mut args = BORE.to_vec();
    args.extend(ALUMINIUM_ON_STEEL);
    args.extend(["-nndd_mesh", m, "-nndd_contact", "hole,pin"]);
    let mut a = args.clone();
    a.extend(["-nndd_contact_discretisation", "node_to_node"]);
    fails_with(1, &a, Some(1), &["'hole' is closed", "mortar"]);
    let mut a = args.clone();
    a.push("-nndd_estimate");
    fails_with(
        1,
        &a,
        Some(1),
        &["-nndd_contact", "'hole' is closed", "estimates"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The estimate of a run's summary.
fn estimate_of(j: &serde_json::Value) -> &serde_json::Value {
    j["estimates"]
        .as_array()
        .and_then(|a| a.last())
        .expect("an estimate")
}

#[test]
fn the_mortar_patch_test_estimates_no_error() {
    let dir = scratch("mortar-patch-estimates");
    // ‖u‖²_E = the lid's work: the pressure times its displacement over the unit width.
    let norm = (patch_pressure() * PATCH_PRESS.abs()).sqrt();
    for (n1, n2) in [(10u64, 17u64), (30, 10)] {
        let msh = patch_mesh(&dir, n1, n2);
        let prefix = dir.join(format!("est-{n1}-{n2}"));
        let mut args = patch_args(&msh);
        args.extend(MORTAR.map(String::from));
        args.extend(["-nndd_estimate", "-nndd_reference_factor", "2"].map(String::from));
        let j = solve(2, &prefix, &strs(&args));
        let e = estimate_of(&j);
        let what = format!("patch {n1}:{n2} with mortar");
        println!(
            "{what}: eta_glo {:.3e}, eta_FE {:.3e}, eta_NNDD {:.3e}, e_ref {:.3e}, |u|_E {norm:.4e}",
            f(e, "eta_glo"),
            f(e, "eta_fe"),
            f(e, "eta_nndd"),
            f(e, "e_ref")
        );
        // (round-off of the recovery on the matched meshes' thin triangles: 1e−7 of ‖u‖_E)
        for key in ["eta_glo", "eta_fe", "eta_nndd", "e_ref"] {
            assert!(f(e, key) < 1e-6 * norm, "{what}: {key} {}", f(e, key));
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn mortar_estimates_bound_the_error_on_hertz_and_the_pin() {
    let dir = scratch("mortar-estimates");
    let hertz = hertz_mesh(&dir, "1.5", "1");
    let pin = dir.join("pin-1.msh");
    gmsh(PIN_HOLE_GEO, &[("level", "1"), ("ratio", "1.5")], &[], &pin);
    for (name, opts, msh) in [
        ("hertz 1:1.5", HERTZ_NM_OPTS, &hertz),
        ("pin 2:3", PIN_HOLE_OPTS, &pin),
    ] {
        let mut glo = Vec::new();
        for (np, r) in [(2, "4"), (2, "8"), (1, "4"), (3, "4")] {
            let prefix = dir.join(format!("{}-{np}-{r}", &name[..3]));
            let mut args = MORTAR.to_vec();
            args.extend(["-nndd_estimate", "-nndd_reference_factor", r]);
            let j = solve_meshed(np, opts, msh, &prefix, &args);
            let e = estimate_of(&j);
            let what = format!("{name} on {np} rank(s), r = {r}");
            assert_eq!(j["converged"], true, "{what}");
            let meaning = j["estimate_meaning"]["eta_glo"].to_string();
            assert!(meaning.contains("mortar nodal gaps"), "{what}: {meaning}");
            let (g, e_ref) = (f(e, "eta_glo"), f(e, "e_ref"));
            println!(
                "{what}: eta_glo {g:.6e} (correction {:.3e}), eta_FE {:.6e}, eta_NNDD {:.3e}, e_ref {e_ref:.6e}, effectivity {:.4}",
                f(e, "eta_glo_correction"),
                f(e, "eta_fe"),
                f(e, "eta_nndd"),
                g / e_ref
            );
            assert!(g >= e_ref, "{what}: eta_glo {g} < e_ref {e_ref}");
            assert!(g < 1.6 * e_ref, "{what}: effectivity {}", g / e_ref);
            assert!(f(e, "eta_nndd") < 1e-4 * g, "{what}: {e}");
            let fe = f(e, "eta_fe");
            assert!(
                fe > 0.7 * g && fe <= g,
                "{what}: eta_FE {fe} vs eta_glo {g}"
            );
            glo.push(g);
        }
        for g in &glo {
            assert!((g - glo[0]).abs() < 1e-6 * glo[0], "{name}: {glo:?}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Finer, the curves' nodes come near each other: on Hertz 1:1.5 at level 4 a node of one
/// curve lies 2.7e−4 of a segment from a node of the other. Its partner inserted there would
/// cut a sliver off the matched mesh's triangle, whose stresses equilibrate to 7e−4 only; the
/// matching pairs such nodes as they are (`conform::NEAR`). The estimate's stresses are
/// equilibrated to 1e−8, and η^glo bounds e_ref.
#[test]
fn mortar_estimates_where_the_curves_nodes_come_near_each_other() {
    let dir = scratch("mortar-near");
    let msh = hertz_mesh(&dir, "1.5", "4");
    let args = ["-nndd_estimate", "-nndd_reference_factor", "2"];
    let j = hertz_run(2, &msh, &dir.join("h4"), &args);
    let e = estimate_of(&j);
    let (g, e_ref) = (f(e, "eta_glo"), f(e, "e_ref"));
    let residuals = &j["equilibrium_residuals"];
    println!("Hertz 1:1.5 level 4: eta_glo {g:.6e}, e_ref {e_ref:.6e}, residuals {residuals}");
    for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
        assert!(f(residuals, key) < 1e-8, "{key}: {residuals}");
    }
    assert!(g >= e_ref, "eta_glo {g} < e_ref {e_ref}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A mortar run's estimates hold no whole field: each rank keeps the run's fields at its block
/// of the output, Γc and the outline, and carries the iterate to the matched meshes at the
/// matched nodes it keeps (its block, Γc and the outline), gathering the run's field at their
/// sources alone (`Transfer::stencil_nodes`); the matched elements' maps reach the run's
/// elements through the ranks whose blocks hold their parents. On Hertz 1:1.5 (level 3, its
/// bodies in bands: `-nndd_mesh_order bands`) with e_ref (r = 2) on 3 and 4 ranks (body 1 on 2
/// and 3), each rank of body 1's group holds the
/// run's field at most at 1.2 times its share of body 1's nodes plus the outline, and the
/// estimate's fields (the carried iterate, the recoveries' overlaps with their rings) at fewer
/// nodes than body 1 has (carried whole, the iterate was held at all of body 1's matched
/// nodes, more). No rank but world rank 0 reads the file or builds a whole mesh: the run's
/// meshes, the matched meshes (world rank 0 sends each rank its parts and its part of the maps
/// between them) and the reference's fine bodies (the matched meshes refined: each other rank
/// holds in their input the part it solves on, less than half of them); η^glo, η^FE and e_ref
/// are the one rank's to 1e−10, and on 4 ranks those of `-nndd_mesh_input every_rank`, which
/// builds every mesh whole on every rank, to 1e−12.
#[test]
fn a_mortar_run_s_estimates_carry_the_iterate_on_each_rank_s_part() {
    let dir = scratch("mortar-held");
    let msh = hertz_mesh(&dir, "1.5", "3");
    let args = [
        "-nndd_estimate",
        "-nndd_reference_factor",
        "2",
        "-nndd_tol",
        "1e-10",
        "-nndd_mesh_order",
        "bands",
    ];
    let base = hertz_run(1, &msh, &dir.join("a"), &args);
    let whole = |key: &str| serde_json::from_value::<Vec<usize>>(base[key].clone()).unwrap()[0];
    let matched = whole("held_matched_mesh_elements_per_rank");
    let nodes = body_nodes(&base);
    let outline = ["body1", "body2"].map(|b| outline_nodes(&dir.join("a"), b));
    let last = last_estimate;
    for ranks in [3, 4] {
        let j = hertz_run(ranks, &msh, &dir.join(format!("b{ranks}")), &args);
        let what = format!("{ranks} ranks");
        let list = |key: &str| -> Vec<usize> { serde_json::from_value(j[key].clone()).unwrap() };
        assert_eq!(list("body_ranks"), [ranks - 1, 1], "{what}");
        let (held, estimated) = (
            list("held_displacement_nodes_per_rank"),
            list("held_estimate_displacement_nodes_per_rank"),
        );
        let share = nodes[0] as f64 / (ranks - 1) as f64;
        for r in 0..ranks - 1 {
            let bound = 1.2 * share + outline[0] as f64;
            assert!(
                held[r] as f64 <= bound,
                "{what}: rank {r} holds body 1 at {} of {} nodes, over {bound}",
                held[r],
                nodes[0]
            );
            assert!(
                estimated[r] < nodes[0],
                "{what}: rank {r}'s estimate holds {} nodes, body 1 has {}",
                estimated[r],
                nodes[0]
            );
        }
        // (the file read, and the run's and the matched meshes built, on world rank 0 alone)
        let points = list("input_file_points_per_rank");
        assert!(
            points[0] > 0 && points[1..].iter().all(|&p| p == 0),
            "{what}: {points:?}"
        );
        let (run, held) = (
            list("input_mesh_elements_per_rank"),
            list("held_matched_mesh_elements_per_rank"),
        );
        let mesh = whole("input_mesh_elements_per_rank");
        assert!(
            run[1..].iter().all(|&n| n < mesh),
            "{what}: {run:?} of {mesh}"
        );
        assert!(
            held.iter().all(|&n| n < matched),
            "{what}: {held:?} of {matched}"
        );
        // (the reference's fine bodies, the matched meshes refined, built on world rank 0
        // alone and dealt: every other rank held in their input the part it holds through
        // their solve)
        let whole = whole("reference_input_mesh_elements_per_rank");
        let (input, fine) = (
            list("reference_input_mesh_elements_per_rank"),
            list("held_reference_mesh_elements_per_rank"),
        );
        assert_eq!(
            input[0], whole,
            "{what}: world rank 0 built both fine bodies"
        );
        assert_eq!(
            input[1..],
            fine[1..],
            "{what}: the other ranks were sent their parts"
        );
        assert!(
            fine[1..].iter().all(|&n| n < whole / 2),
            "{what}: a rank holds a fine body whole: {fine:?} of {whole}"
        );
        for key in ["eta_glo", "eta_fe", "e_ref"] {
            let d = ((last(&j, key) - last(&base, key)) / last(&base, key)).abs();
            println!(
                "hertz 1:1.5 level 3 mortar on {ranks} ranks: {key} {:.12e} (1 rank {:.12e})",
                last(&j, key),
                last(&base, key)
            );
            assert!(d < 1e-10, "{what}: {key} differs by {d:e}");
        }
        assert!(last(&j, "eta_nndd") < 1e-4 * last(&j, "eta_glo"), "{what}");
        if ranks == 4 {
            let mut every = args.to_vec();
            every.extend(["-nndd_mesh_input", "every_rank"]);
            let e = hertz_run(ranks, &msh, &dir.join("every"), &every);
            let held: Vec<usize> =
                serde_json::from_value(e["held_matched_mesh_elements_per_rank"].clone()).unwrap();
            assert_eq!(held, vec![matched; ranks], "every_rank");
            for key in ["eta_glo", "eta_fe", "e_ref"] {
                let d = ((last(&j, key) - last(&e, key)) / last(&e, key)).abs();
                assert!(
                    d < 1e-12,
                    "{what}: {key} differs from every_rank's by {d:e}"
                );
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn each_estimated_step_written_sums_to_its_estimate_on_1_and_4_ranks() {
    let dir = scratch("mortar-steps");
    let msh = hertz_mesh(&dir, "1.5", "2");
    for np in [1, 4] {
        let prefix = dir.join(format!("steps-{np}"));
        let args = ["-nndd_estimate", "-nndd_estimate_every", "3"];
        let j = hertz_run(np, &msh, &prefix, &args);
        let estimates = j["estimates"].as_array().expect("the estimates");
        assert!(
            estimates.len() >= 3,
            "{np} ranks: {} estimates",
            estimates.len()
        );
        for e in estimates {
            let it = f(e, "iteration") as usize;
            for key in ["eta_glo", "eta_fe"] {
                let map = h5(&prefix, &format!("/Function/bodies/{key}/{it}"));
                let sum = map.iter().map(|v| v * v).sum::<f64>().sqrt();
                let d = (sum - f(e, key)).abs() / f(e, key);
                println!("hertz 1:1.5 mortar on {np} rank(s), iteration {it}: {key} (sum of the file's map) {sum:.12e}, estimate {:.12e}", f(e, key));
                assert!(
                    d < 1e-9,
                    "{np} ranks, iteration {it}: {key} map sums to {sum}, the estimate is {}",
                    f(e, key)
                );
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn what_mortar_does_not_do_yet_is_refused() {
    let dir = scratch("mortar-refused");
    let msh = patch_mesh(&dir, 10, 17);
    let args = patch_args(&msh);
    let mut base = strs(&args);
    base.extend(MORTAR);
    // The Dirichlet step on the mortar body (body 2's curve is the finer here).
    let mut a = base.clone();
    a.extend(["-nndd_dirichlet_body", "2"]);
    fails_with(1, &a, Some(1), &["-nndd_dirichlet_body", "use auto or 1"]);
    // A built-in problem, and an unknown value.
    refused(
        1,
        &["-nndd_contact_discretisation", "mortar"],
        "-nndd_contact_discretisation",
    );
    let mut a = strs(&args);
    a.extend(["-nndd_contact_discretisation", "segments"]);
    fails_with(
        1,
        &a,
        Some(1),
        &["-nndd_contact_discretisation", "node_to_node, mortar"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_mortar_run_restarts_on_another_rank_count() {
    let dir = scratch("mortar-restart");
    let msh = hertz_mesh(&dir, "4", "1");
    let straight = hertz_run(2, &msh, &dir.join("straight"), &[]);
    let first = dir.join("first");
    let mut args = MORTAR.to_vec();
    args.extend(["-nndd_max_it", "4", "-nndd_checkpoint_every", "2"]);
    let out = mpirun(
        2,
        &[
            &[
                "-options_file",
                HERTZ_NM_OPTS,
                "-nndd_mesh",
                msh.to_str().unwrap(),
            ][..],
            &args,
            &["-nndd_output", first.to_str().unwrap()],
        ]
        .concat(),
    );
    assert_eq!(out.status.code(), Some(3), "stopped at max_it");
    let point = format!("{}.checkpoint.json", first.display());
    let resumed = hertz_run(3, &msh, &dir.join("resumed"), &["-nndd_restart", &point]);
    assert_eq!(resumed["converged"], true);
    let (e, e0) = (
        f(&resumed, "potential_energy"),
        f(&straight, "potential_energy"),
    );
    println!(
        "mortar restart: 4 iterations on 2 ranks, then {} on 3: energy {e:.10e} (straight {e0:.10e})",
        resumed["iterations"]
    );
    assert!((e - e0).abs() < 1e-8 * e0.abs(), "{e} vs {e0}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A fixed θ too large for the mortar interface operator diverges: the run says so (exit 3,
/// "try a smaller -nndd_theta"), and the overlap of its last iterate is a warning, not an
/// error blamed on the contact curves.
#[test]
fn a_diverging_theta_is_said_as_such_not_blamed_on_the_curves() {
    let dir = scratch("mortar-diverged");
    let msh = hertz_mesh(&dir, "4", "2");
    let prefix = dir.join("run");
    let out = mpirun(
        2,
        &[
            "-options_file",
            HERTZ_NM_OPTS,
            "-nndd_mesh",
            msh.to_str().unwrap(),
            "-nndd_contact_discretisation",
            "mortar",
            "-nndd_theta",
            "0.25",
            "-nndd_output",
            prefix.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("diverged") && stderr.contains("try a smaller -nndd_theta"),
        "{stderr}"
    );
    assert!(
        stderr.contains("which did not converge, overlaps the other body"),
        "{stderr}"
    );
    assert!(!stderr.contains("nndd: error"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
