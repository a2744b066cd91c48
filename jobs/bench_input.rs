//! What building a Gmsh problem's bodies once costs and saves (`-nndd_mesh_input`): `paper`
//! drawn in Gmsh at level n (`gmsh -2 -format msh41 -bin -setnumber n N
//! examples/paper/paper.geo`, 2 n² triangles per body), solved without estimates (θ = 0.25 to
//! 1e-8) with `root` (world rank 0 builds both bodies and sends each rank its part) and
//! `every_rank` (each rank builds both) in turn on each rank count. Per run one row: the
//! elements of the meshes world rank 0 and the others held in the input and their peak
//! resident memory then (the summary's `input_mesh_elements_per_rank` and
//! `input_peak_memory_mib_per_rank`), the run's largest peak and the sum over the ranks, the
//! input's time (`timings.input`), the run's total and the potential energy. More ranks than
//! cores run oversubscribed: their memory is what is measured, not their speed. Run through
//! `jobs/bench-input [--ranks LIST] [n …]` (default n = 512 on 2 and 8 ranks); the table goes to
//! `results/bench-input.txt`.

#[path = "runner.rs"]
mod runner;

use std::io::Write;
use std::process::Command;

fn main() {
    let (levels, ranks) = parse_args();
    let dir = runner::scratch("bench-input");
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let mut lines = vec![
        format!("# jobs/bench-input: paper drawn in Gmsh, no estimate, theta 0.25, tol 1e-8; MiB per rank (peak resident), oversubscribed above {cores} ranks"),
        format!(
            "{:>5} {:>5} {:>9} {:>10} {:>10} {:>12} {:>10} {:>12} {:>8} {:>8} {:>8} {:>7} {:>16}",
            "n", "ranks", "dofs", "input", "rank0 elts", "others elts", "rank0 MiB", "others MiB",
            "max MiB", "sum MiB", "input s", "total s", "energy J/m"
        ),
    ];
    for &n in &levels {
        let msh = dir.join(format!("paper-{n}.msh"));
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
        let msh = msh.to_str().expect("utf-8 path").to_string();
        for &p in &ranks {
            for input in ["root", "every_rank"] {
                eprintln!("bench-input: n = {n} on {p} ranks, -nndd_mesh_input {input} …");
                let prefix = dir.join(format!("n{n}-p{p}-{input}"));
                let args = problem_args(&msh, input);
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

/// The options of `paper` on the Gmsh mesh `msh` (examples/paper/paper.opts gives its curves,
/// conditions, θ and tolerance), no estimate, its bodies built as `input` says.
fn problem_args(msh: &str, input: &str) -> Vec<String> {
    [
        "-nndd_mesh",
        msh,
        "-nndd_estimate",
        "false",
        "-nndd_estimate_every",
        "0",
        "-nndd_reference_factor",
        "0",
        "-nndd_mesh_input",
        input,
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// One row of the table from a run's summary `j` and its wall time.
fn row(n: usize, p: usize, input: &str, j: &serde_json::Value, wall: f64) -> String {
    let list = |key: &str| -> Vec<f64> {
        j[key].as_array().map_or(Vec::new(), |a| {
            a.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect()
        })
    };
    let (elements, input_peaks, peaks) = (
        list("input_mesh_elements_per_rank"),
        list("input_peak_memory_mib_per_rank"),
        list("peak_memory_mib_per_rank"),
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
        "{n:>5} {p:>5} {:>9} {input:>10} {:>10} {:>12} {:>10} {:>12} {max:>8.0} {sum:>8.0} {:>8.2} {wall:>7.1} {:>16.10e}",
        runner::num(j, "dofs"),
        first(&elements),
        others(&elements),
        first(&input_peaks),
        others(&input_peaks),
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

/// `[--ranks LIST] [n …]`: the levels (default 512) and the rank counts (default 2 and 8).
fn parse_args() -> (Vec<usize>, Vec<usize>) {
    let fail = |msg: String| -> ! {
        eprintln!("bench-input: {msg}");
        std::process::exit(2);
    };
    let (mut levels, mut ranks) = (Vec::new(), vec![2, 8]);
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
            level => match level.parse::<usize>() {
                Ok(n) if n >= 2 => levels.push(n),
                _ => fail(format!(
                    "'{level}': expected --ranks LIST or a level n >= 2"
                )),
            },
        }
    }
    if levels.is_empty() {
        levels.push(512);
    }
    (levels, ranks)
}
