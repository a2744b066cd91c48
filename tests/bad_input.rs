//! Capability: bad input is refused with one line naming the option and the accepted range,
//! a non-zero exit, no panic or backtrace, and no result file.

mod common;
use common::*;

#[test]
fn theta_must_be_positive() {
    refused(1, &["-nndd_theta", "0"], "-nndd_theta");
    refused(2, &["-nndd_theta", "-0.5"], "-nndd_theta");
}

#[test]
fn estimator_settings_in_range() {
    refused(1, &["-nndd_stop_ratio", "0"], "-nndd_stop_ratio");
    refused(
        1,
        &["-nndd_reference_factor", "1"],
        "-nndd_reference_factor",
    );
    refused(1, &["-nndd_estimate_every", "-2"], "-nndd_estimate_every");
    refused(1, &["-nndd_memory_limit", "-1"], "-nndd_memory_limit");
}

#[test]
fn young_modulus_must_be_positive() {
    refused(1, &["-nndd_E", "-2e11"], "-nndd_E");
    refused(1, &["-nndd_E", "0"], "-nndd_E");
}

#[test]
fn poisson_ratio_in_range() {
    refused(1, &["-nndd_nu", "0.5"], "-nndd_nu");
    refused(1, &["-nndd_nu", "-1"], "-nndd_nu");
}

#[test]
fn mesh_size_must_be_positive() {
    refused(1, &["-nndd_n", "0"], "-nndd_n");
    refused(1, &["-nndd_body2_ny", "-3"], "-nndd_body2_ny");
    refused(1, &["-nndd_body2_nx", "5"], "-nndd_body2_nx");
}

#[test]
fn unknown_names_are_refused() {
    refused(1, &["-nndd_problem", "hertz"], "-nndd_problem");
    // Beside -nndd_mesh too (the name is checked before the file is read).
    let line = fails_with(
        2,
        &["-nndd_problem", "hertz", "-nndd_mesh", "no.msh"],
        Some(1),
        &["-nndd_problem: unknown value 'hertz'"],
    );
    assert!(line.contains("(accepted: paper, uniform, mesh (with -nndd_mesh))"));
    refused(1, &["-nndd_solver", "penalty"], "-nndd_solver");
    refused(1, &["-nndd_stop", "never"], "-nndd_stop");
    refused(1, &["-nndd_recovery", "spr"], "-nndd_recovery");
    // An order of a Gmsh problem's bodies: a name it does not know, and on a built-in problem.
    let line = fails_with(
        1,
        &["-nndd_mesh_order", "hilbert", "-nndd_mesh", "no.msh"],
        Some(1),
        &["-nndd_mesh_order: unknown value 'hilbert'"],
    );
    assert!(line.contains("file, bands"), "{line}");
    fails_with(
        1,
        &["-nndd_mesh_order", "bands"],
        Some(1),
        &["-nndd_mesh_order", "orders the bodies of a Gmsh problem"],
    );
}

/// `-nndd_mesh` solves the meshed problem: another problem named beside it used to be
/// ignored; `-nndd_problem mesh` is accepted.
#[test]
fn another_problem_beside_a_mesh_is_refused() {
    for (np, problem) in [(1, "paper"), (2, "uniform")] {
        fails_with(
            np,
            &["-nndd_problem", problem, "-nndd_mesh", "no.msh"],
            Some(1),
            &[&format!(
                "nndd: error: -nndd_problem: '{problem}' conflicts with -nndd_mesh no.msh, which solves the meshed problem (beside -nndd_mesh: -nndd_problem mesh, or none)"
            )],
        );
    }
    // `mesh` goes on to the file.
    fails_with(
        1,
        &["-nndd_problem", "mesh", "-nndd_mesh", "no.msh"],
        Some(1),
        &["nndd: error: -nndd_mesh: cannot read no.msh"],
    );
}

