//! The PETSc-style monitor lines of `-nndd_monitor` (`%.12e`-formatted numbers, one line per
//! NNDD iteration, one more per estimated iteration).

use crate::dd::nndd::IterationRecord;
use crate::estimate::EstimateRecord;

/// One line per NNDD iteration (`-nndd_monitor`), and the estimates of an estimated one.
/// `contact_nodes`: the number of Γc node pairs; `elapsed`: seconds since the loop started.
pub fn monitor_line(
    r: &IterationRecord,
    contact_nodes: usize,
    elapsed: f64,
    est: Option<&EstimateRecord>,
) {
    // `-nndd_theta auto` adds the θ of the update's new direction and its secant columns.
    let secant = r.secant_columns.map_or(String::new(), |k| {
        format!(
            " theta {} secant {k} fraction {:.3}",
            sci(r.theta, 3),
            r.secant_fraction.unwrap_or(1.0)
        )
    });
    // The contact QP's iterations, and the method when Clarabel solved it.
    let clarabel = if r.qp_solver == "clarabel" {
        " (clarabel)"
    } else {
        ""
    };
    // Friction: the pairs sticking, and Coulomb's fixed-point solves.
    let friction = match (r.stick, r.coulomb_iterations) {
        (Some(s), Some(k)) => format!(" stick {s} coulomb_its {k}"),
        (Some(s), None) => format!(" stick {s}"),
        _ => String::new(),
    };
    println!(
        "{:4} NNDD dlambda/lambda {} |R| {} balance {} active {}/{}{friction} qp_its {}{clarabel}{secant} time {:.3} s",
        r.iteration,
        sci(r.lambda_change, 12),
        sci(r.residual, 6),
        sci(r.force_balance, 3),
        r.active,
        contact_nodes,
        r.qp_iterations,
        elapsed
    );
    if let Some(e) = est {
        println!("{}", estimate_text(e));
    }
    use std::io::Write;
    let _ = std::io::stdout().flush();
}

/// The estimates of one iteration, in the monitor's format.
pub fn estimate_text(e: &EstimateRecord) -> String {
    let mut s = format!(
        "{:4} NNDD eta_glo {} eta_FE {} eta_NNDD {} ratio {:.4}",
        e.iteration,
        sci(e.eta_glo, 6),
        sci(e.eta_fe, 6),
        sci(e.eta_nndd, 6),
        e.eta_ratio
    );
    if let (Some(r), Some(g)) = (e.e_ref, e.effectivity) {
        s += &format!(" e_ref {} effectivity {:.4}", sci(r, 6), g);
    }
    s
}

/// C's `%.{digits}e` (PETSc's monitors): `1.234e-03`, not Rust's `1.234e-3`.
pub fn sci(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    let s = format!("{:.*e}", digits, x);
    let (mant, exp) = s.split_once('e').expect("scientific format");
    let e: i32 = exp.parse().expect("exponent");
    format!("{mant}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

/// A line on standard error, written whole: formatted first, then one write. Standard error is
/// unbuffered, so `eprintln!` writes each formatted piece on its own, and mpirun can put a line
/// of standard output between two pieces of it (`nndd: warning: the NNDD nndd: mesh …`).
pub fn say(args: std::fmt::Arguments) {
    use std::io::Write as _;
    let line = format!("{args}\n");
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}
