//! Capability: MPI ranks. `-n 1` (both bodies on one rank) and `-n 2` (one body per rank)
//! give the same solution; other rank counts are refused with a clear error.

mod common;
use common::*;

#[test]
fn one_and_two_ranks_agree() {
    let dir = scratch("ranks");
    let args = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "12",
        "-nndd_tol",
        "1e-12",
    ];
    let j1 = solve(1, &dir.join("r1"), &args);
    let j2 = solve(2, &dir.join("r2"), &args);
    assert_eq!(j1["ranks"], 1);
    assert_eq!(j2["ranks"], 2);
    assert_eq!(j1["iterations"], j2["iterations"]);
    for body in ["body1", "body2"] {
        let ds = format!("/steps/0/{body}/displacement");
        let d = rel_max_diff(&h5(&dir.join("r2"), &ds), &h5(&dir.join("r1"), &ds));
        assert!(d < 1e-10, "{body}: -n 1 and -n 2 differ by {d:e}");
    }
    let (a, b) = (f(&j1, "potential_energy"), f(&j2, "potential_energy"));
    assert!(((a - b) / a).abs() < 1e-12);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn monolithic_on_two_ranks_agrees_with_one() {
    let dir = scratch("ranks-mono");
    let args = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "10",
        "-nndd_solver",
        "monolithic",
    ];
    let j1 = solve(1, &dir.join("m1"), &args);
    let j2 = solve(2, &dir.join("m2"), &args);
    let ds = "/steps/0/body2/displacement";
    assert!(rel_max_diff(&h5(&dir.join("m2"), ds), &h5(&dir.join("m1"), ds)) < 1e-10);
    assert_eq!(j1["contact_zone"], j2["contact_zone"]);
    std::fs::remove_dir_all(&dir).ok();
}
