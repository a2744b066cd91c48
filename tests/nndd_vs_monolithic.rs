//! Capability: the NNDD converges to the solution of the discrete global contact problem
//! (docs/method.md §2, "Fixed point"), checked against the independent monolithic QP.

mod common;
use common::*;

fn compare(n: &str) {
    let dir = scratch(&format!("mono{n}"));
    let (a, b) = (dir.join("nndd"), dir.join("mono"));
    let base = ["-nndd_problem", "paper", "-nndd_n", n, "-nndd_tol", "1e-10"];
    let ja = solve(2, &a, &[&base[..], &["-nndd_solver", "nndd"]].concat());
    let jb = solve(
        1,
        &b,
        &[&base[..], &["-nndd_solver", "monolithic"]].concat(),
    );
    assert_eq!(ja["status"], "converged");
    let its = ja["iterations"].as_u64().unwrap();
    // θ auto (the default): 6 (n = 8) and 7 (n = 16) iterations; θ = 0.25 needs 40–50.
    assert!((3..=20).contains(&its), "NNDD iterations to 1e-10: {its}");
    let (ea, eb) = (f(&ja, "potential_energy"), f(&jb, "potential_energy"));
    assert!(((ea - eb) / eb).abs() < 1e-9, "energies {ea} vs {eb}");
    for body in ["body1", "body2"] {
        let u = |p| field(p, body, "displacement");
        let d = rel_max_diff(&u(&a), &u(&b));
        assert!(
            d < 1e-7,
            "{body} displacements differ by {d:e} (relative, max norm)"
        );
    }
    let (fa, fb) = (f(&ja, "contact_force"), f(&jb, "contact_force"));
    assert!(((fa - fb) / fb).abs() < 1e-7, "contact forces {fa} vs {fb}");
    assert_eq!(ja["contact_zone"], jb["contact_zone"]);
    assert_eq!(ja["active_nodes"], jb["active_nodes"]);
    // docs/benchmarks.md: partial contact, the blocks open near x = 1.
    let zone = ja["contact_zone"].as_array().unwrap();
    let x_max = zone[1].as_f64().unwrap();
    assert!(
        zone[0].as_f64().unwrap() == 0.0 && x_max > 0.8 && x_max < 1.0,
        "contact zone {zone:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn nndd_equals_monolithic_n8() {
    compare("8");
}

#[test]
fn nndd_equals_monolithic_n16() {
    compare("16");
}
