//! Faults end every rank, promptly, with one line (an injected panic, an internal error, too);
//! a run stopped by a signal
//! writes a restart point that any rank count continues from. Every run here is under a
//! time limit, so that a hang fails the test instead of CI: the process group is killed and
//! the test says how long it waited.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use common::{f, json, scratch, spawn, wait_within, walk, Ended};

/// The tests of this file run one at a time: their time limits assume the machine's cores.
static SERIAL: Mutex<()> = Mutex::new(());

/// How long a failing job may take to end.
const LIMIT: Duration = Duration::from_secs(10);

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// `paper` n = 8 (estimates every 3 iterations, checkpoints every 4) on `np` ranks, output at
/// `prefix`, with `-nndd_fault spec`.
fn spawn_faulted(np: usize, prefix: &Path, spec: &str) -> Child {
    let args = [
        "-nndd_n",
        "8",
        "-nndd_theta",
        "0.25",
        "-nndd_estimate_every",
        "3",
        "-nndd_checkpoint_every",
        "4",
        "-nndd_output",
        prefix.to_str().unwrap(),
        "-nndd_fault",
        spec,
    ];
    spawn(np, &args)
}

/// `base` then `extra` on `np` ranks, required to succeed within `limit`.
fn solved(np: usize, base: &[&str], extra: &[&str], limit: Duration, what: &str) -> Ended {
    let args: Vec<&str> = base.iter().chain(extra).copied().collect();
    let e = wait_within(spawn(np, &args), limit, what);
    assert_eq!(e.code, Some(0), "{what}:\n{}", e.stderr);
    e
}

/// The lines nndd itself wrote to stderr.
fn our_lines(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.starts_with("nndd:")).collect()
}

/// A failed job: non-zero exit, one `nndd: error` line containing `needle`, no Rust panic or
/// PETSc traceback.
fn assert_failed_once(e: &Ended, needle: &str, what: &str) {
    assert!(
        e.code != Some(0),
        "{what}: exit 0\n{}\n{}",
        e.stdout,
        e.stderr
    );
    let ours = our_lines(&e.stderr);
    assert_eq!(
        ours.len(),
        1,
        "{what}: expected one line, got:\n{}",
        e.stderr
    );
    assert!(
        ours[0].starts_with("nndd: error") && ours[0].contains(needle),
        "{what}: '{}' does not say '{needle}'",
        ours[0]
    );
    for bad in [
        "panicked",
        "RUST_BACKTRACE",
        "PETSC ERROR",
        "internal error",
    ] {
        assert!(
            !e.stderr.contains(bad) && !e.stdout.contains(bad),
            "{what}: '{bad}' in\n{}",
            e.stderr
        );
    }
}

/// The result files under their final names.
fn results_left(prefix: &Path) -> Vec<String> {
    ["h5", "xdmf", "json"]
        .iter()
        .map(|x| format!("{}.{x}", prefix.display()))
        .filter(|p| Path::new(p).exists())
        .collect()
}

