//! Figure 3 of Gallimard, Choi & Sassi (2013): η^glo, η^FE and η^NNDD of the `paper`
//! benchmark against the number of dofs at a fixed 6 NNDD iterations, n = 4 … 256
//! (about 15 s; `--quick`: n = 4, 8). The paper: η^glo tends to the horizontal asymptote
//! η^NNDD while η^FE falls with the mesh size.
//!
//! Run: `jobs/study-fig3 [--quick] [--out DIR]` → `DIR/fig3.csv`, `DIR/fig3.png` (default
//! DIR = results/studies) and a table on stdout.

#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;
#[path = "study.rs"]
mod study;

use plot::{Scale, SeriesLabelPosition};

fn main() {
    let opts = study::options("fig3");
    plot::register_font();
    let levels: &[usize] = if opts.quick {
        &[4, 8]
    } else {
        &[4, 8, 16, 32, 64, 128, 256]
    };
    let dir = runner::scratch("fig3");
    let mut rows = Vec::new();
    for (k, &n) in levels.iter().enumerate() {
        eprintln!("fig3: n = {n} ({}/{}) …", k + 1, levels.len());
        let ns = n.to_string();
        let (j, wall) = runner::run(
            2,
            &dir.join(format!("n{n}")),
            &[
                "-nndd_n",
                &ns,
                "-nndd_stop",
                "none",
                "-nndd_max_it",
                "6",
                "-nndd_estimate",
                "-nndd_estimate_every",
                "0",
                "-nndd_reference_factor",
                "0",
            ],
        );
        let row = study::Row::last(n, &j);
        assert_eq!(row.iteration, 6, "fig3: the estimate is not of iteration 6");
        eprintln!("fig3: n = {n}: {} dofs, {wall:.1} s", row.dofs);
        rows.push(row);
    }
    std::fs::remove_dir_all(&dir).ok();

    study::print_table(&rows);
    study::write_csv(&opts.out.join("fig3.csv"), &rows);
    let png = opts.out.join("fig3.png");
    study::plot_estimates(
        &png,
        "Errors after 6 NNDD iterations (paper Fig. 3)",
        "number of dofs",
        Scale::Log,
        SeriesLabelPosition::UpperRight,
        &rows,
        |r| r.dofs as f64,
    );
    eprintln!(
        "fig3: wrote {} and {}",
        opts.out.join("fig3.csv").display(),
        png.display()
    );
}
