//! Capability: either body takes the NNDD's Dirichlet step, the other its contact step
//! (`-nndd_dirichlet_body`; `auto`, the default, gives the Dirichlet step to the stiffer body),
//! with the same discrete solution and the same estimates (docs/method.md §2, "Which body takes
//! the Dirichlet step").

mod common;
use common::*;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// `paper` n = 16 with body 1 a hundred times softer than body 2: `auto` puts the Dirichlet step
/// on body 2 and converges in a few iterations to the monolithic solution on 1, 2 and 3 ranks;
/// the Dirichlet step forced onto body 1 reaches the same solution, and is warned about.
#[test]
fn the_stiffer_body_takes_the_dirichlet_step_on_any_rank_count() {
    let dir = scratch("dirichlet-body-ranks");
    let soft = ["-nndd_n", "16", "-nndd_body1_E", "2.1e9"];
    let mut m = soft.to_vec();
    m.extend(["-nndd_solver", "monolithic"]);
    let mono = solve(1, &dir.join("mono"), &m);
    let em = f(&mono, "potential_energy");
    let force_m = field(&dir.join("mono"), "contact", "normal_force");
    for np in [1, 2, 3] {
        let p = dir.join(format!("auto{np}"));
        let j = solve(np, &p, &soft);
        assert_eq!(j["dirichlet_body"], 2, "{np} ranks: the stiffer body");
        assert_eq!(j["status"], "converged", "{np} ranks");
        assert!(j["warnings"].as_array().unwrap().is_empty(), "{np} ranks");
        let it = f(&j, "iterations");
        assert!((3.0..=15.0).contains(&it), "{np} ranks: {it} iterations");
        let e = f(&j, "potential_energy");
        assert!(rel(e, em) < 1e-10, "{np} ranks: energy {e} against {em}");
        assert_eq!(j["contact_zone"], mono["contact_zone"], "{np} ranks");
        // The contact forces on body 2, whichever body's QP gave them.
        let force = field(&p, "contact", "normal_force");
        let d = rel_max_diff(&force, &force_m);
        assert!(d < 1e-7, "{np} ranks: contact forces differ by {d:e}");
        // The final check of the reported iterate: both bodies in equilibrium, no penetration.
        let c = &j["solution_check"];
        for key in ["penetration", "tension", "complementarity"] {
            assert!(f(c, key) < 1e-9, "{np} ranks: {key} {}", f(c, key));
        }
        for r in c["equilibrium"].as_array().unwrap() {
            assert!(r.as_f64().unwrap() < 1e-9, "{np} ranks: equilibrium {r}");
        }
    }
    let p = dir.join("body1");
    let forced = solve(2, &p, &[&soft[..], &["-nndd_dirichlet_body", "1"]].concat());
    assert_eq!(forced["dirichlet_body"], 1);
    let e = f(&forced, "potential_energy");
    assert!(
        rel(e, em) < 1e-10,
        "Dirichlet step on body 1: {e} against {em}"
    );
    let w = forced["warnings"].as_array().unwrap();
    assert!(
        w.iter().any(|w| w
            .as_str()
            .unwrap()
            .contains("body 1 takes the Dirichlet step (-nndd_dirichlet_body 1) but is 100 times softer than body 2")),
        "{w:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The estimates of a converged iterate are those of the discrete solution, whichever body
/// took the Dirichlet step: η^glo and η^FE agree, η^NNDD vanishes, and η^glo bounds e_ref at
/// every estimated iteration of the Dirichlet step on body 2.
#[test]
fn the_estimates_do_not_depend_on_the_dirichlet_body() {
    let dir = scratch("dirichlet-body-estimates");
    let base = [
        "-nndd_n",
        "8",
        "-nndd_body1_E",
        "2.1e10",
        "-nndd_tol",
        "1e-12",
        "-nndd_estimate",
        "-nndd_estimate_every",
        "2",
        "-nndd_reference_factor",
        "4",
    ];
    let run = |body: &str| {
        let p = dir.join(format!("body{body}"));
        let j = solve(
            2,
            &p,
            &[&base[..], &["-nndd_dirichlet_body", body]].concat(),
        );
        assert_eq!(j["dirichlet_body"].as_u64().unwrap().to_string(), body);
        assert_eq!(j["status"], "converged", "Dirichlet step on body {body}");
        j
    };
    let (one, two) = (run("1"), run("2"));
    let last = |j: &serde_json::Value| j["estimates"].as_array().unwrap().last().unwrap().clone();
    let (a, b) = (last(&one), last(&two));
    for key in ["eta_glo", "eta_fe", "e_ref"] {
        let (x, y) = (f(&a, key), f(&b, key));
        assert!(rel(y, x) < 1e-6, "{key}: {y} (body 2) against {x} (body 1)");
    }
    for (j, e) in [(&one, &a), (&two, &b)] {
        assert!(
            f(e, "eta_nndd") < 1e-5 * f(e, "eta_glo"),
            "eta_NNDD {} of a converged iterate (Dirichlet step on body {})",
            f(e, "eta_nndd"),
            j["dirichlet_body"]
        );
        let r = &j["equilibrium_residuals"];
        for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
            assert!(f(r, key) < 1e-12, "residual {key}: {}", f(r, key));
        }
    }
    let estimates = two["estimates"].as_array().unwrap();
    assert!(estimates.len() >= 3, "{} estimates", estimates.len());
    for e in estimates {
        assert!(
            f(e, "eta_glo") >= f(e, "e_ref"),
            "iteration {}: eta_glo {} below e_ref {}",
            e["iteration"],
            f(e, "eta_glo"),
            f(e, "e_ref")
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A restart point remembers the body of the Dirichlet step (λ is that body's Γc
/// displacement) and the bodies of the Neumann step: a run that would put either elsewhere is
/// refused, and one with the same choices repeats the uninterrupted iterates.
#[test]
fn a_restart_keeps_the_dirichlet_body() {
    let dir = scratch("dirichlet-body-restart");
    let base = [
        "-nndd_n",
        "16",
        "-nndd_body1_E",
        "2.1e9",
        "-nndd_checkpoint_every",
        "2",
    ];
    let full = dir.join("full");
    let a = solve(2, &full, &base);
    assert_eq!(a["dirichlet_body"], 2);
    let checkpoint = dir.join("full.checkpoint.json");
    let cp = checkpoint.to_str().unwrap();
    let line = fails_with(
        2,
        &[
            &base[..],
            &["-nndd_restart", cp, "-nndd_dirichlet_body", "1"],
        ]
        .concat(),
        Some(1),
        &[
            "-nndd_restart",
            "its Dirichlet step is on body 2, this run's on body 1",
        ],
    );
    assert!(line.starts_with("nndd: error: "), "{line}");
    // θ auto with the stiffer body's Neumann step alone (auto): another update is refused too.
    fails_with(
        2,
        &[
            &base[..],
            &["-nndd_restart", cp, "-nndd_neumann_bodies", "both"],
        ]
        .concat(),
        Some(1),
        &[
            "-nndd_restart",
            "its Neumann step is taken by 'dirichlet', this run's by 'both'",
        ],
    );
    let again = dir.join("again");
    let b = solve(2, &again, &[&base[..], &["-nndd_restart", cp]].concat());
    assert_eq!(a["history"], b["history"]);
    assert_eq!(a["potential_energy"], b["potential_energy"]);
    std::fs::remove_dir_all(&dir).ok();
}

const HERTZ_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const HERTZ_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");

/// Hertz level 2 with the block (body 1) a thousand times softer than the cylinder, while the
/// contact set grows from nothing: `auto` gives the Dirichlet step to the stiffer cylinder and θ
/// auto converges in a few iterations to the monolithic solution. The Dirichlet step forced onto
/// the soft block is warned about and needs many more iterations, and its secant steps are
/// often short (a correction that cancels most of θ d, or one cut at a predicted change of the
/// contact set). A short step is not convergence: that run too ends at the monolithic solution
/// (a stop on ‖Δλ‖ alone reported 'converged' 56 iterations in, with one contact pair missing
/// and the energy 6.8e−5 off).
#[test]
fn hertz_with_a_soft_block_converges_either_way() {
    let dir = scratch("dirichlet-body-soft-block");
    let msh = gmsh_level(HERTZ_GEO, &dir, "hertz", 2);
    let soft = ["-nndd_body1_E", "2.1e8", "-nndd_body1_nu", "0.3"];
    let mono = solve_meshed(
        1,
        HERTZ_OPTS,
        &msh,
        &dir.join("mono"),
        &[&soft[..], &["-nndd_solver", "monolithic"]].concat(),
    );
    let em = f(&mono, "potential_energy");
    let run = |body: &str| {
        let j = solve_meshed(
            2,
            HERTZ_OPTS,
            &msh,
            &dir.join(format!("body{body}")),
            &[&soft[..], &["-nndd_dirichlet_body", body]].concat(),
        );
        assert_eq!(j["status"], "converged", "Dirichlet step {body}");
        let e = f(&j, "potential_energy");
        assert!(
            rel(e, em) < 1e-9,
            "Dirichlet step {body}: energy {e} against {em} after {} iterations",
            j["iterations"]
        );
        assert_eq!(
            j["contact_zone"], mono["contact_zone"],
            "Dirichlet step {body}"
        );
        assert_eq!(
            j["active_nodes"], mono["active_nodes"],
            "Dirichlet step {body}"
        );
        j
    };
    let auto = run("auto");
    assert_eq!(auto["dirichlet_body"], 2, "the stiffer cylinder");
    assert!(auto["warnings"].as_array().unwrap().is_empty());
    let it = f(&auto, "iterations");
    assert!((3.0..=30.0).contains(&it), "{it} iterations");
    let forced = run("1");
    let w = forced["warnings"].as_array().unwrap();
    assert!(
        w.iter().any(|w| w.as_str().unwrap().contains(
            "body 1 takes the Dirichlet step (-nndd_dirichlet_body 1) but is 1000 times softer than body 2"
        )),
        "{w:?}"
    );
    let it1 = f(&forced, "iterations");
    assert!(
        it1 > 2.0 * it,
        "Dirichlet step on body 1: {it1}, auto: {it} iterations"
    );
    std::fs::remove_dir_all(&dir).ok();
}
