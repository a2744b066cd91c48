//! Capability: any number of MPI ranks. `-n 1` (both bodies on one rank), `-n 2` (one body per
//! rank) and `-n N` (each body METIS-partitioned over its group of ranks) give the same
//! solution, the same estimates and the same result file.

mod common;
use common::*;

const HERTZ_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const HERTZ_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");

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
    same_displacements(&dir.join("r1"), &dir.join("r2"), "-n 1 and -n 2");
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
    let u = |name| field(&dir.join(name), "body2", "displacement");
    assert!(rel_max_diff(&u("m2"), &u("m1")) < 1e-10);
    assert_eq!(j1["contact_zone"], j2["contact_zone"]);
    std::fs::remove_dir_all(&dir).ok();
}

/// Every number of the run that must not depend on the rank count.
fn compare(j: &serde_json::Value, base: &serde_json::Value, what: &str) {
    let rel = |a: f64, b: f64| ((a - b) / b).abs();
    assert_eq!(j["iterations"], base["iterations"], "{what}: iterations");
    assert_eq!(
        j["contact_zone"], base["contact_zone"],
        "{what}: contact zone"
    );
    for key in ["potential_energy", "contact_force"] {
        let d = rel(f(j, key), f(base, key));
        assert!(d < 1e-9, "{what}: {key} differs by {d:e}");
    }
    let (e, b) = (&j["estimates"], &base["estimates"]);
    assert_eq!(e.as_array().unwrap().len(), b.as_array().unwrap().len());
    for (x, y) in e.as_array().unwrap().iter().zip(b.as_array().unwrap()) {
        for key in ["eta_glo", "eta_fe", "eta_nndd"] {
            // Relative to η^glo: a converged η^NNDD is itself at the solves' round-off.
            let d = ((f(x, key) - f(y, key)) / f(y, "eta_glo")).abs();
            assert!(
                d < 1e-9,
                "{what}: {key} at iteration {} differs by {d:e}",
                x["iteration"]
            );
        }
    }
    let r = &j["equilibrium_residuals"];
    for key in ["divergence", "internal_jump", "element_jump", "boundary"] {
        assert!(f(r, key) < 1e-10, "{what}: residual {key} = {}", r[key]);
    }
}

/// For both recoveries (the default `patch`, whose warm-started η^FE recovery needs the
/// larger overlap of `Overlap::rings_for`, and `patch-classic`).
#[test]
fn one_to_six_ranks_give_the_same_solution_and_estimates() {
    for recovery in ["patch", "patch-classic"] {
        one_to_six_ranks(recovery);
    }
}

