//! Speed benchmark: `paper` on `-n 2` at several mesh levels to tol 1e-8, printing
//! wall time, iterations and the phase split (maximum over ranks, from the JSON summary).
//! Run through `jobs/bench-speed [n …]`.

#[path = "runner.rs"]
mod runner;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let levels: Vec<usize> = if args.is_empty() {
        vec![16, 64, 256, 512]
    } else {
        args.iter()
            .map(|a| a.parse().expect("mesh levels are integers"))
            .collect()
    };
    let dir = runner::scratch("bench");
    println!(
        "{:>5} {:>9} {:>4} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
        "n",
        "dofs",
        "its",
        "wall_s",
        "assem",
        "factor",
        "iface",
        "fields",
        "dirich",
        "contact",
        "neumann",
        "wait",
        "output",
        "iter/fac",
        "MiB/rank"
    );
    for n in levels {
        let prefix = dir.join(format!("paper{n}"));
        eprintln!("bench-speed: n = {n} …");
        // The solver alone: no estimates, no reference solution.
        let args = [
            "-nndd_n",
            &n.to_string(),
            "-nndd_tol",
            "1e-8",
            "-nndd_estimate_every",
            "0",
            "-nndd_reference_factor",
            "0",
        ];
        let (j, wall) = runner::run(2, &prefix, &args);
        let t = &j["timings"];
        let g = |k: &str| t[k].as_f64().unwrap();
        let its = j["iterations"].as_u64().unwrap();
        let per_iter =
            (g("dirichlet_step").max(g("contact_step")) + g("neumann_step") + g("exchange"))
                / its as f64;
        println!(
            "{:>5} {:>9} {:>4} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.2} {:>9.4} {:>8.0}",
            n,
            j["dofs"],
            its,
            wall,
            g("assembly"),
            g("factorisation"),
            g("interface"),
            g("fields"),
            g("dirichlet_step"),
            g("contact_step"),
            g("neumann_step"),
            g("exchange"),
            g("output"),
            per_iter / g("factorisation"),
            j["peak_memory_mib"].as_f64().unwrap()
        );
    }
    std::fs::remove_dir_all(&dir).ok();
    println!("wall_s: mpirun start to end; phases: seconds, maximum over the 2 ranks (iface: S, D and the free solutions; fields: the reported displacements); wait: time a rank waited for the other");
    println!("iter/fac: cost of one NNDD iteration over the one-time factorisation");
}
