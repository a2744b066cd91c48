//! Cattaneo and Mindlin's partial slip (examples/hertz/hertz-friction.opts: the Hertz cylinder
//! and its block both steel, the lid pressed 12 mm down and pushed s sideways, Coulomb μ = 0.3):
//! for each mesh level and each target ratio r = Q/(μP), the lid's push s that gives Q/(μP) = r
//! to 1e−3 by a secant iteration on s (2 ranks, NNDD to tol 1e−8), then the contact half-width
//! a, the stick zone's half-width c and centre and the peak shear against the formulas
//! (jobs/cattaneo_formula.rs), the NNDD's iterations against the same problem without friction,
//! the Coulomb fixed points' solves and the contact step's share of the loop. A second table:
//! the iterations with and without friction on examples/hertz (steel on aluminium, levels 1–3)
//! and examples/pin (level 2).
//!
//! Run: `jobs/cattaneo [--levels 1,2,3,4] [--ratios 0.3,0.6,0.9]` → the tables on stdout and in
//! `results/cattaneo/table.txt`, and the shear along Γc of the finest level against the
//! formulas' in `docs/img/cattaneo-shear.png`.

#[path = "cattaneo_formula.rs"]
mod cattaneo_formula;
#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use cattaneo_formula::{cattaneo, measure, Cattaneo};
use runner::num;

const OPTS: &str = "examples/hertz/hertz-friction.opts";
const GEO: &str = "examples/hertz/hertz.geo";
const MU: f64 = 0.3;
const RADIUS: f64 = 1.0;
const E: f64 = 2.1e11;
const NU: f64 = 0.3;
/// The secant stops when |Q/(μP) − r| is below this, or after `MAX_SOLVES` solves.
const RATIO_TOL: f64 = 1e-3;
const MAX_SOLVES: usize = 12;
/// The secant's first two pushes per unit of r (Q/(μP) is nearly linear in s: at level 2,
/// s = 1e−3 gives 0.177 and s = 3e−3 gives 0.521).
const S_PER_RATIO: [f64; 2] = [5.8e-3, 5.0e-3];
/// The friction lines of the options file: left out for the frictionless runs.
const FRICTION_OPTIONS: [&str; 2] = ["-nndd_friction", "-nndd_friction_coefficient"];

/// `[--levels 1,2,3,4] [--ratios 0.3,0.6,0.9]`.
struct Args {
    levels: Vec<usize>,
    ratios: Vec<f64>,
}

fn parse_args() -> Args {
    let mut a = Args {
        levels: vec![1, 2, 3, 4],
        ratios: vec![0.3, 0.6, 0.9],
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    let list = |v: Option<&String>, what: &str| -> Vec<String> {
        let v = v.unwrap_or_else(|| panic!("{what} needs a comma-separated list"));
        v.split(',').map(str::to_string).collect()
    };
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--levels" => {
                a.levels = list(it.next(), "--levels")
                    .iter()
                    .map(|s| s.parse().expect("a level"))
                    .collect()
            }
            "--ratios" => {
                a.ratios = list(it.next(), "--ratios")
                    .iter()
                    .map(|s| s.parse().expect("a ratio in (0, 1)"))
                    .collect()
            }
            other => {
                eprintln!("cattaneo: unknown argument {other}");
                std::process::exit(1);
            }
        }
    }
    a
}

/// A finished run: its summary, output prefix and wall time (mpirun start to end).
struct Solved {
    j: serde_json::Value,
    prefix: PathBuf,
    wall: f64,
}

/// `mpirun -n 2 nndd -options_file OPTS ARGS -nndd_output PREFIX`; ends the job on failure.
fn solve(opts: &str, prefix: PathBuf, args: &[&str]) -> Solved {
    let (j, wall) = runner::try_run(2, opts, &[], &prefix, args)
        .unwrap_or_else(|e| panic!("{}: {e}", prefix.display()));
    assert_eq!(j["converged"], true, "{}: not converged", prefix.display());
    Solved { j, prefix, wall }
}

/// Q/(μP) of a frictional run (Q < 0: body 2 is held back).
fn ratio(j: &serde_json::Value) -> f64 {
    let c = &j["contact"];
    num(c, "tangential_force").abs() / (MU * num(c, "normal_force"))
}

