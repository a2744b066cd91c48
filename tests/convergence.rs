//! Capability: the NNDD's convergence on `paper` (iteration counts within a range), and a
//! non-converging run reported as such (a status and a hint, not a panic).

mod common;
use common::*;

#[test]
fn paper_iterations_for_the_two_thetas() {
    let dir = scratch("conv");
    let a = solve(2, &dir.join("q"), &["-nndd_n", "16", "-nndd_theta", "0.25"]);
    let b = solve(2, &dir.join("h"), &["-nndd_n", "16", "-nndd_theta", "0.5"]);
    let (ia, ib) = (
        a["iterations"].as_u64().unwrap(),
        b["iterations"].as_u64().unwrap(),
    );
    assert!((30..=45).contains(&ia), "θ = 0.25: {ia} iterations");
    assert!((12..=25).contains(&ib), "θ = 0.5: {ib} iterations");
    // The NNDD history: the change in λ decreases overall by the tolerance.
    let h = a["history"].as_array().unwrap();
    assert!(h.last().unwrap()["lambda_change"].as_f64().unwrap() <= 1e-8);
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