/// A mesh path that is not a regular file (a device, a pipe, a directory) is refused before
/// it is read: `/dev/zero` used to be read until the memory ran out.
#[test]
fn a_mesh_that_is_not_a_regular_file_is_refused() {
    let dir = scratch("mesh-not-file");
    let dir_name = dir.to_str().unwrap();
    for (np, path) in [(1, "/dev/zero"), (2, "/dev/zero"), (2, dir_name)] {
        let t = std::time::Instant::now();
        fails_with(
            np,
            &["-nndd_mesh", path],
            Some(1),
            &[&format!(
                "nndd: error: -nndd_mesh: cannot read {path}: it is not a regular file"
            )],
        );
        assert!(t.elapsed().as_secs() < 30, "{:?}", t.elapsed());
    }
    // A file beyond 4 GiB (sparse: no disk used) is refused before it is read.
    let huge = dir.join("huge.msh");
    let f = std::fs::File::create(&huge).unwrap();
    f.set_len((4 << 30) + 1).unwrap();
    fails_with(
        2,
        &["-nndd_mesh", huge.to_str().unwrap()],
        Some(1),
        &["4294967297 bytes, more than a mesh file may have (4 GiB)"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn malformed_numbers_are_refused() {
    refused(1, &["-nndd_theta", "quarter"], "-nndd_theta");
}

/// A tolerance of 1 or more is met at the first iteration: it used to "converge" to a wrong
/// answer (1e300: one iteration, twice the contact force).
#[test]
fn tolerance_must_be_below_one() {
    for (np, tol) in [(1, "1e300"), (2, "1"), (1, "0")] {
        let line = fails_with(np, &["-nndd_n", "4", "-nndd_tol", tol], Some(1), &[]);
        assert_eq!(
            line,
            format!("nndd: error: -nndd_tol must be in (0, 1) (got {tol})")
        );
    }
}

/// A valued option given without its value (last on the line, or followed by another
/// option) is refused, naming what it accepts; PETSc reads a number so given as not given.
#[test]
fn options_without_their_value_are_refused() {
    let cases: [(&[&str], &str); 5] = [
        (&["-nndd_tol"], "-nndd_tol: needs a value (in (0, 1))"),
        (
            &["-nndd_E", "-nndd_monitor"],
            "-nndd_E: needs a value (> 0)",
        ),
        (
            &["-nndd_max_it"],
            "-nndd_max_it: needs a value (a positive integer (at most 65536))",
        ),
        (&["-nndd_theta"], "-nndd_theta: needs a value"),
        (
            &["-nndd_stop"],
            "-nndd_stop: needs a value (accepted: tol, balanced, none)",
        ),
    ];
    for (k, (args, message)) in cases.iter().enumerate() {
        let mut all = vec!["-nndd_n", "4"];
        all.extend_from_slice(args);
        let line = fails_with(1 + k % 2, &all, Some(1), &[message]);
        assert!(line.starts_with("nndd: error: -nndd_"), "{line}");
    }
}

/// PETSc's integers are 32-bit: 4294967295 reads as -1 and 4294967297 as 1 (which used to
/// run one iteration); the message quotes the number written.
#[test]
fn integers_beyond_32_bits_are_quoted_as_written() {
    for (np, v) in [(1, "4294967295"), (2, "4294967297")] {
        let line = fails_with(np, &["-nndd_n", "4", "-nndd_max_it", v], Some(1), &[]);
        let expected = format!("-nndd_max_it must be a positive integer (at most 65536) (got {v})");
        assert_eq!(line, format!("nndd: error: {expected}"));
    }
}

#[test]
fn recovery_sweeps_out_of_range_are_refused() {
    refused(1, &["-nndd_recovery_sweeps", "0"], "-nndd_recovery_sweeps");
    refused(
        1,
        &["-nndd_recovery_warm_sweeps", "-1"],
        "-nndd_recovery_warm_sweeps",
    );
    refused(
        1,
        &["-nndd_recovery_warm_change", "-0.1"],
        "-nndd_recovery_warm_change",
    );
}

#[test]
fn unwritable_output_is_refused() {
    let dir = scratch("unwritable");
    let blocker = dir.join("file");
    std::fs::write(&blocker, b"x").unwrap();
    let prefix = blocker.join("run");
    let out = mpirun(
        2,
        &["-nndd_n", "4", "-nndd_output", prefix.to_str().unwrap()],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    let ours: Vec<&str> = stderr.lines().filter(|l| l.starts_with("nndd:")).collect();
    assert_eq!(ours.len(), 1, "{stderr}");
    assert!(ours[0].contains("-nndd_output"), "{}", ours[0]);
    // Not "File exists": the directory part names the file.
    let expected = format!(
        "its directory {} is a file, not a directory",
        blocker.display()
    );
    assert!(ours[0].ends_with(&expected), "{}", ours[0]);
    assert!(!stderr.contains("panicked"));
    assert_eq!(walk(&dir), vec![blocker]);
    std::fs::remove_dir_all(&dir).ok();
}

/// `DIR/.` and `DIR/..` name no file: `DIR/.` used to write the hidden `DIR/..h5`, `..json`
/// and an `.xdmf` referring to a file it did not name.
#[test]
fn output_prefix_without_a_file_name_is_refused() {
    let dir = scratch("dot-prefix");
    for (np, last) in [(1, "."), (2, ".."), (2, ".")] {
        let prefix = format!("{}/{last}", dir.display());
        let out = mpirun(np, &["-nndd_n", "4", "-nndd_output", &prefix]);
        assert_eq!(out.status.code(), Some(1));
        let stderr = String::from_utf8_lossy(&out.stderr);
        let ours: Vec<&str> = stderr.lines().filter(|l| l.starts_with("nndd:")).collect();
        let expected = format!(
            "nndd: error: -nndd_output {prefix}: not a usable output prefix: its file name is '{last}'; give a directory and a file-name prefix, e.g. results/run1"
        );
        assert_eq!(ours, vec![expected.as_str()], "{stderr}");
    }
    assert_eq!(walk(&dir), Vec::<std::path::PathBuf>::new());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn more_ranks_than_the_mesh_can_use_are_refused() {
    // n = 4: 25 nodes per body, fewer than 16 per rank on 3 ranks (2 for body 1).
    refused(3, &[], "mpirun -n");
}

#[test]
fn body1_ranks_out_of_range_are_refused() {
    refused(2, &["-nndd_body1_ranks", "2"], "-nndd_body1_ranks");
    refused(1, &["-nndd_body1_ranks", "-1"], "-nndd_body1_ranks");
}

/// A bodies' solver option naming a type PETSc does not know is bad input (exit 1, the
/// option named), not a failure of the solve: it ended with exit 2 and PETSc's raw message
/// (`PETSc error 86 in KSPSetFromOptions: …`). Every rank of the body's group meets it, on
/// either body and any rank count, and under -help.
#[test]
fn unknown_solver_types_are_refused() {
    let known = "is not a known type";
    for (np, n, args, option) in [
        (
            1,
            "4",
            &["-body1_ksp_type", "foo"][..],
            "-body1_ksp_type: 'foo'",
        ),
        (
            2,
            "4",
            &["-body2_pc_type", "bar"][..],
            "-body2_pc_type: 'bar'",
        ),
        (
            3,
            "8",
            &["-body1_ksp_type", "foo"][..],
            "-body1_ksp_type: 'foo'",
        ),
        (
            2,
            "4",
            &[
                "-body1_pc_type",
                "lu",
                "-body1_pc_factor_mat_solver_type",
                "baz",
            ][..],
            "-body1_pc_factor_mat_solver_type: 'baz'",
        ),
    ] {
        let all = [&["-nndd_n", n][..], args].concat();
        let line = fails_with(
            np,
            &all,
            Some(1),
            &[&format!("nndd: error: {option} {known}")],
        );
        assert!(line.ends_with("; -help lists the types)"), "{line}");
    }
    // With -help too (the listing of the bodies' options meets it first; PETSc's own help text
    // is on stdout, so only the error line is looked at).
    let out = mpirun(2, &["-help", "-body2_ksp_type", "foo"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let ours: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("nndd: error"))
        .collect();
    assert_eq!(
        ours,
        ["nndd: error: -body2_ksp_type: 'foo' is not a known type (Unable to find requested KSP type foo; -help lists the types)"],
        "{stderr}"
    );
}

#[test]
fn superlu_dist_refuses_a_second_factorisation_on_body_1() {
    refused(
        2,
        &[
            "-nndd_dirichlet_step",
            "system",
            "-body1_pc_type",
            "lu",
            "-body1_pc_factor_mat_solver_type",
            "superlu_dist",
        ],
        "-nndd_dirichlet_step",
    );
}

/// A mesh or a reference mesh that would not fit in the machine's memory is refused before
/// anything is built, with the estimated need (the model of `src/app/capacity.rs`: 13 TiB for
/// the reference mesh 32768, 20 TiB for the mesh 40000) and, for the reference, the largest
/// factor that fits; a small factor runs.
#[test]
fn meshes_beyond_the_memory_are_refused_before_any_solve() {
    let t = std::time::Instant::now();
    let line = fails_with(
        2,
        &[
            "-nndd_n",
            "512",
            "-nndd_reference_factor",
            "64",
            "-nndd_estimate",
        ],
        Some(1),
        &[
            "-nndd_reference_factor 64",
            "mesh 32768",
            "GiB",
            "available",
            "at most",
        ],
    );
    assert!(line.contains("(4295229444 dofs)"), "{line}");
    fails_with(
        1,
        &["-nndd_n", "40000"],
        Some(1),
        &["-nndd_n 40000", "GiB", "available", "coarser mesh"],
    );
    // Refused at once: no mesh was built (n = 40000 is 6.4e9 dofs).
    assert!(t.elapsed().as_secs() < 30, "{:?}", t.elapsed());
    let dir = scratch("fits");
    let args = [
        "-nndd_n",
        "8",
        "-nndd_reference_factor",
        "2",
        "-nndd_estimate",
    ];
    let j = solve(2, &dir.join("r2"), &args);
    assert!(j["estimates"][0]["e_ref"].as_f64().unwrap() > 0.0);
    std::fs::remove_dir_all(&dir).ok();
}

/// `-nndd_memory_check warn` runs a mesh the memory model refuses, saying the model's line as
/// a warning before any mesh is built: `paper` n = 4000 (64 M dofs, about 164 GiB by the
/// model) goes on to its problem's set-up, where an injected fault on rank 0 (`-nndd_fault
/// 0:mesh`, once the built-in grids' problems, their formulas, are made) ends it; refused by
/// default, with the warning's line as the error.
#[test]
fn a_refused_mesh_runs_with_a_warning_under_memory_check_warn() {
    let refused = fails_with(
        2,
        &["-nndd_n", "4000", "-nndd_fault", "0:mesh"],
        Some(1),
        &[
            "-nndd_n 4000",
            "GiB",
            "available",
            "-nndd_memory_check warn",
        ],
    );
    let dir = scratch("memory-warn");
    let prefix = dir.join("run");
    let out = mpirun(
        2,
        &[
            "-nndd_output",
            prefix.to_str().unwrap(),
            "-nndd_n",
            "4000",
            "-nndd_memory_check",
            "warn",
            "-nndd_fault",
            "0:mesh",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let errors: Vec<&str> = (stderr.lines())
        .filter(|l| l.starts_with("nndd: error"))
        .collect();
    assert_eq!(
        errors,
        ["nndd: error: injected fault in phase 'mesh' on rank 0 (-nndd_fault)"],
        "{stderr}"
    );
    let warnings: Vec<&str> = (stderr.lines())
        .filter(|l| l.starts_with("nndd: warning:"))
        .collect();
    // Said once, by rank 0, before the fault: the refusal's line (the memory available may
    // differ by a little between the runs), and that it runs anyway.
    let model = refused.trim_start_matches("nndd: error: ");
    let need = &model[..model.find(" (estimated;").expect(model)];
    assert!(model.ends_with(" (or -nndd_memory_check warn)"), "{model}");
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].starts_with(&format!("nndd: warning: {need} (estimated;"))
            && warnings[0].ends_with(
                "; use a coarser mesh or more nodes; run anyway (-nndd_memory_check warn)"
            ),
        "{stderr}"
    );
    let at = |needle: &str| {
        stderr
            .find(needle)
            .unwrap_or_else(|| panic!("{needle}: {stderr}"))
    };
    assert!(at("nndd: warning:") < at("injected fault"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
