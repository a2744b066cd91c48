//! Iterations of the NNDD for bodies of different stiffness: `paper` (n = 16 unless `--n N`,
//! tol 1e−8) with E¹ = ratio · E² (E² = 210 GPa), ratio = 1000 … 0.001, with `-nndd_theta auto`
//! (the secant update, src/dd/secant.rs) and with the best fixed θ of a scan (0.5 … 0.0005),
//! each checked against the monolithic solve.
//!
//! Run: `jobs/stiffness [--n N]` → a table on stdout and `results/stiffness.txt` (n = 16) or
//! `results/stiffness-nN.txt`.

#[path = "runner.rs"]
mod runner;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n = match args.as_slice() {
        [] => "16".to_string(),
        [flag, v] if flag == "--n" && v.parse::<usize>().is_ok() => v.clone(),
        _ => {
            eprintln!("stiffness: usage: jobs/stiffness [--n N]");
            std::process::exit(1);
        }
    };
    let ratios = [1000.0, 100.0, 10.0, 1.0, 0.1, 0.01, 0.001];
    let thetas = [
        "0.5", "0.25", "0.1", "0.05", "0.01", "0.005", "0.001", "0.0005",
    ];
    let dir = runner::scratch("stiffness");
    let mut table = String::from(
        "  E1/E2   auto_iter   auto_dE      best_theta   best_iter   (fixed theta: iterations, '-' = diverged/stagnated/max_it)\n",
    );
    for ratio in ratios {
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
        let run = |theta: &str| -> Option<(u64, f64)> {
            let mut a = base.to_vec();
            a.extend(["-nndd_theta", theta]);
            let prefix = dir.join("nndd");
            let (j, _) = runner::try_run(2, "petsc-options/paper.opts", &[], &prefix, &a).ok()?;
            let e = runner::num(&j, "potential_energy");
            j["converged"].as_bool().unwrap_or(false).then(|| {
                (
                    j["iterations"].as_u64().unwrap_or(0),
                    (e - em).abs() / em.abs(),
                )
            })
        };
        eprintln!("stiffness: E1/E2 = {ratio} …");
        let auto = run("auto");
        let mut scan = String::new();
        let mut best: Option<(&str, u64)> = None;
        for t in thetas {
            let r = run(t);
            scan.push_str(&format!(
                " {t}:{}",
                r.map_or("-".into(), |(i, _)| i.to_string())
            ));
            if let Some((i, _)) = r {
                if best.is_none_or(|(_, b)| i < b) {
                    best = Some((t, i));
                }
            }
        }
        let (bt, bi) = best.map_or(("-".to_string(), "-".to_string()), |(t, i)| {
            (t.to_string(), i.to_string())
        });
        table.push_str(&format!(
            "{ratio:>7}   {:>9}   {:>9}   {bt:>10}   {bi:>9}  {scan}\n",
            auto.map_or("-".into(), |(i, _)| i.to_string()),
            auto.map_or("-".into(), |(_, de)| format!("{de:.1e}")),
        ));
    }
    table.push_str(&format!("(paper n = {n}, 2 ranks, tol 1e-8; auto_dE: relative energy difference to the monolithic solve)\n"));
    print!("{table}");
    std::fs::create_dir_all("results").ok();
    let out = if n == "16" {
        "results/stiffness.txt".to_string()
    } else {
        format!("results/stiffness-n{n}.txt")
    };
    std::fs::write(&out, &table).expect("results/stiffness*.txt");
}
