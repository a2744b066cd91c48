//! A result file that cannot be written (here: the file-size limit, `ulimit -f`, hit while
//! `PREFIX.h5` is written) ends every rank within seconds, on 1, 2 and 3 ranks: one line
//! `nndd: error: …` naming the file, a non-zero exit that is neither a crash (139) nor the
//! kernel's SIGXFSZ (153), the previous run's result files byte for byte, and no temporary
//! left. Every run is under a time limit, so that a hang fails the test: its process group is
//! killed and the test says how long it waited.

mod common;

use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use common::{scratch, wait_within, walk};

/// The file-size limit of the failing runs, in KiB: what mpirun's own shared-memory files
/// need (below about 8 MiB mpirun itself fails), and below the size of the runs' `.h5`.
const LIMIT_KIB: u64 = 8000;

/// How long a run may take before it counts as a hang.
const HANG: Duration = Duration::from_secs(60);

/// `mpirun -n np nndd args…` under `ulimit -f limit_kib` (none: unlimited), in its own process
/// group, its output piped.
fn spawn(np: usize, args: &[&str], limit_kib: Option<u64>) -> Child {
    let mut line = format!(
        "exec mpirun -n {np} --oversubscribe --bind-to none {}",
        env!("CARGO_BIN_EXE_nndd")
    );
    for a in args {
        assert!(
            a.chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_./:".contains(c)),
            "{a}"
        );
        line.push(' ');
        line.push_str(a);
    }
    if let Some(kib) = limit_kib {
        line = format!("ulimit -f {kib}; {line}");
    }
    Command::new("bash")
        .args(["-c", &line])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .expect("bash and mpirun start")
}

/// The result files of `prefix` and their bytes.
fn results_of(prefix: &Path) -> Vec<(String, Vec<u8>)> {
    ["h5", "xdmf", "json"]
        .iter()
        .map(|x| {
            let p = format!("{}.{x}", prefix.display());
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
            (p, bytes)
        })
        .collect()
}

fn sorted(mut v: Vec<std::path::PathBuf>) -> Vec<std::path::PathBuf> {
    v.sort();
    v
}

#[test]
fn a_write_past_the_file_size_limit_ends_every_rank_with_one_line() {
    let dir = scratch("write-faults");
    let cases: [(&str, Vec<&str>); 3] = [
        ("results", vec!["-nndd_n", "192"]),
        (
            "results with estimates",
            vec!["-nndd_n", "128", "-nndd_estimate"],
        ),
        (
            "results with checkpoints",
            vec!["-nndd_n", "192", "-nndd_checkpoint_every", "2"],
        ),
    ];
    let mut table = Vec::new();
    for (k, (case, args)) in cases.iter().enumerate() {
        let prefix = dir.join(format!("run{k}"));
        let p = prefix.to_str().unwrap();
        let mut all: Vec<&str> = vec!["-nndd_problem", "paper", "-nndd_output", p];
        all.extend(args.iter().copied());
        // An earlier run writes the files the failing runs must leave as they are.
        let first = wait_within(
            spawn(2, &all, None),
            HANG,
            &format!("{case}: the first run"),
        );
        assert_eq!(first.code, Some(0), "{case}:\n{}", first.stderr);
        let before = results_of(&prefix);
        let h5_size = before[0].1.len() as u64;
        assert!(
            h5_size > 1024 * LIMIT_KIB,
            "{case}: the .h5 ({h5_size} bytes) must exceed the limit"
        );
        let files_before = sorted(walk(&dir));
        for np in [1, 2, 3] {
            let what = format!("{case} on {np} rank(s) under ulimit -f {LIMIT_KIB}");
            let e = wait_within(spawn(np, &all, Some(LIMIT_KIB)), HANG, &what);
            assert!(
                e.signal.is_none() && e.code.is_some_and(|c| c != 0 && c < 128),
                "{what}: ended by {:?} / signal {:?} (139: a crash, 153: SIGXFSZ):\n{}",
                e.code,
                e.signal,
                e.stderr
            );
            let ours: Vec<&str> = e
                .stderr
                .lines()
                .filter(|l| l.starts_with("nndd:"))
                .collect();
            assert_eq!(
                ours.len(),
                1,
                "{what}: expected one line, got:\n{}",
                e.stderr
            );
            let h5 = format!("{p}.h5");
            assert!(
                ours[0].starts_with("nndd: error: ") && ours[0].contains(&h5),
                "{what}: '{}' does not name {h5}",
                ours[0]
            );
            for bad in [
                "panicked",
                "backtrace",
                "RUST_BACKTRACE",
                "PETSC ERROR",
                "internal error",
                "Segmentation",
            ] {
                assert!(
                    !e.stderr.contains(bad) && !e.stdout.contains(bad),
                    "{what}: '{bad}' in\n{}",
                    e.stderr
                );
            }
            // The earlier run's results, byte for byte, and nothing else (no temporary); the
            // restart points are small and rewritten by the failing run itself.
            assert_eq!(results_of(&prefix), before, "{what}: the results changed");
            assert_eq!(sorted(walk(&dir)), files_before, "{what}: files left");
            table.push(format!(
                "{what}: exit {:?} in {:.1} s: {}",
                e.code, e.seconds, ours[0]
            ));
        }
    }
    println!("{}", table.join("\n"));
    std::fs::remove_dir_all(&dir).ok();
}
