//! Capability: the `uniform` patch test (docs/benchmarks.md): exact stresses, and the NNDD's
//! convergence rates on two mirror-image bodies (docs/method.md §2, "Relaxation").

mod common;
use common::*;

/// σ_yy = E u_D / (2 (1 − ν²)) in both bodies, σ_xx = σ_xy = 0, with the Dirichlet step on
/// either body.
#[test]
fn stresses_are_exact() {
    for body in ["1", "2"] {
        stresses_are_exact_with_the_dirichlet_step_on(body);
    }
}

fn stresses_are_exact_with_the_dirichlet_step_on(dirichlet_body: &str) {
    let dir = scratch(&format!("uniform-stress{dirichlet_body}"));
    let p = dir.join("u");
    let j = solve(
        2,
        &p,
        &[
            "-nndd_problem",
            "uniform",
            "-nndd_n",
            "6",
            "-nndd_tol",
            "1e-13",
            "-nndd_dirichlet_body",
            dirichlet_body,
        ],
    );
    assert_eq!(
        j["dirichlet_body"].as_u64().unwrap().to_string(),
        dirichlet_body
    );
    let (e, nu, ud) = (
        j["young"][0].as_f64().unwrap(),
        j["poisson"][0].as_f64().unwrap(),
        f(&j, "u_d"),
    );
    let syy = e * ud / (2.0 * (1.0 - nu * nu));
    assert!((syy + 1.1326e7).abs() < 1e4, "exact σ_yy {syy}");
    for body in ["body1", "body2"] {
        let s = field(&p, body, "stress");
        assert_eq!(s.len() % 6, 0);
        for c in s.chunks(6) {
            // Stored as xx yy zz xy yz xz.
            assert!(
                (c[1] - syy).abs() < 1e-9 * syy.abs(),
                "{body} σ_yy {} vs {syy}",
                c[1]
            );
            assert!(
                c[0].abs() < 1e-9 * syy.abs() && c[3].abs() < 1e-9 * syy.abs(),
                "{body} σ_xx/σ_xy {c:?}"
            );
            // Plane strain: σ_zz = ν σ_yy.
            assert!(
                (c[2] - nu * syy).abs() < 1e-9 * syy.abs(),
                "{body} σ_zz {c:?}"
            );
        }
    }
    // Full contact; the contact force is −σ_yy times the interface length 1.
    assert_eq!(j["contact_zone"], serde_json::json!([0.0, 1.0]));
    assert!((f(&j, "contact_force") + syy).abs() < 1e-9 * syy.abs());
    std::fs::remove_dir_all(&dir).ok();
}

/// θ = 1/2: the first update gives the exact λ, so iteration 2 is converged, with the
/// Dirichlet step on either body (mirror images: the same interface operator).
#[test]
fn theta_half_converges_after_one_update() {
    for body in ["1", "2"] {
        theta_half_converges_with_the_dirichlet_step_on(body);
    }
}

fn theta_half_converges_with_the_dirichlet_step_on(dirichlet_body: &str) {
    let dir = scratch(&format!("uniform-half{dirichlet_body}"));
    let j = solve(
        2,
        &dir.join("u"),
        &[
            "-nndd_problem",
            "uniform",
            "-nndd_n",
            "8",
            "-nndd_theta",
            "0.5",
            "-nndd_tol",
            "1e-10",
            "-nndd_dirichlet_body",
            dirichlet_body,
        ],
    );
    let h = j["history"].as_array().unwrap();
    assert_eq!(j["iterations"], 2, "history {h:?}");
    let r1 = h[0]["residual"].as_f64().unwrap();
    let r2 = h[1]["residual"].as_f64().unwrap();
    assert!(
        r2 < 1e-12 * r1,
        "defect after one update {r2:e} (first {r1:e})"
    );
    assert!(h[1]["lambda_change"].as_f64().unwrap() < 1e-12);
    std::fs::remove_dir_all(&dir).ok();
}

/// θ = 1/4: the λ error, hence the update and the defect, halves at every iteration, with the
/// Dirichlet step on either body.
#[test]
fn theta_quarter_halves_the_error() {
    for body in ["1", "2"] {
        theta_quarter_halves_with_the_dirichlet_step_on(body);
    }
}

fn theta_quarter_halves_with_the_dirichlet_step_on(dirichlet_body: &str) {
    let dir = scratch(&format!("uniform-quarter{dirichlet_body}"));
    let j = solve(
        1,
        &dir.join("u"),
        &[
            "-nndd_problem",
            "uniform",
            "-nndd_n",
            "8",
            "-nndd_theta",
            "0.25",
            "-nndd_tol",
            "1e-9",
            "-nndd_dirichlet_body",
            dirichlet_body,
        ],
    );
    let h = j["history"].as_array().unwrap();
    assert!(h.len() >= 25, "iterations {}", h.len());
    for w in h.windows(2) {
        // λ_{p+1} − λ_p = −θ μ e_p (μ = 2), so consecutive changes relate as the errors.
        let (a, b) = (
            w[0]["residual"].as_f64().unwrap(),
            w[1]["residual"].as_f64().unwrap(),
        );
        assert!(
            (b / a - 0.5).abs() < 1e-6,
            "defect ratio {} at iteration {}",
            b / a,
            w[1]["iteration"]
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
