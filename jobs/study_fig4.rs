//! Figure 4 of Gallimard, Choi & Sassi (2013): the effectivity index γ = η^glo/e_ref (26) of
//! the converged NNDD (tol 1e-8) against the number of dofs, e_ref against the reference
//! solution on the nested mesh 8n, n = 4 … 64 (about 20 s, n = 64's reference mesh has
//! 1.05 M dofs and takes 1 GiB; `--quick`: n = 4, 8). The paper: γ ≈ 1.2 (and γ ≥ 1, η^glo
//! being a guaranteed bound).
//!
//! Run: `jobs/study-fig4 [--quick] [--out DIR]` → `DIR/fig4.csv`, `DIR/fig4.png` (default
//! DIR = results/studies) and a table on stdout.

#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;
#[path = "study.rs"]
mod study;

use plot::{Scale, Series, SeriesLabelPosition};

fn main() {
    let opts = study::options("fig4");
    plot::register_font();
    let levels: &[usize] = if opts.quick {
        &[4, 8]
    } else {
        &[4, 8, 16, 32, 64]
    };
    let dir = runner::scratch("fig4");
    let mut rows = Vec::new();
    for (k, &n) in levels.iter().enumerate() {
        eprintln!("fig4: n = {n} ({}/{}) …", k + 1, levels.len());
        let ns = n.to_string();
        let (j, wall) = runner::run(
            2,
            &dir.join(format!("n{n}")),
            &[
                "-nndd_n",
                &ns,
                "-nndd_stop",
                "tol",
                "-nndd_tol",
                "1e-8",
                "-nndd_estimate",
                "-nndd_estimate_every",
                "0",
                "-nndd_reference_factor",
                "8",
            ],
        );
        let row = study::Row::last(n, &j);
        assert!(
            row.effectivity.is_some(),
            "fig4: no effectivity in the summary"
        );
        eprintln!(
            "fig4: n = {n}: {} dofs, {} iterations, {wall:.1} s",
            row.dofs, row.iteration
        );
        rows.push(row);
    }
    std::fs::remove_dir_all(&dir).ok();

    study::print_table(&rows);
    study::write_csv(&opts.out.join("fig4.csv"), &rows);
    let gamma: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.dofs as f64, r.effectivity.unwrap()))
        .collect();
    let ends = [gamma[0].0, gamma[gamma.len() - 1].0];
    let png = opts.out.join("fig4.png");
    plot::line_chart(
        &png,
        &plot::Chart {
            title: "Effectivity of the converged NNDD (paper Fig. 4)",
            x_label: "number of dofs",
            y_label: "effectivity γ = η^glo / e_ref",
            x_scale: Scale::Log,
            y_scale: Scale::Linear,
            legend: SeriesLabelPosition::MiddleLeft,
        },
        &[
            Series::new("γ (reference mesh 8n)", gamma),
            Series::line("paper: γ ≈ 1.2", ends.iter().map(|&x| (x, 1.2)).collect()),
            Series::line("bound: γ = 1", ends.iter().map(|&x| (x, 1.0)).collect()),
        ],
    )
    .unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    eprintln!(
        "fig4: wrote {} and {}",
        opts.out.join("fig4.csv").display(),
        png.display()
    );
}
