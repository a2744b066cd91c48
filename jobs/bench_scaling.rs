//! Scaling benchmark: `paper` to tol 1e-8 with the estimate of the final iterate, at several
//! mesh levels n and rank counts N, next to the monolithic solve (N = 2) of the same mesh.
//! One row per (n, N) with the phase split, the peak memory per rank and the NNDD/monolithic
//! time ratios, then the growth exponents of the NNDD wall time with the dofs. The table also
//! goes to `results/bench-scaling.txt`. `--hertz`: the same for the Gmsh path, the Hertz
//! benchmark (examples/hertz) at mesh levels L, meshed by Gmsh (`results/bench-scaling-hertz.txt`).
//! `--estimate-up-to L`: the levels above L run without the estimate (the growth of the solve
//! alone is printed too).
//! `--recovery NAME`: the NNDD runs' -nndd_recovery (to compare `patch` with `patch-classic`).
//! Run through `jobs/bench-scaling [--quick] [--hertz] [--ranks 1,2,4] [--estimate-up-to L] [--recovery NAME] [n or L …]`.

#[path = "runner.rs"]
mod runner;

use std::io::Write;

use serde_json::Value;

const USAGE: &str =
    "usage: jobs/bench-scaling [--quick] [--hertz] [--ranks 1,2,4] [--estimate-up-to L] [--recovery NAME] [n …]
  n …           mesh levels (default 64 128 256 512 1024; --quick: 64 128)
  --hertz       the Hertz benchmark meshed by Gmsh instead, at levels L (default 2 3 4 5 6,
                52404 dofs at L = 4, x4 per level; --quick: 2 3)
  --ranks LIST  MPI rank counts of the NNDD runs (default 1,2,4; mpirun --oversubscribe above 2)
  --estimate-up-to L  no estimate on the levels above L (default: the estimate on every level)
  --recovery NAME     the -nndd_recovery of the NNDD runs (default patch; patch-classic: the
                      recovery it replaced, to compare)
  The monolithic solve runs once per n on 2 ranks. NNDD=path picks the binary.";

/// One mesh level of the benchmark: its options and its expected dofs.
struct Case {
    opts: &'static str,
    args: Vec<String>,
    dofs: usize,
}

impl Case {
    /// `paper` at level n, or the Hertz mesh of level L (meshed into `dir` by Gmsh).
    fn new(hertz: bool, level: usize, dir: &std::path::Path) -> Case {
        if !hertz {
            return Case {
                opts: "petsc-options/paper.opts",
                args: vec!["-nndd_n".into(), level.to_string()],
                dofs: dofs_of(level),
            };
        }
        let msh = dir.join(format!("hertz-{level}.msh"));
        runner::gmsh_level("examples/hertz/hertz.geo", level, &msh);
        Case {
            opts: "examples/hertz/hertz.opts",
            args: vec!["-nndd_mesh".into(), msh.display().to_string()],
            dofs: (52404.0 * 4f64.powi(level as i32 - 4)) as usize,
        }
    }

    fn with(&self, extra: &[&str]) -> Vec<String> {
        let mut a = self.args.clone();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    }
}

/// A finished run: its summary and wall time (mpirun start to end), or why it failed.
type Outcome = Result<(Value, f64), String>;

