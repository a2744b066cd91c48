//! Capability: meshes adapted to the estimates until the bound meets the user's tolerance
//! (`-nndd_adapt_tol ε`, docs/method.md §8).
//! - The sizes shrink where the error sits and grow elsewhere, and Gmsh's new mesh follows
//!   them: on Hertz (examples/hertz-nonmatching) with an error at the contact and a target that
//!   keeps the element count, the elements there shrink, the far field coarsens, and the
//!   element count is near the prediction.
//! - The new mesh keeps the physical names (so the options' conditions still apply) and its
//!   curves on the geometry: every node of the cylinder's arc on the circle to 1e−9 of R.
//! - The loop on `paper` from its coarse mesh (examples/paper/paper.geo, n = 8) to ε = 4 %:
//!   η^glo falls every cycle and ends below ε ‖u_h‖_E, above e_ref at every cycle, with the
//!   same meshes and numbers on 1, 2 and 3 ranks; ParaView's time series of the cycles and the
//!   last cycle alone; the run that cannot reach ε in its cycles ends with exit 3, as does
//!   one whose next meshes would not fit in the memory it may use (`-nndd_memory_limit`).
//! - Curved contact curves remeshed from one view (the pin in its groove, examples/pin): their
//!   nodes come close to each other, and making them match moves them onto their partners
//!   instead of inserting slivers beside them; the second cycle solves and η^glo falls.
//! - Bad input: one line naming the option; gmsh failing at a remesh ends every rank with one
//!   line, exit 2, the run's own files not written.

mod common;
use common::HERTZ_NM_GEO as HERTZ_GEO;
use common::{f, mpirun, paper_mesh_args, refused, scratch, solve, PAPER_GEO};

use std::path::Path;

use nndd::estimate::size_field::{nodal_sizes, size_field, triangle_size, Limits, Strategy};
use nndd::fem::geo;

/// The mean size of the triangles whose centroids lie within `radius` of `at` (or beyond it,
/// `inside` false).
fn mean_size(m: &nndd::fem::gmsh::GmshMesh, at: [f64; 2], radius: f64, inside: bool) -> f64 {
    let sizes: Vec<f64> = m
        .triangles
        .iter()
        .map(|t| t.0.map(|v| m.points[v]))
        .filter(|p| {
            let c = [
                (p[0][0] + p[1][0] + p[2][0]) / 3.0,
                (p[0][1] + p[1][1] + p[2][1]) / 3.0,
            ];
            ((c[0] - at[0]).hypot(c[1] - at[1]) < radius) == inside
        })
        .map(triangle_size)
        .collect();
    sizes.iter().sum::<f64>() / sizes.len() as f64
}

