//! The contact discretisations on curves meshed on their own: node to node (the curves made
//! to match) against mortar (`-nndd_contact_discretisation mortar`, the curves as meshed).
//! Hertz (examples/hertz-nonmatching) with the cylinder 1.5, 4 and 10 times coarser than the
//! block at the contact and the other way round, and the pin in its hole meshed 2:3
//! (examples/pin-hole, ratio 1.5), levels 1–3, 2 ranks, θ auto, tol 1e−8, each with the
//! monolithic solve of the same discretisation.
//!
//! Mortar runs twice: its initial gap measured to the smooth curves through the nodes (the
//! default) and between the polygons as meshed (`-nndd_mortar_gap polygons`).
//!
//! Run: `jobs/mortar [--levels 1,2,3]` → a table on stdout and in `results/mortar/table.txt`,
//! and the pressure along Γc of Hertz at ratio 10 (level 3, every discretisation) and of the
//! pin (level 3, mortar's two gaps) in `docs/img/mortar-hertz-10.png` and
//! `docs/img/mortar-pin-hole.png`.

#[path = "hertz_fit.rs"]
mod hertz_fit;
#[path = "plot.rs"]
mod plot;
#[path = "runner.rs"]
mod runner;

use std::path::Path;

const HERTZ_MATERIALS: [(f64, f64); 2] = [(7e10, 0.33), (2.1e11, 0.3)];
/// The discretisations compared: a label (also the runs' file names) and its options; mortar
/// with its gap measured to the smooth curves through the nodes (the default) and between the
/// polygons as meshed (`-nndd_mortar_gap polygons`).
const DISCRETISATIONS: [(&str, [&str; 4]); 3] = [
    (
        "node_to_node",
        [
            "-nndd_contact_discretisation",
            "node_to_node",
            "-nndd_mortar_gap",
            "curves",
        ],
    ),
    (
        "mortar-polygons",
        [
            "-nndd_contact_discretisation",
            "mortar",
            "-nndd_mortar_gap",
            "polygons",
        ],
    ),
    (
        "mortar",
        [
            "-nndd_contact_discretisation",
            "mortar",
            "-nndd_mortar_gap",
            "curves",
        ],
    ),
];

/// A case: its name, example folder and the Gmsh `ratio` of its meshes.
struct Case {
    name: &'static str,
    example: &'static str,
    ratio: &'static str,
}

const CASES: &[Case] = &[
    Case {
        name: "hertz 1.5",
        example: "hertz-nonmatching",
        ratio: "1.5",
    },
    Case {
        name: "hertz 4",
        example: "hertz-nonmatching",
        ratio: "4",
    },
    Case {
        name: "hertz 10",
        example: "hertz-nonmatching",
        ratio: "10",
    },
    Case {
        name: "hertz 1/1.5",
        example: "hertz-nonmatching",
        ratio: "0.6667",
    },
    Case {
        name: "hertz 1/4",
        example: "hertz-nonmatching",
        ratio: "0.25",
    },
    Case {
        name: "hertz 1/10",
        example: "hertz-nonmatching",
        ratio: "0.1",
    },
    Case {
        name: "pin 2:3",
        example: "pin-hole",
        ratio: "1.5",
    },
];

/// Γc's pairs ordered by arc length from one end: (s, x, pressure, force, active).
struct Profile {
    s: Vec<f64>,
    x: Vec<f64>,
    pressure: Vec<f64>,
    force: Vec<f64>,
    active: Vec<bool>,
}

fn profile(j: &serde_json::Value, prefix: &Path) -> Profile {
    let pts: Vec<[f64; 2]> = runner::read_h5(prefix, "/Mesh/contact/geometry")
        .chunks(2)
        .map(|p| [p[0], p[1]])
        .collect();
    let mut s = vec![0.0; pts.len()];
    for k in 1..pts.len() {
        s[k] = s[k - 1] + (pts[k][0] - pts[k - 1][0]).hypot(pts[k][1] - pts[k - 1][1]);
    }
    let mut p = Profile {
        s,
        x: pts.iter().map(|p| p[0]).collect(),
        pressure: runner::read_field(j, prefix, "contact", "pressure"),
        force: runner::read_field(j, prefix, "contact", "normal_force"),
        active: runner::read_field(j, prefix, "contact", "active")
            .iter()
            .map(|&a| a > 0.5)
            .collect(),
    };
    // By increasing x (the pairs of a body-2 pair side run the other way).
    if p.x.len() > 1 && p.x[0] > p.x[p.x.len() - 1] {
        let total = p.s[p.s.len() - 1];
        for v in [&mut p.x, &mut p.pressure, &mut p.force] {
            v.reverse();
        }
        p.s = p.s.iter().rev().map(|s| total - s).collect();
        p.active.reverse();
    }
    p
}

