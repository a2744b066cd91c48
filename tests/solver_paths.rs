//! Capability: the subdomain solvers are PETSc KSPs configured by `-body1_`/`-body2_` options,
//! and every alternative path computes the same discrete solution: the Dirichlet step by its
//! own factorised system or condensed with S¹, the interface Schur complement from MUMPS or
//! from back-solves, a Krylov solver instead of a factorisation, the contact QP with or without
//! the certified warm start.

mod common;
use common::*;

fn displacements(prefix: &std::path::Path) -> Vec<f64> {
    let mut u = h5(prefix, "/steps/0/body1/displacement");
    u.extend(h5(prefix, "/steps/0/body2/displacement"));
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

const BASE: [&str; 6] = [
    "-nndd_problem",
    "paper",
    "-nndd_n",
    "10",
    "-nndd_tol",
    "1e-11",
];

#[test]
fn dirichlet_step_system_equals_condensed() {
    let dir = scratch("paths-dirichlet");
    let a = solve(
        2,
        &dir.join("c"),
        &[&BASE[..], &["-nndd_dirichlet_step", "condensed"]].concat(),
    );
    let b = solve(
        2,
        &dir.join("s"),
        &[&BASE[..], &["-nndd_dirichlet_step", "system"]].concat(),
    );
    assert_eq!(a["dirichlet_step"], "condensed");
    assert_eq!(b["dirichlet_step"], "system");
    assert_eq!(a["iterations"], b["iterations"]);
    same(&dir.join("c"), &dir.join("s"), 1e-10);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn schur_complement_from_mumps_equals_back_solves() {
    // PETSc's own Cholesky has no Schur complement: S is formed from m back-solves.
    let dir = scratch("paths-schur");
    let a = solve(2, &dir.join("m"), &BASE);
    let native = [
        "-body1_pc_factor_mat_solver_type",
        "petsc",
        "-body2_pc_factor_mat_solver_type",
        "petsc",
    ];
    let b = solve(2, &dir.join("p"), &[&BASE[..], &native[..]].concat());
    assert_eq!(a["schur_source"], "mumps");
    assert_eq!(b["schur_source"], "solves");
    assert_eq!(
        b["dirichlet_step"], "system",
        "without a free S¹ the Dirichlet system is factored"
    );
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
    assert_eq!(j["schur_source"], "solves");
    same(&dir.join("d"), &dir.join("k"), 1e-7);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn warm_start_is_exact_and_clarabel_solves_the_open_steps() {
    let dir = scratch("paths-warm");
    let a = solve(2, &dir.join("w"), &BASE);
    let b = solve(
        2,
        &dir.join("c"),
        &[&BASE[..], &["-nndd_qp_warm_start", "0"]].concat(),
    );
    same(&dir.join("c"), &dir.join("w"), 1e-12);
    let its = |j: &serde_json::Value| -> Vec<u64> {
        j["history"]
            .as_array()
            .unwrap()
            .iter()
            .map(|h| h["qp_iterations"].as_u64().unwrap())
            .collect()
    };
    let (wa, wb) = (its(&a), its(&b));
    assert!(
        wb.iter().all(|&k| k > 0),
        "without warm start Clarabel runs every step: {wb:?}"
    );
    assert!(wa[0] > 0, "the first contact step is Clarabel's: {wa:?}");
    assert!(
        wa.iter().filter(|&&k| k == 0).count() > wa.len() / 2,
        "warm start certified too rarely: {wa:?}"
    );
    for j in [&a, &b] {
        assert!(
            f(j, "qp_kkt_residual") < 1e-12,
            "KKT residual {}",
            f(j, "qp_kkt_residual")
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// SuperLU_DIST on both bodies, with estimates against a reference solution (whose bodies are
/// set up beside the run's): `auto` condenses the Dirichlet step and every body has a
/// communicator of its own, so no two SuperLU_DIST factorisations share one (PETSc 3.18 frees
/// their process grid twice then: heap corruption, which aborted 4 of 34 runs on 3 ranks and
/// hung one on 1 rank, and valgrind's invalid writes in every run). The same solution
/// and estimates as MUMPS, on 1 rank (both bodies on it) and on 3 (body 1 over two).
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
        assert_eq!(j["schur_source"], "solves", "{np} ranks");
        same(&dir.join("m"), &dir.join(&name), 1e-10);
        for k in ["eta_glo", "eta_fe", "effectivity"] {
            let (a, b) = (last(&j, k), last(&direct, k));
            assert!(((a - b) / b).abs() < 1e-9, "{np} ranks, {k}: {a} vs {b}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
