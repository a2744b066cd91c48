//! Capability: body 1's contact side need not be horizontal. The contact
//! direction of a pair is body 1's outward normal at its node; where it is not (0, 1) the pair's
//! nodes get rotated nodal frames.
//! - `paper` turned by an angle φ (its mesh file's nodes rotated, its data rotated) is the same
//!   problem: the same energy, contact force, iterations and estimates, and the displacements
//!   are the turned ones; every pair's direction is the turned (0, 1).
//! - examples/pin: a pin pressed into a cylindrical groove of body 1 (a concave, curved contact
//!   side): on 3 ranks the NNDD equals the monolithic solve and the 1-rank NNDD, the contact
//!   directions are the groove's radii, the contact arc is symmetric to a mesh spacing, the
//!   recovered stresses are equilibrated to round-off and η^glo ≥ e_ref.
//! - A displacement prescribed at a rotated contact node is refused, naming the option.

mod common;
use common::*;

use std::path::{Path, PathBuf};

const PAPER_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper/paper.opts");
const PIN_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.geo");
const PIN_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.opts");

/// The turn of the rotated `paper` (rad).
const PHI: f64 = 0.3;

/// `src` (MSH 4.1 ASCII) with its nodes turned by `phi` about the origin, written to `dst`.
fn rotate_msh(src: &Path, dst: &Path, phi: f64) {
    let text = std::fs::read_to_string(src).unwrap();
    let (c, s) = (phi.cos(), phi.sin());
    let mut out = String::with_capacity(text.len());
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        out.push_str(line);
        out.push('\n');
        if line != "$Nodes" {
            continue;
        }
        let head: Vec<usize> = lines
            .next()
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        out.push_str(&format!(
            "{} {} {} {}\n",
            head[0], head[1], head[2], head[3]
        ));
        for _ in 0..head[0] {
            let block = lines.next().unwrap();
            out.push_str(block);
            out.push('\n');
            let b: Vec<usize> = block
                .split_whitespace()
                .map(|v| v.parse().unwrap())
                .collect();
            assert_eq!(b[2], 0, "no parametric coordinates");
            for _ in 0..b[3] {
                out.push_str(lines.next().unwrap());
                out.push('\n');
            }
            for _ in 0..b[3] {
                let p: Vec<f64> = lines
                    .next()
                    .unwrap()
                    .split_whitespace()
                    .map(|v| v.parse().unwrap())
                    .collect();
                let (x, y) = (c * p[0] - s * p[1], s * p[0] + c * p[1]);
                out.push_str(&format!("{x:e} {y:e} {:e}\n", p[2]));
            }
        }
    }
    std::fs::write(dst, out).unwrap();
}

