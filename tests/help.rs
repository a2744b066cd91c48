//! Capability: `-help` lists every `-nndd_` option with its default, and the per-body solver
//! options, without solving.

mod common;
use common::*;

#[test]
fn help_lists_options() {
    let out = mpirun(1, &["-help"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for opt in [
        "-nndd_problem <now paper",
        "-nndd_n <now 8",
        "-nndd_theta <now auto",
        "-nndd_tol <1e-08",
        "-nndd_max_it",
        "-nndd_solver <now nndd",
        "-nndd_E <2.1e+11",
        "-nndd_nu <0.27",
        "-nndd_monitor",
        "-nndd_output <now results/paper",
        "-nndd_body1_nx",
        "-nndd_adapt_tol",
        "-nndd_adapt_max_cycles <now 8",
        "-nndd_adapt_strategy <now optimal",
        "-nndd_friction <now none",
        "-nndd_friction_coefficient",
        "-nndd_friction_threshold",
        "-body1_ksp_type",
        "-body2_pc_type",
    ] {
        assert!(text.contains(opt), "-help lacks '{opt}':\n{text}");
    }
    assert!(!text.contains("converged after"), "-help must not solve");
}

/// `-version` prints nndd's version (after PETSc's) and exits 0 without solving or writing.
#[test]
fn version_prints_and_exits() {
    let dir = scratch("version");
    let prefix = dir.join("out/run");
    let out = mpirun(
        2,
        &[
            "-version",
            "-nndd_n",
            "4",
            "-nndd_output",
            prefix.to_str().unwrap(),
        ],
    );
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let ours: Vec<&str> = text.lines().filter(|l| l.starts_with("nndd ")).collect();
    assert_eq!(
        ours,
        [format!("nndd {}", env!("CARGO_PKG_VERSION"))],
        "{text}"
    );
    assert!(text.contains("Petsc Release Version"), "{text}");
    assert!(!text.contains("converged after"), "-version must not solve");
    assert!(walk(&dir).is_empty(), "-version wrote {:?}", walk(&dir));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn log_view_shows_the_stages() {
    let dir = scratch("logview");
    let out = mpirun(
        2,
        &[
            "-nndd_n",
            "8",
            "-nndd_estimate",
            "-nndd_reference_factor",
            "4",
            "-log_view",
            "-nndd_output",
            dir.join("r").to_str().unwrap(),
        ],
    );
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for stage in [
        "Assembly",
        "Factorisation",
        "Interface operators",
        "Dirichlet step",
        "Contact step",
        "Neumann step",
        "Fields",
        "Estimation",
        "Estimation/traction QP",
        "Estimation/re-solves",
        "Estimation/recovery",
        "Estimation/element sums",
        "Estimation/e_ref",
        "Estimation/reduction",
        "Reference solve",
        "Output",
    ] {
        assert!(
            text.lines().any(|l| l.contains(&format!(" {stage}:"))),
            "-log_view lacks stage {stage}:\n{text}"
        );
    }
    // The summary splits the estimation time the same way: the parts cover it (each part is
    // a maximum over the ranks, so their sum may exceed it a little).
    let j = json(&dir.join("r"));
    let t = &j["timings"];
    let total = f(t, "estimation");
    let parts = &t["estimation_parts"];
    let names = [
        "traction_qp",
        "resolves",
        "recovery",
        "element_sums",
        "e_ref",
        "reduction",
    ];
    for name in names {
        assert!(f(parts, name) > 0.0, "{name}: {parts}");
    }
    // Every phase in one stage: the reference solve (16 times the dofs, its own assembly and
    // factorisation) in "Reference solve", not in the run's stages, so -log_view's stage times
    // (averages over the ranks) agree with the summary's (maxima).
    let stage = |name: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.contains(&format!(" {name}:")) && l.contains('%'))
            .unwrap_or_else(|| panic!("no stage {name}"));
        let after = line.split_once(&format!("{name}:")).unwrap().1;
        after.split_whitespace().next().unwrap().parse().unwrap()
    };
    for (name, key) in [
        ("Assembly", "assembly"),
        ("Factorisation", "factorisation"),
        ("Reference solve", "reference"),
    ] {
        let (s, m) = (stage(name), f(t, key));
        assert!(
            s <= 1.5 * m + 2e-3 && s >= 0.3 * m - 2e-3,
            "stage {name} {s} s against the summary's {key} {m} s"
        );
    }
    let sum: f64 = names.iter().map(|n| f(parts, n)).sum();
    assert!(
        sum > 0.8 * total && sum < 2.0 * total,
        "parts {sum} vs estimation {total}: {parts}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `nndd -help | head -1`: the reader closes the pipe first; the process ends quietly by
/// SIGPIPE, as `cat` does, not through PETSc's signal handler (a page of `PETSC ERROR` lines
/// and MPI_ABORT, exit 59).
#[test]
fn a_closed_output_pipe_ends_the_process_quietly() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_nndd"))
        .arg("-help")
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("nndd runs");
    drop(child.stdout.take()); // the reader is gone before the first line
    let out = child.wait_with_output().expect("nndd ends");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.signal(),
        Some(libc::SIGPIPE),
        "{:?}: {err}",
        out.status
    );
    assert!(
        !err.contains("PETSC ERROR") && !err.contains("MPI_ABORT"),
        "{err}"
    );
}

/// A phase that may take long (here: bodies of 101 250 dofs) is announced by one line with its
/// size before it starts: each body's setup (assembly and factorisation) and the final estimate.
#[test]
fn long_phases_are_announced() {
    let dir = scratch("long-phases");
    let prefix = dir.join("run");
    let out = mpirun(
        2,
        &[
            "-nndd_n",
            "224",
            "-nndd_estimate",
            "-nndd_output",
            prefix.to_str().unwrap(),
        ],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    for body in [1, 2] {
        let line = format!(
            "nndd: body {body}: 101250 dofs on 1 rank(s): assembling and factoring (-body{body}_pc_type cholesky) …"
        );
        assert_eq!(text.matches(&line).count(), 1, "{text}");
    }
    let estimating = text
        .find("nndd: estimating the errors of iteration")
        .expect("announced");
    let estimated = text.find("nndd: estimates at iteration").expect("reported");
    assert!(estimating < estimated, "{text}");
    assert!(text.contains("(202500 dofs) …"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}