#[test]
fn bad_input_ends_every_rank_promptly_with_one_line() {
    let _s = serial();
    let dir = scratch("faults-input");
    let prefix = dir.join("run");
    let p = prefix.to_str().unwrap();
    let missing_opts = dir.join("missing.opts");
    let nesting = dir.join("nesting.opts");
    std::fs::write(
        &nesting,
        format!("-nndd_n 4\n-options_file {}\n", missing_opts.display()),
    )
    .unwrap();
    let cases: [(&str, Vec<&str>, &str); 4] = [
        (
            "missing options file",
            vec!["-options_file", missing_opts.to_str().unwrap()],
            "-options_file",
        ),
        (
            "missing nested options file",
            vec!["-options_file", nesting.to_str().unwrap()],
            "missing.opts",
        ),
        (
            "missing mesh file",
            vec!["-nndd_mesh", "/nonexistent/two-bodies.msh"],
            "-nndd_mesh",
        ),
        (
            "invalid option value",
            vec!["-nndd_theta", "-1"],
            "-nndd_theta",
        ),
    ];
    for np in [1, 2, 4] {
        for (what, args, needle) in &cases {
            let mut all = vec!["-nndd_n", "4", "-nndd_output", p];
            all.extend(args.iter().copied());
            let what = format!("{what} on {np} rank(s)");
            let e = wait_within(spawn(np, &all), 3 * LIMIT, &what);
            assert!(
                e.seconds < LIMIT.as_secs_f64(),
                "{what}: {:.1} s",
                e.seconds
            );
            assert_failed_once(&e, needle, &what);
            // Bad input is agreed on: no rank aborts, so nothing but our line and mpirun's
            // own note of the non-zero exit.
            assert!(!e.stderr.contains("MPI_ABORT"), "{what}:\n{}", e.stderr);
            assert!(walk(&dir)
                .iter()
                .all(|f| f.extension().is_some_and(|x| x == "opts")));
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `-nndd_fault RANK:PHASE` in every phase, on 2 and 3 ranks: the job ends within the limit
/// with one line naming the fault, and no result file exists under its final name.
#[test]
fn a_fault_on_one_rank_in_any_phase_ends_the_job() {
    let _s = serial();
    let dir = scratch("faults-phases");
    let phases = [
        "init",
        "options",
        "mesh",
        "assembly",
        "factorisation",
        "ksp",
        "qp",
        "estimate",
        "checkpoint",
        "output",
    ];
    let mut table = Vec::new();
    for np in [2, 3] {
        for rank in [np - 1, 0] {
            for phase in phases {
                let prefix = dir.join(format!("run-{np}-{rank}-{phase}"));
                let spec = format!("{rank}:{phase}");
                let what = format!("fault {spec} on {np} ranks");
                let e = wait_within(spawn_faulted(np, &prefix, &spec), 3 * LIMIT, &what);
                assert!(
                    e.seconds < LIMIT.as_secs_f64(),
                    "{what}: {:.1} s",
                    e.seconds
                );
                assert_failed_once(&e, "-nndd_fault", &what);
                let left = results_left(&prefix);
                assert!(left.is_empty(), "{what}: left {left:?}");
                table.push(format!(
                    "{np} ranks, fault {spec:<16} exit {:?} in {:.1} s",
                    e.code, e.seconds
                ));
            }
        }
    }
    println!("{}", table.join("\n"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `-nndd_fault RANK:PHASE:panic`: an internal error (a panic) of one rank, in the middle of
/// the solve and in the estimate and output phases, where the other ranks wait in collectives
/// for it, ends the whole job within the limit, with the line of the internal error, and no
/// result file exists under its final name.
#[test]
fn a_panic_on_one_rank_ends_the_job() {
    let _s = serial();
    let dir = scratch("faults-panic");
    let mut table = Vec::new();
    for phase in ["ksp", "estimate", "output"] {
        let prefix = dir.join(format!("run-{phase}"));
        let spec = format!("1:{phase}:panic");
        let what = format!("fault {spec} on 3 ranks");
        let e = wait_within(spawn_faulted(3, &prefix, &spec), 3 * LIMIT, &what);
        assert!(
            e.seconds < LIMIT.as_secs_f64(),
            "{what}: {:.1} s",
            e.seconds
        );
        assert!(e.code != Some(0), "{what}: exit 0\n{}", e.stderr);
        let ours = our_lines(&e.stderr);
        assert!(
            ours.iter()
                .any(|l| l.starts_with("nndd: internal error (rank 1)")
                    && l.contains(&format!("injected panic in phase '{phase}'"))),
            "{what}: no line of the internal error in\n{}",
            e.stderr
        );
        let left = results_left(&prefix);
        assert!(left.is_empty(), "{what}: left {left:?}");
        table.push(format!(
            "3 ranks, fault {spec:<18} exit {:?} in {:.1} s",
            e.code, e.seconds
        ));
    }
    println!("{}", table.join("\n"));
    std::fs::remove_dir_all(&dir).ok();
}

/// Start a long run; return the child once its monitor has printed `iteration`.
fn started_until(np: usize, args: &[&str], iteration: usize) -> (Child, Vec<String>) {
    started_at(np, args, |line| {
        line.split_whitespace()
            .next()
            .and_then(|w| w.parse::<usize>().ok())
            .is_some_and(|i| i >= iteration)
    })
}

/// The rank processes of a job (mpirun's children).
fn ranks_of(child: &Child) -> Vec<i32> {
    let out = Command::new("pgrep")
        .args(["-P", &child.id().to_string()])
        .output()
        .expect("pgrep");
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .filter_map(|p| p.parse().ok())
        .collect()
}

/// SIGTERM to every rank (as a batch system's time limit sends it): the run stops at the
/// end of an iteration, writes its results marked interrupted and a restart point, exits 4;
/// the restart on another rank count converges to the uninterrupted run's solution in the
/// remaining iterations. A checkpoint of another problem is refused with one line.
#[test]
fn sigterm_writes_a_restart_point_that_another_rank_count_continues() {
    let _s = serial();
    let dir = scratch("faults-sigterm");
    // Back-solves in the Neumann steps keep an iteration a few milliseconds long (the
    // condensed ones take microseconds), so that the signal arrives mid-run.
    let long = [
        "-nndd_n",
        "128",
        "-nndd_neumann_step",
        "solve",
        "-nndd_theta",
        "0.02",
        "-nndd_estimate_every",
        "0",
        "-nndd_reference_factor",
        "0",
        "-nndd_monitor",
    ];
    let full = dir.join("full");
    let out = ["-nndd_output", full.to_str().unwrap()];
    solved(2, &long, &out, 12 * LIMIT, "uninterrupted run");
    let reference = json(&full);

    let cut = dir.join("cut");
    let mut args: Vec<&str> = long.to_vec();
    args.extend(["-nndd_output", cut.to_str().unwrap()]);
    let (child, _) = started_until(2, &args, 20);
    let ranks = ranks_of(&child);
    assert_eq!(ranks.len(), 2, "{ranks:?}");
    for pid in &ranks {
        // SAFETY: kill(2) on the job's own processes.
        unsafe {
            libc::kill(*pid, libc::SIGTERM);
        }
    }
    let e = wait_within(child, 3 * LIMIT, "interrupted run");
    assert_eq!(
        e.code,
        Some(4),
        "exit code of an interrupted run:\n{}",
        e.stderr
    );
    assert!(
        e.stderr.contains("interrupted by a signal") && e.stderr.contains("-nndd_restart"),
        "{}",
        e.stderr
    );
    let summary = json(&cut);
    assert_eq!(summary["stop_reason"], "interrupted");
    assert_eq!(summary["converged"], false);
    let stopped_at = f(&summary, "iterations") as usize;
    let checkpoint = dir.join("cut.checkpoint.json");
    let cp: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&checkpoint).unwrap()).unwrap();
    assert_eq!(cp["state"]["iteration"].as_u64(), Some(stopped_at as u64));
    let total = f(&reference, "iterations") as usize;
    assert!(
        (20..total).contains(&stopped_at),
        "stopped at {stopped_at} of {total}"
    );

    // Continue on 3 ranks.
    let resumed = dir.join("resumed");
    let cp = checkpoint.to_str().unwrap();
    let out = [
        "-nndd_output",
        resumed.to_str().unwrap(),
        "-nndd_restart",
        cp,
    ];
    solved(3, &long, &out, 12 * LIMIT, "restart on 3 ranks");
    let r = json(&resumed);
    let (e_ref, e_res) = (f(&reference, "potential_energy"), f(&r, "potential_energy"));
    let rel = (e_res - e_ref).abs() / e_ref.abs();
    println!(
        "SIGTERM after iteration {stopped_at}; restart on 3 ranks: {} iterations (uninterrupted: {total}), energy {e_res:.12e} vs {e_ref:.12e}, relative difference {rel:.1e}",
        f(&r, "iterations")
    );
    assert!(rel < 1e-10, "energy differs by {rel:e}");
    let its = f(&r, "iterations") as usize;
    assert!(its.abs_diff(total) <= 1, "{its} iterations against {total}");
    assert_eq!(r["history"].as_array().unwrap().len(), its);
    // The history before the cut is the checkpoint's, exactly.
    assert_eq!(
        r["history"].as_array().unwrap()[..stopped_at],
        summary["history"].as_array().unwrap()[..]
    );

    // Another material, mesh or θ: refused, with what differs.
    let refused = dir.join("refused");
    for (extra, needle) in [
        (["-nndd_E", "2e11"], "material"),
        (["-nndd_n", "32"], "mesh"),
        (["-nndd_theta", "0.25"], "-nndd_theta"),
    ] {
        let mut args: Vec<&str> = long.to_vec();
        args.extend(["-nndd_restart", checkpoint.to_str().unwrap()]);
        args.extend(["-nndd_output", refused.to_str().unwrap()]);
        args.extend(extra);
        let what = format!("restart with {extra:?}");
        let e = wait_within(spawn(2, &args), 3 * LIMIT, &what);
        assert_failed_once(&e, needle, &what);
        assert!(our_lines(&e.stderr)[0].contains("-nndd_restart"));
        assert!(results_left(&refused).is_empty());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Restart points written by `-nndd_checkpoint_every` on the same rank count give the
/// uninterrupted run's iterates exactly (θ auto: the secant state is in the checkpoint).
#[test]
fn a_restart_repeats_the_uninterrupted_iterates_exactly() {
    let _s = serial();
    let dir = scratch("faults-every");
    let base = [
        "-nndd_n",
        "16",
        "-nndd_theta",
        "auto",
        "-nndd_estimate_every",
        "0",
        "-nndd_reference_factor",
        "0",
        "-nndd_checkpoint_every",
        "4",
    ];
    let full = dir.join("full");
    let out = ["-nndd_output", full.to_str().unwrap()];
    solved(2, &base, &out, 6 * LIMIT, "run with checkpoints");
    let a = json(&full);
    let checkpoint = dir.join("full.checkpoint.json");
    let cp: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&checkpoint).unwrap()).unwrap();
    let at = cp["state"]["iteration"].as_u64().unwrap() as usize;
    let total = f(&a, "iterations") as usize;
    assert!(
        at.is_multiple_of(4) && at < total && at >= 4,
        "checkpoint at {at} of {total}"
    );
    assert!(
        cp["state"]["secant"].is_object(),
        "θ auto keeps its secant state"
    );

    let again = dir.join("again");
    let cp = checkpoint.to_str().unwrap();
    let out = ["-nndd_output", again.to_str().unwrap(), "-nndd_restart", cp];
    solved(2, &base, &out, 6 * LIMIT, "restart");
    let b = json(&again);
    assert_eq!(a["history"], b["history"], "restart from iteration {at}");
    assert_eq!(a["potential_energy"], b["potential_energy"]);
    std::fs::remove_dir_all(&dir).ok();
}

/// kill -9 of one rank: the job ends (mpirun's own message), no result file under its final
/// name.
#[test]
fn kill_9_of_one_rank_ends_the_job() {
    let _s = serial();
    let dir = scratch("faults-kill9");
    let prefix = dir.join("run");
    // Back-solves in the Neumann steps keep the run going when the rank is killed.
    let args = [
        "-nndd_n",
        "128",
        "-nndd_neumann_step",
        "solve",
        "-nndd_theta",
        "0.02",
        "-nndd_estimate_every",
        "0",
        "-nndd_reference_factor",
        "0",
        "-nndd_monitor",
        "-nndd_output",
        prefix.to_str().unwrap(),
    ];
    let (child, _) = started_until(2, &args, 20);
    let ranks = ranks_of(&child);
    assert_eq!(ranks.len(), 2, "{ranks:?}");
    // SAFETY: kill(2) on one of the job's own processes.
    unsafe {
        libc::kill(ranks[1], libc::SIGKILL);
    }
    let e = wait_within(child, 3 * LIMIT, "job with a killed rank");
    assert!(e.code != Some(0));
    assert!(e.seconds < LIMIT.as_secs_f64(), "{:.1} s", e.seconds);
    assert!(
        results_left(&prefix).is_empty(),
        "{:?}",
        results_left(&prefix)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Start a long run; return the child once its monitor has printed a line for which `at`
/// holds (the lines so far).
fn started_at(np: usize, args: &[&str], at: impl Fn(&str) -> bool) -> (Child, Vec<String>) {
    let mut child = spawn(np, args);
    let out = child.stdout.take().unwrap();
    let mut lines = Vec::new();
    let mut reader = BufReader::new(out);
    let t0 = Instant::now();
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line).unwrap() == 0 {
            panic!(
                "the run ended before the line looked for:\n{}",
                lines.join("")
            );
        }
        let found = at(&line);
        lines.push(line);
        if found {
            break;
        }
        assert!(
            t0.elapsed() < 6 * LIMIT,
            "no such line yet:\n{}",
            lines.join("")
        );
    }
    let drain = std::thread::spawn(move || {
        let mut rest = String::new();
        std::io::Read::read_to_string(&mut reader, &mut rest).ok();
    });
    std::mem::forget(drain);
    (child, lines)
}

/// The monitor line of an NNDD iteration that meets the tolerances 1e-8 on the change and on
/// the force balance (the last one).
fn converged_line(line: &str) -> bool {
    let value = |key: &str| {
        let mut words = line.split_whitespace();
        words.any(|w| w == key)
            && words
                .next()
                .and_then(|v| v.parse::<f64>().ok())
                .is_some_and(|v| v <= 1e-8)
    };
    value("dlambda/lambda") && value("balance")
}

/// One case of [`sigterm_outside_the_nndd_loop_ends_the_run_at_once`]: the run, the monitor
/// line after which (and `delay_ms` later) the signal goes to every rank or to the last only,
/// and the phases its line may name.
struct PhaseCase<'a> {
    case: &'static str,
    args: &'a [&'a str],
    at: fn(&str) -> bool,
    delay_ms: u64,
    phases: &'static [&'static str],
    every_rank: bool,
}

/// SIGTERM in a phase with nothing worth keeping (the reference solve, the monolithic solve,
/// the final estimate), to every rank or to one: the run ends at once with exit 5 and one
/// line saying in which phase, and writes no file. (The NNDD loop's own stop, with results
/// and a restart point, is the test above.)
#[test]
fn sigterm_outside_the_nndd_loop_ends_the_run_at_once() {
    let _s = serial();
    let dir = scratch("faults-phase-signals");
    let reference = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "48",
        "-nndd_estimate",
        "-nndd_reference_factor",
        "8",
        "-nndd_monitor",
    ];
    let monolithic = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "256",
        "-nndd_solver",
        "monolithic",
        "-nndd_estimate",
        "-nndd_monitor",
    ];
    let estimate = [
        "-nndd_problem",
        "paper",
        "-nndd_n",
        "256",
        "-nndd_estimate",
        "-nndd_monitor",
    ];
    let setup_done = |l: &str| l.contains(" setup ");
    let reference_begun = |l: &str| l.contains("solving the reference solution");
    let cases = [
        // The reference solve takes seconds after its monitor line.
        PhaseCase {
            case: "reference solve",
            args: &reference,
            at: reference_begun,
            delay_ms: 500,
            phases: &["the reference solve"],
            every_rank: true,
        },
        PhaseCase {
            case: "reference solve, one rank signalled",
            args: &reference,
            at: reference_begun,
            delay_ms: 500,
            phases: &["the reference solve"],
            every_rank: false,
        },
        // The monolithic QP right after the setup, then the estimate of its solution.
        PhaseCase {
            case: "monolithic run",
            args: &monolithic,
            at: setup_done,
            delay_ms: 0,
            phases: &[
                "the setup",
                "the monolithic solve",
                "the estimate of the monolithic solution",
            ],
            every_rank: true,
        },
        // The estimate of the reported iterate follows the last iteration's line.
        PhaseCase {
            case: "final estimate",
            args: &estimate,
            at: converged_line,
            delay_ms: 0,
            phases: &["the final estimate"],
            every_rank: true,
        },
    ];
    let mut table = Vec::new();
    for PhaseCase {
        case,
        args,
        at,
        delay_ms,
        phases,
        every_rank,
    } in cases
    {
        for np in [1, 2, 3] {
            if !every_rank && np == 1 {
                continue;
            }
            let prefix = dir.join(format!("run-{np}"));
            let mut all: Vec<&str> = args.to_vec();
            all.extend(["-nndd_output", prefix.to_str().unwrap()]);
            let what = format!("SIGTERM during the {case} on {np} rank(s)");
            let (child, _) = started_at(np, &all, at);
            std::thread::sleep(Duration::from_millis(delay_ms));
            let ranks = ranks_of(&child);
            assert_eq!(ranks.len(), np, "{ranks:?}");
            let signalled = if every_rank {
                &ranks[..]
            } else {
                &ranks[np - 1..]
            };
            for pid in signalled {
                // SAFETY: kill(2) on the job's own processes.
                unsafe {
                    libc::kill(*pid, libc::SIGTERM);
                }
            }
            let e = wait_within(child, LIMIT, &what);
            assert_eq!(e.code, Some(5), "{what}: exit status\n{}", e.stderr);
            let ours = our_lines(&e.stderr);
            assert_eq!(
                ours.len(),
                1,
                "{what}: expected one line, got:\n{}",
                e.stderr
            );
            assert!(
                phases.iter().any(|p| ours[0].starts_with(&format!(
                    "nndd: stopped by SIGTERM during {p}; no results written"
                ))),
                "{what}: '{}' names none of {phases:?}",
                ours[0]
            );
            for bad in [
                "panicked",
                "RUST_BACKTRACE",
                "PETSC ERROR",
                "internal error",
            ] {
                assert!(!e.stderr.contains(bad), "{what}: '{bad}' in\n{}", e.stderr);
            }
            let left = walk(&dir);
            assert!(left.is_empty(), "{what}: left {left:?}");
            table.push(format!(
                "{what}: exit {:?} {:.1} s after the signal: {}",
                e.code, e.seconds, ours[0]
            ));
        }
    }
    println!("{}", table.join("\n"));
    std::fs::remove_dir_all(&dir).ok();
}
