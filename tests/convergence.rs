//! Capability: the NNDD's convergence on `paper` (iteration counts within a range), θ auto
//! where the contact set changes often (nearly incompressible bodies, a roof's ridge, curves
//! meshed 1:10) against the monolithic solve, and a non-converging run reported as such (a
//! status and a hint, not a panic).

mod common;
use common::*;

use std::path::Path;

#[test]
fn paper_iterations_for_the_two_thetas() {
    let dir = scratch("conv");
    let a = solve(2, &dir.join("q"), &["-nndd_n", "16", "-nndd_theta", "0.25"]);
    let b = solve(2, &dir.join("h"), &["-nndd_n", "16", "-nndd_theta", "0.5"]);
    let (ia, ib) = (
        a["iterations"].as_u64().unwrap(),
        b["iterations"].as_u64().unwrap(),
    );
    // Converged needs the forces balanced to 1e-8 as well as the change in λ: at θ = 0.25 the
    // force balance is about 15 times the change, which takes 9 iterations more than the
    // change alone (38).
    assert!((40..=55).contains(&ia), "θ = 0.25: {ia} iterations");
    assert!((12..=25).contains(&ib), "θ = 0.5: {ib} iterations");
    // The NNDD history: the change in λ and the force balance decrease by the tolerance.
    let h = a["history"].as_array().unwrap();
    let last = h.last().unwrap();
    assert!(last["lambda_change"].as_f64().unwrap() <= 1e-8);
    assert!(last["force_balance"].as_f64().unwrap() <= 1e-8);
    let before = &h[h.len() - 2];
    assert!(before["force_balance"].as_f64().unwrap() > 1e-8, "{before}");
    assert!(h[5]["lambda_change"].as_f64().unwrap() > 1e-3);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn too_large_theta_is_reported_not_converged() {
    let dir = scratch("conv-bad");
    let p = dir.join("bad");
    let out = mpirun(
        2,
        &[
            "-nndd_n",
            "8",
            "-nndd_theta",
            "1.2",
            "-nndd_output",
            p.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("try a smaller -nndd_theta"), "{stderr}");
    assert!(!stderr.contains("panicked"));
    let j = json(&p);
    assert_eq!(j["converged"], false);
    let status = j["status"].as_str().unwrap();
    assert!(
        status == "diverged" || status == "stagnated",
        "status {status}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A load that overflows double precision (`-nndd_F_max 1e300`: the energy is its square)
/// is reported as not finite, exit 3, with the data's magnitudes named as the cause, not a
/// relaxation to make smaller.
#[test]
fn an_overflowing_load_is_named_not_blamed_on_theta() {
    let dir = scratch("conv-overflow");
    let p = dir.join("big");
    let out = mpirun(
        2,
        &[
            "-nndd_n",
            "8",
            "-nndd_F_max",
            "1e300",
            "-nndd_output",
            p.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("not finite") && stderr.contains("overflow"),
        "{stderr}"
    );
    assert!(!stderr.contains("-nndd_theta ("), "{stderr}");
    assert!(!stderr.contains("panicked"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `-nndd_theta auto` (the default: a secant update restarted at contact-set changes,
/// src/dd/secant.rs) converges to the monolithic solution for bodies of very different stiffness,
/// E¹/E² = 1000 … 0.001, where no fixed θ suits them all (θ = 0.25 diverges at 1000 and at 0.001,
/// and every fixed θ needs hundreds of iterations at 0.01, docs/results.md). The default is
/// `auto`: the runs below do not name θ.
#[test]
fn theta_auto_converges_for_stiffness_ratios_1000_to_0_001() {
    let dir = scratch("conv-auto");
    for ratio in ["1000", "100", "10", "1", "0.1", "0.01", "0.001"] {
        let e1 = format!("{:e}", ratio.parse::<f64>().unwrap() * 2.1e11);
        let base = ["-nndd_n", "16", "-nndd_body1_E", &e1];
        let mut m = base.to_vec();
        m.extend(["-nndd_solver", "monolithic"]);
        let mono = solve(1, &dir.join("mono"), &m);
        let j = solve(2, &dir.join("auto"), &base);
        assert_eq!(j["converged"], true, "E1/E2 = {ratio}");
        assert_eq!(j["theta_auto"], true, "auto is the default");
        let it = j["iterations"].as_u64().unwrap();
        assert!((3..=25).contains(&it), "E1/E2 = {ratio}: {it} iterations");
        let (e, em) = (f(&j, "potential_energy"), f(&mono, "potential_energy"));
        assert!(
            (e - em).abs() < 1e-10 * em.abs(),
            "E1/E2 = {ratio}: {e} vs {em}"
        );
        // The secant model is used (columns from the second iteration on).
        let h = j["history"].as_array().unwrap();
        assert_eq!(
            h[0]["secant_columns"], 0,
            "E1/E2 = {ratio}: a plain first step"
        );
        assert!(
            h.iter().any(|r| r["secant_columns"].as_u64().unwrap() >= 2),
            "E1/E2 = {ratio}: no secant step"
        );
    }
    // The fixed θ = 0.25 with body 1 a thousand times softer is reported, exit 3.
    let p = dir.join("fixed");
    let out = mpirun(
        2,
        &[
            "-nndd_n",
            "8",
            "-nndd_body1_E",
            "2.1e8",
            "-nndd_theta",
            "0.25",
            "-nndd_output",
            p.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("try a smaller -nndd_theta (now 0.25)"),
        "{stderr}"
    );
    let status = json(&p)["status"].as_str().unwrap().to_string();
    assert!(
        status == "diverged" || status == "stagnated",
        "status {status}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// θ auto where the contact set changes at every early iteration and the interface operator's
/// spectrum is far from the two points of proportional bodies: each case converges within 30
/// iterations (47 on the flat roof on a nearly incompressible block, where the contact set
/// settles after 14 and the secant update then needs 33 for the locking body's spread
/// spectrum) to the monolithic energy (1e−8).
/// Runs on 2 ranks; `label`: the case in the messages.
fn theta_auto_case(dir: &Path, label: &str, args: &[&str], most: u64) {
    // (the output prefix again last: an options file in `args` may name its own)
    let run = |name: &str, extra: &[&str]| {
        let prefix = dir.join(format!("{}-{name}", label.replace(' ', "-")));
        let p = prefix.to_str().unwrap().to_string();
        let mut all = args.to_vec();
        all.extend_from_slice(extra);
        all.extend(["-nndd_output", &p]);
        solve(2, &prefix, &all)
    };
    let a = run("nndd", &[]);
    let m = run("mono", &["-nndd_solver", "monolithic"]);
    let its = a["iterations"].as_u64().unwrap();
    let (e, em) = (f(&a, "potential_energy"), f(&m, "potential_energy"));
    println!("theta auto, {label}: {its} iterations, energy {e:.10e} (monolithic {em:.10e})");
    assert_eq!(a["status"], "converged", "{label}");
    assert!(its <= most, "{label}: {its} iterations");
    assert!(
        (e - em).abs() <= 1e-8 * em.abs(),
        "{label}: {e:e} vs {em:e}"
    );
}

/// `paper` with one body nearly incompressible (ν = 0.4999) and the other ν = 0: with the
/// Dirichlet step on body 2 ν = 0.4999 diverged after 6 plain steps at θ = 1/μ₀ (the contact
/// set changed at each, so the secant update never learnt the map's stiffness).
#[test]
fn theta_auto_with_a_nearly_incompressible_body() {
    let dir = scratch("conv-nu");
    for (label, nu1, nu2) in [("nu1", "0.4999", "0"), ("nu2", "0", "0.4999")] {
        let args = [
            "-nndd_n",
            "16",
            "-nndd_body1_nu",
            nu1,
            "-nndd_body2_nu",
            nu2,
        ];
        theta_auto_case(&dir, label, &args, 30);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// tests/convergence/roof.geo meshed with its sides at `beta` degrees into `dir`, and the
/// options that press it onto the block (body 1's ν `nu`, body 2's 0.3).
fn roof(dir: &Path, beta: &str, nu: &str) -> Vec<String> {
    let geo = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/convergence/roof.geo");
    let msh = dir.join(format!("roof-{beta}.msh"));
    gmsh(geo, &[("beta", beta)], &[], &msh);
    let m = msh.to_str().unwrap();
    [
        "-nndd_mesh",
        m,
        "-nndd_contact",
        "top,roof",
        "-nndd_bc_base_ux",
        "0",
        "-nndd_bc_base_uy",
        "0",
        "-nndd_bc_lid_ux",
        "0",
        "-nndd_bc_lid_uy",
        "-2e-2",
        "-nndd_E",
        "7e10",
        "-nndd_body1_nu",
        nu,
        "-nndd_body2_nu",
        "0.3",
        "-nndd_max_it",
        "2000",
    ]
    .map(String::from)
    .to_vec()
}

/// A roof pressed onto a block (tests/convergence/roof.geo): the 90° ridge (sides at 45°) and
/// a flat roof (5°), and the flat one with the block nearly incompressible.
#[test]
fn theta_auto_on_a_roof() {
    let dir = scratch("conv-roof");
    for (beta, nu, most) in [("45", "0.3", 30), ("5", "0.3", 30), ("5", "0.4999", 30)] {
        let args = roof(&dir, beta, nu);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        theta_auto_case(&dir, &format!("roof {beta} deg, nu1 {nu}"), &args, most);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// examples/hertz-nonmatching with the cylinder's arc meshed 10 and 20 times coarser than the
/// block's top: the contact zone spans a segment or two of the cylinder, and the contact set
/// changes at every early iteration (diverged after 7 at ratio 10 without the stiffness
/// learnt across those changes).
#[test]
fn theta_auto_on_curves_meshed_1_to_10() {
    let dir = scratch("conv-ratio");
    let (geo, opts) = (HERTZ_NM_GEO, HERTZ_NM_OPTS);
    for ratio in ["10", "20", "0.1"] {
        let msh = dir.join(format!("hertz-{ratio}.msh"));
        gmsh(geo, &[("level", "1"), ("ratio", ratio)], &[], &msh);
        let m = msh.to_str().unwrap().to_string();
        let args = [
            "-options_file",
            opts,
            "-nndd_mesh",
            &m,
            common::NODE_TO_NODE[0],
            common::NODE_TO_NODE[1],
        ];
        theta_auto_case(&dir, &format!("hertz ratio {ratio}"), &args, 30);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// examples/pin-hole with a 1 mm clearance instead of 20 µm, the pin pushed 1.05 mm: the gap
/// closes over a millimetre before the contact zone (±1.9 mm) forms, on matching arcs and on
/// the pin's arc meshed 1.5 times finer.
#[test]
fn theta_auto_on_a_pin_with_1_mm_clearance() {
    let dir = scratch("conv-clearance");
    let geo = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/pin-hole/pin-hole.geo"
    );
    let opts = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/pin-hole/pin-hole.opts"
    );
    for ratio in ["1", "1.5"] {
        let msh = dir.join(format!("pin-{ratio}.msh"));
        let set = [("level", "1"), ("ratio", ratio), ("clearance", "1e-3")];
        gmsh(geo, &set, &[], &msh);
        let m = msh.to_str().unwrap().to_string();
        let args = [
            "-options_file",
            opts,
            "-nndd_mesh",
            &m,
            "-nndd_bc_bore_uy",
            "-1.05e-3",
            common::NODE_TO_NODE[0],
            common::NODE_TO_NODE[1],
        ];
        theta_auto_case(
            &dir,
            &format!("pin 1 mm clearance ratio {ratio}"),
            &args,
            30,
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The flat roof on a nearly incompressible block: the paper's update (both Neumann steps)
/// needs 45 iterations of θ auto, the Dirichlet body's Neumann step alone (θ auto's default,
/// `-nndd_neumann_bodies auto`) 14, to the same answer (docs/method.md §2).
#[test]
fn the_dirichlet_bodys_neumann_step_alone_gives_the_same_answer_sooner() {
    let dir = scratch("conv-bodies");
    let base = roof(&dir, "5", "0.4999");
    let run = |bodies: &str| {
        let mut args: Vec<&str> = base.iter().map(String::as_str).collect();
        args.extend(["-nndd_neumann_bodies", bodies]);
        solve(2, &dir.join(bodies), &args)
    };
    let (both, auto) = (run("both"), run("auto"));
    for j in [&both, &auto] {
        assert_eq!(j["status"], "converged");
    }
    assert_eq!(
        both["neumann_step"],
        serde_json::json!(["condensed", "condensed"])
    );
    assert_eq!(
        auto["neumann_step"],
        serde_json::json!(["condensed", "none"])
    );
    let (eb, ea) = (f(&both, "potential_energy"), f(&auto, "potential_energy"));
    let (ib, ia) = (
        both["iterations"].as_u64().unwrap(),
        auto["iterations"].as_u64().unwrap(),
    );
    println!("roof 5 deg, block nu 0.4999: both {ib} iterations, dirichlet {ia}");
    assert!((eb - ea).abs() <= 1e-9 * eb.abs(), "{eb:e} vs {ea:e}");
    assert!(ia <= 20 && ib >= 2 * ia, "both {ib}, dirichlet {ia}");
    std::fs::remove_dir_all(&dir).ok();
}
