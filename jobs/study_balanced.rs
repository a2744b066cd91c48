//! Balanced stopping against the fixed tolerance on the `paper` benchmark: for n = 8 … 256
//! (`--quick`: n = 8, 16), the NNDD stopped at ‖Δλ‖/‖λ‖ ≤ 1e-8 and stopped at the first
//! iteration where η^NNDD ≤ κ η^FE (κ = 0.1, `-nndd_stop balanced`, a recovery-free η^NNDD
//! check every iteration, full estimates at the first check and at the stop): the iterations
//! of each, the iterations saved, η^glo of each final iterate and its relative change, and the
//! wall times. About 1 minute, most of it n = 128 and 256.
//!
//! Run: `jobs/study-balanced [--quick] [--out DIR]` → `DIR/balanced.csv` (default DIR =
//! results/studies) and a table on stdout.

#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;
#[path = "study.rs"]
mod study;

use study::Row;

/// The stopping ratio κ of `-nndd_stop balanced`.
const KAPPA: &str = "0.1";

/// The two runs of one mesh: fixed tolerance and balanced stopping.
struct Pair {
    n: usize,
    /// Estimates of the final iterates.
    tol: Row,
    bal: Row,
    /// Wall times (s) and the balanced run's `stop_reason`.
    wall_tol: f64,
    wall_bal: f64,
    reason: String,
}

impl Pair {
    fn saved(&self) -> i64 {
        self.tol.iteration as i64 - self.bal.iteration as i64
    }
    /// (η^glo_balanced − η^glo_tol)/η^glo_tol.
    fn change(&self) -> f64 {
        (self.bal.eta_glo - self.tol.eta_glo) / self.tol.eta_glo
    }
}

fn main() {
    let opts = study::options("balanced");
    let levels: &[usize] = if opts.quick {
        &[8, 16]
    } else {
        &[8, 16, 32, 64, 128, 256, 512]
    };
    let dir = runner::scratch("balanced");
    let mut pairs = Vec::new();
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
        let tol = ["-nndd_stop", "tol", "-nndd_estimate_every", "0"];
        let (j_tol, wall_tol) = runner::run(
            2,
            &dir.join(format!("tol{n}")),
            &[&common[..], &tol].concat(),
        );
        let bal = [
            "-nndd_stop",
            "balanced",
            "-nndd_stop_ratio",
            KAPPA,
            "-nndd_estimate_every",
            "1",
        ];
        let (j_bal, wall_bal) = runner::run(
            2,
            &dir.join(format!("bal{n}")),
            &[&common[..], &bal].concat(),
        );
        let p = Pair {
            n,
            tol: Row::last(n, &j_tol),
            bal: Row::last(n, &j_bal),
            wall_tol,
            wall_bal,
            reason: j_bal["stop_reason"].as_str().unwrap_or("?").to_string(),
        };
        for (j, r) in [(&j_tol, &p.tol), (&j_bal, &p.bal)] {
            assert_eq!(
                j["iterations"].as_u64(),
                Some(r.iteration),
                "balanced: the last estimate is not of the final iterate"
            );
        }
        eprintln!(
            "balanced: n = {n}: {} → {} iterations ({}), {wall_tol:.1} s → {wall_bal:.1} s",
            p.tol.iteration, p.bal.iteration, p.reason
        );
        pairs.push(p);
    }
    std::fs::remove_dir_all(&dir).ok();

    let mut csv = String::from(
        "n,dofs,iterations_tol,iterations_balanced,iterations_saved,eta_glo_tol,\
         eta_glo_balanced,eta_glo_rel_change,eta_fe_balanced,eta_nndd_balanced,wall_tol_s,\
         wall_balanced_s,stop_reason_balanced\n",
    );
    println!(
        "{:>4} {:>7} {:>6} {:>6} {:>6} {:>12} {:>12} {:>10} {:>11} {:>8} {:>8}  stop",
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
        "wall_bal"
    );
    for p in &pairs {
        let (a, b) = (&p.tol, &p.bal);
        csv += &format!(
            "{},{},{},{},{},{:.10e},{:.10e},{:.6e},{:.10e},{:.10e},{:.3},{:.3},{}\n",
            p.n,
            a.dofs,
            a.iteration,
            b.iteration,
            p.saved(),
            a.eta_glo,
            b.eta_glo,
            p.change(),
            b.eta_fe,
            b.eta_nndd,
            p.wall_tol,
            p.wall_bal,
            p.reason
        );
        println!(
            "{:>4} {:>7} {:>6} {:>6} {:>6} {:>12.5e} {:>12.5e} {:>10.2e} {:>11.3e} {:>8.2} {:>8.2}  {}",
            p.n, a.dofs, a.iteration, b.iteration, p.saved(), a.eta_glo, b.eta_glo, p.change(),
            b.eta_nndd / b.eta_fe, p.wall_tol, p.wall_bal, p.reason
        );
    }
    println!(
        "(tol: -nndd_tol 1e-8; bal: -nndd_stop balanced -nndd_stop_ratio {KAPPA}, η^NNDD checked every \
         iteration; rel_change = (eta_glo_bal - eta_glo_tol) / eta_glo_tol; wall times in s)"
    );
    study::write(&opts.out.join("balanced.csv"), &csv);
    eprintln!(
        "balanced: wrote {}",
        opts.out.join("balanced.csv").display()
    );
}
