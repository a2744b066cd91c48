//! Every result is checked before it is reported: each subdomain solve's backward error, the
//! materials' conditioning, the reported iterate's equilibrium and contact conditions, the
//! restart point's checksum, and the options files' syntax. A check that fails ends the run
//! with one line naming the cause and the options that fix it, and writes no result.

mod common;
use common::*;

use std::path::Path;
use std::time::{Duration, Instant};

const HERTZ_GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.geo");
const HERTZ_OPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hertz/hertz.opts");

/// A failed run: exit `code`, one `nndd: error` line saying each of `needles`
/// ([`fails_with`]).
fn failed(np: usize, args: &[&str], code: i32, needles: &[&str]) -> String {
    fails_with(np, args, Some(code), needles)
}

/// `preonly` with a preconditioner that is no solver gave "converged" and a wrong energy
/// (hypre: 2.6 % off); every subdomain solve's backward error is now checked, and the message
/// names the body's options and the fix.
#[test]
fn a_preconditioner_applied_once_is_refused_with_the_fix() {
    for (np, body, pc) in [
        (2, 2, "none"),
        (2, 2, "hypre"),
        (2, 2, "gamg"),
        (2, 2, "jacobi"),
        (1, 1, "sor"),
        (3, 1, "none"),
        (3, 2, "ilu"),
    ] {
        let option = format!("-body{body}_pc_type");
        let line = failed(
            np,
            &["-nndd_problem", "paper", "-nndd_n", "16", &option, pc],
            2,
            &[
                &format!("body {body}"),
                "backward error",
                &format!("-body{body}_pc_type {pc}"),
                &format!("-body{body}_ksp_type cg"),
            ],
        );
        assert!(!line.contains("theta"), "not a θ problem: {line}");
    }
}