fn main() {
    let (levels, ranks, hertz, estimate_up_to, recovery) = parse_args();
    let dir = runner::scratch("scaling");
    std::fs::create_dir_all(&dir).expect("scratch directory");
    std::fs::create_dir_all("results").expect("results/ directory");
    let table = if hertz {
        "results/bench-scaling-hertz.txt"
    } else {
        "results/bench-scaling.txt"
    };
    let mut out = Out::new(table);
    out.line(&format!(
        "# jobs/bench-scaling: {}, tol 1e-8, final estimate (no reference, -nndd_recovery {recovery}){}; {} on {} ({} cores); {} = {:?}, N = {:?}",
        if hertz { "Hertz (Gmsh meshes)" } else { "paper" },
        estimate_up_to.map_or(String::new(), |l| format!(" up to level {l}")),
        now(),
        hostname(),
        std::thread::available_parallelism().map_or(0, |c| c.get()),
        if hertz { "L" } else { "n" },
        levels,
        ranks
    ));
    out.line(&header());

    let total_runs = levels.len() * (ranks.len() + 1);
    let mut count = 0;
    // (N, dofs, wall, wall without the estimate, estimated) of the successful NNDD runs, for
    // the expected times and the exponents.
    let mut done: Vec<(usize, usize, f64, f64, bool)> = Vec::new();
    let mut mono_done: Vec<(usize, f64)> = Vec::new();
    for &n in &levels {
        let case = Case::new(hertz, n, &dir);
        let dofs = case.dofs;
        // The monolithic solve of this mesh, once, on 2 ranks, without estimates.
        count += 1;
        progress(
            count,
            total_runs,
            n,
            dofs,
            2,
            "monolithic",
            guess(&mono_done, dofs, 2, false),
        );
        let prefix = dir.join(format!("mono{n}"));
        let mono_args = case.with(&[
            "-nndd_solver",
            "monolithic",
            "-nndd_estimate_every",
            "0",
            "-nndd_reference_factor",
            "0",
        ]);
        let mono_args: Vec<&str> = mono_args.iter().map(String::as_str).collect();
        let mono = runner::try_run(2, case.opts, &[], &prefix, &mono_args);
        clean(&prefix);
        match &mono {
            Ok((j, wall)) => {
                mono_done.push((j["dofs"].as_u64().map_or(dofs, |d| d as usize), *wall))
            }
            Err(e) => eprintln!("bench-scaling: monolithic n = {n} failed: {e}"),
        }
        let estimate = estimate_up_to.is_none_or(|l| n <= l);
        for &np in &ranks {
            count += 1;
            // Expected time: from the earlier runs on as many ranks, else from any earlier run.
            let time = |r: &(usize, usize, f64, f64, bool)| (r.1, if estimate { r.2 } else { r.3 });
            let mut earlier: Vec<(usize, f64)> = done
                .iter()
                .filter(|r| r.0 == np && (r.4 || !estimate))
                .map(time)
                .collect();
            if earlier.is_empty() {
                earlier = done.iter().map(time).collect();
            }
            let expect = guess(&earlier, dofs, np, estimate);
            let what = if estimate {
                "NNDD + final estimate"
            } else {
                "NNDD (no estimate)"
            };
            progress(count, total_runs, n, dofs, np, what, expect);
            let prefix = dir.join(format!("nndd{n}-{np}"));
            let mpirun_args: &[&str] = if np > 2 { &["--oversubscribe"] } else { &[] };
            // The estimate of the final iterate only, no reference solution.
            let mut extra = vec!["-nndd_tol", "1e-8"];
            if estimate {
                extra.push("-nndd_estimate");
            }
            extra.extend(["-nndd_estimate_every", "0", "-nndd_reference_factor", "0"]);
            extra.extend(["-nndd_recovery", &recovery]);
            let args = case.with(&extra);
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let res: Outcome = runner::try_run(np, case.opts, mpirun_args, &prefix, &args);
            clean(&prefix);
            match &res {
                Ok((j, wall)) => {
                    let dofs = j["dofs"].as_u64().map_or(dofs, |d| d as usize);
                    let estim = j["timings"]["estimation"].as_f64().unwrap_or(0.0);
                    done.push((np, dofs, *wall, wall - estim, estimate));
                    let k = j["estimates"].as_array().map_or(0, |e| e.len());
                    if k != estimate as usize {
                        eprintln!(
                            "bench-scaling: n = {n}, N = {np}: {k} estimate records (expected {})",
                            estimate as usize
                        );
                    }
                }
                Err(e) => eprintln!("bench-scaling: n = {n}, N = {np} failed: {e}"),
            }
            out.line(&row(n, dofs, np, &res, &mono));
        }
    }
    std::fs::remove_dir_all(&dir).ok();

    out.line("");
    for note in NOTES {
        out.line(note);
    }
    out.line("");
    out.line("Growth of the NNDD wall time with the dofs, wall ∝ dofs^p (log ratio):");
    for &np in &ranks {
        // With the estimate (the runs that had it), and without it (wall − estimation).
        for (label, with) in [("with the estimate", true), ("without it", false)] {
            let runs: Vec<(usize, f64)> = done
                .iter()
                .filter(|r| r.0 == np && (r.4 || !with))
                .map(|r| (r.1, if with { r.2 } else { r.3 }))
                .collect();
            match (runs.first(), runs.last()) {
                (Some(a), Some(b)) if b.0 > a.0 => out.line(&format!(
                    "  N = {np}, {label}: p = {:.2} between {} and {} dofs",
                    exponent(*a, *b),
                    a.0,
                    b.0
                )),
                _ => out.line(&format!(
                    "  N = {np}, {label}: -  (fewer than two successful mesh levels)"
                )),
            }
        }
    }
    let two: Vec<(usize, f64)> = done
        .iter()
        .filter(|r| r.0 == 2 && r.4)
        .map(|r| (r.1, r.2))
        .collect();
    let at = |n: usize| two.iter().find(|r| r.0 == dofs_of(n)).copied();
    if !hertz {
        match (at(128), at(1024)) {
            (Some(a), Some(b)) => out.line(&format!(
                "  N = 2, n = 128 to 1024: p = {:.2}",
                exponent(a, b)
            )),
            _ => out.line("  N = 2, n = 128 to 1024: -  (needs both levels run on 2 ranks)"),
        }
    }
    if let (Some(a), Some(b)) = (mono_done.first(), mono_done.last()) {
        if b.0 > a.0 {
            out.line(&format!(
                "  monolithic (N = 2): p = {:.2} between {} and {} dofs",
                exponent(*a, *b),
                a.0,
                b.0
            ));
        }
    }
    eprintln!("bench-scaling: table written to {table}");
}

