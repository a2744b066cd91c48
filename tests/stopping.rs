//! Capability: stopping rules. `-nndd_stop balanced` ends the NNDD at the first estimated
//! iteration where η^NNDD ≤ κ η^FE (the algebra no longer matters next to the mesh);
//! `-nndd_stop none` runs a fixed number of iterations; the summary says why a run ended.

mod common;
use common::*;

#[test]
fn balanced_stopping_saves_iterations_not_accuracy() {
    let dir = scratch("stop-balanced");
    let base = ["-nndd_n", "16", "-nndd_tol", "1e-8"];
    let tol = solve(
        2,
        &dir.join("t"),
        &[&base[..], &["-nndd_estimate"]].concat(),
    );
    let bal = solve(
        2,
        &dir.join("b"),
        &[
            &base[..],
            &["-nndd_stop", "balanced", "-nndd_stop_ratio", "0.1"],
        ]
        .concat(),
    );
    assert_eq!(tol["stop_reason"], "tol");
    assert_eq!(bal["stop_reason"], "balanced");
    assert_eq!(bal["converged"], true);
    let (it_t, it_b) = (
        tol["iterations"].as_u64().unwrap(),
        bal["iterations"].as_u64().unwrap(),
    );
    assert!(it_b < it_t / 2, "balanced {it_b} vs tol {it_t} iterations");
    // Every iteration was estimated; the criterion holds at the last one only.
    let est = bal["estimates"].as_array().unwrap();
    assert_eq!(est.len() as u64, it_b);
    let holds = |e: &serde_json::Value| f(e, "eta_nndd") <= 0.1 * f(e, "eta_fe");
    assert!(holds(est.last().unwrap()));
    assert!(est[..est.len() - 1].iter().all(|e| !holds(e)));
    // The bound it reports is within a few per cent of the fully converged one.
    let (gb, gt) = (
        f(est.last().unwrap(), "eta_glo"),
        f(
            tol["estimates"].as_array().unwrap().last().unwrap(),
            "eta_glo",
        ),
    );
    assert!(
        gb >= gt && gb < 1.05 * gt,
        "η^glo balanced {gb} vs converged {gt}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn fixed_iteration_count_and_stop_reasons() {
    let dir = scratch("stop-none");
    let j = solve(
        1,
        &dir.join("n"),
        &[
            "-nndd_n",
            "6",
            "-nndd_stop",
            "none",
            "-nndd_max_it",
            "6",
            "-nndd_estimate",
        ],
    );
    assert_eq!(j["iterations"], 6);
    assert_eq!(j["stop_reason"], "max_it");
    assert_eq!(j["estimates"][0]["iteration"], 6);
    let m = solve(
        1,
        &dir.join("m"),
        &["-nndd_n", "6", "-nndd_solver", "monolithic"],
    );
    assert_eq!(m["stop_reason"], "direct");
    std::fs::remove_dir_all(&dir).ok();
}
