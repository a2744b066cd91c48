//! Capability: a body held only by contact (force-controlled contact, docs/method.md §2, "A
//! body held only by contact"): a roller and a load leave its rigid motion free, the contact
//! holds it. It takes the Dirichlet step, no Neumann step; the monolithic solve condenses it
//! through its Dirichlet system.

mod common;
use common::*;
use std::path::Path;

const BLOCKS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/floating/blocks.geo");

/// The two blocks of tests/floating/blocks.geo pressed by p on body 2's lid: rollers on both
/// left sides and under body 1, nothing holding body 2 vertically but the contact.
fn blocks_args(msh: &Path) -> Vec<String> {
    [
        "-nndd_mesh",
        msh.to_str().unwrap(),
        "-nndd_contact",
        "top1,bottom2",
        "-nndd_bc_base_uy",
        "0",
        "-nndd_bc_left1_ux",
        "0",
        "-nndd_bc_left2_ux",
        "0",
        "-nndd_bc_lid_traction",
        "0,-1e8",
        "-nndd_tol",
        "1e-12",
    ]
    .into_iter()
    .chain(ALUMINIUM_ON_STEEL)
    .map(String::from)
    .collect()
}

/// The patch test under a load: σ_yy = −p and σ_xx = 0 in both bodies (plane strain), so
/// u_x = ε_xx x and u_y = ε_yy (y + ½) in body 1, u_y = ½ε¹_yy + ε²_yy y in body 2, with
/// ε_xx = ν(1 + ν)p/E and ε_yy = −(1 − ν²)p/E; the potential energy is −½ p ∫ u_y over the lid.
/// P1 displacements hold it exactly: every node to round-off, on matching sizes and on
/// contact sides meshed 1:10, on 1, 2 and 3 ranks, by the NNDD and the monolithic solve.
#[test]
fn a_roller_and_a_load_give_the_exact_patch_solution() {
    let dir = scratch("floating-patch");
    let p = 1e8;
    let (e, nu) = ([7e10, 2.1e11], [0.33, 0.3]);
    let exx = [0, 1].map(|k| nu[k] * (1.0 + nu[k]) * p / e[k]);
    let eyy = [0, 1].map(|k| -(1.0 - nu[k] * nu[k]) * p / e[k]);
    let exact = |k: usize, x: [f64; 2]| -> [f64; 2] {
        match k {
            0 => [exx[0] * x[0], eyy[0] * (x[1] + 0.5)],
            _ => [exx[1] * x[0], 0.5 * eyy[0] + eyy[1] * x[1]],
        }
    };
    let energy = 0.5 * p * (0.5 * eyy[0] + 0.5 * eyy[1]);
    for (h1, h2) in [("0.125", "0.1"), ("0.2", "0.02")] {
        let msh = dir.join(format!("blocks-{h2}.msh"));
        gmsh(BLOCKS, &[("h1", h1), ("h2", h2)], &[], &msh);
        let args = blocks_args(&msh);
        for (np, solver) in [(1, "nndd"), (2, "nndd"), (3, "nndd"), (2, "monolithic")] {
            let prefix = dir.join(format!("b{h2}-{np}-{solver}"));
            let mut a: Vec<&str> = args.iter().map(String::as_str).collect();
            a.extend(["-nndd_solver", solver]);
            let j = solve(np, &prefix, &a);
            let what = format!("h1 {h1} h2 {h2}, {np} rank(s), {solver}");
            assert_eq!(j["converged"], true, "{what}");
            // Curves that do not match: `auto` would couple them by mortar, which a body held
            // only by contact does not have yet, so they are made to match, and the run says so.
            assert_eq!(
                j["contact_curves"]["discretisation"], "node_to_node",
                "{what}"
            );
            assert!(
                j["warnings"]
                    .to_string()
                    .contains("held only by contact, which the mortar"),
                "{what}: {}",
                j["warnings"]
            );
            // (on several ranks world rank 0 alone made them match and built the bodies)
            let file: Vec<u64> =
                serde_json::from_value(j["input_file_points_per_rank"].clone()).unwrap();
            assert!(
                file[0] > 0 && file[1..].iter().all(|&n| n == 0),
                "{what}: {file:?}"
            );
            if solver == "nndd" {
                assert_eq!(j["dirichlet_body"], 2, "{what}: the body held by contact");
                assert_eq!(j["neumann_step"][1], "none", "{what}");
            }
            let en = f(&j, "potential_energy");
            assert!(
                (en - energy).abs() < 1e-10 * energy.abs(),
                "{what}: energy {en:e} vs {energy:e}"
            );
            let force = f(&j, "contact_force");
            assert!(
                (force - p).abs() < 1e-10 * p,
                "{what}: contact force {force:e}"
            );
            let mut worst = 0.0f64;
            for k in 0..2 {
                let grid = format!("body{}", k + 1);
                let (x, u) = (
                    points(&prefix, &grid),
                    field(&prefix, &grid, "displacement"),
                );
                let per = u.len() / (x.len() / 2);
                for (i, xy) in x.chunks(2).enumerate() {
                    let ue = exact(k, [xy[0], xy[1]]);
                    for c in 0..2 {
                        worst = worst.max((u[per * i + c] - ue[c]).abs());
                    }
                }
            }
            let scale = 0.5 * (eyy[0] + eyy[1]).abs();
            println!("{what}: energy {en:.12e} (exact {energy:.12e}), |u - u_exact| {worst:.1e}");
            assert!(worst < 1e-10 * scale, "{what}: |u − u_exact| = {worst:e}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// examples/hertz/hertz-force.opts: the cylinder's lid on a roller and loaded on that same
/// curve (`-nndd_bc_lid_ux 0` with `-nndd_bc_lid_traction 0,-3e8`), the cylinder held vertically by
/// the contact alone: the NNDD equals the monolithic solve, on 1 and 3 ranks as on 2, and the
/// contact force is the load (3e8 Pa on the 2 m lid).
#[test]
fn force_controlled_hertz_equals_the_monolithic_solve() {
    let dir = scratch("floating-hertz");
    let geo = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
    let msh = gmsh_level(geo, &dir, "hertz", 1);
    let opts = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/hertz/hertz-force.opts"
    );
    let run = |np: usize, solver: &str| {
        let prefix = dir.join(format!("h-{np}-{solver}"));
        solve_meshed(np, opts, &msh, &prefix, &["-nndd_solver", solver])
    };
    let mono = run(2, "monolithic");
    let fit = hertz_fit_of(&dir.join("h-2-monolithic"));
    println!(
        "force-controlled hertz level 1: a {:.5} vs Hertz {:.5} ({:.2} %), p0 {:.4e} vs {:.4e} ({:.2} %)",
        fit.a_h, fit.a, 100.0 * fit.a_err(), fit.p0_h, fit.p0, 100.0 * fit.p0_err()
    );
    // Hertz's a and p₀ for the applied force (0.7 % and 2.0 % here, level 1).
    assert!((fit.force - 6e8).abs() < 1e-8 * 6e8, "force {}", fit.force);
    assert!(fit.a_err() < 0.05 && fit.p0_err() < 0.05, "{fit:?}");
    let em = f(&mono, "potential_energy");
    for np in [1, 2, 3] {
        let j = run(np, "nndd");
        let e = f(&j, "potential_energy");
        println!(
            "force-controlled hertz, {np} rank(s): {} iterations, energy {e:.12e} (monolithic {em:.12e})",
            j["iterations"]
        );
        assert_eq!(j["status"], "converged");
        assert!(
            (e - em).abs() < 1e-8 * em.abs(),
            "{np} ranks: {e:e} vs {em:e}"
        );
        let force = f(&j, "contact_force");
        assert!(
            (force - 6e8).abs() < 1e-8 * 6e8,
            "{np} ranks: force {force:e}"
        );
    }
    // Level 3: Hertz's half-width and peak pressure for the applied force within 3 %.
    let msh3 = gmsh_level(geo, &dir, "hertz", 3);
    let j = solve_meshed(2, opts, &msh3, &dir.join("h3"), &[]);
    assert_eq!(j["status"], "converged");
    let fit = hertz_fit_of(&dir.join("h3"));
    println!(
        "force-controlled hertz level 3: {} iterations, a {:.5} vs Hertz {:.5} ({:.2} %), p0 {:.4e} vs {:.4e} ({:.2} %)",
        j["iterations"], fit.a_h, fit.a, 100.0 * fit.a_err(), fit.p0_h, fit.p0, 100.0 * fit.p0_err()
    );
    assert!(fit.a_err() < 0.03 && fit.p0_err() < 0.03, "{fit:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// What a body held only by contact cannot do, each refused in one line naming the option.
#[test]
fn what_a_body_held_by_contact_cannot_do_is_refused() {
    let dir = scratch("floating-refused");
    let msh = dir.join("blocks.msh");
    gmsh(BLOCKS, &[], &[], &msh);
    let base = blocks_args(&msh);
    let with = |drop: &[&str], extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = Vec::new();
        let mut it = base.iter();
        while let Some(k) = it.next() {
            let v = it.next().unwrap();
            if !drop.contains(&k.as_str()) {
                a.extend([k.clone(), v.clone()]);
            }
        }
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let cases: [(Vec<String>, &[&str]); 6] = [
        (
            with(&[], &["-nndd_estimate"]),
            &["-nndd_estimate", "held only by contact"],
        ),
        (
            with(&[], &["-nndd_dirichlet_body", "1"]),
            &["-nndd_dirichlet_body", "use auto or 2"],
        ),
        (
            with(&[], &["-nndd_dirichlet_step", "condensed"]),
            &["-nndd_dirichlet_step condensed", "use auto or system"],
        ),
        // Nothing holds body 2 horizontally, with or without the contact.
        (
            with(&["-nndd_bc_left2_ux"], &[]),
            &["body 2 can move as a rigid body, even pressed"],
        ),
        // Both bodies held only by contact: nothing holds the pair.
        (
            with(&["-nndd_bc_base_uy"], &["-nndd_bc_base_traction", "0,1e8"]),
            &["neither body is held"],
        ),
        // A load along the roller's component.
        (
            with(
                &[],
                &[
                    "-nndd_bc_lid_ux",
                    "0",
                    "-nndd_bc_lid_traction_end",
                    "1e6,-1e8",
                ],
            ),
            &["-nndd_bc_lid_traction", "nonzero tx"],
        ),
    ];
    for (args, needles) in cases {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        for np in [1, 2] {
            fails_with(np, &a, Some(1), needles);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
