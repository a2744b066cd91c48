//! Figure 5 of Gallimard, Choi & Sassi (2013): η^glo, η^FE and η^NNDD of the `paper`
//! benchmark against the NNDD iteration at n = 15 (1024 dofs; the paper has 1002), estimated
//! at every iteration for 40 iterations (the NNDD reaches tol 1e-8 at about 38), so the
//! plateau shows (`--quick`: n = 4, 10 iterations). The paper: η^glo tends to the horizontal
//! asymptote η^FE while η^NNDD falls with the iterations.
//!
//! Run: `jobs/study-fig5 [--quick] [--out DIR]` → `DIR/fig5.csv`, `DIR/fig5.png` (default
//! DIR = results/studies) and a table on stdout.

#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;
#[path = "study.rs"]
mod study;

use plot::{Scale, SeriesLabelPosition};

fn main() {
    let opts = study::options("fig5");
    plot::register_font();
    let (n, iterations) = if opts.quick { (4, 10) } else { (15, 40) };
    let dir = runner::scratch("fig5");
    eprintln!("fig5: n = {n}, {iterations} iterations (1/1) …");
    let (ns, its) = (n.to_string(), iterations.to_string());
    let (j, wall) = runner::run(
        2,
        &dir.join(format!("n{n}")),
        &[
            "-nndd_n",
            &ns,
            "-nndd_stop",
            "none",
            "-nndd_max_it",
            &its,
            "-nndd_tol",
            "1e-8",
            "-nndd_estimate_every",
            "1",
            "-nndd_reference_factor",
            "0",
        ],
    );
    std::fs::remove_dir_all(&dir).ok();
    let rows: Vec<study::Row> = j["estimates"]
        .as_array()
        .expect("the run has estimates")
        .iter()
        .map(|e| study::Row::new(n, &j, e))
        .collect();
    eprintln!(
        "fig5: n = {n}: {} dofs, {} estimates, {wall:.1} s",
        j["dofs"],
        rows.len()
    );

    study::print_table(&rows);
    study::write_csv(&opts.out.join("fig5.csv"), &rows);
    let png = opts.out.join("fig5.png");
    let title = format!(
        "Errors along the NNDD iterations, {} dofs (paper Fig. 5)",
        j["dofs"]
    );
    study::plot_estimates(
        &png,
        &title,
        "NNDD iteration",
        Scale::Linear,
        SeriesLabelPosition::MiddleRight,
        &rows,
        |r| r.iteration as f64,
    );
    eprintln!(
        "fig5: wrote {} and {}",
        opts.out.join("fig5.csv").display(),
        png.display()
    );
}
