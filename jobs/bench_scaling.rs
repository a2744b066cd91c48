//! Strong scaling: one problem on 1, 2, 4, 8 … ranks (`--ranks`), to tol 1e-8 with the paper's
//! θ = 0.25 (`petsc-options/paper.opts`; `--hertz`: the Hertz example meshed by Gmsh, θ auto),
//! the solve only (`--estimate`: with the estimate of the final iterate), and the monolithic
//! solve of the same mesh on 2 ranks. Per (level, rank count) one row: the wall time (mpirun
//! start to end), each phase (maximum over the ranks), the flops PETSc logged (summed over the
//! ranks, what `-log_view` totals) and MUMPS's factorisation flops (RINFOG(3), both bodies),
//! the speed-up and the parallel efficiency against 2 ranks, the bodies' setup imbalance, the
//! contact steps' share of the loop, NNDD / monolithic, and the peak memory. The table goes
//! to `results/bench-scaling.txt` (`--hertz`: `results/bench-scaling-hertz.txt`), and a
//! strong-scaling chart of the wall time to the PNG beside it.
//! Run through `jobs/bench-scaling [--ranks 1,2,4,8] [--hertz] [--estimate] [--no-monolithic]
//! [--quick] [level …]`.

#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;

use std::io::Write;

use serde_json::Value;

const USAGE: &str =
    "usage: jobs/bench-scaling [--ranks 1,2,4,8] [--hertz] [--estimate] [--no-monolithic] [--quick] [level …]
  level …       paper: n (default 256 512; --quick: 64 128); --hertz: the Gmsh level L
                (default 5 6; --quick: 3 4)
  --ranks LIST  MPI rank counts (default 1,2,4,8; mpirun --oversubscribe above the cores)
  --hertz       the Hertz example (examples/hertz) instead of paper
  --estimate    each NNDD run also estimates its final iterate
  --no-monolithic  skip the monolithic solve (n/mono: -), for levels too large for it
  The monolithic solve runs once per level on 2 ranks. NNDD=path picks the binary;
  NNDD_SUMMARIES=dir keeps each run's JSON summary there, and its output with the monitor
  (a .log, written as the run goes).";

/// One mesh level of the benchmark: its options file and arguments.
struct Case {
    opts: &'static str,
    args: Vec<String>,
}

impl Case {
    /// `paper` at level n (θ = 0.25), or the Hertz mesh of level L (meshed into `dir`).
    fn new(hertz: bool, level: usize, dir: &std::path::Path) -> Case {
        if !hertz {
            return Case {
                opts: "petsc-options/paper.opts",
                args: vec!["-nndd_n".into(), level.to_string()],
            };
        }
        let msh = dir.join(format!("hertz-{level}.msh"));
        runner::gmsh_level("examples/hertz/hertz.geo", level, &msh);
        Case {
            opts: "examples/hertz/hertz.opts",
            args: vec!["-nndd_mesh".into(), msh.display().to_string()],
        }
    }

    fn run(&self, np: usize, prefix: &std::path::Path, extra: &[&str]) -> Outcome {
        let mut args: Vec<&str> = self.args.iter().map(String::as_str).collect();
        args.extend(["-nndd_tol", "1e-8", "-nndd_estimate_every", "0"]);
        args.extend(["-nndd_reference_factor", "0"]);
        args.extend(extra);
        let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
        let mpirun: &[&str] = if np > cores {
            &["--oversubscribe"]
        } else {
            &[]
        };
        let res = runner::try_run(np, self.opts, mpirun, prefix, &args);
        for ext in ["h5", "xdmf", "json"] {
            std::fs::remove_file(format!("{}.{ext}", prefix.display())).ok();
        }
        res
    }
}

/// A finished run: its summary and wall time, or why it failed.
type Outcome = Result<(Value, f64), String>;

