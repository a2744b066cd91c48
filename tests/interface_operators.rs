//! Capability: each body's interface operators S^α (the Schur complement of its Neumann system
//! on the Γc normal dofs) and D^α = (S^α)⁻¹ come from its one factorisation on any rank count:
//! MUMPS's Schur complement on one rank, MUMPS's entries of K⁻¹ on several. Both equal the
//! operators formed from m back-solves (`-nndd_schur solves`) to 1e−10 (relative, Frobenius),
//! on `paper` and on the pin in its groove (rotated nodal frames), with body 1 and body 2 each
//! spread over ranks.

mod common;
use common::*;

use std::path::Path;

const PIN_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.geo");
const PIN_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pin/pin.opts");

/// Body α's S and D as `-nndd_schur_view` wrote them (row-major), and their source.
fn operators(prefix: &Path, alpha: usize) -> (Vec<f64>, Vec<f64>, String) {
    let path = format!("{}.body{alpha}_schur.json", prefix.display());
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    let m = j["m"].as_u64().unwrap() as usize;
    let take = |k: &str| -> Vec<f64> {
        let v: Vec<f64> = j[k]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(v.len(), m * m, "{path}: {k}");
        v
    };
    (
        take("schur"),
        take("delassus"),
        j["source"].as_str().unwrap().into(),
    )
}

fn frobenius_rel(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let n: f64 = b.iter().map(|y| y * y).sum();
    (d / n).sqrt()
}

/// One problem: its command line, and a run on `np` ranks with `extra` options.
struct Case<'a> {
    name: &'a str,
    args: Vec<String>,
}

impl Case<'_> {
    fn run(&self, dir: &Path, tag: &str, np: usize, extra: &[&str]) -> serde_json::Value {
        let prefix = dir.join(format!("{}-{tag}", self.name));
        let mut args: Vec<&str> = self.args.iter().map(String::as_str).collect();
        args.extend(["-nndd_schur_view", "-nndd_output", prefix.to_str().unwrap()]);
        args.extend(extra);
        let out = mpirun(np, &args);
        assert!(
            out.status.success(),
            "{} {tag}: {}",
            self.name,
            String::from_utf8_lossy(&out.stderr)
        );
        json(&prefix)
    }
}

fn check(case: &Case, dir: &Path) {
    // The reference: m back-solves, both bodies on one rank.
    let reference = case.run(dir, "solves1", 1, &["-nndd_schur", "solves"]);
    assert_eq!(
        reference["schur_source"],
        serde_json::json!(["solves", "solves"])
    );
    let reference_ops = |alpha| operators(&dir.join(format!("{}-solves1", case.name)), alpha);
    // (tag, ranks, options, the expected sources of body 1 and body 2)
    let runs: [(&str, usize, &[&str], [&str; 2]); 7] = [
        ("schur1", 1, &[], ["mumps_schur", "mumps_schur"]),
        (
            "inverse1",
            1,
            &["-nndd_schur", "mumps_inverse"],
            ["mumps_inverse", "mumps_inverse"],
        ),
        (
            "body1on2",
            3,
            &["-nndd_body1_ranks", "2"],
            ["mumps_inverse", "mumps_schur"],
        ),
        (
            "body2on2",
            3,
            &["-nndd_body1_ranks", "1"],
            ["mumps_schur", "mumps_inverse"],
        ),
        (
            "both4",
            4,
            &["-nndd_body1_ranks", "2"],
            ["mumps_inverse", "mumps_inverse"],
        ),
        (
            // MUMPS's entries of K⁻¹ 7 columns at a time for body 2 (the user's ICNTL(27)).
            "block7",
            4,
            &["-nndd_body1_ranks", "2", "-body2_mat_mumps_icntl_27", "7"],
            ["mumps_inverse", "mumps_inverse"],
        ),
        (
            "solves4",
            4,
            &["-nndd_body1_ranks", "2", "-nndd_schur", "solves"],
            ["solves", "solves"],
        ),
    ];
    for (tag, np, extra, sources) in runs {
        let j = case.run(dir, tag, np, extra);
        assert_eq!(j["schur_source"], serde_json::json!(sources), "{tag}");
        assert_eq!(j["dirichlet_step"], "condensed", "{tag}");
        for alpha in [1, 2] {
            let (s, d, source) = operators(&dir.join(format!("{}-{tag}", case.name)), alpha);
            assert_eq!(source, sources[alpha - 1], "{tag}");
            let (s0, d0, _) = reference_ops(alpha);
            let (es, ed) = (frobenius_rel(&s, &s0), frobenius_rel(&d, &d0));
            assert!(
                es < 1e-10 && ed < 1e-10,
                "{} {tag}, body {alpha}: S differs by {es:e}, D by {ed:e}",
                case.name
            );
        }
        let (a, b) = (f(&j, "potential_energy"), f(&reference, "potential_energy"));
        assert!(((a - b) / b).abs() < 1e-11, "{tag}: energy {a} vs {b}");
    }
}

#[test]
fn paper_operators_from_the_factorisation_equal_back_solves() {
    let dir = scratch("iface-paper");
    let case = Case {
        name: "paper",
        args: PAPER_16_TIGHT.map(String::from).to_vec(),
    };
    check(&case, &dir);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pin_operators_from_the_factorisation_equal_back_solves() {
    let dir = scratch("iface-pin");
    let msh = gmsh_level(PIN_GEO, &dir, "pin", 1);
    let case = Case {
        name: "pin",
        args: vec![
            "-options_file".into(),
            PIN_OPTS.into(),
            "-nndd_mesh".into(),
            msh.display().to_string(),
            "-nndd_tol".into(),
            "1e-11".into(),
        ],
    };
    check(&case, &dir);
    std::fs::remove_dir_all(&dir).ok();
}

/// The choices that cannot be had are refused with one line naming the option.
#[test]
fn impossible_schur_choices_are_refused() {
    refused(
        3,
        &["-nndd_n", "16", "-nndd_schur", "mumps_schur"],
        "-nndd_schur mumps_schur",
    );
    refused(
        2,
        &[
            "-nndd_n",
            "16",
            "-nndd_schur",
            "mumps_inverse",
            "-body2_pc_factor_mat_solver_type",
            "petsc",
        ],
        "-nndd_schur mumps_inverse",
    );
    refused(2, &["-nndd_n", "16", "-nndd_schur", "lu"], "-nndd_schur");
}
