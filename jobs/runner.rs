//! Shared by the job programs: run `nndd` under mpirun and read its JSON summary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// A dataset of the run's `PREFIX.h5`, as f64.
pub fn read_h5(prefix: &Path, dataset: &str) -> Vec<f64> {
    let f = hdf5::File::open(format!("{}.h5", prefix.display())).expect("h5 opens");
    f.dataset(dataset)
        .expect(dataset)
        .read_raw::<f64>()
        .expect(dataset)
}

/// The reported iterate's field `name` of grid `grid`, from the dataset the summary `j` lists.
pub fn read_field(j: &serde_json::Value, prefix: &Path, grid: &str, name: &str) -> Vec<f64> {
    let fd = j["fields"]
        .as_array()
        .expect("the summary lists the fields")
        .iter()
        .find(|f| f["grid"] == grid && f["name"] == name)
        .unwrap_or_else(|| panic!("no field {grid}/{name} in the summary"));
    read_h5(prefix, fd["dataset"].as_str().expect("a dataset path"))
}

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

/// A summary's array of numbers, such as a per-rank one (`peak_memory_mib_per_rank`): NaN for
/// an entry that is not a number, empty where the summary does not have it.
pub fn nums(v: &serde_json::Value, key: &str) -> Vec<f64> {
    v[key].as_array().map_or(Vec::new(), |a| {
        a.iter().map(|x| x.as_f64().unwrap_or(f64::NAN)).collect()
    })
}

/// The solve's time in a summary: assembly + factorisation + interface operators + the NNDD
/// loop (its steps and exchanges) + the fields, each a maximum over the ranks.
pub fn solve_seconds(summary: &serde_json::Value) -> f64 {
    let t = &summary["timings"];
    [
        "assembly",
        "factorisation",
        "interface",
        "fields",
        "dirichlet_step",
        "contact_step",
        "neumann_step",
        "exchange",
    ]
    .iter()
    .map(|k| num(t, k))
    .sum()
}

/// Like [`run`], with another options file and extra mpirun arguments (e.g. `--oversubscribe`),
/// and a failed run (bad input, solver failure, killed for lack of memory …) is an `Err` with
/// its exit status and one line of its stderr (nndd's error, else mpirun's) instead of ending
/// the job. With `NNDD_SUMMARIES=dir` the run keeps its summary there and writes its output,
/// with the monitor, to a log beside it as it goes (`{name}-ranks{N}.log`), so that a run the
/// job's time limit kills still says how far it got.
pub fn try_run(
    ranks: usize,
    options_file: &str,
    mpirun_args: &[&str],
    prefix: &Path,
    args: &[&str],
) -> Result<(serde_json::Value, f64), String> {
    let exe = std::env::var("NNDD").unwrap_or_else(|_| "target/release/nndd".into());
    let kept = std::env::var("NNDD_SUMMARIES").ok().map(|dir| {
        let name = prefix
            .file_name()
            .map_or("run".into(), |n| n.to_string_lossy());
        Path::new(&dir).join(format!("{name}-ranks{ranks}"))
    });
    let mut cmd = Command::new("mpirun");
    cmd.args(mpirun_args)
        .args([
            "-n",
            &ranks.to_string(),
            &exe,
            "-options_file",
            options_file,
        ])
        .args(["-nndd_monitor", if kept.is_some() { "1" } else { "0" }])
        .args(args)
        .args(["-nndd_output", prefix.to_str().expect("utf-8 path")]);
    let t = std::time::Instant::now();
    let (status, stderr) = match &kept {
        Some(keep) => {
            let log = keep.with_extension("log");
            let file = std::fs::create_dir_all(keep.parent().expect("a directory"))
                .and_then(|_| std::fs::File::create(&log))
                .map_err(|e| format!("{}: {e}", log.display()))?;
            let copy = file
                .try_clone()
                .map_err(|e| format!("{}: {e}", log.display()))?;
            let status = cmd
                .stdout(file)
                .stderr(copy)
                .status()
                .map_err(|e| format!("mpirun: {e}"))?;
            (status, std::fs::read_to_string(&log).unwrap_or_default())
        }
        None => {
            let out = cmd.output().map_err(|e| format!("mpirun: {e}"))?;
            (
                out.status,
                String::from_utf8_lossy(&out.stderr).into_owned(),
            )
        }
    };
    let wall = t.elapsed().as_secs_f64();
    if !status.success() {
        return Err(failure(status, &stderr));
    }
    let path = format!("{}.json", prefix.display());
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{path}: {e}"))?;
    let summary = serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?;
    if let Some(keep) = kept {
        // (the benchmarks delete their scratch summaries)
        let keep = keep.with_extension("json");
        std::fs::write(&keep, &text).map_err(|e| format!("{}: {e}", keep.display()))?;
    }
    Ok((summary, wall))
}

