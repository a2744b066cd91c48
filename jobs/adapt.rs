//! Adaptive meshes against uniform refinement (`-nndd_adapt_tol`, docs/method.md §8), 2 ranks:
//! `paper` from examples/paper/paper.geo (n = 8), Hertz (examples/hertz-nonmatching), the pin
//! in its groove (examples/pin) and the rounded punch (examples/punch-nonmatching) from their
//! level-1 meshes, to ε = 1 % (optimal strategy; Dörfler with θ = 0.5 on `paper` for comparison). For each: every cycle's dofs,
//! iterations, η^glo/‖u_h‖_E, its time and the share of the remeshing, the estimate's cost
//! against the solve's; the effectivity η^glo/e_ref (r = 4) on the two smallest cycles; the
//! uniform meshes of the same geometry with the same solve and estimate (the NNDD to its
//! tolerance, node to node) until their dofs pass 300 000; the rates p of η^glo ∝ dofs^−p and the dofs
//! uniform refinement needs for the adaptive run's final η^glo (log-linear between its meshes,
//! or extrapolated along its last rate where it was not reached, marked ~).
//!
//! Run: `jobs/adapt [--tol 0.01] [--cases paper,hertz,pin,punch]` → a table on stdout and in
//! `results/adapt/table.txt`, and `docs/img/adapt-CASE.png` (η^glo/‖u_h‖_E against dofs,
//! adaptive and uniform).

#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;

use std::fmt::Write as _;
use std::path::Path;

use runner::num;

/// A case: its name, options file and geometry, the Gmsh parameter its uniform meshes step
/// (and the values), and its first mesh's value.
struct Case {
    name: &'static str,
    opts: &'static str,
    geo: &'static str,
    parameter: &'static str,
    first: usize,
    uniform: &'static [usize],
}

const CASES: [Case; 4] = [
    Case {
        name: "paper",
        opts: "examples/paper/paper.opts",
        geo: "examples/paper/paper.geo",
        parameter: "n",
        first: 8,
        uniform: &[8, 16, 32, 64, 128, 256, 384],
    },
    Case {
        name: "hertz",
        opts: "examples/hertz-nonmatching/hertz-nonmatching.opts",
        geo: "examples/hertz-nonmatching/hertz-nonmatching.geo",
        parameter: "level",
        first: 1,
        uniform: &[1, 2, 3, 4, 5, 6],
    },
    Case {
        name: "pin",
        opts: "examples/pin/pin.opts",
        geo: "examples/pin/pin.geo",
        parameter: "level",
        first: 1,
        uniform: &[1, 2, 3, 4, 5],
    },
    Case {
        name: "punch",
        opts: "examples/punch-nonmatching/punch-nonmatching.opts",
        geo: "examples/punch-nonmatching/punch-nonmatching.geo",
        parameter: "level",
        first: 1,
        uniform: &[1, 2, 3, 4, 5],
    },
];

/// The uniform meshes stop once their dofs pass this.
const UNIFORM_DOFS: f64 = 3e5;

/// A run that ended with exit 3 (not reached) still wrote its summary: read it.
fn run_allowing_unreached(opts: &str, prefix: &Path, args: &[&str]) -> serde_json::Value {
    match runner::try_run(2, opts, &[], prefix, args) {
        Ok((j, _)) => j,
        Err(e) if e.starts_with("exit 3") => {
            let text = std::fs::read_to_string(format!("{}.json", prefix.display()))
                .expect("the summary of a run that ended with exit 3");
            serde_json::from_str(&text).expect("JSON")
        }
        Err(e) => {
            eprintln!("adapt: {} failed: {e}", prefix.display());
            std::process::exit(1);
        }
    }
}

/// The least-squares slope −p of log η against log dofs.
fn rate(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    if points.len() < 2 {
        return f64::NAN;
    }
    let (xs, ys): (Vec<f64>, Vec<f64>) = points.iter().map(|(d, e)| (d.ln(), e.ln())).unzip();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    -sxy / sxx
}

/// One cycle's estimate cost over its solve's, from the cycle's own summary.
fn estimate_over_solve(prefix: &Path, cycle: usize) -> f64 {
    let path = format!("{}-cycle{cycle}.json", prefix.display());
    let Ok(text) = std::fs::read_to_string(&path) else {
        return f64::NAN;
    };
    let j: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
    num(&j["timings"], "estimation") / runner::solve_seconds(&j)
}

