//! Capability: what a new user trips over is said, not taken silently.
//! - A misspelt `-nndd_` option is refused with the nearest known one; an option that does not
//!   apply to the problem is refused; PETSc options of the bodies' solvers that nothing read
//!   are a warning.
//! - `-nndd_stop none` runs exactly `-nndd_max_it` iterations; iterates that grow without
//!   bound are "diverged"; the reference solution of e_ref converges whatever θ the run uses.
//! - A Gmsh problem's summary speaks of it (no benchmark fields), with the contact zone's
//!   length and peak pressure; a mesh without physical groups is told how to name them.

mod common;
use common::*;

const HERTZ_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const HERTZ_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");

#[test]
fn a_misspelt_option_is_refused_with_the_one_meant() {
    for (typo, meant) in [
        ("-nndd_body1_young", "-nndd_body1_E"),
        ("-nndd_tool", "-nndd_tol"),
        ("-nndd_bdy2_nu", "-nndd_body2_nu"),
    ] {
        for np in [1, 2] {
            fails_with(
                np,
                &["-nndd_n", "4", typo, "0.3"],
                Some(1),
                &[typo, "unknown option", &format!("did you mean {meant}?")],
            );
        }
    }
    // PETSc's names are case-insensitive: a known option in other case is that option.
    let dir = scratch("newcomer-case");
    let j = solve(1, &dir.join("r"), &["-nndd_n", "4", "-NNDD_TOL", "1e-3"]);
    assert_eq!(f(&j, "tol"), 1e-3);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_option_that_does_not_apply_is_refused() {
    let dir = scratch("newcomer-apply");
    let msh = gmsh_level(HERTZ_GEO, &dir, "hertz", 0);
    let m = msh.to_str().unwrap();
    for option in ["-nndd_n", "-nndd_u_D", "-nndd_F_max", "-nndd_body2_nx"] {
        fails_with(
            2,
            &["-options_file", HERTZ_OPTS, "-nndd_mesh", m, option, "8"],
            Some(1),
            &[option, "does not apply to a Gmsh problem"],
        );
    }
    fails_with(
        1,
        &["-nndd_n", "4", "-nndd_contact", "a,b"],
        Some(1),
        &["-nndd_contact", "needs -nndd_mesh"],
    );
    fails_with(
        1,
        &["-nndd_n", "4", "-nndd_bc_top_uy", "0"],
        Some(1),
        &["-nndd_bc_top_uy", "boundary condition of a Gmsh problem"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn solver_options_nothing_read_are_a_warning() {
    let dir = scratch("newcomer-left");
    let j = solve(
        2,
        &dir.join("r"),
        &[
            "-nndd_n",
            "4",
            "-body1_ksp_tpye",
            "cg",
            "-body2_pc_type",
            "lu",
        ],
    );
    let w: Vec<&str> = j["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("-body1_ksp_tpye was given but no solver of the bodies read it"),
        "{w:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `paper` n = 16 with body 1 ten times stiffer and θ = 0.5: the iterates grow without bound.
const BLOWS_UP: [&str; 6] = [
    "-nndd_n",
    "16",
    "-nndd_body1_E",
    "2.1e12",
    "-nndd_theta",
    "0.5",
];

#[test]
fn a_run_that_blows_up_is_diverged_unless_asked_for_a_fixed_count() {
    let dir = scratch("newcomer-diverged");
    let out = mpirun(
        2,
        &[
            &BLOWS_UP[..],
            &["-nndd_output", dir.join("d").to_str().unwrap()],
        ]
        .concat(),
    );
    assert_eq!(out.status.code(), Some(3), "not converged: exit 3");
    let j = json(&dir.join("d"));
    assert_eq!(j["status"], "diverged");
    assert!(f(&j, "iterations") < 20.0, "{}", j["iterations"]);
    // -nndd_stop none: exactly -nndd_max_it iterations, however the iterates go.
    let out = mpirun(
        2,
        &[
            &BLOWS_UP[..],
            &[
                "-nndd_stop",
                "none",
                "-nndd_max_it",
                "40",
                "-nndd_output",
                dir.join("n").to_str().unwrap(),
            ],
        ]
        .concat(),
    );
    assert!(out.status.code().is_some());
    let j = json(&dir.join("n"));
    assert_eq!(f(&j, "iterations"), 40.0, "{}", j["status"]);
    assert_eq!(j["stop_reason"], "max_it");
    std::fs::remove_dir_all(&dir).ok();
}

/// The reference solution of e_ref converges (θ auto) though the run diverges with its θ: the
/// run's e_ref is that of the converged run's reference.
#[test]
fn the_reference_solution_converges_whatever_the_runs_theta() {
    let dir = scratch("newcomer-reference");
    let est = ["-nndd_estimate", "-nndd_reference_factor", "4"];
    mpirun(
        2,
        &[
            &BLOWS_UP[..],
            &est[..],
            &["-nndd_output", dir.join("d").to_str().unwrap()],
        ]
        .concat(),
    );
    let d = json(&dir.join("d"));
    assert_eq!(d["status"], "diverged");
    let good = solve(
        2,
        &dir.join("c"),
        &[&BLOWS_UP[..4], &est[..], &["-nndd_tol", "1e-10"]].concat(),
    );
    // The same reference solve (θ auto, whatever the run's θ), converged in a few iterations.
    let it = f(&d, "reference_iterations");
    assert_eq!(it, f(&good, "reference_iterations"));
    assert!((3.0..=40.0).contains(&it), "{it} iterations");
    let e_d = f(&d["estimates"][0], "e_ref");
    assert!(e_d.is_finite() && e_d < 1e4, "e_ref {e_d}");
    assert!(f(&d["estimates"][0], "effectivity") > 1.0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_mesh_problems_summary_speaks_of_it() {
    let dir = scratch("newcomer-summary");
    let msh = gmsh_level(HERTZ_GEO, &dir, "hertz", 1);
    let prefix = dir.join("r");
    let j = solve_meshed(2, HERTZ_OPTS, &msh, &prefix, &["-nndd_estimate"]);
    for key in ["n", "grids", "u_d", "f_max", "theta"] {
        assert!(j.get(key).is_none(), "{key} in a mesh problem's summary");
    }
    assert_eq!(j["theta_auto"], true);
    let mesh = &j["mesh"];
    assert_eq!(
        mesh["contact"],
        serde_json::json!(["block_top", "cylinder_arc"])
    );
    let lid = mesh["conditions"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["curve"] == "lid")
        .expect("the lid's condition");
    assert_eq!(lid["u"], serde_json::json!([0.0, -1.2e-2]));
    // Estimates carry only estimates.
    let e = &j["estimates"][0];
    for key in ["lambda_change", "residual", "active"] {
        assert!(e.get(key).is_none(), "{key} in {e}");
    }
    // The contact zone against the HDF5 contact data.
    let c = &j["contact"];
    let x = points(&prefix, "contact");
    let active = field(&prefix, "contact", "active");
    let pressure = field(&prefix, "contact", "pressure");
    let on: Vec<usize> = (0..active.len()).filter(|&k| active[k] > 0.5).collect();
    let (a, b) = (on[0], on[on.len() - 1]);
    let length: f64 = (a..b)
        .map(|k| (x[2 * k + 2] - x[2 * k]).hypot(x[2 * k + 3] - x[2 * k + 1]))
        .sum();
    assert!((f(c, "zone_length") - length).abs() < 1e-12, "{c}");
    let peak = pressure.iter().fold(0.0_f64, |m, &p| m.max(p));
    assert!((f(c, "peak_pressure") - peak).abs() < 1e-9 * peak, "{c}");
    assert!((f(c, "normal_force") - f(&j, "contact_force")).abs() < 1e-9 * peak);
    // The closing line gives the zone in significant digits.
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_mesh_without_physical_groups_is_told_how_to_name_them() {
    let dir = scratch("newcomer-nophys");
    let geo = dir.join("square.geo");
    std::fs::write(
        &geo,
        "Point(1)={0,0,0};Point(2)={1,0,0};Point(3)={1,1,0};Point(4)={0,1,0};\
         Line(1)={1,2};Line(2)={2,3};Line(3)={3,4};Line(4)={4,1};\
         Curve Loop(1)={1,2,3,4};Plane Surface(1)={1};\n",
    )
    .unwrap();
    let msh = dir.join("square.msh");
    gmsh(geo.to_str().unwrap(), &[], &[], &msh);
    fails_with(
        1,
        &[
            "-nndd_mesh",
            msh.to_str().unwrap(),
            "-nndd_contact",
            "a,b",
            "-nndd_bc_ground_ux",
            "0",
        ],
        Some(1),
        &[
            "-nndd_mesh",
            "has no physical surface 'body1' or 'body2'",
            "Physical Surface(\"body1\")",
        ],
    );
    std::fs::remove_dir_all(&dir).ok();
}
