//! Capability: the subdomain solvers are PETSc KSPs configured by `-body1_`/`-body2_` options,
//! and every alternative path computes the same discrete solution: the Dirichlet step by its
//! own factorised system or condensed with S¹, the Neumann steps by back-solves or condensed
//! with D^α, the interface operators from MUMPS or from back-solves, a Krylov solver instead of
//! a factorisation.

mod common;
use common::*;

fn displacements(prefix: &std::path::Path) -> Vec<f64> {
    let mut u = field(prefix, "body1", "displacement");
    u.extend(field(prefix, "body2", "displacement"));
    u
}

fn same(reference: &std::path::Path, other: &std::path::Path, tol: f64) {
    let d = rel_max_diff(&displacements(other), &displacements(reference));
    assert!(
        d < tol,
        "{} differs from {} by {d:e}",
        other.display(),
        reference.display()
    );
}

/// Both bodies take the Neumann step (θ auto's default is the Dirichlet body's alone), so
/// that each body's Neumann path is exercised.
const BASE: [&str; 8] = [
    "-nndd_problem",
    "paper",
    "-nndd_n",
    "10",
    "-nndd_tol",
    "1e-11",
    "-nndd_neumann_bodies",
    "both",
];

#[test]
fn dirichlet_step_system_equals_condensed() {
    // Estimated every fourth iteration: the system step forms u¹_p with T¹_p there, and T¹_p
    // alone (K u on each rank's rows, gathered at Γc) at the others, the last one's field
    // formed after the loop; on 4 ranks each body's system is spread over a group of 2.
    let dir = scratch("paths-dirichlet");
    let estimated = ["-nndd_estimate_every", "4", "-nndd_reference_factor", "0"];
    let run = |np: usize, name: &str, step: &str| {
        let args = [&BASE[..], &estimated, &["-nndd_dirichlet_step", step]].concat();
        solve(np, &dir.join(name), &args)
    };
    let a = run(2, "c", "condensed");
    assert_eq!(a["dirichlet_step"], "condensed");
    let estimates = |j: &serde_json::Value| -> Vec<(u64, f64)> {
        let list = j["estimates"].as_array().expect("estimates");
        let each = |e: &serde_json::Value| (e["iteration"].as_u64().unwrap(), f(e, "eta_glo"));
        list.iter().map(each).collect()
    };
    let (ea, iterations) = (estimates(&a), a["iterations"].as_u64().unwrap());
    assert!(
        !ea.is_empty() && iterations % 4 != 0,
        "{iterations} iterations, estimated {ea:?}"
    );
    for (np, name) in [(2, "s"), (4, "s4")] {
        let b = run(np, name, "system");
        assert_eq!(b["dirichlet_step"], "system", "{np} ranks");
        assert_eq!(a["iterations"], b["iterations"], "{np} ranks");
        same(&dir.join("c"), &dir.join(name), 1e-10);
        for ((pa, ga), (pb, gb)) in ea.iter().zip(estimates(&b)) {
            assert_eq!(*pa, pb);
            assert!(
                (ga - gb).abs() <= 1e-9 * ga,
                "{np} ranks, iteration {pa}: η^glo {ga} and {gb}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn neumann_step_solve_equals_condensed() {
    let dir = scratch("paths-neumann");
    let a = solve(2, &dir.join("c"), &BASE);
    let b = solve(
        2,
        &dir.join("s"),
        &[&BASE[..], &["-nndd_neumann_step", "solve"]].concat(),
    );
    assert_eq!(
        a["neumann_step"],
        serde_json::json!(["condensed", "condensed"])
    );
    assert_eq!(b["neumann_step"], serde_json::json!(["solve", "solve"]));
    assert_eq!(a["iterations"], b["iterations"]);
    same(&dir.join("c"), &dir.join("s"), 1e-10);
    std::fs::remove_dir_all(&dir).ok();
}

/// PETSc's copy of each body's matrix for MUMPS (its triples i, j, a_ij of the upper triangle:
/// (nonzeros + dofs) / 2 of them, 16 bytes each) is freed once MUMPS has factored it, on one
/// rank and over a group of two, and kept where MUMPS's error analysis or iterative refinement
/// reads it in every solve: the estimates' re-solves then run on it, and the solutions agree.
#[test]
fn mumps_copy_of_the_matrix_is_freed_once_factored_unless_a_solve_reads_it() {
    let dir = scratch("paths-freed");
    let args = [&BASE[..], &["-nndd_estimate_every", "5"]].concat();
    for np in [1, 3] {
        let a = solve(np, &dir.join(format!("a{np}")), &args);
        let keep = [
            "-body1_mat_mumps_icntl_11",
            "1",
            "-body2_mat_mumps_icntl_10",
            "2",
        ];
        let b = solve(
            np,
            &dir.join(format!("b{np}")),
            &[&args[..], &keep[..]].concat(),
        );
        for k in 0..2 {
            let nonzeros = a["stiffness_nonzeros"][k].as_f64().unwrap();
            let dofs = a["body_dofs"][k].as_f64().unwrap();
            let expected = (nonzeros + dofs) / 2.0 * 16.0 / (1u64 << 20) as f64;
            let freed = a["freed_matrix_copy_mib"][k].as_f64().unwrap();
            assert!(
                (freed - expected).abs() < 1e-9 * expected,
                "{np} ranks, body {}: {freed} MiB freed, {expected} expected",
                k + 1
            );
            assert_eq!(b["freed_matrix_copy_mib"][k].as_f64(), Some(0.0));
        }
        assert_eq!(a["dirichlet_step"], "condensed");
        assert!(!b["estimates"].as_array().unwrap().is_empty());
        same(
            &dir.join(format!("a{np}")),
            &dir.join(format!("b{np}")),
            1e-10,
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn schur_complement_from_mumps_equals_back_solves() {
    // PETSc's own Cholesky has no Schur complement: body 2's S is formed from m back-solves,
    // and body 1 (whose operators would cost back-solves too) solves its own systems.
    let dir = scratch("paths-schur");
    let a = solve(2, &dir.join("m"), &BASE);
    let native = [
        "-body1_pc_factor_mat_solver_type",
        "petsc",
        "-body2_pc_factor_mat_solver_type",
        "petsc",
    ];
    let b = solve(2, &dir.join("p"), &[&BASE[..], &native[..]].concat());
    assert_eq!(
        a["schur_source"],
        serde_json::json!(["mumps_schur", "mumps_schur"])
    );
    assert_eq!(b["schur_source"], serde_json::json!(["none", "solves"]));
    assert_eq!(
        b["dirichlet_step"], "system",
        "without S¹ from the factorisation the Dirichlet system is factored"
    );
    assert_eq!(b["neumann_step"], serde_json::json!(["solve", "condensed"]));
    same(&dir.join("m"), &dir.join("p"), 1e-10);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn krylov_subdomain_solver_gives_the_same_solution() {
    let dir = scratch("paths-krylov");
    solve(1, &dir.join("d"), &BASE);
    let mut args = BASE.to_vec();
    for b in ["-body1_", "-body2_"] {
        for (k, v) in [
            ("ksp_type", "cg"),
            ("pc_type", "gamg"),
            ("ksp_rtol", "1e-14"),
            ("ksp_atol", "1e-30"),
        ] {
            args.push(Box::leak(format!("{b}{k}").into_boxed_str()));
            args.push(v);
        }
    }
    let j = solve(1, &dir.join("k"), &args);
    assert_eq!(j["schur_source"], serde_json::json!(["none", "solves"]));
    same(&dir.join("d"), &dir.join("k"), 1e-7);
    std::fs::remove_dir_all(&dir).ok();
}

/// SuperLU_DIST on both bodies, with estimates against a reference solution (whose bodies are
/// set up beside the run's): `auto` condenses the Dirichlet step and every body has a
/// communicator of its own, so no two SuperLU_DIST factorisations share one (PETSc 3.18 frees
/// their process grid twice then: heap corruption, which aborted 4 of 34 runs on 3 ranks and
/// hung one on 1 rank, and valgrind's invalid writes in every run). The same solution
/// and estimates as MUMPS, on 1 rank (both bodies on it) and on 3 (body 1 over two), on
/// `paper` and on Hertz meshed on its own (mortar).
#[test]
fn superlu_dist_gives_the_same_solution_and_estimates() {
    let dir = scratch("paths-superlu");
    let mut args = BASE.to_vec();
    args.extend(["-nndd_estimate", "-nndd_reference_factor", "2"]);
    let direct = solve(2, &dir.join("m"), &args);
    for b in ["-body1_", "-body2_"] {
        for (k, v) in [
            ("pc_type", "lu"),
            ("pc_factor_mat_solver_type", "superlu_dist"),
        ] {
            args.push(Box::leak(format!("{b}{k}").into_boxed_str()));
            args.push(v);
        }
    }
    let last = |j: &serde_json::Value, k: &str| {
        j["estimates"].as_array().unwrap().last().unwrap()[k]
            .as_f64()
            .unwrap()
    };
    for np in [1, 3] {
        let name = format!("s{np}");
        let j = solve(np, &dir.join(&name), &args);
        assert_eq!(j["dirichlet_step"], "condensed", "{np} ranks");
        assert_eq!(
            j["schur_source"],
            serde_json::json!(["solves", "solves"]),
            "{np} ranks"
        );
        same(&dir.join("m"), &dir.join(&name), 1e-10);
        for k in ["eta_glo", "eta_fe", "effectivity"] {
            let (a, b) = (last(&j, k), last(&direct, k));
            assert!(((a - b) / b).abs() < 1e-9, "{np} ranks, {k}: {a} vs {b}");
        }
    }
    // Hertz meshed on its own by mortar (examples/hertz-nonmatching, level 1, 1.5:1), body 1
    // over two ranks of three: SuperLU_DIST's multiple-right-hand-side solve corrupted the heap
    // there (SIGABRT in pdReDistribute_B_to_X), so its back-solves go one column at a time.
    let hertz = |np: usize, name: &str, superlu: bool| {
        let (geo, opts) = (HERTZ_NM_GEO, HERTZ_NM_OPTS);
        let mut a = vec!["-nndd_geo_set", "level=1,ratio=1.5"];
        a.extend(["-nndd_estimate", "-nndd_reference_factor", "2"]);
        if superlu {
            a.extend([
                "-body1_pc_type",
                "lu",
                "-body1_pc_factor_mat_solver_type",
                "superlu_dist",
            ]);
            a.extend([
                "-body2_pc_type",
                "lu",
                "-body2_pc_factor_mat_solver_type",
                "superlu_dist",
            ]);
        }
        solve_meshed(np, opts, std::path::Path::new(geo), &dir.join(name), &a)
    };
    let mumps = hertz(2, "hertz-m", false);
    let superlu = hertz(3, "hertz-s3", true);
    assert_eq!(superlu["contact_curves"]["discretisation"], "mortar");
    for k in ["potential_energy", "contact_force"] {
        let (a, b) = (f(&superlu, k), f(&mumps, k));
        assert!(((a - b) / b).abs() < 1e-10, "Hertz, {k}: {a} vs {b}");
    }
    let (a, b) = (last(&superlu, "eta_glo"), last(&mumps, "eta_glo"));
    assert!(((a - b) / b).abs() < 1e-9, "Hertz, eta_glo: {a} vs {b}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A MUMPS factorisation that fails is an error in one line naming INFOG(1), INFOG(2) and the
/// option to change (before: a later MatMumpsGetInverseTranspose's "INFOG(1)=-3", which says
/// nothing of the cause): `paper` n = 64 on 6 ranks (3 per body) dealt in METIS's parts
/// outgrows a workspace relaxed by 0 % (ICNTL(14)); MUMPS's default relaxation solves it. (In
/// the grid's row blocks, `-nndd_partition auto`, MUMPS's estimate suffices without it.)
#[test]
fn a_failed_mumps_factorisation_names_its_cause() {
    let args = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "64",
        "-nndd_partition",
        "metis",
    ];
    fails_with(
        6,
        &[
            &args[..],
            &[
                "-body1_mat_mumps_icntl_14",
                "0",
                "-body2_mat_mumps_icntl_14",
                "0",
            ],
        ]
        .concat(),
        Some(2),
        // (both bodies' factorisations fail: the one reported is whichever ends first)
        &[
            "_mat_mumps_icntl_14 (a percentage >= 0",
            "INFOG(1) = -9",
            "estimate + 0 %",
        ],
    );
    let dir = scratch("paths-mumps-workspace");
    let j = solve(6, &dir.join("default"), &args);
    assert_eq!(j["ranks"], 6);
    std::fs::remove_dir_all(&dir).ok();
}

/// Where MUMPS's default workspace falls short (INFOG(1) = −9: `paper` drawn in Gmsh, n = 32,
/// on 8 ranks, 4 per body: one body or both in every one of 5 runs here, which one varying;
/// before, the run ended there), the factorisation is made again with the relaxation raised
/// (20 → 90 %), world rank 0 says so naming the option and the summary's `warnings` hold the
/// same lines, and the solution is the one rank's.
#[test]
fn a_factorisation_short_of_workspace_is_made_again_with_more() {
    let dir = scratch("paths-mumps-relaxed");
    let msh = dir.join("paper-32.msh");
    let geo = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper/paper.geo");
    gmsh(geo, &[("n", "32")], &[], &msh);
    let args = paper_mesh_args(&msh, "contact1,contact2", "-1e-4");
    let mut args: Vec<&str> = args.iter().map(String::as_str).collect();
    args.extend(["-nndd_tol", "1e-10"]);
    let one = solve(1, &dir.join("one"), &args);
    let prefix = dir.join("eight");
    let p = prefix.to_str().unwrap();
    let out = mpirun(8, &[&args[..], &["-nndd_output", p]].concat());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "8 ranks: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    // (the warnings go to stderr, as PETSc's do)
    let stderr = String::from_utf8_lossy(&out.stderr);
    let said: Vec<&str> = (stderr.lines())
        .filter(|l| l.contains("fell short"))
        .collect();
    for w in &said {
        assert!(
            w.contains("INFOG(1) = -9") && w.contains("_mat_mumps_icntl_14 90"),
            "{w}"
        );
    }
    let eight: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{p}.json")).unwrap()).unwrap();
    // Each said once, by world rank 0 whichever group factored it, and in the summary.
    let summary: Vec<String> = (eight["warnings"].as_array().unwrap().iter())
        .map(|w| w.as_str().unwrap())
        .filter(|w| w.contains("fell short"))
        .map(|w| format!("nndd: warning: {w}"))
        .collect();
    assert_eq!(said, summary, "{stderr}");
    assert_eq!(eight["iterations"], one["iterations"]);
    same(&dir.join("one"), &prefix, 1e-10);
    std::fs::remove_dir_all(&dir).ok();
}
