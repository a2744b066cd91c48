//! Capability: a Gmsh example of the user's kind (examples/punch): a flat steel punch with
//! rounded corners pressed onto an aluminium foundation, with a horizontal traction on one
//! side. The interface is paired straight across, with g₀ = 0 under the flat bottom and
//! g₀ > 0 growing on the rounded corners; under the load the contact zone reaches onto the
//! corners. On 3 ranks the NNDD converges, equals the monolithic solve and the 1-rank NNDD;
//! the contact forces balance the reactions of the lid and of the clamped base; the
//! recovered stresses are exactly equilibrated and η^glo ≈ η^FE > 0.

mod common;
use common::*;
use nndd::fem::{assemble_stiffness, Material, Mesh};

use std::path::{Path, PathBuf};

const GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/punch/punch.geo");
const OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/punch/punch.opts");
/// The horizontal traction on the punch's right side (punch.opts) and that side's length
/// (punch.geo: from y = r = 0.2 up to the lid at y = h = 0.5).
const SIDE_TRACTION: f64 = -5e8;
const SIDE_LENGTH: f64 = 0.3;

/// `gmsh … -setnumber level LEVEL punch.geo -o DIR/punch-LEVEL.msh`.
fn mesh(dir: &Path, level: u32) -> PathBuf {
    gmsh_level(GEO, dir, "punch", level)
}

/// Solve examples/punch/punch.opts on `msh` (options after the file override it, the
/// output prefix too).
fn punch(np: usize, msh: &Path, prefix: &Path, extra: &[&str]) -> serde_json::Value {
    solve_meshed(np, OPTS, msh, prefix, extra)
}

fn converged(j: &serde_json::Value, what: &str, range: std::ops::RangeInclusive<f64>) {
    assert_eq!(j["status"], "converged", "{what}: {}", j["status"]);
    assert_eq!(j["converged"], true, "{what}");
    let it = f(j, "iterations");
    assert!(range.contains(&it), "{what}: {it} iterations");
}

/// The displacements (x, y per node) of `body` at step 0.
fn displacement(prefix: &Path, body: &str) -> Vec<f64> {
    field(prefix, body, "displacement")
        .chunks(3)
        .flat_map(|c| [c[0], c[1]])
        .collect()
}

/// Body `body`'s mesh as written to the results.
fn body_mesh(prefix: &Path, body: &str) -> Mesh {
    let points: Vec<[f64; 2]> = points(prefix, body)
        .chunks(2)
        .map(|p| [p[0], p[1]])
        .collect();
    let triangles = cells(prefix, body)
        .chunks(3)
        .map(|t| [t[0] as usize, t[1] as usize, t[2] as usize])
        .collect();
    Mesh::unstructured(points, triangles)
}

/// The resultant of the nodal forces K u of body `k` over its nodes on its top (the lid) or
/// its bottom (the base) line: the reaction there, plus any load on those nodes.
fn reaction(prefix: &Path, j: &serde_json::Value, k: usize, top: bool) -> [f64; 2] {
    let body = ["body1", "body2"][k];
    let mesh = body_mesh(prefix, body);
    let mat = Material {
        young: j["young"][k].as_f64().unwrap(),
        poisson: j["poisson"][k].as_f64().unwrap(),
    };
    let ku = assemble_stiffness(&mesh, &mat).matvec(&displacement(prefix, body));
    let y_line = if top {
        mesh.origin[1] + mesh.size[1]
    } else {
        mesh.origin[1]
    };
    let mut r = [0.0; 2];
    for (n, p) in mesh.points.iter().enumerate() {
        if (p[1] - y_line).abs() < 1e-9 {
            r[0] += ku[2 * n];
            r[1] += ku[2 * n + 1];
        }
    }
    r
}