/// The node-to-node oscillation of the pressure: the largest |e_k − (e_{k−1} + e_{k+1})/2| over
/// the pairs between the first and the last in contact (open pairs there included), relative
/// to the peak, with e = p_h − p the error against the exact profile `exact` where there is
/// one (a smooth error has none), else e = p_h.
fn oscillation(p: &Profile, exact: Option<&dyn Fn(f64) -> f64>) -> f64 {
    let peak = p.pressure.iter().fold(0.0_f64, |m, &v| m.max(v));
    let e: Vec<f64> = (0..p.x.len())
        .map(|k| p.pressure[k] - exact.map_or(0.0, |f| f(p.x[k])))
        .collect();
    let (Some(first), Some(last)) = (
        p.active.iter().position(|&a| a),
        p.active.iter().rposition(|&a| a),
    ) else {
        return 0.0;
    };
    let mut worst: f64 = 0.0;
    for k in first + 1..last {
        worst = worst.max((e[k] - 0.5 * (e[k - 1] + e[k + 1])).abs());
    }
    worst / peak
}

/// Open pairs between the first and the last pair in contact.
fn open_inside(p: &Profile) -> usize {
    let first = p.active.iter().position(|&a| a);
    let last = p.active.iter().rposition(|&a| a);
    match (first, last) {
        (Some(a), Some(b)) => p.active[a..=b].iter().filter(|&&x| !x).count(),
        _ => 0,
    }
}

fn chart(title: &'static str, png: &str, series: Vec<plot::Series>) {
    let chart = plot::Chart {
        title,
        x_label: "x (m)",
        y_label: "pressure (MPa)",
        x_scale: plot::Scale::Linear,
        y_scale: plot::Scale::Linear,
        legend: plot::SeriesLabelPosition::UpperRight,
    };
    std::fs::create_dir_all("docs/img").expect("docs/img");
    plot::line_chart(Path::new(png), &chart, &series).expect("plot");
    eprintln!("mortar: wrote {png}");
}

