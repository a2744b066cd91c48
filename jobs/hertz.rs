//! The Hertz benchmark (examples/hertz): meshes the four levels with Gmsh, solves each on 2
//! ranks (NNDD to tol 1e−8, and the monolithic check), and compares the contact half-width,
//! the peak pressure and the pressure profile with Hertz's, with the estimates of the final
//! iterate on the levels up to `--estimate-up-to L` (default: all) and e_ref and the
//! effectivity against the reference solution on the mesh refined r times (`--reference-factor
//! r`, default 4: each triangle split into r²; 0: none).
//!
//! Run: `jobs/hertz [--levels 1,2,3,4] [--estimate-up-to L] [--reference-factor r]
//! [--example hertz-nonmatching]` → a table on stdout, `results/EXAMPLE/table.txt` and the
//! pressure profile of the finest level against Hertz's in `docs/img/EXAMPLE-pressure.png`.
//! `--example hertz-nonmatching` solves the same problem with the two bodies meshed on their
//! own (examples/hertz-nonmatching; its levels have the same block size at the contact).

#[path = "hertz_fit.rs"]
mod hertz_fit;
#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;

use std::path::Path;

const MATERIALS: [(f64, f64); 2] = [(7e10, 0.33), (2.1e11, 0.3)];

fn main() {
    let runner::LevelArgs {
        levels,
        estimate_up_to,
        reference_factor,
        example,
    } = runner::LevelArgs::parse("hertz");
    let geo = format!("examples/{example}/{example}.geo");
    let opts = format!("examples/{example}/{example}.opts");
    let results = format!("results/{example}");
    let dir = Path::new(&results);
    std::fs::create_dir_all(dir).expect("results dir");
    let mut table = String::from(
        "level     dofs  pairs  inserted  moved   iter   a_h        a          a_err    p0_h        p0          p0_err   L2_err   eta_glo      e_ref        effect   eta_nndd     mono_dE     input_s  solve_s  estim_s  wall_s\n",
    );
    let mut finest = None;
    for &level in &levels {
        let msh = dir.join(format!("{example}-{level}.msh"));
        runner::gmsh_level(&geo, level, &msh);
        let prefix = dir.join(format!("level{level}"));
        let m = msh.to_str().unwrap();
        let r = reference_factor.to_string();
        // (node to node: examples/hertz-nonmatching's figures in docs/results.md are the
        // curves made to match; jobs/mortar compares the two discretisations)
        let mut extra = vec![
            "-nndd_mesh",
            m,
            "-nndd_contact_discretisation",
            "node_to_node",
        ];
        if level <= estimate_up_to {
            extra.push("-nndd_estimate");
            if reference_factor > 1 {
                extra.extend(["-nndd_reference_factor", &r]);
            }
        }
        eprintln!("hertz: level {level} …");
        let (j, wall) = runner::try_run(2, &opts, &[], &prefix, &extra)
            .unwrap_or_else(|e| panic!("level {level}: {e}"));
        let mono_prefix = dir.join(format!("level{level}-mono"));
        let (mono, _) = runner::try_run(
            2,
            &opts,
            &[],
            &mono_prefix,
            &[
                "-nndd_mesh",
                m,
                "-nndd_solver",
                "monolithic",
                "-nndd_contact_discretisation",
                "node_to_node",
            ],
        )
        .unwrap_or_else(|e| panic!("level {level} monolithic: {e}"));
        let x: Vec<f64> = runner::read_h5(&prefix, "/Mesh/contact/geometry")
            .chunks(2)
            .map(|p| p[0])
            .collect();
        let active: Vec<bool> = runner::read_field(&j, &prefix, "contact", "active")
            .iter()
            .map(|&a| a > 0.5)
            .collect();
        let pressure = runner::read_field(&j, &prefix, "contact", "pressure");
        let h = hertz_fit::fit(
            &x,
            &runner::read_field(&j, &prefix, "contact", "normal_force"),
            &pressure,
            &active,
            1.0,
            MATERIALS,
        );
        let est = &j["estimates"][0];
        let t = |k: &str| runner::num(&j["timings"], k);
        let e = runner::num(&j, "potential_energy");
        let em = runner::num(&mono, "potential_energy");
        let curves = &j["contact_curves"];
        let pair = |k: &str| {
            let v = |i: usize| curves[k][i].as_u64().unwrap_or(0);
            format!("{}+{}", v(0), v(1))
        };
        table.push_str(&format!(
            "{level:>5} {:>8} {:>6} {:>9} {:>6} {:>6}   {:.6}   {:.6}   {:6.2} %  {:.4e}  {:.4e}  {:6.2} %  {:6.4}   {:.4e}   {:.4e}   {:6.4}   {:.4e}   {:.2e}   {:7.2}  {:7.2}  {:7.2}  {:.1}\n",
            j["dofs"].as_u64().unwrap_or(0),
            curves["pairs"].as_u64().unwrap_or(0),
            pair("inserted"),
            pair("moved"),
            j["iterations"].as_u64().unwrap_or(0),
            h.a_h,
            h.a,
            100.0 * h.a_err(),
            h.p0_h,
            h.p0,
            100.0 * h.p0_err(),
            h.l2,
            runner::num(est, "eta_glo"),
            runner::num(est, "e_ref"),
            runner::num(est, "effectivity"),
            runner::num(est, "eta_nndd"),
            (e - em).abs() / em.abs(),
            t("input"),
            runner::solve_seconds(&j),
            t("estimation"),
            wall,
        ));
        finest = Some((x, pressure, h));
    }
    table.push_str(&format!("(2 ranks; pairs: Γc's node pairs; inserted, moved: nodes inserted into and moved on the block's + the cylinder's contact curve to make them match; a_h: half the extent of the contact set, ends half-way to the first open node; p0_h: the largest lumped nodal pressure; L2_err: ‖p_h − p‖/‖p‖ on the paired interface; eta_glo, eta_nndd: the final iterate's estimates, NaN where not estimated; e_ref: energy norm of u_ref − u_h, u_ref on the mesh refined {reference_factor}x (each triangle into {}), effect = eta_glo/e_ref; mono_dE: relative energy difference NNDD − monolithic; input_s: options + mesh file + problem with the Γc pairing; solve_s: assembly + factorisation + NNDD loop; estim_s: the estimate; wall_s: mpirun start to end, with the reference solve)\n", reference_factor * reference_factor));
    print!("{table}");
    std::fs::write(dir.join("table.txt"), &table).expect("table");
    if let Some((x, p, h)) = finest {
        let computed: Vec<(f64, f64)> = x.iter().zip(&p).map(|(&x, &p)| (x, p / 1e9)).collect();
        let exact: Vec<(f64, f64)> = (0..=400)
            .map(|i| {
                let xi = x[0] + (x[x.len() - 1] - x[0]) * i as f64 / 400.0;
                (xi, h.pressure(xi) / 1e9)
            })
            .collect();
        let chart = plot::Chart {
            title: "Hertz: contact pressure, finest level",
            x_label: "x (m)",
            y_label: "pressure (GPa)",
            x_scale: plot::Scale::Linear,
            y_scale: plot::Scale::Linear,
            legend: plot::SeriesLabelPosition::UpperRight,
        };
        std::fs::create_dir_all("docs/img").expect("docs/img");
        let png = format!("docs/img/{example}-pressure.png");
        let out = Path::new(&png);
        plot::line_chart(
            out,
            &chart,
            &[
                plot::Series::new("nndd (nodal, lumped)", computed),
                plot::Series::line("Hertz p0 sqrt(1 - x^2/a^2)", exact),
            ],
        )
        .expect("plot");
        eprintln!("hertz: wrote {} and {results}/table.txt", out.display());
    }
}