/// An iterative KSP that stops short of an accurate solve is refused too (its own tolerance
/// is the limit), and one that converges is accepted with the factorisation's answer.
#[test]
fn an_iterative_solve_is_held_to_its_tolerance() {
    let dir = scratch("checked-iterative");
    let base = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "16",
        "-nndd_tol",
        "1e-10",
    ];
    let direct = solve(2, &dir.join("direct"), &base);
    let mut cg = base.to_vec();
    cg.extend([
        "-body2_ksp_type",
        "cg",
        "-body2_pc_type",
        "gamg",
        "-body2_ksp_norm_type",
        "unpreconditioned",
    ]);
    let mut tight = cg.clone();
    tight.extend(["-body2_ksp_rtol", "1e-12"]);
    let j = solve(2, &dir.join("cg"), &tight);
    let (a, b) = (f(&j, "potential_energy"), f(&direct, "potential_energy"));
    assert!(((a - b) / b).abs() < 1e-8, "cg {a} vs direct {b}");
    // Two CG iterations cannot reach 1e-12, and say so (KSP reason: max_it).
    let mut short = tight.clone();
    short.extend(["-body2_ksp_max_it", "2"]);
    failed(2, &short, 2, &["body 2", "did not converge", "-body2_ksp"]);
    // A solve converged to a loose tolerance passes its own check (the tolerance is its
    // limit), and the NNDD converges on it; the final check of the reported fields finds
    // body 2 out of equilibrium, and nothing is reported as converged.
    let mut loose = cg.clone();
    loose.extend(["-body2_ksp_rtol", "0.5"]);
    failed(
        2,
        &loose,
        2,
        &[
            "final check",
            "body 2's equilibrium residual",
            "-body2_ksp_rtol",
        ],
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `-bodyα_pc_type lu` is a valid choice: MUMPS's LU, or PETSc's own LU (no Schur complement:
/// S from back-solves), on 1 and 3 ranks, with the default's answer.
#[test]
fn lu_and_other_factor_packages_give_the_same_answer() {
    let dir = scratch("checked-lu");
    let base = PAPER_16_TIGHT;
    let reference = solve(2, &dir.join("default"), &base);
    let e0 = f(&reference, "potential_energy");
    for (np, extra, sources) in [
        (
            1,
            vec!["-body1_pc_type", "lu"],
            ["mumps_schur", "mumps_schur"],
        ),
        (
            3,
            vec!["-body2_pc_type", "lu"],
            ["mumps_inverse", "mumps_schur"],
        ),
        (
            1,
            vec![
                "-body2_pc_type",
                "lu",
                "-body2_pc_factor_mat_solver_type",
                "petsc",
            ],
            ["mumps_schur", "solves"],
        ),
    ] {
        let mut args = base.to_vec();
        args.extend(extra.iter().copied());
        let j = solve(np, &dir.join(format!("lu{np}")), &args);
        assert_eq!(j["schur_source"], serde_json::json!(sources), "{extra:?}");
        let e = f(&j, "potential_energy");
        assert!(((e - e0) / e0).abs() < 1e-10, "{extra:?}: {e} vs {e0}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Moduli whose ratio is beyond what double precision resolves, and ν so close to ½ that the
/// solve loses its digits, are refused; a large but resolvable ratio is solved, the NNDD equal
/// to the monolithic solve; a nearly incompressible body is solved with a warning.
#[test]
fn materials_that_lose_the_digits_are_refused() {
    failed(
        2,
        &["-nndd_n", "8", "-nndd_body1_E", "1e300"],
        1,
        &["-nndd_body1_E", "stiffness ratio", "1e6"],
    );
    // Just beyond the limit, with the reason.
    failed(
        1,
        &["-nndd_n", "8", "-nndd_body2_E", "2.2e17"],
        1,
        &["-nndd_body2_E", "1.0e6", "double precision cannot resolve"],
    );
    failed(
        1,
        &["-nndd_n", "8", "-nndd_nu", "0.4999999999"],
        1,
        &["-nndd_nu", "incompressible", "0.499999995"],
    );
    failed(
        3,
        &["-nndd_n", "8", "-nndd_body2_nu", "0.49999999999"],
        1,
        &["-nndd_body2_nu"],
    );
    // A modulus whose stiffness underflows is a solver failure naming E, not a θ problem.
    let line = failed(
        2,
        &["-nndd_n", "8", "-nndd_E", "1e-300"],
        2,
        &["backward error", "singular", "E and ν"],
    );
    assert!(!line.contains("theta"), "{line}");
    let dir = scratch("checked-materials");
    // Every accepted ratio, either body the stiffer, the Dirichlet step on either body: the
    // monolithic energy to 1e-8 (or a run that says it did not converge), and the forces of
    // a converged run balanced (the issue: body 2 1e8 times stiffer "converged" after 6
    // iterations with its stresses 7 times the monolithic ones).
    for e2 in ["2.1e13", "2.1e15", "2.1e17", "2.1e9", "2.1e7", "2.1e5"] {
        let args = ["-nndd_n", "16", "-nndd_body2_E", e2];
        let mut mono_args = args.to_vec();
        mono_args.extend(["-nndd_solver", "monolithic"]);
        let mono = solve(1, &dir.join("mono"), &mono_args);
        let b = f(&mono, "potential_energy");
        for body in ["1", "2"] {
            let mut a = args.to_vec();
            a.extend(["-nndd_dirichlet_body", body, "-nndd_max_it", "300"]);
            let prefix = dir.join(format!("nndd{body}"));
            let out = mpirun(
                2,
                &[&a[..], &["-nndd_output", prefix.to_str().unwrap()]].concat(),
            );
            let code = out.status.code();
            let nndd: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(prefix.with_extension("json")).unwrap(),
            )
            .unwrap();
            if code == Some(3) {
                // The forced Dirichlet step on a body 1e6 softer: it says it did not converge.
                assert_ne!(nndd["stop_reason"], "tol", "E2 {e2} body {body}");
                continue;
            }
            assert_eq!(code, Some(0), "E2 {e2} body {body}");
            assert_eq!(nndd["stop_reason"], "tol");
            let a = f(&nndd, "potential_energy");
            assert!(
                ((a - b) / b).abs() < 1e-8,
                "E2 {e2} body {body}: {a} vs {b}"
            );
            let last = nndd["history"].as_array().unwrap().last().unwrap().clone();
            assert!(
                f(&last, "force_balance") <= 1e-8,
                "E2 {e2} body {body}: {last}"
            );
            assert!(f(&nndd["solution_check"], "balance") <= 1e-8, "{nndd}");
        }
    }
    let prefix = dir.join("nearly");
    let p = prefix.to_str().unwrap();
    let out = mpirun(
        2,
        &[
            "-nndd_n",
            "8",
            "-nndd_body2_nu",
            "0.49999",
            "-nndd_output",
            p,
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let warning: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("nndd: warning: -nndd_body2_nu"))
        .collect();
    assert_eq!(warning.len(), 1, "{stderr}");
    assert!(warning[0].contains("lock"), "{}", warning[0]);
    let j = json(&prefix);
    assert_eq!(j["warnings"].as_array().unwrap().len(), 1, "{j}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The reported iterate's fields, formed by solves with its Γc forces, are in equilibrium to
/// round-off and satisfy the contact conditions, NNDD and monolithic, on 1, 2 and 3 ranks
/// (paper) and on a curved interface (Hertz); the summary gives the check.
#[test]
fn the_reported_iterate_passes_its_check_on_every_rank_count() {
    let dir = scratch("checked-final");
    let mut runs: Vec<(String, serde_json::Value)> = Vec::new();
    for np in [1, 2, 3] {
        let j = solve(np, &dir.join(format!("p{np}")), &PAPER_16_TIGHT);
        runs.push((format!("paper on {np}"), j));
        let mut mono = PAPER_16_TIGHT.to_vec();
        mono.extend(["-nndd_solver", "monolithic"]);
        let j = solve(np, &dir.join(format!("m{np}")), &mono);
        runs.push((format!("monolithic paper on {np}"), j));
    }
    let msh = gmsh_level(HERTZ_GEO, &dir, "hertz", 1);
    // (-nndd_output after the options file, which sets its own)
    let prefix = dir.join("hertz");
    let args = [
        "-options_file",
        HERTZ_OPTS,
        "-nndd_mesh",
        msh.to_str().unwrap(),
        "-nndd_output",
        prefix.to_str().unwrap(),
    ];
    assert!(mpirun(2, &args).status.success());
    runs.push(("hertz".into(), json(&prefix)));
    for (name, j) in &runs {
        let c = &j["solution_check"];
        for k in 0..2 {
            let r = c["equilibrium"][k].as_f64().unwrap();
            assert!(r < 1e-13, "{name}: body {} equilibrium {r}", k + 1);
        }
        for key in ["penetration", "tension", "complementarity"] {
            let v = c[key].as_f64().unwrap();
            assert!(v < 1e-12, "{name}: {key} {v}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A restart point edited after it was written (one λ by 10 %, one λ = 1e300, every λ
/// doubled) is refused by its checksum; the intact one is continued from.
#[test]
fn an_edited_restart_point_is_refused() {
    let dir = scratch("checked-restart");
    let base = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "16",
        "-nndd_theta",
        "0.05",
    ];
    let mut first = base.to_vec();
    first.extend(["-nndd_checkpoint_every", "5", "-nndd_max_it", "10"]);
    let prefix = dir.join("a");
    let p = prefix.to_str().unwrap();
    let mut args = first.clone();
    args.extend(["-nndd_output", p]);
    let out = mpirun(2, &args);
    assert_eq!(out.status.code(), Some(3), "max_it: exit 3");
    let cp = dir.join("a.checkpoint.json");
    let text = std::fs::read_to_string(&cp).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    type Edit = fn(&mut Vec<serde_json::Value>);
    let edits: [(&str, Edit); 3] = [
        ("ten-percent", |l| {
            l[3] = (l[3].as_f64().unwrap() * 1.1).into();
        }),
        ("huge", |l| l[0] = 1e300.into()),
        ("doubled", |l| {
            for x in l.iter_mut() {
                *x = (x.as_f64().unwrap() * 2.0).into();
            }
        }),
    ];
    for (name, edit) in edits {
        let mut v = value.clone();
        edit(v["state"]["lambda"].as_array_mut().unwrap());
        let edited = dir.join(format!("{name}.json"));
        std::fs::write(&edited, serde_json::to_string(&v).unwrap()).unwrap();
        let mut args = base.to_vec();
        args.extend([
            "-nndd_max_it",
            "40",
            "-nndd_restart",
            edited.to_str().unwrap(),
        ]);
        failed(2, &args, 1, &["-nndd_restart", "checksum"]);
    }
    // The intact file, rewritten by another JSON writer with the same numbers, is accepted.
    let same = dir.join("same.json");
    std::fs::write(&same, serde_json::to_string_pretty(&value).unwrap()).unwrap();
    let mut args = base.to_vec();
    args.extend([
        "-nndd_max_it",
        "12",
        "-nndd_restart",
        same.to_str().unwrap(),
    ]);
    let out = mpirun(3, &args);
    assert_eq!(out.status.code(), Some(3), "{:?}", out);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("nndd: error"));
    std::fs::remove_dir_all(&dir).ok();
}

/// The checksum of a restart point as `src/io/checkpoint.rs` documents it, made again after an
/// edit: the 64-bit `mix` hash of the canonical JSON text without its `checksum` key.
fn reseal(value: &mut serde_json::Value) {
    use nndd::fem::mesh::mix;
    value.as_object_mut().unwrap().remove("checksum");
    let text = serde_json::to_vec(&value).unwrap();
    let mut h = mix(text.len() as u64, 0x6e6e_6464);
    for chunk in text.chunks(8) {
        let mut word = [0u8; 8];
        word[..chunk.len()].copy_from_slice(chunk);
        h = mix(h, u64::from_le_bytes(word));
    }
    value["checksum"] = format!("{h:016x}").into();
}

/// The last value of the JSON array `v` removed.
fn pop(v: &mut serde_json::Value) {
    v.as_array_mut().unwrap().pop();
}

/// `value` with `edit` made to its state and its checksum made again, written to
/// `dir/name.json`; the options that restart `paper` n = 4 from it.
fn doctored(
    dir: &Path,
    name: &str,
    value: &serde_json::Value,
    edit: fn(&mut serde_json::Value),
) -> Vec<String> {
    let mut v = value.clone();
    edit(&mut v["state"]);
    reseal(&mut v);
    let file = dir.join(format!("{name}.json"));
    std::fs::write(&file, serde_json::to_string(&v).unwrap()).unwrap();
    let file = file.to_str().unwrap();
    ["-nndd_n", "4", "-nndd_max_it", "40", "-nndd_restart", file]
        .map(String::from)
        .to_vec()
}

/// A restart point whose λ, contact flags, secant vectors or history do not fit the run, with
/// its checksum made again (so that only the contents can tell), is refused with one line,
/// exit 1: a λ one value short or long (with as many contact flags) used to panic on every
/// rank in the contact step (src/qp/dense.rs, src/dd/contact.rs). No contact flags (none
/// before the first contact step) are accepted.
#[test]
fn a_restart_point_of_the_wrong_length_is_refused() {
    let dir = scratch("restart-lengths");
    let prefix = dir.join("a");
    let p = prefix.to_str().unwrap();
    let first = [
        "-nndd_n",
        "4",
        "-nndd_checkpoint_every",
        "2",
        "-nndd_max_it",
        "3",
    ];
    let out = mpirun(2, &[&first[..], &["-nndd_output", p]].concat());
    assert_eq!(out.status.code(), Some(3), "max_it: exit 3");
    let text = std::fs::read_to_string(dir.join("a.checkpoint.json")).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(value["state"]["lambda"].as_array().unwrap().len(), 5);
    let differs = "the checkpoint does not match this run: its λ has";
    type Edit = fn(&mut serde_json::Value);
    let cases: [(usize, &str, Edit, &str); 5] = [
        (
            2,
            "shorter",
            |s| {
                pop(&mut s["lambda"]);
                pop(&mut s["active"]);
            },
            &format!("{differs} 4 values, this run's contact interface 5 pairs"),
        ),
        (
            1,
            "longer",
            |s| {
                s["lambda"].as_array_mut().unwrap().push(0.0.into());
                s["active"].as_array_mut().unwrap().push(true.into());
            },
            &format!("{differs} 6 values, this run's contact interface 5 pairs"),
        ),
        (
            2,
            "flags",
            |s| pop(&mut s["active"]),
            "inconsistent state: 5 λ values, 4 contact flags",
        ),
        (
            1,
            "secant",
            |s| pop(&mut s["secant"]["previous"]["d"]),
            "the secant update's 'd' has 4 values, λ 5",
        ),
        (
            2,
            "best",
            |s| s["best_at"] = 7.into(),
            "best iteration 7 after iteration 2",
        ),
    ];
    for (np, name, edit, message) in cases {
        let args = doctored(&dir, name, &value, edit);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let line = failed(np, &args, 1, &[message]);
        let file = dir.join(format!("{name}.json"));
        let start = format!("nndd: error: -nndd_restart {}: ", file.display());
        assert!(line.starts_with(&start), "{line}");
    }
    let args = doctored(&dir, "no-flags", &value, |s| {
        s["active"] = serde_json::json!([])
    });
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = mpirun(2, &[&args[..], &["-nndd_output", p]].concat());
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A syntax error in an options file is one line naming the file and the line, exit 1, on
/// every rank count, before PETSc starts (PETSc itself printed 22 error lines after 5 s).
#[test]
fn an_options_file_syntax_error_is_one_line() {
    let dir = scratch("checked-opts");
    let file = dir.join("bad.opts");
    std::fs::write(&file, "-nndd_problem paper\n-nndd_n 8\n-nndd_tol = 1e-8\n").unwrap();
    let name = file.to_str().unwrap().to_string();
    for np in [1, 2, 3] {
        let t = Instant::now();
        failed(
            np,
            &["-options_file", &name],
            1,
            &[&name, "line 3", "extra word '1e-8'"],
        );
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "{np} ranks: {:?}",
            t.elapsed()
        );
    }
    assert!(Path::new(&name).exists());
    std::fs::remove_dir_all(&dir).ok();
}