#[test]
fn a_body_meshed_again_from_the_sizes_of_its_errors() {
    let dir = std::env::temp_dir().join(format!("nndd-test-adapt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let params = vec![("level".to_string(), 1.0), ("ratio".to_string(), 1.5)];
    let first = geo::mesh(Path::new(HERTZ_GEO), &params).expect("gmsh meshes the example");
    let triangles: Vec<[usize; 3]> = first.triangles.iter().map(|t| t.0).collect();
    let sizes: Vec<f64> = triangles
        .iter()
        .map(|t| triangle_size(t.map(|v| first.points[v])))
        .collect();
    // An error that sits at the contact (the origin): e_E² = h_E⁴ / (r_E + 0.02)⁶, steeper
    // than the example's grading (h ∝ r) equidistributes; the target Σ e_E / √N keeps the
    // element count (the sizes only move).
    let squares: Vec<f64> = triangles
        .iter()
        .zip(&sizes)
        .map(|(t, h)| {
            let c = t.map(|v| first.points[v]);
            let r =
                ((c[0][0] + c[1][0] + c[2][0]) / 3.0).hypot((c[0][1] + c[1][1] + c[2][1]) / 3.0);
            h.powi(4) / (r + 0.02).powi(6)
        })
        .collect();
    let target = squares.iter().map(|e| e.sqrt()).sum::<f64>() / (squares.len() as f64).sqrt();
    let field = size_field(
        &squares,
        &sizes,
        target,
        Strategy::Optimal { order: 1.0 },
        Limits::default(),
    );
    let view = dir.join("size.pos");
    let nodal = nodal_sizes(first.points.len(), &triangles, &field.sizes);
    geo::write_background(&view, &first.points, &triangles, &nodal).unwrap();
    let second = geo::remesh(Path::new(HERTZ_GEO), &params, &view).expect("gmsh meshes it again");
    let (near, far) = (
        [
            mean_size(&first, [0.0, 0.0], 0.1, true),
            mean_size(&second, [0.0, 0.0], 0.1, true),
        ],
        [
            mean_size(&first, [0.0, 0.0], 1.5, false),
            mean_size(&second, [0.0, 0.0], 1.5, false),
        ],
    );
    println!(
        "{} -> {} triangles (predicted {:.0}); mean size within 0.1 of the contact {:.4} -> {:.4}, beyond 1.5 {:.4} -> {:.4}",
        first.triangles.len(),
        second.triangles.len(),
        field.elements,
        near[0],
        near[1],
        far[0],
        far[1]
    );
    assert!(near[1] < 0.8 * near[0], "near the contact {near:?}");
    assert!(far[1] > 1.25 * far[0], "far from it {far:?}");
    let count = second.triangles.len() as f64;
    assert!(
        (0.5 * field.elements..2.0 * field.elements).contains(&count),
        "{count} triangles against {} predicted",
        field.elements
    );
    // The names carry over; the cylinder's arc stays on its circle (centre (0, 1), R = 1).
    assert_eq!(first.names, second.names);
    let arc = second.curve_edges("cylinder_arc").expect("the arc");
    let worst = arc
        .iter()
        .flatten()
        .map(|&v| (second.points[v][0].hypot(second.points[v][1] - 1.0) - 1.0).abs())
        .fold(0.0_f64, f64::max);
    println!(
        "{} arc edges, the largest distance of a node to the circle {worst:.1e} R",
        arc.len()
    );
    assert!(arc.len() > 20 && worst < 1e-9, "{worst:e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// examples/paper/paper.opts on paper.geo with n = 8 (256 triangles), and `extra`.
fn paper_adaptive(extra: &[&str]) -> Vec<String> {
    let mut a = paper_mesh_args(Path::new(PAPER_GEO), "contact1,contact2", "-1e-4");
    a.extend(["-nndd_geo_set", "n=8"].map(String::from));
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

fn strs(a: &[String]) -> Vec<&str> {
    a.iter().map(String::as_str).collect()
}

#[test]
fn paper_adapts_until_the_bound_meets_the_tolerance() {
    let dir = scratch("adapt-paper");
    let tol = 0.04;
    let args = paper_adaptive(&["-nndd_adapt_tol", "0.04", "-nndd_reference_factor", "2"]);
    let mut runs = Vec::new();
    for np in [1, 2, 3] {
        let prefix = dir.join(format!("np{np}"));
        let j = solve(np, &prefix, &strs(&args));
        let cycles = j["cycles"].as_array().expect("the cycles").clone();
        for c in &cycles {
            println!(
                "{np} rank(s): cycle {}: {} dofs, {} iterations, eta_glo {:.6e} = {:.3} % of ||u_h||_E, e_ref {:.6e}, effectivity {:.4}, remeshing {:.1} % of {:.3} s",
                c["cycle"],
                c["dofs"],
                c["iterations"],
                f(c, "eta_glo"),
                100.0 * f(c, "relative_error"),
                f(c, "e_ref"),
                f(c, "effectivity"),
                100.0 * f(c, "remesh_share"),
                f(c, "seconds")
            );
        }
        assert!((2..=3).contains(&cycles.len()), "{} cycles", cycles.len());
        assert_eq!(j["adapt"]["verdict"], "reached");
        for w in cycles.windows(2) {
            assert!(f(&w[1], "eta_glo") < f(&w[0], "eta_glo"), "eta_glo rose");
            assert!(f(&w[1], "dofs") > f(&w[0], "dofs"));
        }
        for c in &cycles {
            let rel = f(c, "eta_glo") / f(c, "energy_norm");
            assert!((rel - f(c, "relative_error")).abs() < 1e-12 * rel);
            // The bound holds against the reference solution at every cycle.
            assert!(f(c, "eta_glo") >= f(c, "e_ref"), "{c}");
        }
        let last = cycles.last().unwrap();
        assert!(f(last, "relative_error") <= tol);
        assert!(cycles[..cycles.len() - 1]
            .iter()
            .all(|c| f(c, "relative_error") > tol));
        // The run's summary is the last cycle's: its dofs and estimates.
        assert_eq!(j["dofs"], last["dofs"]);
        // ParaView's files: the cycles as a time series (one grid per cycle, its own mesh and
        // data file), the last cycle alone.
        let series = std::fs::read_to_string(format!("{}.xdmf", prefix.display())).unwrap();
        assert!(series.contains("CollectionType=\"Temporal\""));
        for k in 1..=cycles.len() {
            assert!(
                series.contains(&format!("<Time Value=\"{k}\"/>")),
                "{series}"
            );
            assert!(series.contains(&format!("np{np}-cycle{k}.h5:/Mesh/bodies/geometry")));
        }
        let last_alone =
            std::fs::read_to_string(format!("{}-final.xdmf", prefix.display())).unwrap();
        let k = cycles.len();
        assert!(
            last_alone.contains(&format!("np{np}-cycle{k}.h5:"))
                && !last_alone.contains("Temporal")
        );
        // The last cycle's η^FE map, read back, is its η^FE.
        let cycle_prefix = dir.join(format!("np{np}-cycle{k}"));
        let map = common::field(&cycle_prefix, "bodies", "eta_fe");
        let sum: f64 = map.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(
            (sum - f(last, "eta_fe")).abs() < 1e-8 * sum,
            "{sum} against {}",
            f(last, "eta_fe")
        );
        runs.push(cycles);
    }
    // The same meshes and numbers on every rank count.
    for other in &runs[1..] {
        assert_eq!(other.len(), runs[0].len());
        for (a, b) in runs[0].iter().zip(other) {
            assert_eq!(a["dofs"], b["dofs"]);
            assert_eq!(a["elements"], b["elements"]);
            for key in ["eta_glo", "eta_fe", "energy_norm"] {
                let (x, y) = (f(a, key), f(b, key));
                assert!((x - y).abs() < 1e-8 * x, "{key}: {x} against {y}");
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_tolerance_not_reached_in_the_cycles_ends_with_exit_3() {
    let dir = scratch("adapt-unreached");
    let prefix = dir.join("run");
    let mut args = paper_adaptive(&["-nndd_adapt_tol", "0.01", "-nndd_adapt_max_cycles", "2"]);
    args.extend(["-nndd_output".to_string(), prefix.display().to_string()]);
    let out = mpirun(2, &strs(&args));
    // (the cycles' lines are the monitor's, on stderr)
    let stdout =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stdout}");
    let line = stdout
        .lines()
        .find(|l| l.contains("-nndd_adapt_tol 0.01 (1 %) not reached in 2 cycle(s)"))
        .unwrap_or_else(|| panic!("no closing line in\n{stdout}"));
    println!("{line}");
    let j = common::json(&prefix);
    assert_eq!(j["adapt"]["verdict"], "max_cycles");
    let cycles = j["cycles"].as_array().unwrap();
    assert_eq!(cycles.len(), 2);
    assert!(f(&cycles[1], "relative_error") > 0.01);
    assert!(j["adapt"]["memory"].is_null());
    next_meshes_that_would_not_fit_end_the_cycles(&dir, &args, cycles);
    std::fs::remove_dir_all(&dir).ok();
}

/// The same run held by `-nndd_memory_limit` to between the size check's model of its first
/// and second cycles (`app::capacity::estimate`, from the `cycles` of the run without it):
/// the second meshes are refused after the first cycle, whose numbers stand, the closing line
/// saying why, exit 3; under `-nndd_memory_check warn` the second cycle runs with the model's
/// line first in its warnings.
fn next_meshes_that_would_not_fit_end_the_cycles(
    dir: &Path,
    args: &[String],
    unlimited: &[serde_json::Value],
) {
    let dofs = |c: &serde_json::Value| c["dofs"].as_u64().unwrap() as usize;
    let model = |c| nndd::app::capacity::estimate(2, dofs(c), None) / (1024.0 * 1024.0);
    let (first, second) = (model(&unlimited[0]), model(&unlimited[1]));
    assert!(second > first + 0.5, "{first} and {second} MiB");
    let limit = format!("{:.3}", 0.5 * (first + second));
    for check in ["refuse", "warn"] {
        let prefix = dir.join(format!("limited-{check}"));
        let mut a = args.to_vec();
        a.extend(["-nndd_output", &prefix.display().to_string()].map(String::from));
        a.extend(["-nndd_memory_limit", &limit, "-nndd_memory_check", check].map(String::from));
        let out = mpirun(2, &strs(&a));
        let text = String::from_utf8_lossy(&out.stdout).to_string()
            + &String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{text}");
        let j = common::json(&prefix);
        let cycles = j["cycles"].as_array().unwrap();
        let (x, y) = (f(&cycles[0], "eta_glo"), f(&unlimited[0], "eta_glo"));
        assert!((x - y).abs() < 1e-12 * y, "{x} against {y}");
        let needs = format!(
            "-nndd_adapt_tol 0.01: cycle 2's meshes ({} dofs) need about",
            dofs(&unlimited[1])
        );
        if check == "refuse" {
            let line = text
                .lines()
                .find(|l| {
                    l.contains("(1 %) not reached (the next meshes would not fit) in 1 cycle(s)")
                })
                .unwrap_or_else(|| panic!("no closing line in\n{text}"));
            println!("{line}");
            assert!(
                line.contains(&needs)
                    && line.contains("-nndd_memory_limit (")
                    && line.ends_with("(or -nndd_memory_check warn)"),
                "{line}"
            );
            assert_eq!(j["adapt"]["verdict"], "memory_limit");
            assert_eq!(cycles.len(), 1);
            assert!(j["adapt"]["memory"].as_str().unwrap().contains(&needs));
        } else {
            assert_eq!(j["adapt"]["verdict"], "max_cycles");
            assert_eq!(cycles.len(), 2);
            assert_eq!(dofs(&cycles[1]), dofs(&unlimited[1]));
            let first_warning = j["warnings"][0].as_str().unwrap_or_default();
            assert!(
                first_warning.contains(&needs)
                    && first_warning.ends_with("(-nndd_memory_check warn)"),
                "{}",
                j["warnings"]
            );
            assert_eq!(text.matches(&needs).count(), 1, "{text}");
        }
    }
}

#[test]
fn bad_adaptive_input_is_refused_naming_the_option() {
    let geo = paper_adaptive(&[]);
    let with = |extra: &[&str]| -> Vec<String> {
        let mut a = geo.clone();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    for (extra, option) in [
        (&["-nndd_adapt_tol", "0"][..], "-nndd_adapt_tol"),
        (&["-nndd_adapt_tol", "-0.1"], "-nndd_adapt_tol"),
        (&["-nndd_adapt_tol", "1.5"], "-nndd_adapt_tol"),
        (
            &["-nndd_adapt_tol", "0.1", "-nndd_adapt_max_cycles", "0"],
            "-nndd_adapt_max_cycles",
        ),
        (
            &["-nndd_adapt_tol", "0.1", "-nndd_adapt_strategy", "greedy"],
            "-nndd_adapt_strategy",
        ),
        (
            &[
                "-nndd_adapt_tol",
                "0.1",
                "-nndd_adapt_strategy",
                "dorfler",
                "-nndd_adapt_fraction",
                "0",
            ],
            "-nndd_adapt_fraction",
        ),
        (
            &["-nndd_adapt_tol", "0.1", "-nndd_adapt_fraction", "1.5"],
            "-nndd_adapt_fraction",
        ),
        (&["-nndd_adapt_max_cycles", "3"], "-nndd_adapt_max_cycles"),
        (
            &["-nndd_adapt_tol", "0.1", "-nndd_stop", "none"],
            "-nndd_stop",
        ),
    ] {
        refused(1, &strs(&with(extra)), option);
    }
    // A mesh file has no geometry to remesh; nor has a built-in problem a .geo of its own.
    let dir = scratch("adapt-refusals");
    let msh = dir.join("paper-4.msh");
    common::gmsh(PAPER_GEO, &[("n", "4")], &[], &msh);
    let mut a = paper_mesh_args(&msh, "contact1,contact2", "-1e-4");
    a.extend(["-nndd_adapt_tol", "0.1"].map(String::from));
    refused(2, &strs(&a), "-nndd_adapt_tol");
    refused(1, &["-nndd_adapt_tol", "0.1"], "-nndd_adapt_tol");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn curved_contact_curves_remeshed_from_one_view_are_made_to_match() {
    let dir = scratch("adapt-pin");
    let prefix = dir.join("pin");
    let opts = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.opts");
    let geo = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.geo");
    let p = prefix.display().to_string();
    let args = [
        "-options_file",
        opts,
        "-nndd_mesh",
        geo,
        "-nndd_geo_set",
        "level=1",
        "-nndd_adapt_tol",
        "0.001",
        "-nndd_adapt_max_cycles",
        "2",
        "-nndd_output",
        &p,
    ];
    let out = mpirun(2, &args);
    let text =
        String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(3), "{text}");
    let j = common::json(&prefix);
    let cycles = j["cycles"].as_array().unwrap();
    let curves = &j["contact_curves"];
    println!(
        "pin: {} -> {} dofs, eta_glo {:.4e} -> {:.4e}; cycle 2's curves: {} and {} nodes inserted, {} and {} moved",
        cycles[0]["dofs"], cycles[1]["dofs"], f(&cycles[0], "eta_glo"), f(&cycles[1], "eta_glo"),
        curves["inserted"][0], curves["inserted"][1], curves["moved"][0], curves["moved"][1]
    );
    assert!(f(&cycles[1], "eta_glo") < 0.5 * f(&cycles[0], "eta_glo"));
    let moved = curves["moved"][0].as_u64().unwrap() + curves["moved"][1].as_u64().unwrap();
    assert!(moved > 0, "{curves}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Gmsh failing at a remesh (the .geo breaks when `nndd_cycle` is set) ends every rank with
/// one line naming the option and what gmsh said, exit 2; the first cycle's files stay, the
/// run's own (PREFIX.json, PREFIX.xdmf) are not written.
#[test]
fn gmsh_failing_at_a_remesh_ends_the_run_in_one_line() {
    let dir = scratch("adapt-gmsh-fails");
    let geo = dir.join("paper-breaks.geo");
    let text = std::fs::read_to_string(PAPER_GEO).unwrap()
        + "If (Exists(nndd_cycle))\n  Line(99) = {1, 99};\nEndIf\n";
    std::fs::write(&geo, text).unwrap();
    let prefix = dir.join("run");
    let mut args = paper_mesh_args(&geo, "contact1,contact2", "-1e-4");
    args.extend(
        [
            "-nndd_geo_set",
            "n=4",
            "-nndd_adapt_tol",
            "0.01",
            "-nndd_output",
            prefix.to_str().unwrap(),
        ]
        .map(String::from),
    );
    let out = mpirun(2, &strs(&args));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let ours: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("nndd: error"))
        .collect();
    assert_eq!(ours.len(), 1, "{stderr}");
    println!("{}", ours[0]);
    assert!(ours[0].contains("-nndd_adapt_tol") && ours[0].contains("gmsh says"));
    assert!(!stderr.contains("panicked"));
    assert!(dir.join("run-cycle1.json").exists());
    assert!(!dir.join("run.json").exists() && !dir.join("run.xdmf").exists());
    std::fs::remove_dir_all(&dir).ok();
}
