//! The study programs (`jobs/study_*.rs`, cargo examples) in their `--quick` form: each writes
//! its CSV (and PNG) into a scratch directory, and the numbers show what the paper's figures
//! show: η^FE falls with the dofs (Fig. 3), the effectivity is ≥ 1 (Fig. 4), η^NNDD falls
//! with the iterations while η^glo levels off at η^FE (Fig. 5), and the balanced stopping
//! rule needs no more iterations than the fixed tolerance.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

/// The studies run one at a time: each uses both cores through mpirun.
static SERIAL: Mutex<()> = Mutex::new(());

/// `cargo run --release --example study_NAME -- --quick --out DIR` from the crate root, with
/// this build's nndd; returns DIR.
fn study(name: &str) -> PathBuf {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let out = std::env::temp_dir().join(format!("nndd-study-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let example = format!("study_{name}");
    let run = Command::new(env!("CARGO"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["run", "--quiet", "--release", "--example", &example, "--"])
        .arg("--quick")
        .arg("--out")
        .arg(&out)
        .env("NNDD", env!("CARGO_BIN_EXE_nndd"))
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .env("OPENBLAS_NUM_THREADS", "1")
        .output()
        .expect("cargo runs");
    assert!(
        run.status.success(),
        "{example} failed ({}):\n{}\n{}",
        run.status,
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

/// The rows of a CSV file as maps column → value, after checking its header.
fn csv(path: &Path, header: &str) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(header), "header of {path:?}");
    let keys: Vec<&str> = header.split(',').collect();
    lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            assert_eq!(cells.len(), keys.len(), "row of {path:?}: {l}");
            keys.iter()
                .map(|k| k.to_string())
                .zip(cells.iter().map(|c| c.to_string()))
                .collect()
        })
        .collect()
}

fn num(row: &std::collections::HashMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = {:?} is not a number", row[key]))
}

const HEADER: &str = "n,dofs,iteration,eta_glo,eta_fe,eta_nndd,eta_ratio,e_ref,effectivity";

/// The figure's CSV with `rows` rows, every η positive and finite, and a PNG beside it.
fn figure(out: &Path, name: &str, rows: usize) -> Vec<std::collections::HashMap<String, String>> {
    let table = csv(&out.join(format!("{name}.csv")), HEADER);
    assert_eq!(table.len(), rows, "{name}.csv rows");
    for r in &table {
        for k in ["eta_glo", "eta_fe", "eta_nndd"] {
            let v = num(r, k);
            assert!(v > 0.0 && v.is_finite(), "{name}: {k} = {v}");
        }
    }
    let png = std::fs::read(out.join(format!("{name}.png"))).expect("the PNG exists");
    assert!(
        png.starts_with(b"\x89PNG\r\n\x1a\n"),
        "{name}.png is not a PNG"
    );
    table
}

#[test]
fn fig3_eta_fe_falls_with_the_dofs() {
    let out = study("fig3");
    let t = figure(&out, "fig3", 2);
    assert!(num(&t[1], "dofs") > num(&t[0], "dofs"));
    assert!(t.iter().all(|r| num(r, "iteration") == 6.0));
    assert!(
        num(&t[1], "eta_fe") < num(&t[0], "eta_fe"),
        "eta_fe does not fall"
    );
    std::fs::remove_dir_all(out).ok();
}

#[test]
fn fig4_effectivity_is_at_least_one() {
    let out = study("fig4");
    let t = figure(&out, "fig4", 2);
    for r in &t {
        let gamma = num(r, "effectivity");
        assert!(gamma >= 1.0 && gamma.is_finite(), "effectivity {gamma}");
        assert!(num(r, "e_ref") > 0.0);
    }
    std::fs::remove_dir_all(out).ok();
}

#[test]
fn fig5_eta_nndd_falls_and_eta_glo_levels_off_at_eta_fe() {
    let out = study("fig5");
    let t = figure(&out, "fig5", 10);
    let nndd: Vec<f64> = t.iter().map(|r| num(r, "eta_nndd")).collect();
    assert!(nndd[9] < nndd[0], "eta_nndd does not fall: {nndd:?}");
    let falls = nndd.windows(2).filter(|w| w[1] < w[0]).count();
    assert!(
        falls * 10 >= 8 * (nndd.len() - 1),
        "eta_nndd falls at {falls} of {} steps: {nndd:?}",
        nndd.len() - 1
    );
    let last = &t[9];
    assert!(num(last, "eta_glo") >= 0.9 * num(last, "eta_fe"));
    std::fs::remove_dir_all(out).ok();
}

#[test]
fn balanced_stopping_needs_no_more_iterations() {
    let out = study("balanced");
    let t = csv(
        &out.join("balanced.csv"),
        "n,dofs,iterations_tol,iterations_balanced,iterations_saved,eta_glo_tol,\
         eta_glo_balanced,eta_glo_rel_change,eta_fe_balanced,eta_nndd_balanced,wall_tol_s,\
         wall_balanced_s,stop_reason_balanced",
    );
    assert_eq!(t.len(), 2);
    for r in &t {
        assert!(num(r, "iterations_balanced") <= num(r, "iterations_tol"));
        for k in ["eta_glo_tol", "eta_glo_balanced"] {
            assert!(num(r, k) > 0.0 && num(r, k).is_finite(), "{k}");
        }
    }
    std::fs::remove_dir_all(out).ok();
}