fn main() {
    let Args {
        levels,
        ranks,
        hertz,
        estimate,
        monolithic,
    } = parse_args();
    plot::register_font();
    let dir = runner::scratch("scaling");
    std::fs::create_dir_all("results").expect("results/ directory");
    let stem = if hertz {
        "results/bench-scaling-hertz"
    } else {
        "results/bench-scaling"
    };
    let mut out = Out::new(&format!("{stem}.txt"));
    let cores = std::thread::available_parallelism().map_or(0, |c| c.get());
    out.line(&format!(
        "# jobs/bench-scaling: {}, tol 1e-8, {}; {} on {} ({cores} cores); levels {levels:?}, ranks {ranks:?}",
        if hertz {
            "Hertz (Gmsh meshes, theta auto)"
        } else {
            "paper (theta 0.25)"
        },
        if estimate {
            "with the estimate of the final iterate"
        } else {
            "solve only"
        },
        now(),
        hostname(),
    ));
    out.line(&header());
    // Per level: the wall time of each rank count (for the chart).
    let mut curves: Vec<(usize, Vec<(f64, f64)>)> = Vec::new();
    for &level in &levels {
        let case = Case::new(hertz, level, &dir);
        let mono = match monolithic {
            Monolithic::Run => {
                eprintln!(
                    "bench-scaling {}: level {level}, monolithic on 2 ranks …",
                    now()
                );
                case.run(
                    2,
                    &dir.join(format!("mono-{level}")),
                    &["-nndd_solver", "monolithic"],
                )
            }
            Monolithic::Skip => Err("skipped (--no-monolithic)".into()),
        };
        if let (Monolithic::Run, Err(e)) = (monolithic, &mono) {
            eprintln!("bench-scaling: level {level}, monolithic failed: {e}");
        }
        let mut runs: Vec<(usize, Outcome)> = Vec::new();
        for &np in &ranks {
            eprintln!(
                "bench-scaling {}: level {level}, NNDD on {np} rank(s){} …",
                now(),
                if np > cores { " (oversubscribed)" } else { "" }
            );
            let extra: &[&str] = if estimate { &["-nndd_estimate"] } else { &[] };
            let res = case.run(np, &dir.join(format!("nndd-{level}-{np}")), extra);
            if let Err(e) = &res {
                eprintln!("bench-scaling: level {level}, N = {np} failed: {e}");
            }
            runs.push((np, res));
        }
        let two = runs
            .iter()
            .find(|r| r.0 == 2)
            .and_then(|r| r.1.as_ref().ok())
            .map(|r| r.1);
        for (np, res) in &runs {
            out.line(&row(level, *np, res, two, &mono));
        }
        curves.push((
            level,
            runs.iter()
                .filter_map(|(np, r)| r.as_ref().ok().map(|r| (*np as f64, r.1)))
                .collect(),
        ));
    }
    std::fs::remove_dir_all(&dir).ok();
    out.line("");
    for note in NOTES {
        out.line(note);
    }
    let png = format!("{stem}.png");
    match chart(&png, hertz, cores, &curves) {
        Ok(()) => eprintln!("bench-scaling: table in {stem}.txt, chart in {png}"),
        Err(e) => eprintln!("bench-scaling: {e}"),
    }
}

const NOTES: [&str; 8] = [
    "level: paper n (n x n squares per body) or the Hertz level L; N: ranks; ranks: body ranks [n1, n2]; its: NNDD iterations",
    "wall: mpirun start to end (s); input … output: seconds per phase, maximum over the ranks (iface: S, D and the free solutions;",
    "      loop: the Dirichlet, contact and Neumann steps and the exchanges of all iterations; fields: the reported fields)",
    "flops: what PETSc logged, summed over the ranks (-log_view's total); mumps: MUMPS's factorisation flops (RINFOG(3)), both bodies",
    "speedup, eff: wall on 2 ranks / wall, and speedup x 2 / N; imbal: |t1 - t2| / max(t1, t2) of the bodies' setups (the shorter waits)",
    "qp%: the contact steps' share of the loop; n/mono: NNDD wall / monolithic wall (2 ranks, same mesh); MiB: peak memory, maximum over ranks",
    "More ranks than cores (mpirun --oversubscribe) measure the work that a rank count adds, not its speed-up: MUMPS's parallel",
    "factorisation and solves wait for messages by polling, and a polling rank takes the core from the rank it waits for",
];