/// A failed run's exit status and one line of its output `stderr`: our own error line
/// ("nndd: error…"; the other "nndd: " lines are progress) if any, else mpirun's note of a
/// signal (e.g. the kernel's out-of-memory kill), else the last line.
fn failure(status: std::process::ExitStatus, stderr: &str) -> String {
    let lines: Vec<&str> = stderr
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.chars().all(|c| c == '-'))
        .collect();
    let last = lines
        .iter()
        .find(|l| l.starts_with("nndd: error"))
        .or_else(|| lines.iter().find(|l| l.contains("signal")))
        .or_else(|| lines.last())
        .copied()
        .unwrap_or("");
    let status = match status.code() {
        Some(137) => "exit 137: signal 9, killed (out of memory?)".to_string(),
        Some(c) if c > 128 => format!("exit {c}: signal {}", c - 128),
        Some(c) => format!("exit {c}"),
        None => "killed by a signal".to_string(),
    };
    format!("{status}: {last}")
}

/// `gmsh -2 -format msh41 -setnumber level LEVEL GEO -o OUT` (Gmsh is installed by jobs/setup).
#[allow(dead_code)]
pub fn gmsh_level(geo: &str, level: usize, out: &Path) {
    let st = Command::new("gmsh")
        .args(["-2", "-format", "msh41", "-v", "1", "-setnumber", "level"])
        .arg(level.to_string())
        .arg(geo)
        .arg("-o")
        .arg(out)
        .status()
        .expect("gmsh runs (jobs/setup installs it)");
    assert!(st.success(), "gmsh failed on {geo}, level {level}");
}

/// A comma-separated list of positive whole numbers (`--ranks 1,2,4,8`), or the item that is not.
pub fn positive_list(list: &str) -> Result<Vec<usize>, String> {
    list.split(',')
        .map(|s| match s.trim().parse::<usize>() {
            Ok(v) if v > 0 => Ok(v),
            _ => Err(format!("'{s}' is not a positive integer")),
        })
        .collect()
}

/// The arguments of the mesh-level jobs (jobs/hertz, jobs/pin):
/// `[--levels 1,2,3,4] [--estimate-up-to L] [--reference-factor r]`.
pub struct LevelArgs {
    pub levels: Vec<usize>,
    /// Estimate on the levels up to this one (default: all).
    pub estimate_up_to: usize,
    /// e_ref on the mesh refined r times (default 4; 0 or 1: none).
    pub reference_factor: usize,
    /// The example (a folder of examples/ with NAME.geo and NAME.opts; default: the job's).
    pub example: String,
}

impl LevelArgs {
    /// From the command line; an unknown argument ends `job` with a message.
    pub fn parse(job: &str) -> LevelArgs {
        let mut a = LevelArgs {
            levels: vec![1, 2, 3, 4],
            estimate_up_to: usize::MAX,
            reference_factor: 4,
            example: job.to_string(),
        };
        let args: Vec<String> = std::env::args().skip(1).collect();
        let mut it = args.iter();
        while let Some(arg) = it.next() {
            match arg.as_str() {
                "--levels" => {
                    a.levels = it
                        .next()
                        .expect("--levels 1,2,…")
                        .split(',')
                        .map(|s| s.parse().expect("a level"))
                        .collect()
                }
                "--estimate-up-to" => {
                    a.estimate_up_to = it.next().and_then(|s| s.parse().ok()).expect("a level")
                }
                "--reference-factor" => {
                    a.reference_factor = it.next().and_then(|s| s.parse().ok()).expect("r")
                }
                "--example" => a.example = it.next().expect("--example NAME").clone(),
                other => {
                    eprintln!("{job}: unknown argument {other}");
                    std::process::exit(1);
                }
            }
        }
        a
    }
}