fn main() {
    let mut tol = 0.01;
    let mut names: Vec<String> = CASES.iter().map(|c| c.name.to_string()).collect();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--tol" => tol = it.next().and_then(|s| s.parse().ok()).expect("--tol 0.01"),
            "--cases" => {
                names = it
                    .next()
                    .expect("--cases paper,hertz,punch")
                    .split(',')
                    .map(String::from)
                    .collect()
            }
            other => {
                eprintln!("adapt: unknown argument '{other}' (--tol E, --cases a,b)");
                std::process::exit(2);
            }
        }
    }
    let dir = Path::new("results/adapt");
    std::fs::create_dir_all(dir).expect("results/adapt");
    let tol_text = tol.to_string();
    let mut table = String::new();
    let mut summary = String::new();
    let mut pngs = Vec::new();
    let _ = writeln!(
        table,
        "case    strategy  cycle   dofs     iter  eta_glo/|u|  effectivity  seconds  remesh  est/solve"
    );
    for case in CASES.iter().filter(|c| names.iter().any(|n| n == c.name)) {
        let mut series = Vec::new();
        let first = format!("{}={}", case.parameter, case.first);
        let strategies: &[(&str, &[&str])] = if case.name == "paper" {
            &[
                ("optimal", &[]),
                ("dorfler", &["-nndd_adapt_strategy", "dorfler"]),
            ]
        } else {
            &[("optimal", &[])]
        };
        let mut adaptive_points = Vec::new();
        let mut final_eta = f64::NAN;
        let mut final_dofs = f64::NAN;
        let mut adaptive_seconds = 0.0;
        for (strategy, extra) in strategies {
            let prefix = dir.join(format!("{}-{strategy}", case.name));
            let mut a = vec![
                "-nndd_mesh",
                case.geo,
                "-nndd_geo_set",
                &first,
                "-nndd_adapt_tol",
                &tol_text,
            ];
            a.extend_from_slice(extra);
            let t = std::time::Instant::now();
            let j = run_allowing_unreached(case.opts, &prefix, &a);
            let wall = t.elapsed().as_secs_f64();
            // The effectivity on the two smallest cycles (the same cycles, with e_ref).
            let eff_prefix = dir.join(format!("{}-{strategy}-eref", case.name));
            let mut b = a.clone();
            b.extend(["-nndd_adapt_max_cycles", "2", "-nndd_reference_factor", "4"]);
            let e = run_allowing_unreached(case.opts, &eff_prefix, &b);
            let cycles = j["cycles"].as_array().cloned().unwrap_or_default();
            let eff = e["cycles"].as_array().cloned().unwrap_or_default();
            let mut points = Vec::new();
            for (k, c) in cycles.iter().enumerate() {
                let effectivity = eff
                    .get(k)
                    .map(|x| format!("{:.4}", num(x, "effectivity")))
                    .unwrap_or_else(|| "–".into());
                let _ = writeln!(
                    table,
                    "{:<7} {:<9} {:>5} {:>8} {:>6}  {:>9.3} %  {:>11}  {:>7.2}  {:>5.1} %  {:>8.2}",
                    case.name,
                    strategy,
                    num(c, "cycle"),
                    num(c, "dofs"),
                    num(c, "iterations"),
                    100.0 * num(c, "relative_error"),
                    effectivity,
                    num(c, "seconds"),
                    100.0 * num(c, "remesh_share"),
                    estimate_over_solve(&prefix, k + 1)
                );
                points.push((num(c, "dofs"), num(c, "relative_error")));
            }
            let p = rate(&points);
            let _ = writeln!(
                summary,
                "{} {strategy}: {} after {} cycles ({:.3} %), rate p = {p:.3} over the cycles, {wall:.1} s in all",
                case.name,
                j["adapt"]["verdict"].as_str().unwrap_or("?"),
                cycles.len(),
                100.0 * points.last().map_or(f64::NAN, |x| x.1),
            );
            if *strategy == "optimal" {
                adaptive_points = points.clone();
                if let Some(last) = cycles.last() {
                    final_eta = num(last, "relative_error");
                    final_dofs = num(last, "dofs");
                }
                adaptive_seconds = wall;
            }
            series.push(plot::Series::new(
                &format!("{} {strategy}", case.name),
                points,
            ));
        }
        // Uniform meshes of the same geometry, the same estimates.
        let mut uniform = Vec::new();
        let mut reached: Option<(f64, f64)> = None;
        for &v in case.uniform {
            let prefix = dir.join(format!("{}-uniform-{v}", case.name));
            let set = format!("{}={v}", case.parameter);
            let a = [
                "-nndd_mesh",
                case.geo,
                "-nndd_geo_set",
                &set,
                "-nndd_estimate",
                "-nndd_contact_discretisation",
                "node_to_node",
            ];
            let t = std::time::Instant::now();
            let (j, _) = runner::try_run(2, case.opts, &[], &prefix, &a).unwrap_or_else(|e| {
                eprintln!("adapt: {} failed: {e}", prefix.display());
                std::process::exit(1)
            });
            let wall = t.elapsed().as_secs_f64();
            let last = j["estimates"].as_array().and_then(|e| e.last()).cloned();
            let eta = last.map_or(f64::NAN, |e| num(&e, "eta_glo"));
            let norm = num(&j, "energy_norm");
            let dofs = num(&j, "dofs");
            let _ = writeln!(
                table,
                "{:<7} {:<9} {:>5} {:>8} {:>6}  {:>9.3} %  {:>11}  {:>7.2}",
                case.name,
                "uniform",
                format!("{}{v}", if case.parameter == "n" { "n" } else { "L" }),
                dofs,
                num(&j, "iterations"),
                100.0 * eta / norm,
                "–",
                wall
            );
            uniform.push((dofs, eta / norm));
            if eta / norm <= final_eta && reached.is_none() {
                reached = Some((dofs, wall));
            }
            if dofs > UNIFORM_DOFS || reached.is_some() {
                break;
            }
        }
        let pu = rate(&uniform[uniform.len().saturating_sub(3)..]);
        // The dofs at the adaptive final η: log-linear between the uniform meshes on either
        // side of it, or along the last uniform rate beyond them (marked ~).
        let (needed, how) = match uniform.windows(2).find(|w| w[1].1 <= final_eta) {
            Some(w) => {
                let (a, b) = (w[0], w[1]);
                let s = (final_eta / a.1).ln() / (b.1 / a.1).ln();
                (a.0 * (b.0 / a.0).powf(s), "")
            }
            None => {
                let (d, e) = *uniform.last().expect("a uniform mesh");
                (d * (e / final_eta).powf(1.0 / pu), "~")
            }
        };
        let _ = writeln!(
            summary,
            "{}: uniform rate p = {pu:.3} (last levels); uniform meets the adaptive final {:.3} % at {how}{needed:.0} dofs (log-linear between its meshes): {:.1}x the adaptive {final_dofs:.0}; adaptive p = {:.3}; adaptive run {adaptive_seconds:.1} s{}",
            case.name,
            100.0 * final_eta,
            needed / final_dofs,
            rate(&adaptive_points),
            reached.map_or(String::new(), |(d, s)| format!(", the first uniform run below it ({d:.0} dofs) {s:.1} s"))
        );
        series.push(plot::Series::new(
            &format!("{} uniform", case.name),
            uniform,
        ));
        let title = format!("{}: adaptive meshes against uniform refinement", case.name);
        let chart = plot::Chart {
            title: &title,
            x_label: "dofs",
            y_label: "eta_glo / ||u_h||_E",
            x_scale: plot::Scale::Log,
            y_scale: plot::Scale::Log,
            legend: plot::SeriesLabelPosition::UpperRight,
        };
        std::fs::create_dir_all("docs/img").ok();
        let png = format!("docs/img/adapt-{}.png", case.name);
        if let Err(e) = plot::line_chart(Path::new(&png), &chart, &series) {
            eprintln!("adapt: {e}");
            std::process::exit(1);
        }
        pngs.push(png);
    }
    print!("{table}\n{summary}");
    std::fs::write(dir.join("table.txt"), format!("{table}\n{summary}")).expect("table");
    println!("wrote results/adapt/table.txt and {}", pngs.join(", "));
}
