//! Capability: a problem the user meshed in Gmsh (`-nndd_mesh`): physical surfaces name the
//! bodies, physical curves carry the boundary conditions (`-nndd_bc_NAME_…`) and the contact
//! interface (`-nndd_contact`), the initial gap comes from the geometry. The meshes are made
//! here by Gmsh from `examples/paper/paper.geo` (the `paper` benchmark drawn in Gmsh), or by
//! nndd itself from the `.geo` given as `-nndd_mesh` (`-nndd_geo_set` its parameters).

mod common;
use common::*;

use std::path::{Path, PathBuf};

const GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper/paper.geo");

/// `gmsh -2 -format msh41 [-bin] -setnumber … paper.geo -o DIR/NAME.msh`.
fn mesh(dir: &Path, name: &str, numbers: &[(&str, &str)], extra: &[&str]) -> PathBuf {
    let out = dir.join(format!("{name}.msh"));
    gmsh(GEO, numbers, extra, &out);
    out
}

/// The options of examples/paper/paper.opts for a mesh file and a top displacement.
fn paper_args(msh: &Path, u_top: &str) -> Vec<String> {
    let mut a = paper_mesh_args(msh, "contact1,contact2", u_top);
    a.extend(["-nndd_tol".to_string(), "1e-10".to_string()]);
    a
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn paper_from_gmsh_equals_the_builtin_paper() {
    let dir = scratch("gmsh-paper");
    let ascii = mesh(&dir, "paper-16", &[("n", "16")], &[]);
    let binary = mesh(&dir, "paper-16-bin", &[("n", "16")], &["-bin"]);
    let builtin = solve(
        1,
        &dir.join("builtin"),
        &["-nndd_n", "16", "-nndd_tol", "1e-10"],
    );
    let e0 = f(&builtin, "potential_energy");
    let it0 = f(&builtin, "iterations");
    for (np, msh) in [(1, &ascii), (2, &binary), (3, &ascii)] {
        let args = paper_args(msh, "-1e-4");
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let j = solve(np, &dir.join(format!("gmsh{np}")), &args);
        assert_eq!(f(&j, "dofs"), f(&builtin, "dofs"));
        // Matching contact curves go through the matching unchanged.
        let curves = &j["contact_curves"];
        assert_eq!(curves["inserted"], serde_json::json!([0, 0]), "{curves}");
        assert_eq!(curves["moved"], serde_json::json!([0, 0]), "{curves}");
        assert_eq!(curves["pairs"], curves["nodes"][0], "{curves}");
        assert_eq!(f(&j, "iterations"), it0, "{np} ranks");
        let e = f(&j, "potential_energy");
        assert!(
            rel(e, e0) < 1e-12,
            "{np} ranks: energy {e} vs built-in {e0}"
        );
        let c = f(&j, "contact_force");
        assert!(
            rel(c, f(&builtin, "contact_force")) < 1e-10,
            "contact force {c}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Body 2 lifted by g₀ with its top pushed by u_D is the gap-free problem with u_D + g₀
/// (body 2 translated rigidly by −g₀): the same contact forces and body-1 field. The NNDD
/// equals the monolithic solve, and η^NNDD vanishes as it converges.
#[test]
fn initial_gap_from_the_geometry() {
    let dir = scratch("gmsh-gap");
    let g0 = 2e-5;
    let lifted = mesh(&dir, "lifted", &[("n", "8"), ("g0", "2e-5")], &[]);
    let builtin = solve(
        1,
        &dir.join("builtin"),
        &["-nndd_n", "8", "-nndd_u_D", "-8e-5", "-nndd_tol", "1e-10"],
    );
    let args = paper_args(&lifted, "-1e-4");
    let mut nndd: Vec<&str> = args.iter().map(String::as_str).collect();
    nndd.extend(["-nndd_estimate"]);
    let j = solve(2, &dir.join("gap"), &nndd);
    let c0 = f(&builtin, "contact_force");
    assert!(
        rel(f(&j, "contact_force"), c0) < 1e-9,
        "contact force {} vs {c0}",
        f(&j, "contact_force")
    );
    assert!(c0 > 0.0);
    let u1 = field(&dir.join("gap"), "body1", "displacement");
    let u1_0 = field(&dir.join("builtin"), "body1", "displacement");
    // The Gmsh numbering differs from the built-in one: compare the largest |u¹|.
    let max = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(rel(max(&u1), max(&u1_0)) < 1e-9, "max |u1|");
    // The gap field: g₀ + u²_n − u¹_n ≥ 0, zero on the contact set.
    let gap = field(&dir.join("gap"), "contact", "gap");
    let active = field(&dir.join("gap"), "contact", "active");
    for (g, a) in gap.iter().zip(&active) {
        if *a > 0.5 {
            assert!(g.abs() < 1e-12, "gap {g} on the contact set");
        } else {
            assert!(*g > 0.0 && *g < 10.0 * g0, "open gap {g}");
        }
    }
    let est = &j["estimates"][0];
    let (glo, nn) = (f(est, "eta_glo"), f(est, "eta_nndd"));
    assert!(glo > 0.0 && nn < 1e-4 * glo, "eta_glo {glo}, eta_nndd {nn}");
    let res = &j["equilibrium_residuals"];
    assert!(f(res, "divergence") < 1e-10, "{res}");

    let mut mono = nndd.clone();
    mono.extend(["-nndd_solver", "monolithic"]);
    let m = solve(1, &dir.join("mono"), &mono);
    let (e, em) = (f(&j, "potential_energy"), f(&m, "potential_energy"));
    assert!(rel(e, em) < 1e-9, "NNDD {e} vs monolithic {em}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_meshes_are_refused() {
    let dir = scratch("gmsh-bad");
    let good = mesh(&dir, "good", &[("n", "4")], &[]);
    let run = |args: Vec<String>, option: &str| {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(2, &a, option);
    };
    let with = |msh: &Path, extra: &[&str]| {
        let mut a = paper_args(msh, "-1e-4");
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    // A missing file and a file that is not MSH.
    run(with(&dir.join("missing.msh"), &[]), "-nndd_mesh");
    let text = dir.join("notes.msh");
    std::fs::write(&text, "this is not a mesh\n").unwrap();
    run(with(&text, &[]), "-nndd_mesh");
    // Quadratic triangles.
    let p2 = mesh(&dir, "p2", &[("n", "4")], &["-order", "2"]);
    run(with(&p2, &[]), "-nndd_mesh");
    // No physical surface `body2`.
    let renamed = dir.join("renamed.msh");
    let t = std::fs::read_to_string(&good).unwrap();
    std::fs::write(&renamed, t.replace("\"body2\"", "\"upper\"")).unwrap();
    run(with(&renamed, &[]), "-nndd_mesh");
    // A boundary-condition option naming no curve (a typo), a contact curve that does not
    // exist, a body left free to move, a traction that is not two numbers.
    run(
        with(&good, &["-nndd_bc_rigth2_uy", "0"]),
        "-nndd_bc_rigth2_uy",
    );
    let mut a = with(&good, &[]);
    let i = a.iter().position(|s| s == "contact1,contact2").unwrap();
    a[i] = "contact1,nowhere".into();
    run(a, "-nndd_contact");
    let free: Vec<String> = with(&good, &[])
        .chunks(2)
        .filter(|c| !c[0].starts_with("-nndd_bc_bottom"))
        .flat_map(|c| c.to_vec())
        .collect();
    run(free, "-nndd_bc_");
    run(
        with(&good, &["-nndd_bc_right2_traction", "1e7"]),
        "-nndd_bc_right2_traction",
    );
    // Materials per body are checked like -nndd_E / -nndd_nu.
    run(with(&good, &["-nndd_body2_E", "0"]), "-nndd_body2_E");
    run(with(&good, &["-nndd_body1_nu", "0.5"]), "-nndd_body1_nu");
    std::fs::remove_dir_all(&dir).ok();
}

/// Two materials: body 2 ten times stiffer; the NNDD (θ small enough) equals the monolithic
/// solve, and the summary reports both materials.
#[test]
fn a_material_per_body() {
    let dir = scratch("materials");
    let base = [
        "-nndd_n",
        "8",
        "-nndd_body2_E",
        "2.1e12",
        "-nndd_body2_nu",
        "0.3",
    ];
    let mut n = base.to_vec();
    n.extend(["-nndd_theta", "0.1", "-nndd_tol", "1e-10"]);
    let j = solve(2, &dir.join("nndd"), &n);
    let mut m = base.to_vec();
    m.extend(["-nndd_solver", "monolithic"]);
    let k = solve(1, &dir.join("mono"), &m);
    assert_eq!(j["young"][1].as_f64(), Some(2.1e12));
    assert_eq!(j["poisson"][0].as_f64(), Some(0.27));
    let (e, em) = (f(&j, "potential_energy"), f(&k, "potential_energy"));
    assert!(rel(e, em) < 1e-9, "NNDD {e} vs monolithic {em}");
    let same = solve(
        1,
        &dir.join("same"),
        &["-nndd_n", "8", "-nndd_solver", "monolithic"],
    );
    assert!(
        rel(f(&same, "potential_energy"), em) > 1e-3,
        "the material changed nothing"
    );
    std::fs::remove_dir_all(&dir).ok();
}

const BORE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/conditions/bore.geo");

/// tests/conditions/bore.geo's options: the block clamped at its base, the lid pushed down,
/// and `bore` the condition curves' extra options.
fn bore_args(msh: &Path, bore: &[&str]) -> Vec<String> {
    let mut a: Vec<String> = [
        "-nndd_mesh",
        msh.to_str().unwrap(),
        "-nndd_contact",
        "top1,bottom2",
        "-nndd_bc_base_ux",
        "0",
        "-nndd_bc_base_uy",
        "0",
        "-nndd_bc_lid_ux",
        "0",
        "-nndd_bc_lid_uy",
        "-1e-4",
        "-nndd_tol",
        "1e-10",
    ]
    .map(String::from)
    .to_vec();
    a.extend(bore.iter().map(|s| s.to_string()));
    a
}

/// A closed physical curve (a bore) carries a displacement or a constant traction: the same
/// answer as its two open halves with the same condition (the same mesh), on 1 and 2 ranks.
/// A linear traction needs an open curve, and a curve inside a body carries nothing: both
/// refused in one line (they used to be: the closed bore refused as "closed or in several
/// pieces", the inner line's load taken silently as a load inside the body).
#[test]
fn a_closed_curve_carries_a_condition_and_an_inner_one_is_refused() {
    let dir = scratch("gmsh-bore");
    let closed = dir.join("bore.msh");
    let split = dir.join("bore-split.msh");
    let inner = dir.join("bore-inner.msh");
    gmsh(BORE, &[], &[], &closed);
    gmsh(BORE, &[("split", "1")], &[], &split);
    gmsh(BORE, &[("inner", "1")], &[], &inner);
    let traction = "3e7,-1e7";
    for np in [1, 2] {
        let a = bore_args(&closed, &["-nndd_bc_bore_traction", traction]);
        let j = solve(np, &dir.join(format!("closed{np}")), &strs(&a));
        let halves = [
            "-nndd_bc_bore_a_traction",
            traction,
            "-nndd_bc_bore_b_traction",
            traction,
        ];
        let b = bore_args(&split, &halves);
        let k = solve(np, &dir.join(format!("split{np}")), &strs(&b));
        for key in ["potential_energy", "contact_force"] {
            assert!(rel(f(&j, key), f(&k, key)) < 1e-12, "{key}: {j} vs {k}");
        }
        // The traction does work: the energy differs from the bore left free.
        let free = solve(
            np,
            &dir.join(format!("free{np}")),
            &strs(&bore_args(&closed, &[])),
        );
        let (e, e0) = (f(&j, "potential_energy"), f(&free, "potential_energy"));
        assert!(rel(e, e0) > 1e-3, "{e} vs {e0}");
    }
    // A displacement on the closed bore.
    let a = bore_args(&closed, &["-nndd_bc_bore_ux", "0"]);
    let b = bore_args(
        &split,
        &["-nndd_bc_bore_a_ux", "0", "-nndd_bc_bore_b_ux", "0"],
    );
    let (j, k) = (
        solve(2, &dir.join("closed-u"), &strs(&a)),
        solve(2, &dir.join("split-u"), &strs(&b)),
    );
    assert!(rel(f(&j, "potential_energy"), f(&k, "potential_energy")) < 1e-12);
    // Refused: a linear traction on the closed bore; a traction on the inner line.
    let a = bore_args(
        &closed,
        &[
            "-nndd_bc_bore_traction",
            "0,-1e7",
            "-nndd_bc_bore_traction_end",
            "0,-2e7",
        ],
    );
    fails_with(
        2,
        &strs(&a),
        Some(1),
        &["-nndd_bc_bore_traction_end", "closed", "constant traction"],
    );
    let a = bore_args(&inner, &["-nndd_bc_inner_traction", "0,-1e7"]);
    for np in [1, 2] {
        fails_with(
            np,
            &strs(&a),
            Some(1),
            &[
                "-nndd_bc_inner_*",
                "not on body 1's boundary",
                "inside the body",
            ],
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// A mesh drawn in millimetres (examples/pin-hole scaled by 1000: 80 m as nndd reads it) with
/// moduli in pascals gets a warning naming the remedy, and the user's mesh in metres none. The
/// scaled bodies do not touch (a 50 µm push against a 20 mm clearance): the run converges on
/// the change in λ alone (with no pair in contact there is no force to balance).
#[test]
fn a_mesh_in_millimetres_is_warned_and_bodies_apart_converge() {
    let dir = scratch("gmsh-units");
    let geo = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/pin-hole/pin-hole.geo"
    );
    let opts = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/pin-hole/pin-hole.opts"
    );
    let (mm, m) = (dir.join("mm.msh"), dir.join("m.msh"));
    gmsh(
        geo,
        &[("level", "1")],
        &["-string", "Mesh.ScalingFactor=1000;"],
        &mm,
    );
    gmsh(geo, &[("level", "1")], &[], &m);
    let j = solve_meshed(2, opts, &mm, &dir.join("mm"), &[]);
    let warnings = j["warnings"].to_string();
    assert!(
        warnings.contains("spans 80 m") && warnings.contains("Mesh.ScalingFactor"),
        "{warnings}"
    );
    assert_eq!(j["status"], "converged");
    assert_eq!(f(&j, "contact_force"), 0.0);
    assert!(f(&j, "iterations") <= 20.0, "{}", j["iterations"]);
    let j = solve_meshed(2, opts, &m, &dir.join("m"), &[]);
    assert!(
        !j["warnings"].to_string().contains("ScalingFactor"),
        "{}",
        j["warnings"]
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `-nndd_mesh paper.geo -nndd_geo_set n=8`: meshed by gmsh when the run starts (on rank 0),
/// the same answer as the `.msh` Gmsh makes of it with `-setnumber n 8`, on 1 and 2 ranks; the
/// temporary mesh removed. Bad parameters, parameters for a `.msh` and a geometry gmsh cannot
/// mesh are refused in one line, on every rank.
#[test]
fn a_geo_file_is_meshed_when_the_run_starts() {
    let dir = scratch("gmsh-geo");
    let msh = mesh(&dir, "paper-8", &[("n", "8")], &[]);
    let given = solve(1, &dir.join("msh"), &strs(&paper_args(&msh, "-1e-3")));
    for np in [1, 2] {
        let mut args = paper_args(Path::new(GEO), "-1e-3");
        args.extend(["-nndd_geo_set".into(), "n=8".into()]);
        let j = solve(np, &dir.join(format!("geo-{np}")), &strs(&args));
        println!(
            "paper.geo with n=8 on {np} rank(s): {} dofs, energy {:.12e} (the .msh: {:.12e})",
            j["dofs"],
            f(&j, "potential_energy"),
            f(&given, "potential_energy")
        );
        assert_eq!(j["dofs"], given["dofs"]);
        assert_eq!(
            j["mesh"]["geometry_parameters"],
            serde_json::json!({"n": 8.0})
        );
        assert!(rel(f(&j, "potential_energy"), f(&given, "potential_energy")) < 1e-12);
    }
    let left: Vec<_> = std::fs::read_dir(std::env::temp_dir())
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("nndd-") && n.ends_with("-paper.msh"))
        .collect();
    assert!(left.is_empty(), "temporary meshes left: {left:?}");
    // Refusals.
    let m = msh.to_str().unwrap();
    refused(
        1,
        &[
            "-nndd_mesh",
            m,
            "-nndd_contact",
            "contact1,contact2",
            "-nndd_geo_set",
            "n=8",
        ],
        "-nndd_geo_set",
    );
    refused(
        2,
        &[
            "-nndd_mesh",
            GEO,
            "-nndd_contact",
            "contact1,contact2",
            "-nndd_geo_set",
            "n",
        ],
        "-nndd_geo_set",
    );
    let broken = dir.join("broken.geo");
    std::fs::write(&broken, "Point(1) = {0, 0, 0};\nLine(1) = {1, 2};\n").unwrap();
    let b = broken.to_str().unwrap();
    let line = fails_with(
        2,
        &["-nndd_mesh", b, "-nndd_contact", "a,b"],
        None,
        &["-nndd_mesh", "cannot mesh", "gmsh says"],
    );
    println!("{line}");
    std::fs::remove_dir_all(&dir).ok();
}