/// The push s with Q/(μP) = r on mesh `msh`, by a secant on s from r·S_PER_RATIO: the final
/// s, its run and the number of solves.
fn secant(msh: &str, dir: &Path, level: usize, r: f64) -> (f64, Solved, usize) {
    let run = |k: usize, s: f64| {
        let prefix = dir.join(format!("level{level}-r{r}-{k}"));
        let push = format!("{s:e}");
        let out = solve(OPTS, prefix, &["-nndd_mesh", msh, "-nndd_bc_lid_ux", &push]);
        eprintln!(
            "cattaneo: level {level}, r = {r}: s = {s:.6e} gives Q/(mu P) = {:.5} ({} iterations, {:.1} s)",
            ratio(&out.j),
            out.j["iterations"],
            out.wall
        );
        out
    };
    let (mut s0, mut s1) = (r * S_PER_RATIO[0], r * S_PER_RATIO[1]);
    let mut f0 = ratio(&run(0, s0).j) - r;
    let mut last = run(1, s1);
    let mut solves = 2;
    loop {
        let f1 = ratio(&last.j) - r;
        if f1.abs() < RATIO_TOL || solves >= MAX_SOLVES || f1 == f0 {
            if f1.abs() >= RATIO_TOL {
                eprintln!("cattaneo: level {level}, r = {r}: the secant stalled at {f1:+.1e}");
            }
            return (s1, last, solves);
        }
        // (past full slip Q/(μP) stays 1: halve the step rather than leave s > 0)
        let next = (s1 - f1 * (s1 - s0) / (f1 - f0)).max(0.5 * s1);
        (s0, f0, s1) = (s1, f1, next);
        last = run(solves, s1);
        solves += 1;
    }
}

/// The NNDD loop of a run: iterations, the Coulomb fixed point's solves summed over the
/// contact steps and their maximum in one step, the contact step's share of the loop's time.
struct Loop {
    iterations: u64,
    coulomb_sum: u64,
    coulomb_max: u64,
    contact_share: f64,
}

fn loop_figures(j: &serde_json::Value) -> Loop {
    let coulomb: Vec<u64> = j["history"]
        .as_array()
        .map(|h| {
            h.iter()
                .map(|s| s["coulomb_iterations"].as_u64().unwrap_or(0))
                .collect()
        })
        .unwrap_or_default();
    let t = |k: &str| num(&j["timings"], k);
    let steps = t("dirichlet_step") + t("contact_step") + t("neumann_step") + t("exchange");
    Loop {
        iterations: j["iterations"].as_u64().unwrap_or(0),
        coulomb_sum: coulomb.iter().sum(),
        coulomb_max: coulomb.iter().copied().max().unwrap_or(0),
        contact_share: t("contact_step") / steps,
    }
}

/// The options of hertz-friction.opts without its two friction lines, as arguments (the file's
/// frictionless problem: `-nndd_friction none` is refused beside a coefficient).
fn frictionless_args() -> Vec<String> {
    let text = std::fs::read_to_string(OPTS).expect("examples/hertz/hertz-friction.opts");
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
        .filter(|l| {
            !FRICTION_OPTIONS
                .iter()
                .any(|o| l.split_whitespace().next() == Some(o))
        })
        .flat_map(|l| l.split_whitespace().map(str::to_string).collect::<Vec<_>>())
        .collect()
}

/// The contact grid of a run: the nodes' x, contact_state and shear.
fn contact_grid(run: &Solved) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let x = runner::read_h5(&run.prefix, "/Mesh/contact/geometry")
        .chunks(2)
        .map(|p| p[0])
        .collect();
    let field = |name: &str| runner::read_field(&run.j, &run.prefix, "contact", name);
    (x, field("contact_state"), field("shear"))
}

/// The computed shear (−shear: body 2 is held back in −x) of a run, sorted by x, and the
/// formulas' contact for its P and Q.
struct Profile {
    ratio: f64,
    shear: Vec<(f64, f64)>,
    formula: Cattaneo,
}

fn table_one_header() -> String {
    String::from(
        "level    dofs     r  solves   s (m)        Q/(muP)   a_h       a         a_err    c_h       c         c_err     peak_h      peak        peak_err  stick_x     iter  iter_0  coul_sum  coul_max  contact_%  solve_s  wall_s\n",
    )
}

