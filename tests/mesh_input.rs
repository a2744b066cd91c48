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

/// A run whose later phases read the whole meshes on every rank (here its estimates' overlaps)
/// is sent the parsed file and builds them on every rank, as `every_rank`, whatever
/// `-nndd_mesh_input` says; a built-in problem reports no input mesh (its grids are formulas),
/// and the option is refused beside it.
#[test]
fn a_run_that_reads_whole_meshes_builds_them_on_every_rank() {
    let dir = scratch("mesh-input-whole");
    let problem = paper_drawn_in_gmsh(&dir);
    let mut args: Vec<&str> = problem.iter().map(String::as_str).collect();
    args.extend(["-nndd_estimate", "-nndd_estimate_every", "0"]);
    let j = solve(3, &dir.join("estimated"), &args);
    assert_eq!(
        j["input_mesh_elements_per_rank"],
        serde_json::json!([4096, 4096, 4096])
    );
    let points = j["input_file_points_per_rank"].as_array().unwrap();
    assert!(
        points.len() == 3
            && points
                .iter()
                .all(|p| p == &points[0] && p.as_u64() > Some(2000))
    );
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