/// Wall time against ranks, one curve per level, with the ideal strong scaling from 2 ranks.
fn chart(
    path: &str,
    hertz: bool,
    cores: usize,
    curves: &[(usize, Vec<(f64, f64)>)],
) -> Result<(), String> {
    let name = |level: &usize| {
        if hertz {
            format!("Hertz level {level}")
        } else {
            format!("paper n = {level}")
        }
    };
    let mut series: Vec<plot::Series> = curves
        .iter()
        .filter(|(_, points)| !points.is_empty())
        .map(|(level, points)| plot::Series::new(&name(level), points.clone()))
        .collect();
    // The ideal strong scaling of the largest level, from its time on 2 ranks.
    if let Some((level, points)) = curves.iter().rev().find(|(_, p)| !p.is_empty()) {
        if let Some(&(n2, w2)) = points.iter().find(|p| p.0 == 2.0) {
            let ideal = points.iter().map(|p| (p.0, w2 * n2 / p.0)).collect();
            series.push(plot::Series::line(
                &format!("{}: ideal, 2 ranks' time x 2/N", name(level)),
                ideal,
            ));
        }
    }
    if series.is_empty() {
        return Err("no successful run to chart".into());
    }
    let title = format!("Strong scaling, solve only ({} {cores} cores)", hostname());
    plot::line_chart(
        std::path::Path::new(path),
        &plot::Chart {
            title: &title,
            x_label: "MPI ranks",
            y_label: "wall time (s)",
            x_scale: plot::Scale::Log,
            y_scale: plot::Scale::Log,
            legend: plot::SeriesLabelPosition::UpperRight,
        },
        &series,
    )
}

/// Whether each level also runs the monolithic solve (the `n/mono` column).
#[derive(Clone, Copy)]
enum Monolithic {
    Run,
    Skip,
}

/// The command line: levels, rank counts and what each level runs.
struct Args {
    levels: Vec<usize>,
    ranks: Vec<usize>,
    hertz: bool,
    estimate: bool,
    monolithic: Monolithic,
}

fn parse_args() -> Args {
    let mut levels = Vec::new();
    let mut ranks = vec![1, 2, 4, 8];
    let (mut quick, mut hertz, mut estimate) = (false, false, false);
    let mut monolithic = Monolithic::Run;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            "--quick" => quick = true,
            "--hertz" => hertz = true,
            "--estimate" => estimate = true,
            "--no-monolithic" => monolithic = Monolithic::Skip,
            "--ranks" => {
                let list = args
                    .next()
                    .unwrap_or_else(|| usage("--ranks needs a list, e.g. 1,2,4,8"));
                ranks = runner::positive_list(&list)
                    .unwrap_or_else(|e| usage(&format!("--ranks: {e}")));
            }
            _ => match a.parse::<usize>() {
                Ok(v) if v > 0 => levels.push(v),
                _ => usage(&format!("unknown argument '{a}'")),
            },
        }
    }
    if levels.is_empty() {
        levels = match (hertz, quick) {
            (false, true) => vec![64, 128],
            (false, false) => vec![256, 512],
            (true, true) => vec![3, 4],
            (true, false) => vec![5, 6],
        };
    }
    levels.sort_unstable();
    levels.dedup();
    ranks.sort_unstable();
    ranks.dedup();
    Args {
        levels,
        ranks,
        hertz,
        estimate,
        monolithic,
    }
}

fn usage(msg: &str) -> ! {
    eprintln!("bench-scaling: {msg}\n{USAGE}");
    std::process::exit(1);
}