/// The Cattaneo table's rows for one level (the secant for each r, the frictionless run at the
/// final s); the profiles of the final runs.
fn level_rows(level: usize, ratios: &[f64], dir: &Path, table: &mut String) -> Vec<Profile> {
    let msh = dir.join(format!("hertz-{level}.msh"));
    runner::gmsh_level(GEO, level, &msh);
    let m = msh.to_str().expect("utf-8 path");
    let plain = frictionless_args();
    let mut profiles = Vec::new();
    for &r in ratios {
        let (s, run, solves) = secant(m, dir, level, r);
        let c = &run.j["contact"];
        let (p, q) = (num(c, "normal_force"), num(c, "tangential_force"));
        let f = cattaneo(p, q.abs(), MU, RADIUS, E, NU);
        let (x, state, shear) = contact_grid(&run);
        let h = measure(&x, &state, &shear);
        let push = format!("{s:e}");
        let mut args: Vec<&str> = plain.iter().map(String::as_str).collect();
        args.extend(["-nndd_mesh", m, "-nndd_bc_lid_ux", &push]);
        let none = solve(
            "/dev/null",
            dir.join(format!("level{level}-r{r}-frictionless")),
            &args,
        );
        let l = loop_figures(&run.j);
        let err = |h: f64, e: f64| 100.0 * (h / e - 1.0);
        let _ = writeln!(
            table,
            "{level:>5} {:>7} {r:>5} {solves:>7}   {s:.5e}  {:.4}    {:.5}   {:.5}   {:+6.2} %  {:.5}   {:.5}   {:+7.2} %  {:.4e}  {:.4e}  {:+6.2} %  {:+.2e}  {:>5} {:>7} {:>9} {:>9}  {:8.1}  {:7.2}  {:6.1}",
            run.j["dofs"].as_u64().unwrap_or(0),
            ratio(&run.j),
            h.a,
            f.a,
            err(h.a, f.a),
            h.c,
            f.c,
            err(h.c, f.c),
            h.peak_shear,
            f.peak_shear,
            err(h.peak_shear, f.peak_shear),
            h.stick_centre,
            l.iterations,
            loop_figures(&none.j).iterations,
            l.coulomb_sum,
            l.coulomb_max,
            100.0 * l.contact_share,
            runner::solve_seconds(&run.j),
            run.wall,
        );
        let mut sorted: Vec<(f64, f64)> = x.iter().zip(&shear).map(|(&x, &t)| (x, -t)).collect();
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
        profiles.push(Profile {
            ratio: ratio(&run.j),
            shear: sorted,
            formula: f,
        });
    }
    profiles
}

/// The iterations with and without friction on examples/hertz (levels 1–3, pushed 3 mm) and
/// examples/pin (level 2, pushed 0.5 mm), Coulomb μ = 0.3.
fn iteration_table(dir: &Path) -> String {
    let mut table = String::from(
        "case    level    dofs  iter_0  iter_mu  ratio   coul_sum  coul_max  contact_%_0  contact_%_mu  Q/(muP)\n",
    );
    let cases = [
        ("hertz", 1, "3e-3"),
        ("hertz", 2, "3e-3"),
        ("hertz", 3, "3e-3"),
        ("pin", 2, "5e-4"),
    ];
    for (name, level, push) in cases {
        let (geo, opts) = (
            format!("examples/{name}/{name}.geo"),
            format!("examples/{name}/{name}.opts"),
        );
        let msh = dir.join(format!("{name}-{level}.msh"));
        runner::gmsh_level(&geo, level, &msh);
        let m = msh.to_str().expect("utf-8 path");
        eprintln!("cattaneo: {name} level {level}, with and without friction …");
        let none = solve(
            &opts,
            dir.join(format!("{name}{level}-frictionless")),
            &["-nndd_mesh", m],
        );
        let coulomb = solve(
            &opts,
            dir.join(format!("{name}{level}-coulomb")),
            &[
                "-nndd_mesh",
                m,
                "-nndd_bc_lid_ux",
                push,
                "-nndd_friction",
                "coulomb",
                "-nndd_friction_coefficient",
                "0.3",
            ],
        );
        let (l0, l) = (loop_figures(&none.j), loop_figures(&coulomb.j));
        let _ = writeln!(
            table,
            "{name:<6} {level:>6} {:>7} {:>7} {:>8}  {:5.2} {:>10} {:>9}  {:11.1}  {:12.1}  {:.4}",
            coulomb.j["dofs"].as_u64().unwrap_or(0),
            l0.iterations,
            l.iterations,
            l.iterations as f64 / l0.iterations as f64,
            l.coulomb_sum,
            l.coulomb_max,
            100.0 * l0.contact_share,
            100.0 * l.contact_share,
            ratio(&coulomb.j),
        );
    }
    table.push_str("(2 ranks, NNDD to tol 1e-8; iter_0: without friction (the lid not pushed sideways), iter_mu: Coulomb mu = 0.3 with the lid pushed ux = 3e-3 (hertz) or 5e-4 (pin); ratio = iter_mu/iter_0; coul_sum, coul_max: the Coulomb fixed point's solves over all contact steps and the most in one; contact_%: the contact step's share of the loop's time (dirichlet + contact + neumann steps + exchange); Q/(muP) of the frictional run)\n");
    table
}

