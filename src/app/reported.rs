//! The reported iterate's estimate, in two parts around the freeing of the bodies: its
//! re-solves with the bodies' factorisations ([`resolve_reported`]), then its recoveries and
//! element sums ([`finish_reported`]), so that the run's peak memory is the larger of the two
//! phases, not their sum (docs/scaling.md, "Memory per rank").

use std::time::Instant;

use super::options::Settings;
use super::{AppError, LONG_PHASE_DOFS};
use crate::dd::displacement::Displacement;
use crate::dd::nndd::{self, Iterate, IterationRecord, NnddResult, Status};
use crate::estimate::estimator::InParts;
use crate::estimate::{EstimateRecord, Estimator};
use crate::io::{fields, monitor};
use crate::os::signals::{self, StopPhase};
use crate::parallel::layout::Layout;
use crate::petsc::log::Stages;

/// The reported iterate's estimate, re-solved ([`Estimator::resolve_cold`]).
pub struct Pending {
    parts: InParts,
    /// Whether the loop estimated that iterate too (its record is replaced).
    in_loop: bool,
}

/// The reported iterate's estimate (not when a signal stopped the run: it must end soon), its
/// η^glo recovery cold: one bound per iterate, whichever iterates were estimated before (an
/// estimate of it in the loop may have started warm: it is made again). Its re-solves here,
/// with the bodies; its recoveries by [`finish_reported`]. The time (s) and what is left.
pub(super) fn resolve_reported(
    settings: &Settings,
    ctx: &nndd::Context,
    estimator: Option<&Estimator>,
    res: &NnddResult,
    estimates: &[EstimateRecord],
) -> Result<(f64, Option<Pending>), AppError> {
    let Some(est) = estimator.filter(|_| res.status != Status::Interrupted) else {
        return Ok((0.0, None));
    };
    let in_loop = estimates.last().map(|e| e.iteration) == Some(res.iterations);
    if in_loop && !est.starts_warm() {
        return Ok((0.0, None));
    }
    let t = Instant::now();
    let _s = ctx.stages.estimation.enter();
    let before = signals::enter(StopPhase::FinalEstimate);
    let dofs = settings.problem.dofs();
    if ctx.layout.is_root() && dofs >= LONG_PHASE_DOFS {
        println!(
            "nndd: estimating the errors of iteration {} ({dofs} dofs) …",
            res.last.iteration
        );
    }
    let parts = est.resolve_cold(ctx.bodies, &res.last)?;
    signals::enter(before);
    let pending = Pending { parts, in_loop };
    Ok((t.elapsed().as_secs_f64(), Some(pending)))
}

/// The rest of the reported iterate's estimate ([`resolve_reported`]) of `last`, once the
/// bodies' factorisations are freed: its recoveries, its record among the estimates and in the
/// history (a run's `Solution::estimates`, `history`), its monitor line. Its time (s;
/// collective).
#[allow(clippy::too_many_arguments)]
pub fn finish_reported(
    settings: &Settings,
    layout: &Layout,
    stages: &Stages,
    estimator: Option<&Estimator>,
    pending: Option<Pending>,
    last: &Iterate,
    estimates: &mut Vec<EstimateRecord>,
    history: &mut [IterationRecord],
) -> Result<f64, AppError> {
    let (Some(pending), Some(est)) = (pending, estimator) else {
        return Ok(0.0);
    };
    let t = Instant::now();
    let _s = stages.estimation.enter();
    let before = signals::enter(StopPhase::FinalEstimate);
    let rec = est.finish_cold(pending.parts, &last.u)?;
    signals::enter(before);
    if settings.output.monitor && layout.is_root() {
        let again = if pending.in_loop {
            " (cold recovery)"
        } else {
            ""
        };
        println!("{}{again}", monitor::estimate_text(&rec));
    }
    if pending.in_loop {
        estimates.pop();
    }
    keep_for_output(estimates, layout, est);
    estimates.push(rec);
    attach_estimates(history, estimates);
    Ok(t.elapsed().as_secs_f64())
}

/// Before a new estimate joins `estimates`: the newest so far, now kept only for the output,
/// keeps what this rank writes of it alone (its η maps and displacement on its rows of the
/// `bodies` grid, [`EstimateRecord::keep_rows`]; the newest stays whole: an adaptive run's
/// size field reads it).
pub(super) fn keep_for_output(estimates: &mut [EstimateRecord], layout: &Layout, est: &Estimator) {
    if let Some(last) = estimates.last_mut() {
        let problems = est.run_problems();
        let kept = fields::kept_rows(layout, problems);
        let contact = |u: &[Displacement; 2]| fields::contact_displacement(problems, u);
        last.keep_rows(&kept.cells, &kept.nodes, contact);
    }
}

/// Each estimate into the history record of its iteration.
pub(super) fn attach_estimates(history: &mut [IterationRecord], estimates: &[EstimateRecord]) {
    for e in estimates {
        if let Some(h) = history.iter_mut().find(|h| h.iteration == e.iteration) {
            h.eta_glo = Some(e.eta_glo);
            h.eta_fe = Some(e.eta_fe);
            h.eta_nndd = Some(e.eta_nndd);
            h.eta_ratio = Some(e.eta_ratio);
            h.e_ref = e.e_ref;
            h.effectivity = e.effectivity;
        }
    }
}
