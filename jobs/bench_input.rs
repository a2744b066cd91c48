//! What building a Gmsh problem's bodies once costs and saves (`-nndd_mesh_input`): `paper`
//! drawn in Gmsh at level n (`gmsh -2 -format msh41 -bin -setnumber n N
//! examples/paper/paper.geo`, 2 n² triangles per body), solved (θ = 0.25 to 1e-8) without
//! estimates, or with one estimate of the final iterate under `--estimate` (and the reference
//! solution of factor R under `--reference R`, its peak once its fine bodies are built in the
//! columns "ref"), with `root` (world
//! rank 0 builds both bodies and sends each rank its part, and its shares of the estimates) and
//! `every_rank` (each rank builds both) in turn on each rank count, the first of the two
//! alternating from one rank count to the next (a run's time depends on what ran before it).
//! Per run one row: the
//! elements of the meshes world rank 0 and the others held in the input and their peak
//! resident memory then (the summary's `input_mesh_elements_per_rank` and
//! `input_peak_memory_mib_per_rank`), the run's largest peak and the sum over the ranks, the
//! input's time (`timings.input`), the run's total and the potential energy. More ranks than
//! cores run oversubscribed: their memory is what is measured, not their speed. Under
//! `--adapt TOL` each run adapts instead, from examples/paper/paper.geo at level n
//! (`-nndd_adapt_tol TOL`, at most 4 cycles; the row is the last cycle's, its dofs, input and
//! peaks, the total the whole run's). Run through `jobs/bench-input [--ranks LIST]
//! [--estimate] [--reference R] [--adapt TOL] [n …]` (default n = 512 on 2 and 8 ranks); the
//! table goes to `results/bench-input.txt`.

#[path = "runner.rs"]
mod runner;

use std::io::Write;
use std::process::Command;

/// What the command line asks for ([`parse_args`]).
struct Args {
    levels: Vec<usize>,
    ranks: Vec<usize>,
    estimate: bool,
    /// The reference factor (0: none).
    reference: usize,
    /// `-nndd_adapt_tol` (none: a run on the level's mesh).
    adapt: Option<f64>,
}

fn main() {
    let Args {
        levels,
        ranks,
        estimate,
        reference,
        adapt,
    } = parse_args();
    let dir = runner::scratch("bench-input");
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let mut lines = vec![
        format!("# jobs/bench-input{}: paper drawn in Gmsh, {}, theta 0.25, tol 1e-8; MiB per rank (peak resident), oversubscribed above {cores} ranks",
            std::env::args().skip(1).map(|a| format!(" {a}")).collect::<String>(),
            match (adapt, estimate, reference) {
                (Some(tol), ..) => format!("adaptive from paper.geo to eta_glo <= {tol} ||u_h||_E, the last cycle's row"),
                (None, false, _) => "no estimate".to_string(),
                (None, true, 0) => "one estimate".to_string(),
                (None, true, r) => format!("one estimate, reference factor {r}"),
            }),
        format!(
            "{:>5} {:>5} {:>9} {:>10} {:>10} {:>12} {:>10} {:>12} {:>9} {:>12} {:>8} {:>8} {:>8} {:>7} {:>16}",
            "n", "ranks", "dofs", "input", "rank0 elts", "others elts", "rank0 MiB", "others MiB",
            "ref0 MiB", "ref others", "max MiB", "sum MiB", "input s", "total s", "energy J/m"
        ),
    ];
    for &n in &levels {
        let msh = dir.join(format!("paper-{n}.msh"));
        let how = match adapt {
            Some(tol) => How::Adapt(tol),
            None => How::Once {
                estimate,
                reference,
            },
        };
        // (an adaptive run meshes the geometry itself)
        if adapt.is_none() {
            let st = Command::new("gmsh")
                .args([
                    "-2",
                    "-format",
                    "msh41",
                    "-bin",
                    "-v",
                    "1",
                    "-setnumber",
                    "n",
                ])
                .arg(n.to_string())
                .arg("examples/paper/paper.geo")
                .arg("-o")
                .arg(&msh)
                .status()
                .expect("gmsh runs (jobs/setup installs it)");
            assert!(st.success(), "gmsh failed on paper.geo, n = {n}");
        }
        let msh = msh.to_str().expect("utf-8 path").to_string();
        for (i, &p) in ranks.iter().enumerate() {
            let order = match i % 2 {
                0 => ["root", "every_rank"],
                _ => ["every_rank", "root"],
            };
            for input in order {
                eprintln!("bench-input: n = {n} on {p} ranks, -nndd_mesh_input {input} …");
                let prefix = dir.join(format!("n{n}-p{p}-{input}"));
                let args = problem_args(n, &msh, input, how);
                let args: Vec<&str> = args.iter().map(String::as_str).collect();
                let mpirun: &[&str] = if p > cores { &["--oversubscribe"] } else { &[] };
                let row =
                    match runner::try_run(p, "examples/paper/paper.opts", mpirun, &prefix, &args) {
                        Ok((j, wall)) => row(n, p, input, &j, wall),
                        Err(e) => format!("{n:>5} {p:>5} {input:>10} failed: {e}"),
                    };
                eprintln!("{row}");
                lines.push(row);
                // (the table so far: a run stopped part-way keeps its finished rows)
                write_table(&lines);
            }
        }
        std::fs::remove_file(&msh).ok();
    }
    print!("{}", lines.join("\n") + "\n");
    std::fs::remove_dir_all(&dir).ok();
}