/// The effectivity of η^glo against e_ref (r = 2, 4) with friction: the Cattaneo setup
/// (Coulomb, the lid pushed 3.5 mm: Q/(μP) ≈ 0.6) and the Hertz cylinder of
/// examples/hertz/hertz.opts with Tresca g = 300 MPa, levels 1–2.
fn effectivity_table(dir: &Path) -> String {
    let mut table = String::from(
        "case      level    dofs   r   iter   eta_glo      eta_FE       eta_NNDD     e_ref        effectivity  split   estim_s\n",
    );
    let coulomb: [&str; 2] = ["-nndd_bc_lid_ux", "3.5e-3"];
    let tresca: [&str; 6] = [
        "-nndd_bc_lid_ux",
        "3e-3",
        "-nndd_friction",
        "tresca",
        "-nndd_friction_threshold",
        "3e8",
    ];
    let cases: [(&str, &str, &[&str]); 2] = [
        ("coulomb", OPTS, &coulomb),
        ("tresca", "examples/hertz/hertz.opts", &tresca),
    ];
    for (name, opts, extra) in cases {
        for level in [1, 2] {
            let msh = dir.join(format!("hertz-{level}.msh"));
            runner::gmsh_level(GEO, level, &msh);
            let m = msh.to_str().expect("utf-8 path");
            for r in ["2", "4"] {
                eprintln!("cattaneo: estimates, {name} level {level}, r = {r} …");
                let mut args = vec![
                    "-nndd_mesh",
                    m,
                    "-nndd_estimate",
                    "-nndd_reference_factor",
                    r,
                ];
                args.extend_from_slice(extra);
                let run = solve(opts, dir.join(format!("eff-{name}{level}-r{r}")), &args);
                let e = run.j["estimates"]
                    .as_array()
                    .and_then(|a| a.last())
                    .cloned()
                    .unwrap_or_default();
                let (glo, fe, nndd) = (num(&e, "eta_glo"), num(&e, "eta_fe"), num(&e, "eta_nndd"));
                let _ = writeln!(
                    table,
                    "{name:<8} {level:>6} {:>7}  {r:>2} {:>6}   {glo:.5e}  {fe:.5e}  {nndd:.3e}    {:.5e}  {:.4}       {:.4}  {:.2}",
                    run.j["dofs"].as_u64().unwrap_or(0),
                    run.j["iterations"].as_u64().unwrap_or(0),
                    num(&e, "e_ref"),
                    num(&e, "effectivity"),
                    (fe * fe + nndd * nndd) / (glo * glo),
                    num(&run.j["timings"], "estimation"),
                );
            }
        }
    }
    table.push_str("(2 ranks, NNDD to tol 1e-8, the estimates of the final iterate; e_ref against the NNDD on the mesh refined r times; split = (eta_FE^2 + eta_NNDD^2)/eta_glo^2; Coulomb: the Tresca CRE with g = mu |t_n| of the admissible traction, docs/method.md section 9)\n");
    table
}