fn one_to_six_ranks(recovery: &str) {
    let dir = scratch(&format!("ranks-n-{recovery}"));
    // paper.opts's problem (its -nndd_output would override the test's).
    let args = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "16",
        "-nndd_theta",
        "0.25",
        "-nndd_estimate_every",
        "12",
        "-nndd_tol",
        "1e-10",
        "-nndd_recovery",
        recovery,
    ];
    let base = solve(1, &dir.join("n1"), &args);
    assert_eq!(base["body_ranks"], serde_json::json!([1, 1]));
    let u1: Vec<Vec<f64>> = ["body1", "body2"]
        .iter()
        .map(|b| field(&dir.join("n1"), b, "displacement"))
        .collect();
    for n in [2, 3, 4, 6] {
        let prefix = dir.join(format!("n{n}"));
        let j = solve(n, &prefix, &args);
        let what = format!("-n {n}, {recovery}");
        assert_eq!(j["ranks"], n);
        let ranks: Vec<u64> = j["body_ranks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect();
        assert_eq!(ranks.iter().sum::<u64>() as usize, n, "{what}: {ranks:?}");
        compare(&j, &base, &what);
        // Each rank preallocates from its own elements (the other ranks' rows travel): the
        // stiffness holds every node pair sharing an element, 2 × 2 entries each, on any rank
        // count (a 16 × 16 grid, one diagonal per cell; nndd checks its preallocation exact).
        let (nx, ny) = (16, 16);
        let edges = nx * (ny + 1) + (nx + 1) * ny + nx * ny;
        let pairs = (nx + 1) * (ny + 1) + 2 * edges;
        let nonzeros: Vec<f64> = j["stiffness_nonzeros"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(nonzeros, vec![(4 * pairs) as f64; 2], "{what}");
        for (k, b) in ["body1", "body2"].iter().enumerate() {
            let u = field(&prefix, b, "displacement");
            let d = rel_max_diff(&u, &u1[k]);
            assert!(d < 1e-9, "{what}: {b} displacement differs by {d:e}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// With an estimate every 10 iterations, and at every iteration (the reported iterate then
/// estimated in the loop and again cold, the estimates before it kept for the output by rows).
#[test]
fn four_ranks_write_the_file_one_rank_writes() {
    for every in ["10", "1"] {
        // (each body 12 × 12 × 2 = 288 elements; a rank holds its group's body's mesh alone)
        let j = ranks_write_what_one_writes(4, every, &PAPER_12, &[]);
        assert_eq!(
            j["held_mesh_elements_per_rank"],
            serde_json::json!(vec![288; 4])
        );
        // Each rank's shared libraries' resident pages (/proc's RssFile), part of its peak.
        let numbers = |key: &str| -> Vec<f64> {
            (j[key].as_array().unwrap().iter())
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        let (files, peaks) = (
            numbers("file_backed_memory_mib_per_rank"),
            numbers("peak_memory_mib_per_rank"),
        );
        assert_eq!(files.len(), 4);
        for (f, p) in files.iter().zip(&peaks) {
            assert!(1.0 < *f && f < p, "{files:?} against the peaks {peaks:?}");
        }
    }
}

/// Body 2 with four times body 1's elements on 3 ranks: its elements are estimated on ranks
/// outside its group as well, and each element's η values go from there to the rank that
/// writes it.
#[test]
fn three_ranks_write_the_file_one_rank_writes_with_unequal_bodies() {
    // (body 2's 1152 elements dealt over all three ranks with body 1's 288: every rank holds
    // both meshes)
    let j = ranks_write_what_one_writes(3, "10", &PAPER_12, &["-nndd_body2_ny", "48"]);
    assert_eq!(
        j["held_mesh_elements_per_rank"],
        serde_json::json!(vec![1440; 3])
    );
}

/// A body meshed in Gmsh (its points and triangles listed, not a grid's formula) is held on
/// each rank of its group as the part the rank reads once the bodies are partitioned: its elements
/// of the partition and its block of the output's cells (and where it estimates, its overlap
/// and Γc's elements). `paper` drawn in Gmsh, 2048 elements per body, on 6 ranks (3 per
/// body): at most two shares of 2048 / 3 and the METIS imbalance (3 %), against the whole
/// body on 1 and 2 ranks; the written file is the one rank's, with and without estimates.
#[test]
fn six_ranks_hold_the_parts_of_gmsh_bodies_they_read_and_write_the_file_one_rank_writes() {
    let dir = scratch("ranks-gmsh-part");
    let problem = paper_drawn_in_gmsh(&dir);
    let problem: Vec<&str> = problem.iter().map(String::as_str).collect();
    for (every, estimate) in [("0", &[][..]), ("3", &["-nndd_estimate"][..])] {
        let j = ranks_write_what_one_writes(6, every, &problem, estimate);
        assert_eq!(j["body_ranks"], serde_json::json!([3, 3]));
        let held = j["held_mesh_elements_per_rank"].as_array().unwrap().clone();
        let held: Vec<u64> = held.iter().map(|h| h.as_u64().unwrap()).collect();
        let bound = (2.0 * 2048.0 / 3.0 * 1.03) as u64;
        match every {
            // (its partition's elements and its block of the output's)
            "0" => assert!(held.iter().all(|&h| h <= bound), "{held:?} > {bound}"),
            // (and its overlap of the body it estimates, with rings of neighbours: the whole
            // body on a rank where they cover most of this small mesh)
            _ => assert!(held.iter().sum::<u64>() < 6 * 2048, "{held:?}"),
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The reference solution's fine bodies, a Gmsh mesh refined (`-nndd_reference_factor 2`:
/// 8192 elements per body), are held on each rank of their group as the part it reads once
/// they are partitioned: its partition's elements and its block of the fine elements (whose
/// nodes e_ref's transfer reads), at most two shares of 8192 / 3 and the METIS imbalance on 6
/// ranks, against both whole on 1 rank; e_ref is the one rank's.
#[test]
fn the_reference_solution_holds_the_parts_of_its_gmsh_bodies() {
    let dir = scratch("ranks-gmsh-reference-part");
    let problem = paper_drawn_in_gmsh(&dir);
    let mut args: Vec<&str> = problem.iter().map(String::as_str).collect();
    args.extend(["-nndd_estimate", "-nndd_estimate_every", "0"]);
    args.extend(["-nndd_reference_factor", "2"]);
    let one = solve(1, &dir.join("one"), &args);
    let six = solve(6, &dir.join("six"), &args);
    let held = |j: &serde_json::Value| -> Vec<u64> {
        let h = j["held_reference_mesh_elements_per_rank"]
            .as_array()
            .unwrap();
        h.iter().map(|h| h.as_u64().unwrap()).collect()
    };
    assert_eq!(held(&one), [2 * 8192]);
    let bound = (2.0 * 8192.0 / 3.0 * 1.03) as u64;
    let h = held(&six);
    assert!(
        h.len() == 6 && h.iter().all(|&h| h <= bound),
        "{h:?} > {bound}"
    );
    let e_ref = |j: &serde_json::Value| j["estimates"][0]["e_ref"].as_f64().unwrap();
    let d = (e_ref(&six) - e_ref(&one)).abs() / e_ref(&one);
    assert!(e_ref(&one) > 0.0 && d < 1e-10, "e_ref differs by {d:e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// With `-nndd_partition auto` (the default) a body whose numbering is compact is dealt over
/// its group in the output's index blocks (`Partitioner::IndexBlocks`), one distribution for
/// the assembly, the output and the estimates: a rank holds its share of a Gmsh body's elements
/// and its overlap's rings. `paper` drawn in Gmsh and numbered in bands (`-nndd_mesh_order
/// bands`), 2048 elements per body, on 6 ranks: 682 or 683 each, and the file the one rank
/// writes; the reference solution's fine bodies (8192 elements each) alike, 2730 or 2731 each,
/// e_ref the one rank's. The built-in `paper` with METIS's parts writes the one rank's file too.
/// With an estimate, n = 128 (32768 elements per body) on 6 ranks, each rank holds at most
/// 1.2 times its share plus the halo its recovery can read: the elements within R vertex rings
/// of its block, R = Δ + 3 (the overlap's 2 + colours rings, `Overlap::rings_exchanged`, and
/// greedy colours ≤ Δ + 1 for Δ the mesh's largest vertex degree), counted here from the
/// written mesh; METIS's parts with the output's blocks hold more (the whole body on the middle
/// ranks). η^glo is the same with both and on one rank.
#[test]
fn a_body_dealt_in_index_blocks_is_held_as_its_share_on_each_rank() {
    let dir = scratch("ranks-gmsh-blocks");
    ranks_write_what_one_writes(4, "2", &PAPER_12, &["-nndd_partition", "metis"]);
    let problem = paper_drawn_in_gmsh(&dir);
    let mut problem: Vec<&str> = problem.iter().map(String::as_str).collect();
    problem.extend(["-nndd_mesh_order", "bands"]);
    let counts = |j: &serde_json::Value, key: &str| -> Vec<usize> {
        serde_json::from_value(j[key].clone()).unwrap()
    };
    let j = ranks_write_what_one_writes(6, "0", &problem, &[]);
    let held = counts(&j, "held_mesh_elements_per_rank");
    assert!(held.iter().all(|&h| h == 682 || h == 683), "{held:?}");
    assert_eq!(held.iter().sum::<usize>(), 2 * 2048, "{held:?}");
    let mut args = problem.clone();
    args.extend(["-nndd_estimate", "-nndd_estimate_every", "0"]);
    args.extend(["-nndd_reference_factor", "2"]);
    let one = solve(1, &dir.join("one"), &args);
    let six = solve(6, &dir.join("six"), &args);
    let fine = counts(&six, "held_reference_mesh_elements_per_rank");
    assert!(fine.iter().all(|&h| h == 2730 || h == 2731), "{fine:?}");
    let e_ref = |j: &serde_json::Value| j["estimates"][0]["e_ref"].as_f64().unwrap();
    let d = (e_ref(&six) - e_ref(&one)).abs() / e_ref(&one);
    assert!(e_ref(&one) > 0.0 && d < 1e-10, "e_ref differs by {d:e}");
    // One estimate, n = 128.
    let fine = paper_drawn_in_gmsh_at(&dir, 128);
    let mut args: Vec<&str> = fine.iter().map(String::as_str).collect();
    args.extend([
        "-nndd_mesh_order",
        "bands",
        "-nndd_estimate",
        "-nndd_estimate_every",
        "0",
    ]);
    let eta = |j: &serde_json::Value| j["estimates"][0]["eta_glo"].as_f64().unwrap();
    let one = solve(1, &dir.join("one-128"), &args);
    let blocks = solve(6, &dir.join("blocks-128"), &args);
    let bounds = share_and_halo_bounds(&dir.join("blocks-128"), &counts(&blocks, "body_ranks"));
    let held = counts(&blocks, "held_mesh_elements_per_rank");
    println!("n = 128, 6 ranks: held {held:?}, 1.2 x share + halo {bounds:?}");
    for (r, (&h, &(bound, body))) in held.iter().zip(&bounds).enumerate() {
        assert!(h <= bound, "rank {r} holds {h} elements, over {bound}");
        assert!(
            3 * bound < 2 * body,
            "rank {r}: the bound {bound} of {body}"
        );
    }
    args.extend(["-nndd_partition", "metis"]);
    let metis = solve(6, &dir.join("metis-128"), &args);
    let held = counts(&metis, "held_mesh_elements_per_rank");
    assert!(held.iter().zip(&bounds).any(|(&h, b)| h > b.0), "{held:?}");
    for j in [&metis, &blocks] {
        let d = (eta(j) - eta(&one)).abs() / eta(&one);
        assert!(d < 1e-12, "eta_glo differs by {d:e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// For each rank of a run written to `prefix` with `groups` ranks per body, each body dealt in
/// index blocks: 1.2 times its share of its body's elements plus the halo, the elements
/// outside its block within R = Δ + 3 vertex rings of it (Δ: the body's largest vertex
/// degree), and its body's element count; from the written mesh (`Mesh/bodies`).
fn share_and_halo_bounds(prefix: &std::path::Path, groups: &[usize]) -> Vec<(usize, usize)> {
    let f = hdf5::File::open(format!("{}.h5", prefix.display())).unwrap();
    let topology = f.dataset("Mesh/bodies/topology").unwrap();
    let cells: Vec<i64> = topology.read_raw().unwrap();
    let body: Vec<f64> = f.dataset("Mesh/bodies/body").unwrap().read_raw().unwrap();
    let mut bounds = Vec::new();
    for (k, &g) in groups.iter().enumerate() {
        let tri: Vec<[usize; 3]> = (cells.chunks_exact(3).zip(&body))
            .filter(|(_, &b)| b == (k + 1) as f64)
            .map(|(c, _)| [c[0] as usize, c[1] as usize, c[2] as usize])
            .collect();
        let nodes = 1 + tri.iter().flatten().max().unwrap();
        let mut stars: Vec<Vec<usize>> = vec![Vec::new(); nodes];
        let mut neighbours = vec![std::collections::BTreeSet::<usize>::new(); nodes];
        for (e, t) in tri.iter().enumerate() {
            for &a in t {
                stars[a].push(e);
                neighbours[a].extend(t.iter().filter(|&&b| b != a));
            }
        }
        let rings = 3 + neighbours.iter().map(|n| n.len()).max().unwrap();
        let ne = tri.len();
        for p in 0..g {
            let block = ne * p / g..ne * (p + 1) / g;
            let mut held = vec![false; ne];
            block.clone().for_each(|e| held[e] = true);
            for _ in 0..rings {
                let corners: Vec<usize> =
                    (0..ne).filter(|&e| held[e]).flat_map(|e| tri[e]).collect();
                corners
                    .iter()
                    .flat_map(|&a| &stars[a])
                    .for_each(|&e| held[e] = true);
            }
            let halo = held.iter().filter(|&&h| h).count() - block.len();
            bounds.push(((1.2 * block.len() as f64) as usize + halo, ne));
        }
    }
    bounds
}

/// `paper` n = 12 (each body 12 × 12 × 2 = 288 elements).
const PAPER_12: [&str; 4] = ["-nndd_problem", "paper", "-nndd_n", "12"];

/// `paper` n = 12 with body 2 four times as tall (48 rows of cells): on 3 ranks one for body 1,
/// two for body 2.
const UNEQUAL: [&str; 8] = [
    "-nndd_problem",
    "paper",
    "-nndd_n",
    "12",
    "-nndd_body2_ny",
    "48",
    "-nndd_tol",
    "1e-12",
];

/// Without estimates a rank holds the mesh of its group's body alone: body 1's 288 elements
/// on its one rank, body 2's 1152 on each of its two; both on one rank. The solution is the
/// one rank's.
#[test]
fn a_rank_holds_the_mesh_of_its_body_alone() {
    let dir = scratch("ranks-held");
    let args = UNEQUAL;
    let j1 = solve(1, &dir.join("a"), &args);
    let j3 = solve(3, &dir.join("b"), &args);
    let held = |j: &serde_json::Value| j["held_mesh_elements_per_rank"].clone();
    assert_eq!(held(&j1), serde_json::json!([1440]));
    assert_eq!(j3["body_ranks"], serde_json::json!([1, 2]));
    assert_eq!(held(&j3), serde_json::json!([288, 1152, 1152]));
    // The final check's rays and Γc's ends read the other body's outline alone.
    assert_eq!(j1["iterations"], j3["iterations"]);
    assert_eq!(
        j1["contact_curves"]["max_penetration"],
        j3["contact_curves"]["max_penetration"]
    );
    same_displacements(&dir.join("a"), &dir.join("b"), "-n 1 and -n 3");
    std::fs::remove_dir_all(&dir).ok();
}

/// A rank holds the reported displacement at the nodes it reads alone (its block of the
/// output, the outline with Γc), with and without estimates (the checks gather its rows and
/// the estimates its overlap from the blocks): on each rank of body 2's group (13 × 49 = 637
/// nodes, 120 on its outline) its share plus 20 %, a row of 13 and the outline, on 2 and 4
/// ranks; body 1 whole on its one rank; both on one rank. The same of the reference
/// solution's fields with `-nndd_reference_factor 2` (body 2: 25 × 97 = 2425 nodes, 240 on
/// its outline; e_ref reads the coarse field under each rank's block of the fine elements).
/// The solution, the estimates and e_ref are the one rank's.
#[test]
fn a_rank_holds_the_displacement_at_its_nodes_alone() {
    let dir = scratch("ranks-held-u");
    let args = UNEQUAL;
    let estimated = [&args[..], &["-nndd_estimate", "-nndd_estimate_every", "0"]].concat();
    let reference = [&estimated[..], &["-nndd_reference_factor", "2"]].concat();
    let runs = [
        ("solve", &args[..]),
        ("estimate", &estimated[..]),
        ("reference", &reference[..]),
    ];
    for (what, args) in runs {
        let base = solve(1, &dir.join("a"), args);
        let held = |j: &serde_json::Value, key: &str| -> Vec<usize> {
            serde_json::from_value(j[key].clone()).unwrap()
        };
        let mut keys = vec![("held_displacement_nodes_per_rank", 169, 637, 13, 120)];
        if what == "reference" {
            keys.push((
                "held_reference_displacement_nodes_per_rank",
                625,
                2425,
                25,
                240,
            ));
        }
        for &(key, body1, body2, ..) in &keys {
            assert_eq!(held(&base, key), [body1 + body2], "{what}: {key}");
        }
        for ranks in [3, 5] {
            let prefix = dir.join(format!("b{ranks}"));
            let j = solve(ranks, &prefix, args);
            assert_eq!(j["body_ranks"], serde_json::json!([1, ranks - 1]), "{what}");
            for &(key, body1, body2, row, outline) in &keys {
                let h = held(&j, key);
                assert_eq!(h[0], body1, "{what}: {key}: body 1 on its one rank");
                let share = body2 as f64 / (ranks - 1) as f64;
                assert!(
                    (h[1..].iter()).all(|&n| n as f64 <= 1.2 * share + (row + outline) as f64),
                    "{what}, {ranks} ranks: {key} {h:?}"
                );
            }
            if what == "solve" {
                assert_eq!(j["iterations"], base["iterations"]);
                for key in ["potential_energy", "energy_norm"] {
                    let d = (f(&j, key) - f(&base, key)).abs() / f(&base, key).abs();
                    assert!(d < 1e-9, "{ranks} ranks: {key} differs by {d:e}");
                }
            } else {
                compare(&j, &base, &format!("{what}, {ranks} ranks"));
            }
            if what == "reference" {
                let e_ref = |j: &serde_json::Value| f(&j["estimates"][0], "e_ref");
                let d = (e_ref(&j) - e_ref(&base)).abs() / e_ref(&base);
                assert!(
                    e_ref(&base) > 0.0 && d < 1e-10,
                    "{ranks} ranks: e_ref differs by {d:e}"
                );
            }
            same_displacements(
                &dir.join("a"),
                &prefix,
                &format!("{what}, -n 1 and -n {ranks}"),
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A body read from Gmsh is held the same way. With `-nndd_mesh_order bands` its triangles
/// come in Cuthill–McKee bands and its nodes are numbered as the triangles first meet them
/// (`fem::order`), so a rank's block of the output is a band across the body: on Hertz level 3
/// on 3 and 5 ranks each rank of a group of several holds the displacement at most at 1.2
/// times its share of the body's nodes plus the outline. In the file's order (the default) a
/// block of Gmsh's triangles touches nodes all over the body: a rank holds more than that
/// bound. The converged answer is the one rank's in either order, and its estimates in
/// bands too (the first iterations may differ with the rank count: a pair at the edge of the
/// contact set is decided by the solves' round-off).
#[test]
fn a_rank_holds_its_share_of_a_gmsh_body() {
    let dir = scratch("ranks-gmsh-held");
    let msh = gmsh_level(HERTZ_GEO, &dir, "hertz", 3);
    let args = [
        "-nndd_estimate",
        "-nndd_estimate_every",
        "0",
        "-nndd_tol",
        "1e-10",
    ];
    let bands = [&args[..], &["-nndd_mesh_order", "bands"]].concat();
    let base = solve_meshed(1, HERTZ_OPTS, &msh, &dir.join("a"), &bands);
    let nodes = body_nodes(&base);
    let outline = ["body1", "body2"].map(|b| outline_nodes(&dir.join("a"), b));
    let last = last_estimate;
    // Each rank's held nodes over 1.2 × its share + the outline, on groups of several ranks.
    let over = |j: &serde_json::Value| -> Vec<f64> {
        let list = |key: &str| -> Vec<usize> { serde_json::from_value(j[key].clone()).unwrap() };
        let (groups, held) = (list("body_ranks"), list("held_displacement_nodes_per_rank"));
        let mut first = 0;
        let mut ratios = Vec::new();
        for k in 0..2 {
            let g = groups[k];
            let bound = 1.2 * nodes[k] as f64 / g as f64 + outline[k] as f64;
            if g > 1 {
                ratios.extend(held[first..first + g].iter().map(|&h| h as f64 / bound));
            }
            first += g;
        }
        ratios
    };
    for (ranks, order) in [(3, &bands[..]), (5, &bands[..]), (3, &args[..])] {
        let prefix = dir.join(format!("b{ranks}-{}", order.len()));
        let j = solve_meshed(ranks, HERTZ_OPTS, &msh, &prefix, order);
        let what = format!("{ranks} ranks, {order:?}");
        let ratios = over(&j);
        println!("{what}: held nodes over the bound {ratios:.3?}");
        assert!(!ratios.is_empty(), "{what}: a group of several ranks");
        for key in ["potential_energy", "contact_force"] {
            let d = ((f(&j, key) - f(&base, key)) / f(&base, key)).abs();
            assert!(d < 1e-9, "{what}: {key} differs by {d:e}");
        }
        if order.len() == args.len() {
            assert!(ratios.iter().any(|&r| r > 1.0), "{what}: {ratios:?}");
            continue;
        }
        assert!(ratios.iter().all(|&r| r <= 1.0), "{what}: {ratios:?}");
        for key in ["eta_glo", "eta_fe"] {
            let d = ((last(&j, key) - last(&base, key)) / last(&base, "eta_glo")).abs();
            assert!(d < 1e-9, "{what}: {key} differs by {d:e}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Where a body's elements are estimated outside its group (here on 2, 3 and 4 ranks: body
/// 1 of 625 nodes on rank 0, body 2 of 25 × 97 = 2425 dealt over every rank), a rank gathers
/// what its recoveries read of each body it estimates, its overlap and Γc, from the blocks
/// of the body's group, never the whole field: rank 0, body 1's, holds its own whole and at
/// most 3/4 of body 2's (it held both whole, 3050 nodes, when the fields were broadcast). The
/// estimates are the one rank's.
#[test]
fn a_rank_estimating_another_group_s_body_gathers_its_overlap_alone() {
    let dir = scratch("ranks-crossing");
    let args = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "24",
        "-nndd_body2_ny",
        "96",
        "-nndd_tol",
        "1e-10",
        "-nndd_estimate",
        "-nndd_estimate_every",
        "0",
    ];
    let held = |j: &serde_json::Value| -> Vec<usize> {
        serde_json::from_value(j["held_estimate_displacement_nodes_per_rank"].clone()).unwrap()
    };
    let base = solve(1, &dir.join("a"), &args);
    assert_eq!(held(&base), [625 + 2425]);
    for ranks in [2, 3, 4] {
        let prefix = dir.join(format!("b{ranks}"));
        let j = solve(ranks, &prefix, &args);
        let what = format!("{ranks} ranks");
        assert_eq!(j["body_ranks"], serde_json::json!([1, ranks - 1]), "{what}");
        assert_eq!(
            j["held_mesh_elements_per_rank"],
            serde_json::json!(vec![1152 + 4608; ranks]),
            "{what}: every rank estimates elements of both bodies"
        );
        let h = held(&j);
        assert!(h.iter().all(|&n| n < 625 + 2425), "{what}: {h:?}");
        assert!(4 * h[0] <= 4 * 625 + 3 * 2425, "{what}: {h:?}");
        compare(&j, &base, &what);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The `problem` with `extra` options, estimated every `every` iterations, solved on 1 and
/// on `ranks` ranks: the same datasets, the geometry identical, the values to 1e-9; the
/// `ranks`-rank run's summary.
fn ranks_write_what_one_writes(
    ranks: usize,
    every: &str,
    problem: &[&str],
    extra: &[&str],
) -> serde_json::Value {
    let dir = scratch(&format!("ranks-h5-{ranks}-{every}-{}", problem.len()));
    let mut args = problem.to_vec();
    args.extend(["-nndd_tol", "1e-12", "-nndd_estimate_every", every]);
    args.extend(extra);
    solve(1, &dir.join("a"), &args);
    let j = solve(ranks, &dir.join("b"), &args);
    assert_eq!(j["ranks"], ranks);
    let what = format!("{ranks} ranks, every {every}");
    let datasets = same_results(&dir.join("a"), &dir.join("b"), 1e-9, &what);
    assert!(datasets > 20, "{what}: {datasets} datasets");
    std::fs::remove_dir_all(&dir).ok();
    j
}

#[test]
fn iterative_and_out_of_core_options_on_three_ranks_agree_with_mumps() {
    let dir = scratch("ranks-iter");
    let run = |opts: &str, name: &str| {
        let prefix = dir.join(name);
        let p = prefix.to_str().unwrap().to_string();
        // The options file first: its own -nndd_output is overridden by ours after it.
        let out = mpirun(
            3,
            &[
                "-options_file",
                opts,
                "-nndd_n",
                "12",
                "-nndd_monitor",
                "0",
                "-nndd_estimate",
                "-nndd_estimate_every",
                "0",
                "-nndd_reference_factor",
                "0",
                "-nndd_tol",
                "1e-10",
                "-nndd_output",
                &p,
            ],
        );
        assert!(
            out.status.success(),
            "{opts}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        json(&prefix)
    };
    let direct = run("petsc-options/paper.opts", "mumps");
    // MUMPS: one factorisation per body, the interface operators from it on body 1's two
    // ranks too, every step condensed.
    assert_eq!(
        direct["schur_source"],
        serde_json::json!(["mumps_inverse", "mumps_schur"])
    );
    assert_eq!(direct["dirichlet_step"], "condensed");
    assert_eq!(
        direct["neumann_step"],
        serde_json::json!(["condensed", "condensed"])
    );
    let cg = run("petsc-options/iterative.opts", "gamg");
    assert_eq!(cg["body_ranks"], serde_json::json!([2, 1]));
    // CG + GAMG: body 2's operators from back-solves; body 1 solves its own Dirichlet system
    // and its Neumann steps.
    assert_eq!(cg["schur_source"], serde_json::json!(["none", "solves"]));
    assert_eq!(cg["dirichlet_step"], "system");
    assert_eq!(
        cg["neumann_step"],
        serde_json::json!(["solve", "condensed"])
    );
    assert_eq!(cg["iterations"], direct["iterations"]);
    let (a, b) = (f(&cg, "potential_energy"), f(&direct, "potential_energy"));
    assert!(((a - b) / b).abs() < 1e-10, "CG+GAMG {a} vs MUMPS {b}");
    let u = |name| field(&dir.join(name), "body2", "displacement");
    let d = rel_max_diff(&u("gamg"), &u("mumps"));
    assert!(d < 1e-8, "displacements differ by {d:e}");
    // The estimates' re-solves: one multiple-right-hand-side solve with MUMPS (body 1 over
    // two ranks), one solve per column with CG.
    let last = |j: &serde_json::Value, k: &str| {
        j["estimates"].as_array().unwrap().last().unwrap()[k]
            .as_f64()
            .unwrap()
    };
    for k in ["eta_glo", "eta_fe"] {
        let (a, b) = (last(&cg, k), last(&direct, k));
        assert!(((a - b) / b).abs() < 1e-9, "{k}: CG+GAMG {a} vs MUMPS {b}");
    }
    // The low-memory variant: MUMPS with its factors out of core, the same solve.
    let ooc = run("petsc-options/out-of-core.opts", "ooc");
    assert_eq!(ooc["schur_source"], direct["schur_source"]);
    assert_eq!(ooc["iterations"], direct["iterations"]);
    let c = f(&ooc, "potential_energy");
    assert!(
        ((c - b) / b).abs() < 1e-12,
        "out of core {c} vs in core {b}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// e_ref against the reference solution (26), which each rank of a body's group holds as its
/// block of the fine elements and u_ref on their nodes: the same on 1 to 4 ranks, on `paper`
/// (a structured mesh refined 3 times) at every estimated iteration, and on Hertz level 1 (a
/// Gmsh mesh, each triangle split into 4) at the converged iterate (its first iterations
/// differ with the rank count: a contact pair at the edge of the contact set is decided by
/// the solves' round-off there).
#[test]
fn the_reference_error_is_the_same_on_one_to_four_ranks() {
    let dir = scratch("ranks-eref");
    let msh = gmsh_level(HERTZ_GEO, &dir, "hertz", 1);
    let paper = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "8",
        "-nndd_theta",
        "0.25",
        "-nndd_reference_factor",
        "3",
    ];
    let hertz = ["-nndd_reference_factor", "2"];
    let e_ref = |j: &serde_json::Value| -> Vec<f64> {
        let e = j["estimates"].as_array().expect("estimates");
        e.iter().map(|x| f(x, "e_ref")).collect()
    };
    for (name, extra) in [("paper", &paper[..]), ("hertz", &hertz[..])] {
        let mut args = vec!["-nndd_estimate_every", "4", "-nndd_tol", "1e-10"];
        args.extend_from_slice(extra);
        let run = |n: usize| {
            let prefix = dir.join(format!("{name}-n{n}"));
            let j = match name {
                "paper" => solve(n, &prefix, &args),
                _ => solve_meshed(n, HERTZ_OPTS, &msh, &prefix, &args),
            };
            e_ref(&j)
        };
        // (Hertz: the converged iterate's alone)
        let compared = |e: Vec<f64>| match name {
            "paper" => e,
            _ => e[e.len() - 1..].to_vec(),
        };
        let base = run(1);
        assert!(
            base.len() >= 2 && base.iter().all(|&e| e > 0.0),
            "{name}: {base:?}"
        );
        let base = compared(base);
        for n in [2, 3, 4] {
            let e = compared(run(n));
            assert_eq!(e.len(), base.len(), "{name} -n {n}");
            for (a, b) in e.iter().zip(&base) {
                assert!(
                    (a - b).abs() <= 1e-10 * b,
                    "{name} -n {n}: e_ref {a} against {b}"
                );
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