fn turn(v: [f64; 2], phi: f64) -> [f64; 2] {
    let (c, s) = (phi.cos(), phi.sin());
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

/// examples/paper/paper.opts's data (u on the top, the linear load on the right) turned by
/// `phi`, as options that override the file's.
fn turned_data(phi: f64) -> Vec<String> {
    let u = turn([0.0, -1e-4], phi);
    let t = turn([0.0, 1e7], phi);
    [
        ("-nndd_bc_top_ux", format!("{:e}", u[0])),
        ("-nndd_bc_top_uy", format!("{:e}", u[1])),
        ("-nndd_bc_right2_traction", format!("{:e},{:e}", t[0], t[1])),
    ]
    .into_iter()
    .flat_map(|(k, v)| [k.to_string(), v])
    .collect()
}

fn paper_mesh(dir: &Path) -> PathBuf {
    let out = dir.join("paper-8.msh");
    gmsh(PAPER_GEO, &[("n", "8")], &[], &out);
    out
}

fn vectors(prefix: &Path, grid: &str, name: &str) -> Vec<[f64; 2]> {
    field(prefix, grid, name)
        .chunks(3)
        .map(|c| [c[0], c[1]])
        .collect()
}

/// The summary calls η^glo a guaranteed bound and names the problem it refers to.
fn meaning_says_guaranteed(j: &serde_json::Value) -> bool {
    let text = j["estimate_meaning"]["eta_glo"].as_str().unwrap_or("");
    text.starts_with("guaranteed upper bound") && text.contains("interpolates the nodal normals")
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn paper_turned_is_the_same_problem() {
    let dir = scratch("curved-turned");
    let msh = paper_mesh(&dir);
    let turned = dir.join("paper-8-turned.msh");
    rotate_msh(&msh, &turned, PHI);
    let (a, b) = (dir.join("flat"), dir.join("turned"));
    let est = ["-nndd_estimate", "-nndd_reference_factor", "2"];
    let ja = solve_meshed(2, PAPER_OPTS, &msh, &a, &est);
    let data = turned_data(PHI);
    let mut extra: Vec<&str> = data.iter().map(|s| s.as_str()).collect();
    extra.extend_from_slice(&est);
    let jb = solve_meshed(2, PAPER_OPTS, &turned, &b, &extra);
    for j in [&ja, &jb] {
        assert_eq!(j["status"], "converged");
    }
    assert_eq!(ja["iterations"], jb["iterations"], "the same iterates");
    for key in ["potential_energy", "contact_force"] {
        let (x, y) = (f(&jb, key), f(&ja, key));
        assert!(rel(x, y) < 1e-9, "{key}: turned {x:e}, flat {y:e}");
    }
    assert_eq!(ja["active_nodes"], jb["active_nodes"]);
    let (ea, eb) = (&ja["estimates"][0], &jb["estimates"][0]);
    for key in ["eta_glo", "eta_fe", "e_ref"] {
        let (x, y) = (f(eb, key), f(ea, key));
        assert!(rel(x, y) < 1e-8, "{key}: turned {x:e}, flat {y:e}");
    }
    // η^NNDD of the converged NNDD is at the level of the stopping test: equal to 1e−6 η^glo.
    let (x, y) = (f(eb, "eta_nndd"), f(ea, "eta_nndd"));
    assert!(
        (x - y).abs() < 1e-6 * f(ea, "eta_glo"),
        "eta_nndd: turned {x:e}, flat {y:e}"
    );
    assert!(f(eb, "eta_glo") >= f(eb, "e_ref"), "the bound, turned");
    for j in [&ja, &jb] {
        assert!(meaning_says_guaranteed(j));
        // A straight side, turned or not: no correction of û.
        assert_eq!(f(&j["estimates"][0], "eta_glo_correction"), 0.0);
    }
    // The displacements are the flat ones turned; every contact direction is the turned (0, 1).
    for body in ["body1", "body2"] {
        let (ua, ub) = (
            vectors(&a, body, "displacement"),
            vectors(&b, body, "displacement"),
        );
        let scale = ua.iter().fold(0.0f64, |m, u| m.max(u[0].hypot(u[1])));
        for (u, v) in ua.iter().zip(&ub) {
            let w = turn(*u, PHI);
            let d = (w[0] - v[0]).hypot(w[1] - v[1]);
            assert!(d < 1e-9 * scale, "{body}: {v:?} vs turned {w:?}");
        }
    }
    let up = turn([0.0, 1.0], PHI);
    for n in vectors(&b, "contact", "normal") {
        assert!(
            (n[0] - up[0]).abs() < 1e-12 && (n[1] - up[1]).abs() < 1e-12,
            "{n:?}"
        );
    }
    let r = &jb["equilibrium_residuals"];
    for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
        assert!(f(r, key) < 1e-12, "turned residual {key}: {}", f(r, key));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pin_in_a_groove() {
    let dir = scratch("curved-pin");
    let msh = gmsh_level(PIN_GEO, &dir, "pin", 1);
    let (p3, p1, mono) = (dir.join("nndd3"), dir.join("nndd1"), dir.join("mono"));
    let j3 = solve_meshed(
        3,
        PIN_OPTS,
        &msh,
        &p3,
        &["-nndd_estimate", "-nndd_reference_factor", "2"],
    );
    let j1 = solve_meshed(1, PIN_OPTS, &msh, &p1, &[]);
    let jm = solve_meshed(2, PIN_OPTS, &msh, &mono, &["-nndd_solver", "monolithic"]);
    // CG + GAMG on both bodies: the rigid-body near null space in the rotated frames.
    let mut gamg_args = Vec::new();
    for body in ["body1", "body2"] {
        for (k, v) in [
            ("ksp_type", "cg"),
            ("ksp_norm_type", "unpreconditioned"),
            ("ksp_rtol", "1e-12"),
            ("ksp_max_it", "200"),
            ("pc_type", "gamg"),
        ] {
            gamg_args.push(format!("-{body}_{k}"));
            gamg_args.push(v.to_string());
        }
    }
    let gamg: Vec<&str> = gamg_args.iter().map(|s| s.as_str()).collect();
    let jg = solve_meshed(3, PIN_OPTS, &msh, &dir.join("gamg"), &gamg);
    assert_eq!(jg["dirichlet_step"], "system", "body 1 on 2 ranks");
    assert_eq!(jg["iterations"], j3["iterations"]);
    for j in [&j3, &j1, &jg] {
        assert_eq!(j["status"], "converged");
        let it = f(j, "iterations");
        assert!((5.0..=40.0).contains(&it), "{it} iterations");
    }
    let e = f(&jm, "potential_energy");
    for j in [&j3, &j1] {
        let x = f(j, "potential_energy");
        assert!(rel(x, e) < 1e-9, "NNDD energy {x:e} vs monolithic {e:e}");
    }
    for body in ["body1", "body2"] {
        let u = |p: &Path| field(p, body, "displacement");
        let d = rel_max_diff(&u(&p3), &u(&p1));
        assert!(d < 1e-9, "{body}: 3 vs 1 rank(s) differ by {d:e}");
        let d = rel_max_diff(&u(&p3), &u(&mono));
        assert!(d < 1e-6, "{body}: NNDD vs monolithic differ by {d:e}");
    }
    // The contact directions: the groove's radii, toward its centre (0, R1 = 1), except at the
    // two end nodes (the end segments' normals); none is (0, 1) but the bottom's.
    let pts: Vec<[f64; 2]> = points(&p3, "contact")
        .chunks(2)
        .map(|p| [p[0], p[1]])
        .collect();
    let normals = vectors(&p3, "contact", "normal");
    let m = pts.len();
    for k in 1..m - 1 {
        let r = [0.0 - pts[k][0], 1.0 - pts[k][1]];
        let len = r[0].hypot(r[1]);
        let n = normals[k];
        assert!(
            (n[0] - r[0] / len).abs() < 1e-9 && (n[1] - r[1] / len).abs() < 1e-9,
            "pair {k}: normal {n:?}, radius {r:?}"
        );
    }
    // The contact arc: symmetric to a segment (the meshes of the two halves differ).
    let zone = &j3["contact_zone"];
    let (x0, x1) = (zone[0].as_f64().unwrap(), zone[1].as_f64().unwrap());
    let h = (pts[1][0] - pts[0][0]).hypot(pts[1][1] - pts[0][1]);
    assert!(x0 < -0.2 && x1 > 0.2, "the arc grew: [{x0}, {x1}]");
    assert!((x0 + x1).abs() <= 1.5 * h, "zone [{x0}, {x1}], spacing {h}");
    // Rotated frames touch the estimator: exact equilibrium and the bound.
    let r = &j3["equilibrium_residuals"];
    for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
        assert!(f(r, key) < 1e-12, "residual {key}: {}", f(r, key));
    }
    let est = &j3["estimates"][0];
    // A curved side: the bound is proved there too (docs/method.md §5).
    assert!(meaning_says_guaranteed(&j3));
    let (glo, eref) = (f(est, "eta_glo"), f(est, "e_ref"));
    assert!(
        glo >= eref && glo < 2.0 * eref,
        "eta_glo {glo:e}, e_ref {eref:e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn no_displacement_at_a_rotated_contact_node() {
    let dir = scratch("curved-bad");
    let msh = gmsh_level(PIN_GEO, &dir, "pin", 1);
    let m = msh.to_str().unwrap();
    refused(
        2,
        &[
            "-options_file",
            PIN_OPTS,
            "-nndd_mesh",
            m,
            "-nndd_bc_groove_ux",
            "0",
        ],
        "-nndd_bc_groove_ux",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The estimates of the pin in its hole at reference factors 4, 6, 8: (η^glo, [e_ref]),
/// after the per-run checks (converged, equilibrium to round-off, the bound `checked`).
fn hole_estimates(dir: &Path, msh: &Path, name: &str) -> (f64, [f64; 3], serde_json::Value) {
    let mut eta = 0.0;
    let mut e_ref = [0.0; 3];
    let mut last = serde_json::Value::Null;
    for (i, r) in ["4", "6", "8"].into_iter().enumerate() {
        let prefix = dir.join(format!("{name}-r{r}"));
        let j = solve_meshed(
            2,
            PIN_HOLE_OPTS,
            msh,
            &prefix,
            &[
                "-nndd_estimate",
                "-nndd_reference_factor",
                r,
                NODE_TO_NODE[0],
                NODE_TO_NODE[1],
            ],
        );
        assert_eq!(j["status"], "converged");
        assert!(meaning_says_guaranteed(&j));
        let res = &j["equilibrium_residuals"];
        for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
            assert!(
                f(res, key) < 1e-12,
                "{name} r = {r}: residual {key} {}",
                f(res, key)
            );
        }
        let est = &j["estimates"][0];
        (eta, e_ref[i]) = (f(est, "eta_glo"), f(est, "e_ref"));
        // The sliding along the curved sides needs the correction δ of û (docs/method.md §5).
        let delta = f(est, "eta_glo_correction");
        assert!(
            delta > 0.0 && delta < 0.5 * eta,
            "{name}: ‖δ‖ {delta:e}, eta_glo {eta:e}"
        );
        println!(
            "pin in its hole ({name}), r = {r}: eta_glo {eta:.6e} (of which ‖δ‖_E {delta:.4e}), e_ref {:.6e}, effectivity {:.4}",
            e_ref[i],
            eta / e_ref[i]
        );
        last = j;
    }
    (eta, e_ref, last)
}

/// The pin in its hole (examples/pin-hole, the curves matched): both contact sides curved,
/// the pin sliding some 40 µm along the hole at the ends of the contact arc. The reference
/// solution refers to the problem nndd solves (the normal field of the user's mesh, docs/
/// method.md §5), so e_ref converges as r grows and η^glo bounds it at r = 4, 6, 8 and the
/// extrapolated true error, within 1.3 of e_ref(8). (A reference with the fine segments' own
/// normals solves a polygon whose corners lock the sliding: its e_ref grows to 1.25 at r = 8,
/// above η^glo 1.12, and keeps growing.)
#[test]
fn pin_in_its_hole() {
    let dir = scratch("curved-hole");
    let msh = gmsh_level(PIN_HOLE_GEO, &dir, "pin-hole", 1);
    let (eta, e_ref, j) = hole_estimates(&dir, &msh, "matched");
    // The curves' end nodes were moved onto their partners, nothing inserted.
    let warnings = j["warnings"].to_string();
    assert!(!warnings.contains("degenerate"), "{warnings}");
    assert!(e_ref[0] < e_ref[1] && e_ref[1] < e_ref[2], "{e_ref:?}");
    let (q, e_inf) = extrapolate::extrapolate([4.0, 6.0, 8.0], e_ref).expect("e_ref grows with r");
    println!("pin in its hole (matched): extrapolated true error {e_inf:.6e} (q = {q:.2}), effectivity {:.4}", eta / e_inf);
    for e in e_ref.iter().chain([&e_inf]) {
        assert!(eta >= *e, "eta_glo {eta:e} < {e:e}");
    }
    assert!(
        eta <= 1.3 * e_ref[2],
        "eta_glo {eta:e}, e_ref(8) {:e}",
        e_ref[2]
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The pin in its hole with the pin's arc meshed on its own (2:3): the estimate's contact
/// traction t̂ carries the FE contact force (resultant to the NNDD's tolerance: the forces
/// alternate from node to node there, and clipping their consistent density's tensile lobes
/// would add half the force), and η^glo bounds e_ref at r = 4, 6, 8.
#[test]
fn pin_in_its_hole_meshed_on_its_own() {
    let dir = scratch("curved-hole-own");
    let msh = dir.join("pin-hole-1.5.msh");
    gmsh(PIN_HOLE_GEO, &[("level", "1"), ("ratio", "1.5")], &[], &msh);
    let (eta, e_ref, _) = hole_estimates(&dir, &msh, "independent");
    for e in e_ref {
        assert!(eta >= e, "eta_glo {eta:e} < e_ref {e:e}");
    }
    let prefix = dir.join("independent-r8");
    let xy: Vec<[f64; 2]> = points(&prefix, "contact")
        .chunks(2)
        .map(|p| [p[0], p[1]])
        .collect();
    let (hat, force) = (
        field(&prefix, "contact", "pressure_hat"),
        field(&prefix, "contact", "normal_force"),
    );
    let resultant: f64 = (0..xy.len() - 1)
        .map(|k| {
            let h = (xy[k + 1][0] - xy[k][0]).hypot(xy[k + 1][1] - xy[k][1]);
            0.5 * h * (hat[k] + hat[k + 1])
        })
        .sum();
    let total: f64 = force.iter().sum();
    println!("pin in its hole (independent): t_hat resultant {resultant:.9e}, FE normal force {total:.9e}");
    assert!(rel(resultant, total) < 1e-8, "{resultant:e} vs {total:e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Contact curves spanning more than a half circle (the pin in its hole with arcs of ±150°, 300°
/// in all, the curves matched): paired and solved, the NNDD equal to the monolithic solve.
#[test]
fn contact_curves_beyond_a_half_circle() {
    let dir = scratch("curved-arc");
    let msh = dir.join("pin-hole-arc.msh");
    gmsh(PIN_HOLE_GEO, &[("level", "1"), ("arc", "150")], &[], &msh);
    let a = solve_meshed(2, PIN_HOLE_OPTS, &msh, &dir.join("nndd"), &[]);
    let m = solve_meshed(
        2,
        PIN_HOLE_OPTS,
        &msh,
        &dir.join("mono"),
        &["-nndd_solver", "monolithic"],
    );
    assert_eq!(a["status"], "converged");
    let n = a["contact_nodes"].as_u64().unwrap();
    assert_eq!(n, 33, "every node of the 300° arcs paired");
    let (e, em) = (f(&a, "potential_energy"), f(&m, "potential_energy"));
    assert!(rel(e, em) < 1e-8, "{e:e} vs {em:e}");
    std::fs::remove_dir_all(&dir).ok();
}