#[test]
fn punch_on_three_ranks_equals_one_rank_and_the_monolithic_solve() {
    let dir = scratch("punch-ranks");
    let msh = mesh(&dir, 2);
    let mono = punch(1, &msh, &dir.join("mono"), &["-nndd_solver", "monolithic"]);
    assert_eq!(mono["status"], "solved");
    let tight = ["-nndd_tol", "1e-11"];
    let one = punch(1, &msh, &dir.join("n1"), &tight);
    let three = punch(3, &msh, &dir.join("n3"), &tight);
    assert_eq!(three["ranks"], 3);
    converged(&one, "1 rank", 5.0..=40.0);
    converged(&three, "3 ranks", 5.0..=40.0);
    let em = f(&mono, "potential_energy");
    let u_mono: Vec<Vec<f64>> = ["body1", "body2"]
        .iter()
        .map(|b| displacement(&dir.join("mono"), b))
        .collect();
    for (np, j) in [(1, &one), (3, &three)] {
        let p = dir.join(format!("n{np}"));
        let e = f(j, "potential_energy");
        let de = (e - em).abs() / em.abs();
        assert!(de < 1e-9, "{np} ranks: energy {e} vs monolithic {em}");
        assert_eq!(j["contact_zone"], mono["contact_zone"], "{np} ranks");
        assert_eq!(j["active_nodes"], mono["active_nodes"], "{np} ranks");
        for (k, b) in ["body1", "body2"].iter().enumerate() {
            let d = rel_max_diff(&displacement(&p, b), &u_mono[k]);
            println!("{np} ranks: {b} displacement vs monolithic {d:.2e}, energy {de:.2e}");
            assert!(d < 1e-8, "{np} ranks: {b} differs from monolithic by {d:e}");
        }
    }
    // 1 and 3 ranks: the same iteration, up to the round-off of the parallel solves.
    let (i1, i3) = (f(&one, "iterations"), f(&three, "iterations"));
    println!("iterations: {i1} on 1 rank, {i3} on 3 ranks");
    assert!(
        (i1 - i3).abs() <= 1.0,
        "iterations {i1} on 1 rank, {i3} on 3"
    );
    let (e1, e3) = (f(&one, "potential_energy"), f(&three, "potential_energy"));
    assert!((e1 - e3).abs() < 1e-12 * e1.abs(), "energy {e1} vs {e3}");
    for b in ["body1", "body2"] {
        let d = rel_max_diff(
            &displacement(&dir.join("n3"), b),
            &displacement(&dir.join("n1"), b),
        );
        println!("{b}: 3 ranks vs 1 rank {d:.2e}");
        assert!(d < 1e-12, "{b}: 3 ranks differ from 1 rank by {d:e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn punch_contact_reaches_the_rounded_corners_and_balances_the_loads() {
    let dir = scratch("punch-contact");
    let msh = mesh(&dir, 2);
    let p = dir.join("est");
    let j = punch(3, &msh, &p, &["-nndd_estimate"]);
    converged(&j, "punch.opts on 3 ranks", 4.0..=40.0);

    // g₀ of each pair from the geometry: the punch's lowest node straight above x_i.
    let x: Vec<f64> = points(&p, "contact").chunks(2).map(|c| c[0]).collect();
    let punch_pts: Vec<[f64; 2]> = points(&p, "body2")
        .chunks(2)
        .map(|c| [c[0], c[1]])
        .collect();
    let g0: Vec<f64> = x
        .iter()
        .map(|&xi| {
            punch_pts
                .iter()
                .filter(|q| (q[0] - xi).abs() < 1e-9)
                .fold(f64::INFINITY, |m, q| m.min(q[1]))
        })
        .collect();
    assert!(g0.iter().all(|g| g.is_finite() && *g >= 0.0), "{g0:?}");
    let active: Vec<bool> = field(&p, "contact", "active")
        .iter()
        .map(|&a| a > 0.5)
        .collect();
    let gap = field(&p, "contact", "gap");
    let force = field(&p, "contact", "normal_force");
    let m = x.len();
    for i in 0..m {
        if active[i] {
            assert!(
                gap[i].abs() < 1e-12,
                "gap {} at active x = {}",
                gap[i],
                x[i]
            );
            assert!(force[i] > 0.0, "force {} at active x = {}", force[i], x[i]);
        } else {
            assert!(gap[i] > 0.0, "gap {} at open x = {}", gap[i], x[i]);
            assert_eq!(force[i], 0.0, "force at open x = {}", x[i]);
        }
    }
    // The flat bottom (g₀ = 0) is in contact; so are pairs on both rounded corners (g₀ > 0),
    // but not the ends of the paired interface.
    let flat: Vec<f64> = (0..m).filter(|&i| g0[i] == 0.0).map(|i| x[i]).collect();
    let (flat_lo, flat_hi) = (flat[0], flat[flat.len() - 1]);
    assert!((0..m).filter(|&i| g0[i] == 0.0).all(|i| active[i]));
    let corner = |left: bool| {
        (0..m)
            .filter(|&i| active[i] && g0[i] > 0.0 && (x[i] < 0.0) == left)
            .count()
    };
    let (left, right) = (corner(true), corner(false));
    assert!(
        left >= 3 && right >= 3,
        "closed pairs on the corners: {left} left, {right} right"
    );
    assert!(
        !active[0] && !active[m - 1],
        "contact reaches the interface's ends"
    );
    let zone = &j["contact_zone"];
    let (z0, z1) = (zone[0].as_f64().unwrap(), zone[1].as_f64().unwrap());
    assert!(
        z0 < flat_lo && z1 > flat_hi,
        "zone [{z0}, {z1}] vs flat [{flat_lo}, {flat_hi}]"
    );
    let g0_max = (0..m)
        .filter(|&i| active[i])
        .fold(0.0f64, |a, i| a.max(g0[i]));
    println!(
        "contact zone [{z0}, {z1}] (width {:.4}) vs flat bottom [{flat_lo}, {flat_hi}] (width {:.4}); \
         {left} + {right} closed pairs on the corners, largest closed g0 {g0_max:.3e}",
        z1 - z0,
        flat_hi - flat_lo
    );

    // Equilibrium: the contact force (vertical, frictionless) is what the lid pushes and
    // the base holds; the side traction is held by the lid alone.
    let fc = f(&j, "contact_force");
    assert!(fc > 0.0);
    assert!((force.iter().sum::<f64>() - fc).abs() < 1e-9 * fc);
    // The lid's right corner also carries the side traction of the side's top segment.
    let mut lid = reaction(&p, &j, 1, true);
    let (x_max, y_max) = (
        punch_pts.iter().fold(f64::MIN, |a, q| a.max(q[0])),
        punch_pts.iter().fold(f64::MIN, |a, q| a.max(q[1])),
    );
    let below = punch_pts
        .iter()
        .filter(|q| (q[0] - x_max).abs() < 1e-9 && q[1] < y_max - 1e-9)
        .fold(f64::MIN, |a, q| a.max(q[1]));
    lid[0] -= 0.5 * SIDE_TRACTION * (y_max - below);
    let base = reaction(&p, &j, 0, false);
    let side = SIDE_TRACTION * SIDE_LENGTH;
    println!(
        "contact force {fc:.9e}, lid reaction {lid:?}, base reaction {base:?}, side load {side:.3e}; \
         relative: lid y {:.1e}, lid x {:.1e}, base y {:.1e}, base x {:.1e}",
        (lid[1] + fc).abs() / fc,
        (lid[0] + side).abs() / fc,
        (base[1] - fc).abs() / fc,
        base[0].abs() / fc
    );
    // The contact step's body (the foundation: the punch is the stiffer body and takes the
    // Dirichlet step) takes the contact forces as Neumann data: its balance is exact; the
    // Dirichlet step's body's (its Γc displacements are λ) holds to the NNDD's tolerance.
    assert_eq!(
        j["dirichlet_body"], 2,
        "the stiffer punch takes the Dirichlet step"
    );
    let (exact, to_tol) = (1e-10 * fc, 1e-6 * fc);
    assert!(
        (lid[1] + fc).abs() < to_tol,
        "lid {lid:?} vs contact force {fc}"
    );
    assert!(
        (lid[0] + side).abs() < to_tol,
        "lid {lid:?} vs side load {side}"
    );
    assert!(
        (base[1] - fc).abs() < exact,
        "base {base:?} vs contact force {fc}"
    );
    // The contact forces' horizontal parts (on the rounded corners) cancel out.
    assert!(
        base[0].abs() < exact,
        "base {base:?}: a horizontal reaction"
    );

    // The estimates: exactly equilibrated stresses, η^glo ≈ η^FE > 0, η^NNDD small.
    let res = &j["equilibrium_residuals"];
    for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
        assert!(f(res, key) < 1e-12, "{key}: {res}");
    }
    let est = &j["estimates"][0];
    let (glo, fe, nn) = (f(est, "eta_glo"), f(est, "eta_fe"), f(est, "eta_nndd"));
    println!("eta_glo {glo:.6e}, eta_FE {fe:.6e}, eta_NNDD {nn:.3e}");
    // (η^glo and η^FE come from different admissible fields, so either may be the larger
    // near convergence: they agree to η^NNDD's size.)
    assert!(
        fe > 0.0 && (glo / fe - 1.0).abs() < 1e-2,
        "eta_glo {glo}, eta_FE {fe}"
    );
    assert!(nn < 1e-4 * glo, "eta_NNDD {nn} vs eta_glo {glo}");
    std::fs::remove_dir_all(&dir).ok();
}
