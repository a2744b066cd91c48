//! The memory model of the run's size check (`src/app/capacity.rs`) against measured peaks:
//! `paper` solved on 2 ranks at several n, the bodies factored (the built-in MUMPS Cholesky)
//! or solved iteratively (CG + GAMG, n ≤ 256: the iterative bodies re-solve at every NNDD
//! iteration, tens of minutes at n = 512 on 2 cores), and with the reference solution of `-nndd_reference_factor`
//! (its problems held with the mesh's, its factorisations freed before the mesh's are made:
//! factor 8, where the reference dominates, and 2, where the mesh's factorisation is a quarter
//! of the reference's). Per run one row: the dofs of the mesh (and of
//! the reference mesh), the measured peak (the summary's `peak_memory_mib_per_rank`, summed
//! over the ranks), the model's estimate and their ratio. The table goes to
//! `results/bench-memory.txt`. Run through `jobs/bench-memory [--quick]`.

#[path = "runner.rs"]
mod runner;

use std::io::Write;

use nndd::app::capacity;

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let dir = runner::scratch("bench-memory");
    let iterative = [
        "-body1_ksp_type",
        "cg",
        "-body1_pc_type",
        "gamg",
        "-body1_ksp_rtol",
        "1e-12",
        "-body2_ksp_type",
        "cg",
        "-body2_pc_type",
        "gamg",
        "-body2_ksp_rtol",
        "1e-12",
    ];
    // (n, reference factor, iterative)
    let cases: Vec<(usize, usize, bool)> = if quick {
        vec![(32, 0, false), (64, 0, false), (64, 0, true), (8, 8, false)]
    } else {
        vec![
            (64, 0, false),
            (128, 0, false),
            (256, 0, false),
            (512, 0, false),
            (128, 0, true),
            (256, 0, true),
            (16, 8, false),
            (32, 8, false),
            (64, 8, false),
            (128, 2, false),
            (256, 2, false),
        ]
    };
    let ranks = 2;
    let mut lines = vec![
        format!("# jobs/bench-memory: paper on {ranks} ranks, solve to tol 1e-8, peak memory summed over the ranks"),
        format!(
            "{:>5} {:>3} {:>9} {:>11} {:>10} {:>10} {:>6}",
            "n", "r", "solver", "dofs", "peak MiB", "model MiB", "model/peak"
        ),
    ];
    for (n, r, iter) in cases {
        let prefix = dir.join(format!("n{n}-r{r}-{}", if iter { "it" } else { "lu" }));
        let mut args = vec![
            "-nndd_n".to_string(),
            n.to_string(),
            "-nndd_estimate_every".into(),
            "0".into(),
            "-nndd_reference_factor".into(),
            r.to_string(),
        ];
        if r > 0 {
            args.push("-nndd_estimate".into());
        }
        if iter {
            args.extend(iterative.iter().map(|s| s.to_string()));
        }
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        eprintln!(
            "bench-memory: n = {n}, r = {r}, {} …",
            if iter { "iterative" } else { "factored" }
        );
        let (j, _) = runner::run(ranks, &prefix, &refs);
        let peak: f64 = runner::nums(&j, "peak_memory_mib_per_rank").iter().sum();
        let dofs = runner::num(&j, "dofs") as usize;
        let fine = if r > 0 { dofs_of(n * r) } else { 0 };
        let model = capacity::estimate(ranks, dofs, (r > 0).then_some(fine)) / 1048576.0;
        lines.push(format!(
            "{n:>5} {r:>3} {:>9} {:>11} {peak:>10.0} {model:>10.0} {:>10.2}",
            if iter { "cg+gamg" } else { "mumps" },
            if r > 0 {
                format!("{dofs}+{fine}")
            } else {
                dofs.to_string()
            },
            model / peak
        ));
    }
    let table = lines.join("\n") + "\n";
    print!("{table}");
    std::fs::create_dir_all("results").ok();
    std::fs::File::create("results/bench-memory.txt")
        .and_then(|mut f| f.write_all(table.as_bytes()))
        .expect("write results/bench-memory.txt");
    std::fs::remove_dir_all(&dir).ok();
}

/// The dofs of `paper` at level n: two (n+1)² grids of 2-dof nodes.
fn dofs_of(n: usize) -> usize {
    2 * 2 * (n + 1) * (n + 1)
}
