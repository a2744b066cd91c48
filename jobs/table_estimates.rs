//! The table of estimates: for `paper` at n = 4, 8, 16, 32 (default), at iteration 6 and converged,
//! η^glo, η^FE, η^NNDD, e_ref (reference mesh 8n), the effectivity and the ratio (25), for the
//! recoveries `eet` (plain EET + Johnson–Mercier) and `patch` (with patch-wise complementary
//! energy minimisation); then the largest equilibrium residuals and the estimation time as a
//! fraction of the solve time, per n (`--compare 16,64,256,512,1024` by default), for the
//! default recovery and the one it replaced; then the cost of estimates at every
//! iteration against none, per n (`--every 256` by default) and θ. Run through
//! `jobs/table-estimates [--compare n,n,…] [--every n,n,…] [n …]`.

#[path = "runner.rs"]
mod runner;
use runner::num;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    // `--compare n,n,…`: the levels of the recovery comparison; `--every n,n,…`: those of the
    // estimates-every-iteration comparison.
    let compare_levels = take_list(&mut args, "--compare", &[16, 64, 256, 512, 1024]);
    let every_levels = take_list(&mut args, "--every", &[256]);
    let levels: Vec<usize> = if args.is_empty() {
        vec![4, 8, 16, 32]
    } else {
        args.iter().map(|a| a.parse().expect("integers")).collect()
    };
    let dir = runner::scratch("table-estimates");
    println!(
        "{:>4} {:>7} {:>9} {:>5} {:>12} {:>12} {:>12} {:>12} {:>8} {:>7}",
        "n", "dofs", "recovery", "iter", "eta_glo", "eta_fe", "eta_nndd", "e_ref", "gamma", "ratio"
    );
    let mut worst = [0.0f64; 5];
    for &n in &levels {
        for recovery in ["eet", "patch"] {
            eprintln!("table-estimates: n = {n}, {recovery} …");
            let prefix = dir.join(format!("e{n}{recovery}"));
            let ns = n.to_string();
            let (j, _) = runner::run(
                2,
                &prefix,
                &[
                    "-nndd_n",
                    &ns,
                    "-nndd_estimate_every",
                    "6",
                    "-nndd_reference_factor",
                    "8",
                    "-nndd_recovery",
                    recovery,
                ],
            );
            let its = j["iterations"].as_u64().unwrap();
            for e in j["estimates"].as_array().unwrap() {
                let it = e["iteration"].as_u64().unwrap();
                if it == 6 || it == its {
                    println!(
                        "{:>4} {:>7} {:>9} {:>5} {:>12.5e} {:>12.5e} {:>12.5e} {:>12.5e} {:>8.4} {:>7.4}",
                        n,
                        j["dofs"],
                        recovery,
                        if it == its { format!("{it}c") } else { it.to_string() },
                        num(e, "eta_glo"),
                        num(e, "eta_fe"),
                        num(e, "eta_nndd"),
                        num(e, "e_ref"),
                        num(e, "effectivity"),
                        num(e, "eta_ratio")
                    );
                }
            }
            let r = &j["equilibrium_residuals"];
            for (w, k) in worst.iter_mut().zip([
                "divergence",
                "internal_jump",
                "element_jump",
                "boundary",
                "point_reaction",
            ]) {
                *w = w.max(num(r, k));
            }
        }
    }
    println!("(iteration 'Nc': converged, tol 1e-8; gamma = eta_glo / e_ref; ratio = (eta_fe^2 + eta_nndd^2) / eta_glo^2)");
    println!(
        "equilibrium residuals (max over all runs, relative): divergence {:.1e}, internal jumps {:.1e}, element jumps {:.1e}, boundary {:.1e}, point reactions {:.1e}",
        worst[0], worst[1], worst[2], worst[3], worst[4]
    );
    compare(&dir, &compare_levels);
    every(&dir, &every_levels);
    std::fs::remove_dir_all(&dir).ok();
}

