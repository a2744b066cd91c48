//! Iterations of the NNDD for bodies of different stiffness, E¹ = ratio · E² with
//! ratio = 1000 … 0.001, each run checked against the monolithic solve:
//! - `paper` (n = 16 unless `--n N`, E² = 210 GPa, tol 1e−8): `-nndd_theta auto` (the secant
//!   update, src/dd/secant.rs; the Dirichlet step on the stiffer body, `-nndd_dirichlet_body
//!   auto`) against the best fixed θ of a scan (0.5 … 0.0005);
//! - `--hertz [--levels 1,2,3,4]`: examples/hertz (the block E¹ = ratio · 210 GPa, ν = 0.3,
//!   under the steel cylinder) on each level, θ auto with the Dirichlet step on the stiffer
//!   body (auto) and on body 1 (the paper's choice, `-nndd_dirichlet_body 1`). The contact set
//!   grows over the iterations here (from nothing to some 60 pairs), unlike `paper`'s.
//!
//! - `--limits`: `paper` n = 16 at the stiffness ratios 1e2, 1e4 and 1e6 (the largest accepted)
//!   either way, θ auto with the Dirichlet step on either body, each against the monolithic
//!   solve: the iterations, the stop, the interface force balance and the energy difference.
//!
//! Run: `jobs/stiffness [--n N]` → a table on stdout and `results/stiffness.txt` (n = 16) or
//! `results/stiffness-nN.txt`; `jobs/stiffness --hertz` → `results/stiffness-hertz.txt`.

#[path = "runner.rs"]
mod runner;

const RATIOS: [f64; 7] = [1000.0, 100.0, 10.0, 1.0, 0.1, 0.01, 0.001];

/// Iterations and the relative energy difference to the monolithic solve of a converged run,
/// and the body of its Dirichlet step.
struct Converged {
    iterations: u64,
    de: f64,
    dirichlet_body: u64,
}

fn converged(j: &serde_json::Value, em: f64) -> Option<Converged> {
    let e = runner::num(j, "potential_energy");
    j["converged"]
        .as_bool()
        .unwrap_or(false)
        .then(|| Converged {
            iterations: j["iterations"].as_u64().unwrap_or(0),
            de: (e - em).abs() / em.abs(),
            dirichlet_body: j["dirichlet_body"].as_u64().unwrap_or(0),
        })
}

fn cells(c: &Option<Converged>) -> (String, String) {
    c.as_ref().map_or(("-".into(), "-".into()), |c| {
        (c.iterations.to_string(), format!("{:.1e}", c.de))
    })
}

/// examples/hertz on `levels`: θ auto with the Dirichlet step on the stiffer body and on body 1.
fn hertz(levels: &[usize]) {
    let dir = runner::scratch("stiffness-hertz");
    let mut table = String::from(
        "level   dofs    E1/E2   dirichlet  auto_iter  auto_dE    body1_iter  body1_dE   active\n",
    );
    for &level in levels {
        let msh = dir.join(format!("hertz-{level}.msh"));
        runner::gmsh_level("examples/hertz/hertz.geo", level, &msh);
        let msh = msh.to_str().expect("utf-8 path").to_string();
        for ratio in RATIOS {
            let e1 = format!("{:e}", ratio * 2.1e11);
            let base = [
                "-nndd_mesh",
                &msh,
                "-nndd_body1_E",
                &e1,
                "-nndd_body1_nu",
                "0.3",
            ];
            let opts = "examples/hertz/hertz.opts";
            let run = |np: usize, extra: &[&str]| {
                let a = [&base[..], extra].concat();
                runner::try_run(np, opts, &[], &dir.join("run"), &a)
            };
            let (mono, _) = run(1, &["-nndd_solver", "monolithic"])
                .unwrap_or_else(|e| panic!("monolithic: {e}"));
            let em = runner::num(&mono, "potential_energy");
            eprintln!("stiffness: Hertz level {level}, E1/E2 = {ratio} …");
            let auto = run(2, &[]).ok().and_then(|(j, _)| converged(&j, em));
            let body1 = run(2, &["-nndd_dirichlet_body", "1"])
                .ok()
                .and_then(|(j, _)| converged(&j, em));
            let (ai, ad) = cells(&auto);
            let (bi, bd) = cells(&body1);
            table.push_str(&format!(
                "{level:>5} {:>6} {ratio:>8}   {:>9}  {ai:>9}  {ad:>9}  {bi:>10}  {bd:>9}  {:>6}\n",
                mono["dofs"],
                auto.as_ref()
                    .map_or("-".into(), |c| format!("body {}", c.dirichlet_body)),
                mono["active_nodes"],
            ));
        }
    }
    table.push_str("(examples/hertz, 2 ranks, tol 1e-8, theta auto; dirichlet: the body auto chose; body1: -nndd_dirichlet_body 1; dE: relative energy difference to the monolithic solve; active: contact pairs of the solution)\n");
    print!("{table}");
    std::fs::create_dir_all("results").ok();
    std::fs::write("results/stiffness-hertz.txt", &table).expect("results/stiffness-hertz.txt");
}

