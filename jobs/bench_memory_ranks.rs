//! Memory per rank against the rank count: `paper` with one estimate (the reported iterate's,
//! `-nndd_estimate -nndd_estimate_every 0`, no reference) solved on 2, 4 and 8 ranks at
//! n = 512 and on 2 and 8 ranks at n = 1024 (`--quick`: n = 128 and 256). Per run one row: the peak
//! resident memory of each rank (the summary's `peak_memory_mib_per_rank`), its largest and
//! smallest, the ideal (the 2-rank largest × 2 / ranks, where the same binary ran n on 2
//! ranks), their ratio, the sum over the ranks and its ratio to the 2-rank sum, the same sum
//! with the shared libraries' resident pages counted once (the summary's
//! `file_backed_memory_mib_per_rank`: one copy on a machine) and its ratio, the wall time,
//! the solve's time and η^glo. With `NNDD_BEFORE=path/to/nndd` every case runs with that binary
//! too, right after this one's (a before/after table measured in one run). More ranks than
//! cores run oversubscribed: their memory is what is measured, not their speed. The table goes
//! to `results/bench-memory-ranks.txt`. `--every K` estimates every K-th iteration instead
//! (`-nndd_estimate_every K`: many estimated steps, each kept for the output). Run through
//! `jobs/bench-memory-ranks [--quick] [--every K] [--ranks LIST] [n …] [-- OPTIONS…]`: `--ranks`
//! runs every n on each rank count of LIST, levels n replace the default ones, and the options
//! after `--` are given to every run (`-- -body1_mat_mumps_icntl_22 1 -body2_mat_mumps_icntl_22 1`).
//!
//! What no distribution of the work can remove is measured in the same run: each rank count's
//! fixed cost F_P, the largest peak of a run of `paper` n = 8 on P ranks with the same options
//! (the libraries, MPI's and PETSc's buffers: what a process holds whatever its share). The
//! floor is then F_P + (max@2 − F_2) · 2 / P, the largest rank's peak had everything else fallen
//! as 1/P, and the sum's floor P · F_P + (sum@2 − 2 F_2); the table gives both over the ideal and
//! over the 2-rank sum, the least ratios any solver with these per-process costs could reach.

#[path = "runner.rs"]
mod runner;

use std::collections::HashMap;
use std::io::Write;

fn main() {
    let Args {
        every,
        cases,
        extra,
    } = parse_args();
    let dir = runner::scratch("bench-memory-ranks");
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let mut binaries = vec![("this", "target/release/nndd".to_string())];
    if let Ok(before) = std::env::var("NNDD_BEFORE") {
        binaries.push(("before", before));
    }
    let mut lines = vec![
        format!("# jobs/bench-memory-ranks: paper, -nndd_estimate -nndd_estimate_every {every} ({}), solve to tol 1e-8; MiB per rank (peak resident), oversubscribed above {cores} ranks", match every {
            0 => "one estimate".to_string(),
            k => format!("an estimate every {k} iterations"),
        }),
        format!(
            "{:>7} {:>5} {:>5} {:>9} {:>8} {:>8} {:>8} {:>10} {:>8} {:>9} {:>9} {:>11} {:>6} {:>11} {:>12} {:>7} {:>7} {:>12}",
            "binary", "n", "ranks", "dofs", "max MiB", "min MiB", "ideal", "max/ideal", "sum MiB",
            "sum/sum@2", "libs once", "once/once@2", "fixed", "floor/ideal", "sfloor/sum@2",
            "wall s", "solve s", "eta_glo"
        ),
    ];
    if !extra.is_empty() {
        lines.insert(1, format!("# every run with {}", extra.join(" ")));
    }
    // (binary, ranks) → the fixed cost F_P: the largest peak of `paper` n = 8 on those ranks
    let mut fixed: HashMap<(&str, usize), f64> = HashMap::new();
    // (binary, n) → (largest, sum, sum with the libraries once) on 2 ranks
    let mut two: HashMap<(&str, usize), (f64, f64, f64)> = HashMap::new();
    for &(n, ranks) in &cases {
        for (name, exe) in &binaries {
            eprintln!("bench-memory-ranks: {name}, n = {n} on {ranks} ranks …");
            std::env::set_var("NNDD", exe);
            let prefix = dir.join(format!("{name}-n{n}-p{ranks}"));
            let mpirun: &[&str] = if ranks > cores {
                &["--oversubscribe"]
            } else {
                &[]
            };
            let run = |n: usize, prefix: &std::path::Path| {
                let n = n.to_string();
                let every = every.to_string();
                let mut args = vec![
                    "-nndd_n",
                    &n,
                    "-nndd_estimate",
                    "-nndd_estimate_every",
                    &every,
                    "-nndd_reference_factor",
                    "0",
                ];
                args.extend(extra.iter().map(String::as_str));
                runner::try_run(ranks, "petsc-options/paper.opts", mpirun, prefix, &args)
            };
            if !fixed.contains_key(&(*name, ranks)) {
                let tiny = dir.join(format!("{name}-fixed-p{ranks}"));
                match run(FIXED_N, &tiny) {
                    Ok((j, _)) => {
                        let peaks = runner::nums(&j, "peak_memory_mib_per_rank");
                        fixed.insert((name, ranks), peaks.iter().cloned().fold(0.0, f64::max));
                    }
                    Err(e) => eprintln!("bench-memory-ranks: no fixed cost on {ranks} ranks: {e}"),
                }
            }
            let (j, wall) = match run(n, &prefix) {
                Ok(r) => r,
                Err(e) => {
                    lines.push(format!("{name:>7} {n:>5} {ranks:>5} failed: {e}"));
                    write_table(&lines);
                    continue;
                }
            };
            let peaks = runner::nums(&j, "peak_memory_mib_per_rank");
            let max = peaks.iter().cloned().fold(0.0, f64::max);
            let min = peaks.iter().cloned().fold(f64::INFINITY, f64::min);
            let sum: f64 = peaks.iter().sum();
            // The ranks' shared libraries' pages counted once, not once per rank (the
            // summary's file_backed_memory_mib_per_rank; 0 where a binary does not say).
            let files = runner::nums(&j, "file_backed_memory_mib_per_rank");
            let once = sum - files.iter().sum::<f64>() + files.iter().cloned().fold(0.0, f64::max);
            if ranks == 2 {
                two.insert((name, n), (max, sum, once));
            }
            let base = two.get(&(name, n));
            let ideal = base.map(|b| b.0 * 2.0 / ranks as f64);
            let opt = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
            let f_p = fixed.get(&(*name, ranks)).copied();
            let f_2 = fixed.get(&(*name, 2)).copied();
            // The floors of the largest peak and of the sum: what the fixed costs leave,
            // everything else falling as 1/P.
            let floors = base.zip(f_p.zip(f_2)).map(|(b, (fp, f2))| {
                let p = ranks as f64;
                (fp + (b.0 - f2) * 2.0 / p, p * fp + (b.1 - 2.0 * f2))
            });
            let eta = j["estimates"]
                .as_array()
                .and_then(|e| e.last())
                .map_or(f64::NAN, |e| runner::num(e, "eta_glo"));
            lines.push(format!(
                "{name:>7} {n:>5} {ranks:>5} {:>9} {max:>8.0} {min:>8.0} {:>8} {:>10} {sum:>8.0} {:>9} {once:>9.0} {:>11} {:>6} {:>11} {:>12} {wall:>7.1} {:>7.2} {eta:>12.6e}",
                runner::num(&j, "dofs"),
                opt(ideal, 0),
                opt(ideal.map(|i| max / i), 2),
                opt(base.map(|b| sum / b.1), 2),
                opt(base.map(|b| once / b.2), 2),
                opt(f_p, 0),
                opt(floors.zip(ideal).map(|(f, i)| f.0 / i), 2),
                opt(floors.zip(base).map(|(f, b)| f.1 / b.1), 2),
                runner::solve_seconds(&j),
            ));
            eprintln!("{}", lines.last().expect("a row"));
            // (the table so far: a run stopped part-way keeps its finished rows)
            write_table(&lines);
        }
    }
    write_table(&lines);
    print!("{}", lines.join("\n") + "\n");
    std::fs::remove_dir_all(&dir).ok();
}

