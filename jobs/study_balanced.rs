//! Balanced stopping against the fixed tolerance on the `paper` benchmark: for n = 8 … 256
//! (`--quick`: n = 8, 16), the NNDD stopped at ‖Δλ‖/‖λ‖ ≤ 1e-8 and stopped at the first
//! iteration where η^NNDD ≤ κ η^FE (κ = 0.1, `-nndd_stop balanced`, estimating every
//! iteration): the iterations of each, the iterations saved, η^glo of each final iterate and
//! its relative change, and the wall times (the balanced run pays an estimate per iteration).
//!
//! Run: `jobs/study-balanced [--quick] [--out DIR]` → `DIR/balanced.csv` (default DIR =
//! results/studies) and a table on stdout.

#[path = "runner.rs"]
mod runner;
#[path = "study.rs"]
mod study;

/// The stopping ratio κ of `-nndd_stop balanced`.
const KAPPA: &str = "0.1";

fn main() {
    let opts = study::options("balanced");
    let levels: &[usize] = if opts.quick {
        &[8, 16]
    } else {
        &[8, 16, 32, 64, 128, 256]
    };
    let dir = runner::scratch("balanced");
    let header = "n,dofs,iterations_tol,iterations_balanced,iterations_saved,eta_glo_tol,eta_glo_balanced,eta_glo_rel_change,eta_fe_balanced,eta_nndd_balanced,wall_tol_s,wall_balanced_s,stop_reason_balanced";
    let mut csv = format!("{header}\n");
    let mut table = Vec::new();
    for (k, &n) in levels.iter().enumerate() {
        eprintln!("balanced: n = {n} ({}/{}) …", k + 1, levels.len());
        let ns = n.to_string();
        let common = [
            "-nndd_n",
            &ns,
            "-nndd_tol",
            "1e-8",
            "-nndd_estimate",
            "-nndd_reference_factor",
            "0",
        ];
        let (fixed, wall_fixed) = runner::run(
            2,
            &dir.join(format!("tol{n}")),
            &[
                &common[..],
                &["-nndd_stop", "tol", "-nndd_estimate_every", "0"],
            ]
            .concat(),
        );
        let (bal, wall_bal) = runner::run(
            2,
            &dir.join(format!("bal{n}")),
            &[
                &common[..],
                &[
                    "-nndd_stop",
                    "balanced",
                    "-nndd_stop_ratio",
                    KAPPA,
                    "-nndd_estimate_every",
                    "1",
                ],
            ]
            .concat(),
        );
        let (a, b) = (study::Row::last(n, &fixed), study::Row::last(n, &bal));
        let its = |j: &serde_json::Value| j["iterations"].as_u64().expect("iterations");
        let (it_a, it_b) = (its(&fixed), its(&bal));
        let change = (b.eta_glo - a.eta_glo) / a.eta_glo;
        let reason = bal["stop_reason"].as_str().unwrap_or("?").to_string();
        eprintln!(
            "balanced: n = {n}: {it_a} → {it_b} iterations ({reason}), {wall_fixed:.1} s → {wall_bal:.1} s"
        );
        csv += &format!(
            "{n},{},{it_a},{it_b},{},{:.10e},{:.10e},{:.6e},{:.10e},{:.10e},{wall_fixed:.3},{wall_bal:.3},{reason}\n",
            a.dofs,
            it_a as i64 - it_b as i64,
            a.eta_glo,
            b.eta_glo,
            change,
            b.eta_fe,
            b.eta_nndd
        );
        table.push((n, a, b, it_a, it_b, change, wall_fixed, wall_bal, reason));
    }
    std::fs::remove_dir_all(&dir).ok();
    study::write(&opts.out.join("balanced.csv"), &csv);

    println!(
        "{:>4} {:>7} {:>6} {:>6} {:>6} {:>12} {:>12} {:>10} {:>11} {:>8} {:>8}  {}",
        "n",
        "dofs",
        "it_tol",
        "it_bal",
        "saved",
        "eta_glo_tol",
        "eta_glo_bal",
        "rel_change",
        "nndd/fe_bal",
        "wall_tol",
        "wall_bal",
        "stop"
    );
    for (n, a, b, it_a, it_b, change, wa, wb, reason) in &table {
        println!(
            "{:>4} {:>7} {:>6} {:>6} {:>6} {:>12.5e} {:>12.5e} {:>10.2e} {:>11.3e} {:>8.2} {:>8.2}  {}",
            n,
            a.dofs,
            it_a,
            it_b,
            *it_a as i64 - *it_b as i64,
            a.eta_glo,
            b.eta_glo,
            change,
            b.eta_nndd / b.eta_fe,
            wa,
            wb,
            reason
        );
    }
    println!("(tol: -nndd_tol 1e-8; bal: -nndd_stop balanced -nndd_stop_ratio {KAPPA}, estimating every iteration; rel_change = (eta_glo_bal - eta_glo_tol) / eta_glo_tol; wall times in s)");
    eprintln!(
        "balanced: wrote {}",
        opts.out.join("balanced.csv").display()
    );
}