/// `paper` n = 16 at the ratios up to the accepted limit, either body the stiffer, the
/// Dirichlet step on either body.
fn limits() {
    let dir = runner::scratch("stiffness-limits");
    let mut table =
        String::from("  stiffer   ratio  dirichlet   stop         iter   force_balance   dE\n");
    for stiffer in [2, 1] {
        for ratio in [1e2, 1e4, 1e6] {
            let e2 = if stiffer == 2 {
                2.1e11 * ratio
            } else {
                2.1e11 / ratio
            };
            let e2 = format!("{e2:e}");
            let base = [
                "-nndd_n",
                "16",
                "-nndd_E",
                "2.1e11",
                "-nndd_body2_E",
                &e2,
                "-nndd_theta",
                "auto",
                "-nndd_max_it",
                "1000",
                "-nndd_estimate_every",
                "0",
                "-nndd_reference_factor",
                "0",
            ];
            let paper = "petsc-options/paper.opts";
            let mut a = base.to_vec();
            a.extend(["-nndd_solver", "monolithic"]);
            let (mono, _) = runner::try_run(1, paper, &[], &dir.join("mono"), &a)
                .unwrap_or_else(|e| panic!("monolithic: {e}"));
            let em = runner::num(&mono, "potential_energy");
            for body in ["1", "2"] {
                eprintln!(
                    "stiffness: body {stiffer} {ratio:e} times stiffer, Dirichlet body {body} …"
                );
                let mut a = base.to_vec();
                a.extend(["-nndd_dirichlet_body", body]);
                let (j, _) = match runner::try_run(2, paper, &[], &dir.join("nndd"), &a) {
                    Ok(r) => r,
                    Err(e) => {
                        let said = if e.starts_with("exit 3") {
                            "not converged (exit 3)".to_string()
                        } else {
                            format!("failed: {e}")
                        };
                        table
                            .push_str(&format!("{stiffer:>9} {ratio:>7.0e}  {body:>9}   {said}\n"));
                        continue;
                    }
                };
                let fb = j["history"]
                    .as_array()
                    .and_then(|h| h.last())
                    .map_or(f64::NAN, |h| runner::num(h, "force_balance"));
                let de = (runner::num(&j, "potential_energy") - em).abs() / em.abs();
                table.push_str(&format!(
                    "{stiffer:>9} {ratio:>7.0e}  {body:>9}   {:<10} {:>6}   {fb:>13.1e}   {de:.1e}\n",
                    j["stop_reason"].as_str().unwrap_or("?"),
                    j["iterations"].as_u64().unwrap_or(0),
                ));
            }
        }
    }
    table.push_str("(paper n = 16, 2 ranks, theta auto, tol 1e-8 on dlambda and on the force balance |T1 + T2|/max(|T1|, |T2|); dE: relative energy difference to the monolithic solve; beyond 1e6 nndd refuses the moduli)\n");
    print!("{table}");
    std::fs::create_dir_all("results").ok();
    std::fs::write("results/stiffness-limits.txt", &table).expect("results/stiffness-limits.txt");
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = || -> ! {
        eprintln!(
            "stiffness: usage: jobs/stiffness [--n N] | --hertz [--levels 1,2,3,4] | --limits"
        );
        std::process::exit(1);
    };
    let levels = |v: &str| -> Vec<usize> {
        v.split(',')
            .map(|l| l.parse().unwrap_or_else(|_| usage()))
            .collect()
    };
    let n = match args.as_slice() {
        [] => "16".to_string(),
        [flag, v] if flag == "--n" && v.parse::<usize>().is_ok() => v.clone(),
        [h] if h == "--hertz" => return hertz(&[1, 2, 3, 4]),
        [l] if l == "--limits" => return limits(),
        [h, flag, v] if h == "--hertz" && flag == "--levels" => return hertz(&levels(v)),
        _ => usage(),
    };
    let thetas = [
        "0.5", "0.25", "0.1", "0.05", "0.01", "0.005", "0.001", "0.0005",
    ];
    let dir = runner::scratch("stiffness");
    let mut table = String::from(
        "  E1/E2   dirichlet   auto_iter   auto_dE      best_theta   best_iter   (fixed theta: iterations, '-' = diverged/stagnated/max_it)\n",
    );
    for ratio in RATIOS {
        let e1 = format!("{:e}", ratio * 2.1e11);
        // paper.opts estimates every 2 iterations against a reference solution: not needed for
        // iteration counts and energies.
        let base = [
            "-nndd_n",
            &n,
            "-nndd_body1_E",
            &e1,
            "-nndd_max_it",
            "1500",
            "-nndd_estimate_every",
            "0",
            "-nndd_reference_factor",
            "0",
        ];
        let prefix = dir.join("mono");
        let mut a = base.to_vec();
        a.extend(["-nndd_solver", "monolithic"]);
        let (mono, _) = runner::try_run(1, "petsc-options/paper.opts", &[], &prefix, &a)
            .unwrap_or_else(|e| panic!("monolithic: {e}"));
        let em = runner::num(&mono, "potential_energy");
        let run = |theta: &str| -> Option<Converged> {
            let mut a = base.to_vec();
            a.extend(["-nndd_theta", theta]);
            let prefix = dir.join("nndd");
            let (j, _) = runner::try_run(2, "petsc-options/paper.opts", &[], &prefix, &a).ok()?;
            converged(&j, em)
        };
        eprintln!("stiffness: E1/E2 = {ratio} …");
        let auto = run("auto");
        let mut scan = String::new();
        let mut best: Option<(&str, u64)> = None;
        for t in thetas {
            let r = run(t);
            scan.push_str(&format!(
                " {t}:{}",
                r.as_ref().map_or("-".into(), |c| c.iterations.to_string())
            ));
            if let Some(c) = r {
                if best.is_none_or(|(_, b)| c.iterations < b) {
                    best = Some((t, c.iterations));
                }
            }
        }
        let (bt, bi) = best.map_or(("-".to_string(), "-".to_string()), |(t, i)| {
            (t.to_string(), i.to_string())
        });
        let (ai, ad) = cells(&auto);
        table.push_str(&format!(
            "{ratio:>7}   {:>9}   {ai:>9}   {ad:>9}   {bt:>10}   {bi:>9}  {scan}\n",
            auto.as_ref()
                .map_or("-".into(), |c| format!("body {}", c.dirichlet_body)),
        ));
    }
    table.push_str(&format!("(paper n = {n}, 2 ranks, tol 1e-8; dirichlet: the body of the Dirichlet step, -nndd_dirichlet_body auto; auto_dE: relative energy difference to the monolithic solve)\n"));
    print!("{table}");
    std::fs::create_dir_all("results").ok();
    let out = if n == "16" {
        "results/stiffness.txt".to_string()
    } else {
        format!("results/stiffness-n{n}.txt")
    };
    std::fs::write(&out, &table).expect("results/stiffness*.txt");
}
