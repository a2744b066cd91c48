//! Shared by the study programs (`jobs/study-*`): the command line (`--quick`, `--out DIR`),
//! one row of estimates per point, and the CSV file and stdout table of the rows.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use crate::plot::{self, Scale, Series, SeriesLabelPosition};

/// The command line of a study: `[--quick] [--out DIR]`.
pub struct Options {
    /// Only the smallest cases (a smoke run, used by `tests/studies.rs`).
    pub quick: bool,
    /// Where the CSV and PNG files go (default `results/studies`).
    pub out: PathBuf,
}

/// Parse the command line of study `name`; exits with a usage line on anything else.
pub fn options(name: &str) -> Options {
    let usage = || -> ! {
        eprintln!("usage: {name} [--quick] [--out DIR]");
        std::process::exit(1)
    };
    let mut opts = Options {
        quick: false,
        out: PathBuf::from("results/studies"),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quick" => opts.quick = true,
            "--out" => opts.out = args.next().map(PathBuf::from).unwrap_or_else(|| usage()),
            _ => usage(),
        }
    }
    std::fs::create_dir_all(&opts.out).unwrap_or_else(|e| {
        eprintln!("{name}: cannot create {}: {e}", opts.out.display());
        std::process::exit(1)
    });
    opts
}

/// The estimates of one iterate of one run.
#[derive(Clone, Debug)]
pub struct Row {
    pub n: usize,
    pub dofs: u64,
    pub iteration: u64,
    pub eta_glo: f64,
    pub eta_fe: f64,
    pub eta_nndd: f64,
    /// (η^FE² + η^NNDD²)/η^glo², relation (25).
    pub eta_ratio: f64,
    /// Energy norm of u_ref − u_h and η^glo/e_ref, with a reference solution only.
    pub e_ref: Option<f64>,
    pub effectivity: Option<f64>,
}

impl Row {
    /// Row of the estimate `e` (an entry of the summary's `estimates`) of the run `summary`.
    pub fn new(n: usize, summary: &serde_json::Value, e: &serde_json::Value) -> Row {
        let f = |k: &str| {
            e[k].as_f64()
                .unwrap_or_else(|| panic!("estimate without {k}: {e}"))
        };
        Row {
            n,
            dofs: summary["dofs"].as_u64().expect("summary has dofs"),
            iteration: e["iteration"].as_u64().expect("estimate has iteration"),
            eta_glo: f("eta_glo"),
            eta_fe: f("eta_fe"),
            eta_nndd: f("eta_nndd"),
            eta_ratio: f("eta_ratio"),
            e_ref: e["e_ref"].as_f64(),
            effectivity: e["effectivity"].as_f64(),
        }
    }

    /// Row of the last estimate of the run (the final iterate with `-nndd_estimate`).
    pub fn last(n: usize, summary: &serde_json::Value) -> Row {
        let e = summary["estimates"]
            .as_array()
            .and_then(|a| a.last())
            .expect("the run has estimates");
        Row::new(n, summary, e)
    }
}

pub const HEADER: &str = "n,dofs,iteration,eta_glo,eta_fe,eta_nndd,eta_ratio,e_ref,effectivity";

/// Write the rows to `path` as CSV (header row; e_ref, effectivity empty where absent).
pub fn write_csv(path: &std::path::Path, rows: &[Row]) {
    let opt = |v: Option<f64>| v.map(|x| format!("{x:.10e}")).unwrap_or_default();
    let mut text = format!("{HEADER}\n");
    for r in rows {
        text += &format!(
            "{},{},{},{:.10e},{:.10e},{:.10e},{:.10e},{},{}\n",
            r.n,
            r.dofs,
            r.iteration,
            r.eta_glo,
            r.eta_fe,
            r.eta_nndd,
            r.eta_ratio,
            opt(r.e_ref),
            opt(r.effectivity)
        );
    }
    write(path, &text);
}

/// Write a whole file or exit with a message.
pub fn write(path: &std::path::Path, text: &str) {
    std::fs::write(path, text).unwrap_or_else(|e| {
        eprintln!("cannot write {}: {e}", path.display());
        std::process::exit(1)
    });
}

/// Print the rows as a table on stdout.
pub fn print_table(rows: &[Row]) {
    println!(
        "{:>4} {:>8} {:>5} {:>12} {:>12} {:>12} {:>7} {:>12} {:>7}",
        "n", "dofs", "iter", "eta_glo", "eta_fe", "eta_nndd", "ratio", "e_ref", "gamma"
    );
    for r in rows {
        println!(
            "{:>4} {:>8} {:>5} {:>12.5e} {:>12.5e} {:>12.5e} {:>7.4} {:>12} {:>7}",
            r.n,
            r.dofs,
            r.iteration,
            r.eta_glo,
            r.eta_fe,
            r.eta_nndd,
            r.eta_ratio,
            r.e_ref.map(|v| format!("{v:.5e}")).unwrap_or("-".into()),
            r.effectivity
                .map(|v| format!("{v:.4}"))
                .unwrap_or("-".into())
        );
    }
    println!("(ratio = (eta_fe^2 + eta_nndd^2) / eta_glo^2, relation (25); gamma = eta_glo / e_ref, (26))");
}

/// Draw η^glo, η^FE and η^NNDD of `rows` against `x` (errors on a log axis) into `png`; exits
/// with the error on failure.
pub fn plot_estimates(
    png: &Path,
    title: &str,
    x_label: &str,
    x_scale: Scale,
    legend: SeriesLabelPosition,
    rows: &[Row],
    x: fn(&Row) -> f64,
) {
    let curve =
        |f: fn(&Row) -> f64| -> Vec<(f64, f64)> { rows.iter().map(|r| (x(r), f(r))).collect() };
    let chart = plot::Chart {
        title,
        x_label,
        y_label: "error (energy norm)",
        x_scale,
        y_scale: Scale::Log,
        legend,
    };
    let series = [
        Series::new("η^glo", curve(|r| r.eta_glo)),
        Series::new("η^FE", curve(|r| r.eta_fe)),
        Series::new("η^NNDD", curve(|r| r.eta_nndd)),
    ];
    plot::line_chart(png, &chart, &series).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
}
