//! Capability: a Gmsh problem's bodies built once (`-nndd_mesh_input root`, the default on
//! several ranks). World rank 0 builds both bodies and partitions them; every other rank is
//! sent the part of its group's body it reads and never holds a whole body, and the run
//! writes exactly what it writes when every rank builds both bodies (`every_rank`).

mod common;
use common::*;

/// `paper` drawn in Gmsh (2048 elements per body) on 2, 3 and 5 ranks, METIS's parts and
/// index blocks: the parsed file is held on world rank 0 alone (the summary's
/// `input_file_points_per_rank`; on every rank under `every_rank`), and
/// `input_mesh_elements_per_rank` is both bodies' 4096 on world rank 0 and the part sent on each other rank (the whole body on a body's only rank, else at
/// most two shares of it and METIS's 3 % imbalance: its partition and its block of the
/// output), 4096 on every rank under `every_rank`; the result files are the same (the meshes
/// value for value, the fields to round-off), and the solution the same as one rank's.
#[test]
fn ranks_other_than_the_first_are_sent_their_parts_and_write_what_every_rank_building_writes() {
    let dir = scratch("mesh-input");
    let problem = paper_drawn_in_gmsh(&dir);
    let mut args: Vec<&str> = problem.iter().map(String::as_str).collect();
    args.extend(["-nndd_tol", "1e-12"]);
    let one = solve(1, &dir.join("one"), &args);
    for (ranks, partition) in [(2, "metis"), (3, "metis"), (5, "metis"), (5, "blocks")] {
        let run = |input: &str| {
            let prefix = dir.join(format!("{ranks}-{partition}-{input}"));
            let mut a = args.clone();
            a.extend(["-nndd_mesh_input", input, "-nndd_partition", partition]);
            (solve(ranks, &prefix, &a), prefix)
        };
        let (root, root_h5) = run("root");
        let (every, every_h5) = run("every_rank");
        let input = |j: &serde_json::Value| -> Vec<u64> {
            let list = j["input_mesh_elements_per_rank"].as_array().unwrap();
            list.iter().map(|n| n.as_u64().unwrap()).collect()
        };
        assert_eq!(
            input(&every),
            vec![4096; ranks],
            "{ranks} ranks, every_rank"
        );
        // (the parsed file: on world rank 0 alone, else sent to every rank)
        let points = |j: &serde_json::Value| -> Vec<u64> {
            let list = j["input_file_points_per_rank"].as_array().unwrap();
            list.iter().map(|n| n.as_u64().unwrap()).collect()
        };
        let file = points(&one)[0];
        assert!(file >= 2 * 1089 - 33, "{file} points in the file");
        assert_eq!(points(&every), vec![file; ranks]);
        let mut on_root = vec![0; ranks];
        on_root[0] = file;
        assert_eq!(
            points(&root),
            on_root,
            "{ranks} ranks: the file on world rank 0 alone"
        );
        let sent = input(&root);
        let groups: Vec<u64> = serde_json::from_value(root["body_ranks"].clone()).unwrap();
        assert_eq!(sent.len(), ranks);
        assert_eq!(sent[0], 4096, "world rank 0 built both bodies: {sent:?}");
        for (rank, &n) in sent.iter().enumerate().skip(1) {
            let size = if (rank as u64) < groups[0] {
                groups[0]
            } else {
                groups[1]
            };
            let bound = match size {
                1 => 2048,
                _ => (2.0 * 2048.0 / size as f64 * 1.03) as u64,
            };
            assert!(
                n <= bound && n > 2048 / size / 2,
                "{ranks} ranks ({partition}), rank {rank} of a group of {size}: {n} > {bound}"
            );
        }
        assert_eq!(
            root["held_mesh_elements_per_rank"], every["held_mesh_elements_per_rank"],
            "{ranks} ranks: the same parts held through the run"
        );
        assert_eq!(root["iterations"], every["iterations"]);
        // (MUMPS's factorisation over several ranks is not reproducible to the last bit: two
        // runs alike differ by about 1e-16)
        same_results(
            &root_h5,
            &every_h5,
            1e-12,
            &format!("{ranks} ranks ({partition})"),
        );
        let (a, b) = (f(&one, "potential_energy"), f(&root, "potential_energy"));
        assert!(
            ((a - b) / a).abs() < 1e-10,
            "{ranks} ranks: energy {b} against {a}"
        );
        same_displacements(&dir.join("one"), &root_h5, "1 rank and root input");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// An estimating run under `root`: world rank 0 makes every rank's shares of the estimates
/// (its overlaps, their owners) and sends them with the parts, on 3 ranks (a rank estimating
/// elements of both bodies), 5 (METIS; bodies split over their groups and estimated across
/// them) and 4 and 5 (index blocks, each body estimated on its group); on 5 ranks with the
/// reference solution (r = 2), whose fine bodies rank 0 builds from the file it refines and
/// deals alike. No rank but world rank 0 held more of the meshes in the input than it holds
/// through the run (less than both bodies), which is what it holds under `every_rank`, nor the
/// file; the fine parts held are the same; the estimates, e_ref and the result files (the η
/// maps included) are the same in both modes, and one rank's to 1e−10.
#[test]
fn estimating_ranks_are_sent_their_overlaps_and_estimate_what_every_rank_building_estimates() {
    let dir = scratch("mesh-input-estimate");
    let problem = paper_drawn_in_gmsh(&dir);
    let mut args: Vec<&str> = problem.iter().map(String::as_str).collect();
    args.extend([
        "-nndd_tol",
        "1e-12",
        "-nndd_estimate",
        "-nndd_estimate_every",
        "0",
    ]);
    let with_reference = |r: &'static str| {
        let mut a = args.clone();
        a.extend(["-nndd_reference_factor", r]);
        a
    };
    let ones = ["0", "2"].map(|r| solve(1, &dir.join(format!("one-{r}")), &with_reference(r)));
    let eta = |j: &serde_json::Value, key: &str| j["estimates"][0][key].as_f64().unwrap();
    let elements = |j: &serde_json::Value, key: &str| -> Vec<u64> {
        serde_json::from_value(j[key].clone()).unwrap()
    };
    let runs = [
        (3, "metis", "0"),
        (5, "metis", "2"),
        (4, "blocks", "0"),
        (5, "blocks", "2"),
    ];
    for (ranks, partition, r) in runs {
        let what = format!("{ranks} ranks ({partition}, reference factor {r})");
        let one = &ones[(r == "2") as usize];
        let run = |input: &str| {
            let prefix = dir.join(format!("{ranks}-{partition}-{r}-{input}"));
            let mut a = with_reference(r);
            a.extend(["-nndd_mesh_input", input, "-nndd_partition", partition]);
            (solve(ranks, &prefix, &a), prefix)
        };
        let (root, root_h5) = run("root");
        let (every, every_h5) = run("every_rank");
        let held = elements(&root, "held_mesh_elements_per_rank");
        assert_eq!(
            held,
            elements(&every, "held_mesh_elements_per_rank"),
            "{what}"
        );
        let input = elements(&root, "input_mesh_elements_per_rank");
        assert_eq!(input[0], 4096, "{what}: world rank 0 built both bodies");
        assert_eq!(
            input[1..],
            held[1..],
            "{what}: the other ranks sent their parts"
        );
        assert!(
            held[1..].iter().all(|&n| n < 4096),
            "{what}: a rank other than world rank 0 holds both bodies whole: {held:?}"
        );
        assert_eq!(
            elements(&every, "input_mesh_elements_per_rank"),
            vec![4096; ranks]
        );
        // (the reference's fine bodies built on world rank 0 and dealt alike)
        let fine = "held_reference_mesh_elements_per_rank";
        assert_eq!(root[fine], every[fine], "{what}");
        if r == "2" {
            let (held, input) = (
                elements(&root, fine),
                elements(&root, "reference_input_mesh_elements_per_rank"),
            );
            assert_eq!(
                input[0],
                4 * 4096,
                "{what}: world rank 0 built both fine bodies"
            );
            assert_eq!(
                input[1..],
                held[1..],
                "{what}: the others were sent their parts"
            );
            assert_eq!(
                elements(&every, "reference_input_mesh_elements_per_rank"),
                vec![4 * 4096; ranks]
            );
        }
        // (each rank's peak once the fine bodies were built, where the reference is solved)
        let peaks = root["reference_input_peak_memory_mib_per_rank"].as_array();
        match r {
            "2" => assert!(
                peaks.is_some_and(|p| p.len() == ranks && p.iter().all(|m| m.as_f64() > Some(1.0))),
                "{what}: {peaks:?}"
            ),
            _ => assert!(peaks.is_none(), "{what}: {peaks:?}"),
        }
        let file = elements(&root, "input_file_points_per_rank");
        assert!(
            file[0] > 2000 && file[1..].iter().all(|&n| n == 0),
            "{what}: {file:?}"
        );
        // (relative to η^glo: η^NNDD is at round-off, the NNDD converged to 1e-12)
        let scale = eta(one, "eta_glo");
        let keys = match r {
            "2" => &["eta_glo", "eta_fe", "eta_nndd", "e_ref"][..],
            _ => &["eta_glo", "eta_fe", "eta_nndd"][..],
        };
        for &key in keys {
            let (a, b, c) = (eta(one, key), eta(&root, key), eta(&every, key));
            assert!(
                (a - b).abs() < 1e-10 * scale,
                "{what}: {key} {b} against {a}"
            );
            assert!(
                (b - c).abs() < 1e-12 * scale,
                "{what}: {key} {b} against {c}"
            );
        }
        same_results(&root_h5, &every_h5, 1e-12, &what);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A mortar run (curves meshed on their own, coupled as meshed) under `root`: world rank 0
/// sends each rank its part with the mortar body's coupling, on Hertz meshed 1:1.7 (3 ranks,
/// METIS; 4, index blocks) and the pin in its hole, whose closed curves are coupled all round
/// (3 ranks). No rank but world rank 0 holds the file or more of the meshes than it holds
/// through the run, the parts held are those of `every_rank`, and the result files are the same
/// in both modes (to 1e−10: MUMPS's parallel round-off) and one rank's solution to 1e−10.
#[test]
fn a_mortar_run_s_ranks_are_sent_their_parts_with_the_coupling() {
    let dir = scratch("mesh-input-mortar");
    let hertz = gmsh_level(HERTZ_NM_GEO, &dir, "hertz-nm", 2);
    let pin = gmsh_level(PIN_HOLE_GEO, &dir, "pin-hole", 1);
    let elements = |j: &serde_json::Value, key: &str| -> Vec<u64> {
        serde_json::from_value(j[key].clone()).unwrap()
    };
    let cases = [
        ("hertz", HERTZ_NM_OPTS, &hertz, 3, "metis"),
        ("hertz", HERTZ_NM_OPTS, &hertz, 4, "blocks"),
        ("pin", PIN_HOLE_OPTS, &pin, 3, "metis"),
    ];
    for (name, opts, msh, ranks, partition) in cases {
        let what = format!("{name} on {ranks} ranks ({partition})");
        let mortar = [
            "-nndd_contact_discretisation",
            "mortar",
            "-nndd_tol",
            "1e-12",
        ];
        let one = solve_meshed(1, opts, msh, &dir.join(format!("{name}-one")), &mortar);
        let run = |input: &str| {
            let prefix = dir.join(format!("{name}-{ranks}-{partition}-{input}"));
            let mut a = mortar.to_vec();
            a.extend(["-nndd_mesh_input", input, "-nndd_partition", partition]);
            (solve_meshed(ranks, opts, msh, &prefix, &a), prefix)
        };
        let (root, root_h5) = run("root");
        let (every, every_h5) = run("every_rank");
        assert_eq!(root["contact_curves"]["discretisation"], "mortar", "{what}");
        let whole = elements(&every, "input_mesh_elements_per_rank");
        assert!(whole.iter().all(|&n| n == whole[0]), "{what}: {whole:?}");
        let (input, held) = (
            elements(&root, "input_mesh_elements_per_rank"),
            elements(&root, "held_mesh_elements_per_rank"),
        );
        assert_eq!(input[0], whole[0], "{what}: world rank 0 built both bodies");
        assert_eq!(input[1..], held[1..], "{what}: the others sent their parts");
        assert!(
            input[1..].iter().all(|&n| n < whole[0]),
            "{what}: a rank other than world rank 0 holds both bodies: {input:?} of {}",
            whole[0]
        );
        assert_eq!(
            held,
            elements(&every, "held_mesh_elements_per_rank"),
            "{what}"
        );
        let file = elements(&root, "input_file_points_per_rank");
        assert!(
            file[0] > 100 && file[1..].iter().all(|&n| n == 0),
            "{what}: {file:?}"
        );
        assert_eq!(root["iterations"], every["iterations"], "{what}");
        // (MUMPS's factorisation over several ranks is not reproducible to the last bit: two
        // runs alike differ by up to 3e-12 of the largest stress here)
        same_results(&root_h5, &every_h5, 1e-10, &what);
        let (a, b) = (f(&one, "potential_energy"), f(&root, "potential_energy"));
        assert!(
            ((a - b) / a).abs() < 1e-10,
            "{what}: energy {b} against {a}"
        );
        same_displacements(&dir.join(format!("{name}-one")), &root_h5, &what);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// An adaptive run under `root`, on 4 ranks: world rank 0 remeshes each cycle's geometry,
/// keeps the file (no other rank holds it) and deals the bodies, and builds the whole meshes
/// again for the size view; every rank holds its parts through each cycle, not the whole
/// bodies, the same parts as under `every_rank`, and the cycles (their meshes, η^glo and the
/// last cycle's result files) are those of `every_rank`.
#[test]
fn an_adaptive_run_s_cycles_are_dealt_from_world_rank_0() {
    let dir = scratch("mesh-input-adapt");
    let mut args = paper_mesh_args(
        std::path::Path::new(PAPER_GEO),
        "contact1,contact2",
        "-1e-4",
    );
    args.extend(
        [
            "-nndd_geo_set",
            "n=32",
            "-nndd_adapt_tol",
            "0.02",
            "-nndd_adapt_max_cycles",
            "3",
            "-nndd_tol",
            "1e-12",
        ]
        .map(String::from),
    );
    let elements = |j: &serde_json::Value, key: &str| -> Vec<u64> {
        serde_json::from_value(j[key].clone()).unwrap()
    };
    let run = |input: &str| {
        let mut a: Vec<&str> = args.iter().map(String::as_str).collect();
        a.extend(["-nndd_mesh_input", input]);
        solve(4, &dir.join(input), &a)
    };
    let (root, every) = (run("root"), run("every_rank"));
    let cycles = |j: &serde_json::Value| -> Vec<(u64, f64)> {
        let list = j["cycles"].as_array().unwrap();
        list.iter()
            .map(|c| (c["elements"].as_u64().unwrap(), f(c, "eta_glo")))
            .collect()
    };
    let (a, b) = (cycles(&root), cycles(&every));
    assert!(a.len() >= 2, "at least one remeshing: {a:?}");
    assert_eq!(a.len(), b.len());
    for ((na, ea), (nb, eb)) in a.iter().zip(&b) {
        assert_eq!(na, nb, "the same meshes: {a:?} against {b:?}");
        assert!((ea - eb).abs() < 1e-12 * ea, "eta_glo {ea} against {eb}");
    }
    // (the last cycle's input and parts)
    let whole = a.last().unwrap().0;
    let file = elements(&root, "input_file_points_per_rank");
    assert!(
        file[0] > 1000 && file[1..].iter().all(|&n| n == 0),
        "the last cycle's file on world rank 0 alone: {file:?}"
    );
    assert_eq!(
        elements(&every, "input_file_points_per_rank"),
        vec![file[0]; 4]
    );
    let input = elements(&root, "input_mesh_elements_per_rank");
    let held = elements(&root, "held_mesh_elements_per_rank");
    assert_eq!(input[0], whole, "world rank 0 built both bodies");
    assert_eq!(input[1..], held[1..], "the others sent their parts");
    assert_eq!(held, elements(&every, "held_mesh_elements_per_rank"));
    assert!(
        held.iter().all(|&n| n < whole),
        "every rank holds parts, not both bodies: {held:?} of {whole}"
    );
    let last = format!("-cycle{}", a.len());
    let prefix = |input: &str| dir.join(format!("{input}{last}"));
    same_results(
        &prefix("root"),
        &prefix("every_rank"),
        1e-12,
        "the last cycle",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// An adaptive mortar run, whose estimates map its bodies onto matched meshes in every cycle,
/// on 3 ranks: under `root` world rank 0 alone reads each cycle's file and builds its meshes,
/// the matched ones included, and the last cycle's η^glo is `every_rank`'s, under which every
/// rank is sent the file and builds every mesh whole; a built-in problem reports no input mesh
/// (its grids are formulas), and the option is refused beside it.
#[test]
fn an_adaptive_mortar_run_builds_its_meshes_where_mesh_input_says() {
    let dir = scratch("mesh-input-whole");
    let run = |input: &str| {
        let prefix = dir.join(format!("mortar-{input}"));
        // (the prefix after the options file, which names its own)
        let args = [
            "-options_file",
            HERTZ_NM_OPTS,
            "-nndd_mesh",
            HERTZ_NM_GEO,
            "-nndd_geo_set",
            "level=2",
            "-nndd_contact_discretisation",
            "mortar",
            "-nndd_estimate",
            "-nndd_adapt_tol",
            "0.08",
            "-nndd_adapt_max_cycles",
            "2",
            "-nndd_tol",
            "1e-10",
            "-nndd_mesh_input",
            input,
            "-nndd_output",
            prefix.to_str().unwrap(),
        ];
        solve(3, &prefix, &args)
    };
    let (root, every) = (run("root"), run("every_rank"));
    let per_rank = |j: &serde_json::Value, key: &str| -> Vec<u64> {
        serde_json::from_value(j[key].clone()).unwrap()
    };
    for key in [
        "input_file_points_per_rank",
        "held_matched_mesh_elements_per_rank",
    ] {
        let (r, e) = (per_rank(&root, key), per_rank(&every, key));
        assert!(
            e.len() == 3 && e.iter().all(|&p| p == e[0] && p > 100),
            "every_rank: {key} {e:?}"
        );
        assert!(
            r[1..].iter().all(|&p| p < e[0]),
            "root: {key} {r:?} against {e:?}"
        );
    }
    assert_eq!(per_rank(&root, "input_file_points_per_rank")[1..], [0, 0]);
    let eta = |j: &serde_json::Value| j["estimates"][0]["eta_glo"].as_f64().unwrap();
    let d = (eta(&root) - eta(&every)).abs() / eta(&every);
    assert!(d < 1e-9, "the last cycle's eta_glo differs by {d:e}");
    let builtin = ["-nndd_problem", "paper", "-nndd_n", "8"];
    let j = solve(2, &dir.join("builtin"), &builtin);
    assert!(j.get("input_mesh_elements_per_rank").is_none());
    let mut given = builtin.to_vec();
    given.extend(["-nndd_mesh_input", "root"]);
    let out = mpirun(2, &given);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("-nndd_mesh_input"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A failure in the input on world rank 0, which builds the bodies, or on a rank that waits
/// for its part (`-nndd_fault RANK:mesh`), ends every rank within a minute with one line naming
/// the fault, on 3 ranks: no rank is left waiting for bytes that will not come.
#[test]
fn a_fault_in_the_input_on_any_rank_ends_the_job() {
    use std::time::Duration;
    let dir = scratch("mesh-input-fault");
    let problem = paper_drawn_in_gmsh(&dir);
    for rank in ["0", "2"] {
        let prefix = dir.join(format!("fault-{rank}"));
        let spec = format!("{rank}:mesh");
        let mut args: Vec<&str> = problem.iter().map(String::as_str).collect();
        args.extend([
            "-nndd_output",
            prefix.to_str().unwrap(),
            "-nndd_fault",
            &spec,
        ]);
        let child = spawn(3, &args);
        let what = format!("fault {spec} on 3 ranks");
        let e = wait_within(child, Duration::from_secs(60), &what);
        assert!(
            e.code.is_some_and(|c| c != 0),
            "{what}: {:?}\n{}",
            e.code,
            e.stderr
        );
        let lines: Vec<&str> = (e.stderr.lines())
            .filter(|l| l.starts_with("nndd: error") && l.contains("-nndd_fault"))
            .collect();
        assert_eq!(lines.len(), 1, "{what}: {}", e.stderr);
        assert!(
            !prefix.with_extension("h5").exists(),
            "{what}: a result file was left"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
