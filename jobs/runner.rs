//! Shared by the job programs: run `nndd` under mpirun and read its JSON summary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// A scratch directory for the runs of one job.
pub fn scratch(job: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nndd-{job}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// `mpirun -n ranks nndd -options_file petsc-options/paper.opts args… -nndd_output prefix`,
/// without the monitor; exits on failure. Returns the summary and the wall time.
pub fn run(ranks: usize, prefix: &Path, args: &[&str]) -> (serde_json::Value, f64) {
    let exe = std::env::var("NNDD").unwrap_or_else(|_| "target/release/nndd".into());
    let t = std::time::Instant::now();
    let out = Command::new("mpirun")
        .args([
            "-n",
            &ranks.to_string(),
            &exe,
            "-options_file",
            "petsc-options/paper.opts",
            "-nndd_monitor",
            "0",
        ])
        .args(args)
        .args(["-nndd_output", prefix.to_str().expect("utf-8 path")])
        .output()
        .expect("mpirun runs");
    let wall = t.elapsed().as_secs_f64();
    if !out.status.success() {
        eprintln!(
            "nndd {args:?} failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::process::exit(1);
    }
    let text = std::fs::read_to_string(format!("{}.json", prefix.display())).expect("summary");
    (serde_json::from_str(&text).expect("summary is JSON"), wall)
}

pub fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or(f64::NAN)
}