/// The level of the runs that measure a rank count's fixed cost.
const FIXED_N: usize = 8;

/// `results/bench-memory-ranks.txt`: the header and the rows so far.
fn write_table(lines: &[String]) {
    let table = lines.join("\n") + "\n";
    std::fs::create_dir_all("results").ok();
    std::fs::File::create("results/bench-memory-ranks.txt")
        .and_then(|mut f| f.write_all(table.as_bytes()))
        .expect("write results/bench-memory-ranks.txt");
}

/// The command line: the estimate's frequency and the (n, ranks) cases.
struct Args {
    /// `-nndd_estimate_every` (0: the reported iterate alone).
    every: usize,
    cases: Vec<(usize, usize)>,
    /// The options after `--`, given to every run.
    extra: Vec<String>,
}

/// `[--quick] [--every K] [--ranks LIST] [n …] [-- OPTIONS…]`: `--ranks LIST` runs each n on
/// every rank count of LIST; levels n replace the default ones (512 and 1024; `--quick`: 128
/// and 256), whose default rank counts are 2, 4, 8 for the first and 2, 8 for the second; the
/// options after `--` go to every run.
fn parse_args() -> Args {
    let fail = |msg: String| -> ! {
        eprintln!("bench-memory-ranks: {msg}");
        std::process::exit(2);
    };
    let (mut quick, mut every) = (false, 0);
    let mut ranks: Option<Vec<usize>> = None;
    let mut levels = Vec::new();
    let mut extra = Vec::new();
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--" => extra.extend(it.by_ref()),
            "--quick" => quick = true,
            "--every" => {
                every = it.next().and_then(|v| v.parse().ok()).unwrap_or_else(|| {
                    fail(
                    "--every takes a whole number of iterations (0: the reported iterate alone)"
                        .into(),
                )
                })
            }
            "--ranks" => {
                let list = it
                    .next()
                    .unwrap_or_else(|| fail("--ranks needs a list, e.g. 2,4,8".into()));
                ranks = Some(
                    runner::positive_list(&list).unwrap_or_else(|e| fail(format!("--ranks: {e}"))),
                );
            }
            _ => match a.parse::<usize>() {
                Ok(n) if n > 0 => levels.push(n),
                _ => fail(format!(
                    "unknown argument '{a}' (--quick, --every K, --ranks LIST, n …, -- OPTIONS…)"
                )),
            },
        }
    }
    if levels.is_empty() {
        levels = if quick {
            vec![128, 256]
        } else {
            vec![512, 1024]
        };
    }
    let cases = match ranks {
        Some(r) => levels
            .iter()
            .flat_map(|&n| r.iter().map(move |&p| (n, p)))
            .collect(),
        None => levels
            .iter()
            .enumerate()
            .flat_map(|(i, &n)| {
                let r: &[usize] = if i == 0 { &[2, 4, 8] } else { &[2, 8] };
                r.iter().map(move |&p| (n, p))
            })
            .collect(),
    };
    Args {
        every,
        cases,
        extra,
    }
}