/// The formulas' shear μp₀(√(1 − x²/a²) − (c/a)√(1 − x²/c²)) for |x| < c, μp₀√(1 − x²/a²)
/// for c ≤ |x| ≤ a, 0 beyond.
fn formula_shear(f: &Cattaneo, x: f64) -> f64 {
    let root = |x: f64, a: f64| (1.0 - (x / a).powi(2)).max(0.0).sqrt();
    let slip = MU * f.p0 * root(x, f.a);
    if x.abs() < f.c {
        slip - MU * f.p0 * (f.c / f.a) * root(x, f.c)
    } else {
        slip
    }
}

/// `docs/img/cattaneo-shear.png`: −shear at the finest level's Γc nodes (points) against the
/// formulas' (lines), one colour per ratio, on |x| ≤ 1.6 a (the legend over the open nodes).
fn plot_shear(level: usize, profiles: &[Profile]) {
    let half = 1.6 * profiles.iter().map(|p| p.formula.a).fold(0.0, f64::max);
    let mut series = Vec::new();
    for (k, p) in profiles.iter().enumerate() {
        let nodes: Vec<(f64, f64)> = p
            .shear
            .iter()
            .copied()
            .filter(|q| q.0.abs() <= half)
            .collect();
        let (x0, x1) = (nodes[0].0, nodes[nodes.len() - 1].0);
        let line: Vec<(f64, f64)> = (0..=800)
            .map(|i| x0 + (x1 - x0) * i as f64 / 800.0)
            .map(|x| (x, formula_shear(&p.formula, x)))
            .collect();
        let r = p.ratio;
        series.push(plot::Series::points(&format!("nndd, r = {r:.3}"), nodes).coloured(k));
        series.push(plot::Series::line(&format!("formula, r = {r:.3}"), line).coloured(k));
    }
    let title = format!("Cattaneo-Mindlin, level {level}: shear, r = Q/(muP)");
    let chart = plot::Chart {
        title: &title,
        x_label: "x (m)",
        y_label: "-shear (Pa)",
        x_scale: plot::Scale::Linear,
        y_scale: plot::Scale::Linear,
        legend: plot::SeriesLabelPosition::UpperRight,
    };
    std::fs::create_dir_all("docs/img").expect("docs/img");
    let out = Path::new("docs/img/cattaneo-shear.png");
    plot::line_chart(out, &chart, &series).expect("plot");
    eprintln!("cattaneo: wrote {}", out.display());
}

fn main() {
    let Args { levels, ratios } = parse_args();
    plot::register_font();
    let start = std::time::Instant::now();
    let dir = Path::new("results/cattaneo");
    std::fs::create_dir_all(dir).expect("results dir");
    let mut table = table_one_header();
    let mut finest = None;
    for &level in &levels {
        finest = Some((level, level_rows(level, &ratios, dir, &mut table)));
    }
    table.push_str("(2 ranks, NNDD to tol 1e-8; examples/hertz/hertz-friction.opts, both bodies steel, Coulomb mu = 0.3, R = 1; r: the target Q/(muP), reached to 1e-3 by a secant on the lid's push s (solves: the runs it took); a_h, c_h: half the extent of the contact and the stick set, each end half-way to the next node; peak_h: the largest |shear| at a node; a, c, peak: Cattaneo-Mindlin for the run's P and Q; stick_x: the stick zone's centre (m; the finite bodies, not half-spaces, shift it: the peak sits at the stick zone's edge nearer the centre, where mu p exceeds mu p(c): most of peak_err at r = 0.3); iter_0: the same problem without friction; coul_sum, coul_max: the Coulomb fixed point's solves over all contact steps and the most in one; contact_%: the contact step's share of the loop's time (dirichlet + contact + neumann steps + exchange); solve_s, wall_s: the final run's)\n\n");
    table.push_str(&iteration_table(dir));
    table.push('\n');
    table.push_str(&effectivity_table(dir));
    let _ = writeln!(table, "(job: {:.0} s)", start.elapsed().as_secs_f64());
    print!("{table}");
    std::fs::write(dir.join("table.txt"), &table).expect("table");
    if let Some((level, profiles)) = finest {
        plot_shear(level, &profiles);
    }
    eprintln!("cattaneo: wrote results/cattaneo/table.txt");
}
