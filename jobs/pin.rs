//! The pin in a groove (examples/pin): body 1's contact side is curved, so the contact
//! direction turns along Γc (rotated nodal frames). Meshes levels 1 … 4 with Gmsh, solves each on
//! 2 ranks (NNDD to tol 1e−8 and the monolithic check) with the estimate of the final iterate
//! and e_ref on the mesh refined r times (`--reference-factor r`, default 4).
//!
//! Run: `jobs/pin [--levels 1,2,3,4] [--estimate-up-to L] [--reference-factor r]` → a table on stdout and in
//! `results/pin/table.txt`.

#[path = "runner.rs"]
mod runner;

use runner::num;
use std::path::Path;

fn main() {
    let runner::LevelArgs {
        levels,
        estimate_up_to,
        reference_factor,
        ..
    } = runner::LevelArgs::parse("pin");
    let dir = Path::new("results/pin");
    std::fs::create_dir_all(dir).expect("results/pin");
    let mut table = String::from(
        "level     dofs  iter  contact_force  arc_x_min  arc_x_max  eta_glo      eta_fe       e_ref        effect  max_residual  mono_dE    solve_s  estim_s  wall_s\n",
    );
    print!("{table}");
    for &level in &levels {
        let msh = dir.join(format!("pin-{level}.msh"));
        runner::gmsh_level("examples/pin/pin.geo", level, &msh);
        let m = msh.to_str().unwrap();
        let r = reference_factor.to_string();
        let prefix = dir.join(format!("level{level}"));
        let mut extra = vec!["-nndd_mesh", m];
        if level <= estimate_up_to {
            extra.push("-nndd_estimate");
            if reference_factor > 1 {
                extra.extend(["-nndd_reference_factor", &r]);
            }
        }
        let (j, wall) = runner::try_run(2, "examples/pin/pin.opts", &[], &prefix, &extra)
            .unwrap_or_else(|e| panic!("level {level}: {e}"));
        let mono = dir.join(format!("level{level}-mono"));
        let (jm, _) = runner::try_run(
            2,
            "examples/pin/pin.opts",
            &[],
            &mono,
            &["-nndd_mesh", m, "-nndd_solver", "monolithic"],
        )
        .unwrap_or_else(|e| panic!("level {level}, monolithic: {e}"));
        let (e, em) = (num(&j, "potential_energy"), num(&jm, "potential_energy"));
        let est = &j["estimates"][0];
        let res = j["equilibrium_residuals"]
            .as_object()
            .map_or(f64::NAN, |o| {
                o.values().filter_map(|v| v.as_f64()).fold(0.0, f64::max)
            });
        let solve = runner::solve_seconds(&j);
        let zone = &j["contact_zone"];
        let line = format!(
            "{level:5} {:8} {:5}  {:.6e}  {:9.4}  {:9.4}  {:.4e}   {:.4e}   {:.4e}   {:.4}  {:.2e}      {:.2e}   {:7.2}  {:7.2}  {:6.1}\n",
            num(&j, "dofs"),
            num(&j, "iterations"),
            num(&j, "contact_force"),
            zone[0].as_f64().unwrap_or(f64::NAN),
            zone[1].as_f64().unwrap_or(f64::NAN),
            num(est, "eta_glo"),
            num(est, "eta_fe"),
            num(est, "e_ref"),
            num(est, "effectivity"),
            res,
            ((e - em) / em).abs(),
            solve,
            num(&j["timings"], "estimation"),
            wall
        );
        print!("{line}");
        table.push_str(&line);
    }
    std::fs::write(dir.join("table.txt"), &table).expect("results/pin/table.txt");
}