/// The cost of estimates at every iteration: per n and θ (auto, the default, and the paper's
/// 0.25), a run without estimates against one with `-nndd_estimate_every 1` (tol 1e-8, 2
/// ranks, one run each): the summaries' total times, their ratio, the estimates' total and
/// mean time, and the last η^glo.
fn every(dir: &std::path::Path, levels: &[usize]) {
    println!(
        "\n{:>5} {:>6} {:>4} {:>10} {:>10} {:>7} {:>4} {:>10} {:>10} {:>10}",
        "n",
        "theta",
        "its",
        "none_s",
        "every1_s",
        "ratio",
        "est",
        "estim_s",
        "per_est_s",
        "eta_glo"
    );
    for &n in levels {
        for theta in ["auto", "0.25"] {
            let ns = n.to_string();
            let run = |every: &str| {
                eprintln!("table-estimates: n = {n}, theta {theta}, estimate every {every} …");
                let args = [
                    "-nndd_n",
                    &ns,
                    "-nndd_theta",
                    theta,
                    "-nndd_estimate_every",
                    every,
                    "-nndd_reference_factor",
                    "0",
                ];
                runner::run(2, &dir.join(format!("every{n}-{theta}-{every}")), &args).0
            };
            let (none, all) = (run("0"), run("1"));
            let total = |j: &serde_json::Value| num(&j["timings"], "total");
            // (one per iteration, and the final iterate's again after the loop, η^glo cold)
            let est = all["estimates"].as_array().map_or(0, |e| e.len() + 1);
            let estim = num(&all["timings"], "estimation");
            let last = all["estimates"].as_array().and_then(|e| e.last()).cloned();
            println!(
                "{:>5} {:>6} {:>4} {:>10.2} {:>10.2} {:>7.2} {:>4} {:>10.2} {:>10.3} {:>10.5}",
                n,
                theta,
                all["iterations"],
                total(&none),
                total(&all),
                total(&all) / total(&none),
                est,
                estim,
                estim / est.max(1) as f64,
                last.map_or(f64::NAN, |e| num(&e, "eta_glo"))
            );
        }
    }
    println!("(none_s, every1_s: the summaries' total times without estimates and with -nndd_estimate_every 1; ratio = every1_s / none_s; est: estimates made, the final iterate's twice (warm in the loop, then with a cold eta_glo recovery); estim_s: their total time, per_est_s: per estimate)");
}

/// The comma-separated levels after `flag` in `args` (both removed), or `default`.
fn take_list(args: &mut Vec<String>, flag: &str, default: &[usize]) -> Vec<usize> {
    let Some(k) = args.iter().position(|a| a == flag) else {
        return default.to_vec();
    };
    let list = args
        .get(k + 1)
        .unwrap_or_else(|| panic!("{flag} n,n,…"))
        .clone();
    args.drain(k..k + 2);
    list.split(',')
        .map(|a| a.parse().expect("integers"))
        .collect()
}

/// The comparison of recoveries: per n, the solve and one estimate of the final iterate (tol 1e-8,
/// 2 ranks) with the default recovery (`patch`) and the one it replaced (`patch-classic`), one run
/// each: the solve time, the estimate's time, their ratio, the effectivity (against the reference
/// on the mesh 8n, for n ≤ 64) and the peak memory per rank.
fn compare(dir: &std::path::Path, levels: &[usize]) {
    println!(
        "\n{:>5} {:>8} {:>14} {:>4} {:>9} {:>9} {:>7} {:>8} {:>16}",
        "n", "dofs", "recovery", "its", "solve_s", "estim_s", "ratio", "gamma", "MiB/rank"
    );
    for &n in levels {
        for recovery in ["patch", "patch-classic"] {
            eprintln!("table-estimates: comparison n = {n}, {recovery} …");
            let ns = n.to_string();
            let reference = if n <= 64 { "8" } else { "0" };
            let (j, _) = runner::run(
                2,
                &dir.join(format!("c{n}{recovery}")),
                &[
                    "-nndd_n",
                    &ns,
                    "-nndd_estimate",
                    "-nndd_estimate_every",
                    "0",
                    "-nndd_reference_factor",
                    reference,
                    "-nndd_recovery",
                    recovery,
                ],
            );
            let solve = runner::solve_seconds(&j);
            let est = num(&j["timings"], "estimation");
            let last = j["estimates"].as_array().and_then(|e| e.last()).cloned();
            let gamma = last.map_or(f64::NAN, |e| num(&e, "effectivity"));
            let mib: Vec<String> = j["peak_memory_mib_per_rank"]
                .as_array()
                .map(|v| {
                    v.iter()
                        .map(|m| format!("{:.0}", m.as_f64().unwrap_or(0.0)))
                        .collect()
                })
                .unwrap_or_default();
            println!(
                "{:>5} {:>8} {:>14} {:>4} {:>9.3} {:>9.3} {:>7.3} {:>8} {:>16}",
                n,
                j["dofs"],
                recovery,
                j["iterations"],
                solve,
                est,
                est / solve,
                if gamma.is_nan() {
                    "-".to_string()
                } else {
                    format!("{gamma:.4}")
                },
                mib.join(", ")
            );
        }
    }
    println!("(one estimate of the final iterate, tol 1e-8, 2 ranks; solve = assembly + factorisation + NNDD loop, max over ranks; ratio = estim_s / solve_s; gamma = eta_glo / e_ref on the mesh 8n, n <= 64 only; patch: 6 sweeps, the eta_FE recovery warm-started with 1; patch-classic: 10 sweeps each)");
}
