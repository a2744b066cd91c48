//! Issue 3's table: for `paper` at n = 4, 8, 16, 32 (default), at iteration 6 and converged,
//! η^glo, η^FE, η^NNDD, e_ref (reference mesh 8n), the effectivity and the ratio (25), for the
//! recoveries `eet` (plain EET + Johnson–Mercier) and `patch` (with patch-wise complementary
//! energy minimisation); then the largest equilibrium residuals and the estimation time as a
//! fraction of the solve time at n = 64 and 256. Run through `jobs/table-estimates [n …]`.

#[path = "runner.rs"]
mod runner;
use runner::num;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
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
    println!(
        "\n{:>5} {:>9} {:>10} {:>10} {:>10}",
        "n", "dofs", "solve_s", "estim_s", "fraction"
    );
    for n in [64usize, 256] {
        eprintln!("table-estimates: timing n = {n} …");
        let ns = n.to_string();
        let (j, _) = runner::run(
            2,
            &dir.join(format!("t{n}")),
            &[
                "-nndd_n",
                &ns,
                "-nndd_estimate",
                "-nndd_estimate_every",
                "0",
                "-nndd_reference_factor",
                "0",
            ],
        );
        let t = &j["timings"];
        let solve = runner::solve_seconds(&j);
        let est = num(t, "estimation");
        println!(
            "{:>5} {:>9} {:>10.3} {:>10.3} {:>10.3}",
            n,
            j["dofs"],
            solve,
            est,
            est / solve
        );
    }
    println!("(one estimate of the final iterate, patch recovery; solve = assembly + factorisation + NNDD loop, max over ranks)");
    std::fs::remove_dir_all(&dir).ok();
}