/// What each run does.
#[derive(Clone, Copy)]
enum How {
    /// A solve on the level's mesh, one estimate of the final iterate or none, with the
    /// reference solution of factor `reference` (none: 0).
    Once { estimate: bool, reference: usize },
    /// Adaptive cycles from paper.geo at the level until η^glo ≤ TOL ‖u_h‖_E.
    Adapt(f64),
}

/// The options of `paper` at level `n` (examples/paper/paper.opts gives its curves,
/// conditions, θ and tolerance) on the Gmsh mesh `msh` or its geometry, as `how` says, its
/// bodies built as `input` says.
fn problem_args(n: usize, msh: &str, input: &str, how: How) -> Vec<String> {
    let mut args = match how {
        How::Once {
            estimate,
            reference,
        } => vec![
            "-nndd_mesh".into(),
            msh.into(),
            "-nndd_estimate".into(),
            estimate.to_string(),
            "-nndd_estimate_every".into(),
            "0".into(),
            "-nndd_reference_factor".into(),
            reference.to_string(),
        ],
        How::Adapt(tol) => vec![
            "-nndd_mesh".into(),
            "examples/paper/paper.geo".into(),
            "-nndd_geo_set".into(),
            format!("n={n}"),
            "-nndd_adapt_tol".into(),
            tol.to_string(),
            "-nndd_adapt_max_cycles".into(),
            "4".into(),
        ],
    };
    args.extend(["-nndd_mesh_input".into(), input.into()]);
    args
}

/// One row of the table from a run's summary `j` and its wall time.
fn row(n: usize, p: usize, input: &str, j: &serde_json::Value, wall: f64) -> String {
    let list = |key: &str| runner::nums(j, key);
    let (elements, input_peaks, peaks, reference_peaks) = (
        list("input_mesh_elements_per_rank"),
        list("input_peak_memory_mib_per_rank"),
        list("peak_memory_mib_per_rank"),
        list("reference_input_peak_memory_mib_per_rank"),
    );
    let others = |v: &[f64]| -> String {
        let rest = v.get(1..).unwrap_or(&[]);
        let (lo, hi) = rest
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        match rest.len() {
            0 => "-".into(),
            _ if lo == hi => format!("{hi:.0}"),
            _ => format!("{lo:.0}-{hi:.0}"),
        }
    };
    let first = |v: &[f64]| v.first().map_or("-".into(), |x| format!("{x:.0}"));
    let max = peaks.iter().cloned().fold(0.0, f64::max);
    let sum: f64 = peaks.iter().sum();
    format!(
        "{n:>5} {p:>5} {:>9} {input:>10} {:>10} {:>12} {:>10} {:>12} {:>9} {:>12} {max:>8.0} {sum:>8.0} {:>8.2} {wall:>7.1} {:>16.10e}",
        runner::num(j, "dofs"),
        first(&elements),
        others(&elements),
        first(&input_peaks),
        others(&input_peaks),
        first(&reference_peaks),
        others(&reference_peaks),
        runner::num(&j["timings"], "input"),
        runner::num(j, "potential_energy"),
    )
}

/// `results/bench-input.txt`: the header and the rows so far.
fn write_table(lines: &[String]) {
    let table = lines.join("\n") + "\n";
    std::fs::create_dir_all("results").ok();
    std::fs::File::create("results/bench-input.txt")
        .and_then(|mut f| f.write_all(table.as_bytes()))
        .expect("write results/bench-input.txt");
}

/// `[--ranks LIST] [--estimate] [--reference R] [--adapt TOL] [n …]`: the levels (default
/// 512), the rank counts (default 2 and 8), whether each run estimates and the reference factor
/// (0: none; `--reference` implies `--estimate`), or the adaptive runs' tolerance.
fn parse_args() -> Args {
    let fail = |msg: String| -> ! {
        eprintln!("bench-input: {msg}");
        std::process::exit(2);
    };
    let (mut levels, mut ranks, mut estimate, mut reference) = (Vec::new(), vec![2, 8], false, 0);
    let mut adapt = None;
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--ranks" => {
                let list = it
                    .next()
                    .unwrap_or_else(|| fail("--ranks needs a list, e.g. 2,8".into()));
                ranks =
                    runner::positive_list(&list).unwrap_or_else(|e| fail(format!("--ranks: {e}")));
            }
            "--estimate" => estimate = true,
            "--reference" => {
                let r = it.next().and_then(|r| r.parse::<usize>().ok());
                match r {
                    Some(r @ 2..=16) => (estimate, reference) = (true, r),
                    _ => fail("--reference needs a factor in 2..=16".into()),
                }
            }
            "--adapt" => {
                let tol = it.next().and_then(|t| t.parse::<f64>().ok());
                match tol {
                    Some(t) if t > 0.0 && t < 1.0 => adapt = Some(t),
                    _ => fail("--adapt needs a tolerance in (0, 1)".into()),
                }
            }
            level => match level.parse::<usize>() {
                Ok(n) if n >= 2 => levels.push(n),
                _ => fail(format!(
                    "'{level}': expected --ranks LIST, --estimate, --reference R, --adapt TOL or a level n >= 2"
                )),
            },
        }
    }
    if levels.is_empty() {
        levels.push(512);
    }
    Args {
        levels,
        ranks,
        estimate,
        reference,
        adapt,
    }
}