const NOTES: [&str; 8] = [
    "n: the mesh level (paper: n x n per body; --hertz: the Hertz level L); input: options, mesh file and problem with the pairing of Gamma_c (s)",
    "wall: mpirun start to end (s); assem … output: seconds per phase, maximum over the ranks (wait: timings.exchange, time a rank waited in exchanges)",
    "ranks: body ranks [n1, n2] (- when the summary does not say); MiB: peak resident memory, maximum over ranks, and per world rank",
    "loop/mono: NNDD loop time (dirich + contact + neumann + wait, each a maximum over ranks, so the sum can overcount overlap)",
    "           over the monolithic QP time (mono_qp) of the same n on 2 ranks; wall/mono: NNDD wall (with its final estimate) over mono_wall",
    "solve/mono: NNDD wall without the estimation over mono_wall (the same work: setup, solve, output)",
    "its: NNDD iterations to |dlambda| <= 1e-8 |lambda|; estim: the estimate of the final iterate (eta_glo, eta_FE, eta_NNDD)",
    "failed: the run ended without a summary (exit status and its last error line on stderr); the others went on",
];

/// The command line: levels, ranks, --hertz, --estimate-up-to, --recovery.
type Args = (Vec<usize>, Vec<usize>, bool, Option<usize>, String);

fn parse_args() -> Args {
    let mut levels = Vec::new();
    let mut recovery = "patch".to_string();
    let mut estimate_up_to = None;
    let mut ranks = vec![1, 2, 4];
    let mut quick = false;
    let mut hertz = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            "--quick" => quick = true,
            "--hertz" => hertz = true,
            "--estimate-up-to" => {
                estimate_up_to = Some(
                    args.next()
                        .and_then(|s| s.parse::<usize>().ok())
                        .unwrap_or_else(|| usage("--estimate-up-to needs a level")),
                )
            }
            "--recovery" => {
                recovery = args
                    .next()
                    .unwrap_or_else(|| usage("--recovery needs a name, e.g. patch-classic"));
            }
            "--ranks" => {
                let list = args
                    .next()
                    .unwrap_or_else(|| usage("--ranks needs a list, e.g. 1,2,4"));
                ranks = list
                    .split(',')
                    .map(|s| match s.trim().parse::<usize>() {
                        Ok(v) if v > 0 => v,
                        _ => usage(&format!("--ranks: '{s}' is not a positive integer")),
                    })
                    .collect();
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
            (false, false) => vec![64, 128, 256, 512, 1024],
            (true, true) => vec![2, 3],
            (true, false) => vec![2, 3, 4, 5, 6],
        };
    }
    levels.sort_unstable();
    levels.dedup();
    ranks.sort_unstable();
    ranks.dedup();
    (levels, ranks, hertz, estimate_up_to, recovery)
}

fn usage(msg: &str) -> ! {
    eprintln!("bench-scaling: {msg}\n{USAGE}");
    std::process::exit(1);
}

/// Total dofs of `paper` at level n: two (n+1)² grids of 2-dof nodes.
fn dofs_of(n: usize) -> usize {
    2 * 2 * (n + 1) * (n + 1)
}

fn exponent(a: (usize, f64), b: (usize, f64)) -> f64 {
    (b.1 / a.1).ln() / (b.0 as f64 / a.0 as f64).ln()
}

/// Expected wall time: a start-up of ~1 s plus a part ∝ dofs^1.25, scaled from the largest
/// earlier run of the same kind, else a rough a-priori figure for a 2-core machine (n = 512 on
/// 2 ranks: ~20 s, the estimate of the final iterate ~2.5 times that; one rank runs the bodies
/// in turn).
fn guess(earlier: &[(usize, f64)], dofs: usize, ranks: usize, estimate: bool) -> f64 {
    const P: f64 = 1.15;
    const START: f64 = 1.0;
    if let Some(&(d, w)) = earlier.iter().max_by_key(|r| r.0) {
        return START + (w - START).max(0.1) * (dofs as f64 / d as f64).powf(P);
    }
    let base = 20.0 * (dofs as f64 / dofs_of(512) as f64).powf(P);
    let est = if estimate { 3.5 } else { 1.0 };
    let serial = if ranks == 1 { 1.6 } else { 1.0 };
    START + base * est * serial
}