fn main() {
    let mut levels = vec![1, 2, 3];
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.as_slice() {
        [] => {}
        [flag, list] if flag == "--levels" => {
            levels = list
                .split(',')
                .map(|l| l.parse().expect("a level"))
                .collect();
        }
        _ => panic!("mortar: usage: jobs/mortar [--levels 1,2,3]"),
    }
    let dir = Path::new("results/mortar");
    std::fs::create_dir_all(dir).expect("results/mortar");
    let mut table = String::from(
        "case          level  discretisation    dofs  pairs  iter   p0_h        p0_err   oscill   open  L2_err   mono_dE   input_s  couple_s  solve_s\n",
    );
    print!("{table}");
    let mut plots: Vec<(&str, Vec<plot::Series>)> = Vec::new();
    for case in CASES {
        for &level in &levels {
            let tag = format!("{}-{}-{level}", case.example, case.ratio);
            let msh = dir.join(format!("{tag}.msh"));
            let geo = format!("examples/{0}/{0}.geo", case.example);
            let st = std::process::Command::new("gmsh")
                .args(["-2", "-format", "msh41", "-v", "1"])
                .args(["-setnumber", "level", &level.to_string()])
                .args(["-setnumber", "ratio", case.ratio])
                .arg(&geo)
                .arg("-o")
                .arg(&msh)
                .status()
                .expect("gmsh runs (jobs/setup installs it)");
            assert!(st.success(), "gmsh failed on {geo}");
            let opts = format!("examples/{0}/{0}.opts", case.example);
            let m = msh.to_str().expect("utf-8");
            let mut series = Vec::new();
            for (disc, options) in DISCRETISATIONS {
                eprintln!("mortar: {} level {level}, {disc} …", case.name);
                let prefix = dir.join(format!("{tag}-{disc}"));
                let mut base = vec!["-nndd_mesh", m];
                base.extend(options);
                let (j, _) = runner::try_run(2, &opts, &[], &prefix, &base)
                    .unwrap_or_else(|e| panic!("{} level {level} {disc}: {e}", case.name));
                let mono_prefix = dir.join(format!("{tag}-{disc}-mono"));
                let mut mono_args = base.clone();
                mono_args.extend(["-nndd_solver", "monolithic"]);
                let (mono, _) = runner::try_run(2, &opts, &[], &mono_prefix, &mono_args)
                    .unwrap_or_else(|e| {
                        panic!("{} level {level} {disc} monolithic: {e}", case.name)
                    });
                let p = profile(&j, &prefix);
                let (p0_err, l2, osc) = if case.example == "hertz-nonmatching" {
                    let h = hertz_fit::fit(
                        &p.x,
                        &p.force,
                        &p.pressure,
                        &p.active,
                        1.0,
                        HERTZ_MATERIALS,
                    );
                    (
                        format!("{:6.2} %", 100.0 * h.p0_err()),
                        format!("{:6.4}", h.l2),
                        oscillation(&p, Some(&|x| h.pressure(x))),
                    )
                } else {
                    (
                        "     –  ".to_string(),
                        "  –   ".to_string(),
                        oscillation(&p, None),
                    )
                };
                let e = runner::num(&j, "potential_energy");
                let em = runner::num(&mono, "potential_energy");
                let p0_h = p.pressure.iter().fold(0.0_f64, |m, &v| m.max(v));
                let row = format!(
                    "{:<13} {level:>5}  {disc:<15} {:>6} {:>6} {:>5}   {p0_h:.4e}  {p0_err}  {:6.2} %  {:>4}  {l2}   {:.1e}   {:7.3}  {:>8}  {:7.3}\n",
                    case.name,
                    j["dofs"].as_u64().unwrap_or(0),
                    j["contact_curves"]["pairs"].as_u64().unwrap_or(0),
                    j["iterations"].as_u64().unwrap_or(0),
                    100.0 * osc,
                    open_inside(&p),
                    (e - em).abs() / em.abs(),
                    runner::num(&j["timings"], "input"),
                    j["contact_curves"]["coupling_seconds"]
                        .as_f64()
                        .map_or("–".to_string(), |s| format!("{s:.3}")),
                    runner::solve_seconds(&j),
                );
                print!("{row}");
                table.push_str(&row);
                let points: Vec<(f64, f64)> =
                    p.x.iter()
                        .zip(&p.pressure)
                        .map(|(&x, &v)| (x, v / 1e6))
                        .collect();
                // (the pin's node-to-node pressures, 0 to twice the peak from pair to pair,
                // would hide the mortar gaps' difference)
                if !(case.example == "pin-hole" && disc == "node_to_node") {
                    series.push(plot::Series::new(disc, points));
                }
            }
            if level == *levels.last().expect("a level") {
                match case.name {
                    "hertz 10" => plots.push(("docs/img/mortar-hertz-10.png", series)),
                    "pin 2:3" => plots.push(("docs/img/mortar-pin-hole.png", series)),
                    _ => {}
                }
            }
        }
    }
    table.push_str("(2 ranks, theta auto, tol 1e-8; hertz R: the cylinder's contact curve R times coarser than the block's, 1/R the block's; pin 2:3: the pin's curve 1.5 times finer than the hole's; mortar: the gap from each non-mortar node to the smooth curve through the mortar side's nodes (-nndd_mortar_gap curves, the default), mortar-polygons: the dual-weighted distance between the polygons as meshed (-nndd_mortar_gap polygons); pairs: Γc's pairs (node to node: every node of either curve, nodes inserted; mortar: the coarser curve's nodes); p0_h: the largest nodal pressure (force / its share of Γc); p0_err: against Hertz's p0 for the computed force; oscill: the largest |e_k - (e_k-1 + e_k+1)/2| between the first and last pair in contact over p0_h, e the pressure's error against Hertz's profile (hertz) or the pressure itself (pin: the profile's own curvature included); open: open pairs between the first and last pair in contact; L2_err: ||p_h - p|| / ||p|| on the pairs; mono_dE: relative energy difference NNDD - monolithic solve of the same discretisation; input_s: options, mesh, matching or mortar operators; couple_s: the mortar operators and coupling alone (contact_curves.coupling_seconds); solve_s: assembly, factorisation, NNDD)\n");
    std::fs::write(dir.join("table.txt"), &table).expect("table");
    println!("{}", table.lines().last().unwrap_or(""));
    for (png, series) in plots {
        let title = if png.contains("hertz") {
            "Hertz, cylinder 10 times coarser: pressure along the contact"
        } else {
            "Pin in its hole meshed 2:3, mortar: pressure along the contact"
        };
        chart(title, png, series);
    }
}