const COLUMNS: [(&str, usize); 23] = [
    ("level", 5),
    ("dofs", 8),
    ("N", 3),
    ("ranks", 5),
    ("its", 4),
    ("wall", 7),
    ("input", 6),
    ("assem", 6),
    ("factor", 6),
    ("iface", 6),
    ("loop", 6),
    ("fields", 6),
    ("output", 6),
    ("estim", 6),
    ("flops", 8),
    ("mumps", 8),
    ("speedup", 7),
    ("eff", 5),
    ("imbal", 5),
    ("qp%", 5),
    ("n/mono", 6),
    ("MiB", 6),
    ("MiB/rank", 0),
];

fn header() -> String {
    COLUMNS
        .iter()
        .map(|(name, w)| format!("{name:>w$}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn row(level: usize, np: usize, res: &Outcome, two: Option<f64>, mono: &Outcome) -> String {
    let (j, wall) = match res {
        Ok(r) => r,
        Err(e) => return format!("{level:>5} {:>8} {np:>3} failed ({e})", "-"),
    };
    let t = &j["timings"];
    let g = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
    let loop_s = g("dirichlet_step") + g("contact_step") + g("neumann_step") + g("exchange");
    let setup: Vec<f64> = j["body_setup_seconds"]
        .as_array()
        .map_or(Vec::new(), |a| a.iter().filter_map(Value::as_f64).collect());
    let imbalance = match setup[..] {
        [a, b] if a.max(b) > 0.0 => format!("{:.2}", (a - b).abs() / a.max(b)),
        _ => "-".into(),
    };
    let mumps: f64 = j["factorisation_flops"]
        .as_array()
        .map_or(f64::NAN, |a| a.iter().filter_map(Value::as_f64).sum());
    let list = |k: &str, digits: usize| match j[k].as_array() {
        Some(a) => a
            .iter()
            .map(|v| v.as_f64().map_or("?".into(), |x| format!("{x:.digits$}")))
            .collect::<Vec<_>>()
            .join(","),
        None => "-".into(),
    };
    let speedup = two.map(|w2| w2 / wall);
    let cells = [
        level.to_string(),
        j["dofs"].to_string(),
        np.to_string(),
        list("body_ranks", 0),
        j["iterations"].to_string(),
        format!("{wall:.2}"),
        format!("{:.2}", g("input")),
        format!("{:.2}", g("assembly")),
        format!("{:.2}", g("factorisation")),
        format!("{:.2}", g("interface")),
        format!("{loop_s:.3}"),
        format!("{:.2}", g("fields")),
        format!("{:.2}", g("output")),
        format!("{:.2}", g("estimation")),
        format!("{:.2e}", j["logged_flops"].as_f64().unwrap_or(f64::NAN)),
        format!("{mumps:.2e}"),
        speedup.map_or("-".into(), |s| format!("{s:.2}")),
        speedup.map_or("-".into(), |s| format!("{:.2}", s * 2.0 / np as f64)),
        imbalance,
        format!("{:.0}", 100.0 * g("contact_step") / loop_s),
        match mono {
            Ok((_, mw)) => format!("{:.2}", wall / mw),
            Err(_) => "-".into(),
        },
        format!("{:.0}", j["peak_memory_mib"].as_f64().unwrap_or(f64::NAN)),
        list("peak_memory_mib_per_rank", 0),
    ];
    cells
        .iter()
        .zip(COLUMNS)
        .map(|(c, (_, w))| format!("{c:>w$}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Standard output and the table file, line by line (a partial table survives an interrupt).
struct Out {
    file: Option<std::fs::File>,
}

impl Out {
    fn new(path: &str) -> Out {
        let file = std::fs::File::create(path)
            .map_err(|e| eprintln!("bench-scaling: cannot write {path}: {e}"))
            .ok();
        Out { file }
    }

    fn line(&mut self, s: &str) {
        println!("{s}");
        if let Some(f) = self.file.as_mut() {
            writeln!(f, "{s}").ok();
            f.flush().ok();
        }
    }
}

fn now() -> String {
    std::process::Command::new("date")
        .arg("+%F %T")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map_or_else(|| "?".into(), |s| s.trim().to_string())
}

fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map_or_else(|_| "?".into(), |s| s.trim().to_string())
}