fn progress(k: usize, total: usize, n: usize, dofs: usize, np: usize, what: &str, secs: f64) {
    eprintln!(
        "bench-scaling [{k}/{total}] {}: n = {n} ({dofs} dofs), {what} on {np} rank(s){}: expect ~{} …",
        now(),
        if np > 2 { " (oversubscribed)" } else { "" },
        human(secs)
    );
}

fn human(s: f64) -> String {
    if s < 1.5 {
        "1 s".to_string()
    } else if s < 90.0 {
        format!("{s:.0} s")
    } else if s < 5400.0 {
        format!("{:.0} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

fn header() -> String {
    format!(
        "{:>5} {:>8} {:>3} {:>7} {:>4} {:>8} {:>6} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>9} {:>9} {:>9} {:>8} {:>9}  {}",
        "n",
        "dofs",
        "N",
        "ranks",
        "its",
        "wall_s",
        "input",
        "assem",
        "factor",
        "dirich",
        "contact",
        "neumann",
        "wait",
        "estim",
        "output",
        "MiB",
        "loop/mono",
        "wall/mono",
        "solve/mono",
        "mono_qp",
        "mono_wall",
        "MiB/rank"
    )
}

fn row(n: usize, dofs: usize, np: usize, res: &Outcome, mono: &Outcome) -> String {
    let (j, wall) = match res {
        Ok(r) => r,
        Err(e) => return format!("{n:>5} {dofs:>8} {np:>3} failed ({e})"),
    };
    let t = &j["timings"];
    let g = |k: &str| t[k].as_f64();
    let f = |k: &str| g(k).map_or_else(|| "-".to_string(), |v| format!("{v:.2}"));
    let its = j["iterations"]
        .as_u64()
        .map_or_else(|| "-".to_string(), |v| v.to_string());
    let body_ranks = match j["body_ranks"].as_array() {
        Some(a) => a
            .iter()
            .map(|v| v.as_u64().map_or_else(|| "?".into(), |x| x.to_string()))
            .collect::<Vec<_>>()
            .join(","),
        None => "-".to_string(),
    };
    let peak = j["peak_memory_mib"]
        .as_f64()
        .map_or_else(|| "-".to_string(), |v| format!("{v:.0}"));
    let per_rank = match j["peak_memory_mib_per_rank"].as_array() {
        Some(a) => a
            .iter()
            .map(|v| v.as_f64().map_or_else(|| "?".into(), |x| format!("{x:.0}")))
            .collect::<Vec<_>>()
            .join(","),
        None => "-".to_string(),
    };
    let lp = ["dirichlet_step", "contact_step", "neumann_step", "exchange"]
        .iter()
        .map(|k| g(k))
        .sum::<Option<f64>>();
    let est = g("estimation").unwrap_or(0.0);
    let (loop_ratio, wall_ratio, solve_ratio, mono_s, mono_wall) = match mono {
        Ok((m, mwall)) => {
            let mt = m["timings"]["monolithic"].as_f64();
            let lr = match (lp, mt) {
                (Some(a), Some(b)) if b > 0.0 => format!("{:.2}", a / b),
                _ => "-".into(),
            };
            (
                lr,
                format!("{:.2}", wall / mwall),
                format!("{:.2}", (wall - est) / mwall),
                mt.map_or_else(|| "-".into(), |v| format!("{v:.2}")),
                format!("{mwall:.2}"),
            )
        }
        Err(_) => (
            "failed".into(),
            "failed".into(),
            "failed".into(),
            "failed".into(),
            "failed".into(),
        ),
    };
    format!(
        "{:>5} {:>8} {:>3} {:>7} {:>4} {:>8.2} {:>6} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>9} {:>9} {:>9} {:>8} {:>9}  {}",
        n,
        j["dofs"].as_u64().map_or(dofs, |d| d as usize),
        np,
        body_ranks,
        its,
        wall,
        f("input"),
        f("assembly"),
        f("factorisation"),
        f("dirichlet_step"),
        f("contact_step"),
        f("neumann_step"),
        f("exchange"),
        f("estimation"),
        f("output"),
        peak,
        loop_ratio,
        wall_ratio,
        solve_ratio,
        mono_s,
        mono_wall,
        per_rank
    )
}

/// Remove a run's output files (the HDF5 of n = 1024 is large); the summary has been read.
fn clean(prefix: &std::path::Path) {
    for ext in ["h5", "xdmf", "json"] {
        std::fs::remove_file(format!("{}.{ext}", prefix.display())).ok();
    }
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
