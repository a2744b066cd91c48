//! The balanced stopping rule (`-nndd_stop balanced`): the NNDD stops at the first estimated
//! iteration where η^NNDD ≤ κ η^FE, where the algebraic error no longer matters next to the
//! discretisation's. η^FE changes little from one iteration to the next while η^NNDD falls, so
//! the rule is checked cheaply first: the discrete η^NNDD from the Γc forces alone
//! ([`Estimator::eta_nndd`], no recovery) against κ times the η^FE of the last full estimate
//! (at the first check, η^FE computed alone). A full estimate is made only when that check
//! says the rule may hold, and its own η^NNDD and η^FE decide, provided they split η^glo
//! consistently ([`CONSISTENT_SPLIT`]).

use super::error::EstimateError;
use super::estimator::{EstimateRecord, Estimator};
use super::settings::NnddVariant;
use crate::dd::body::Body;
use crate::dd::nndd::{Iterate, IterationRecord, StopRule};

/// The largest (η^FE² + η^NNDD²)/η^glo² at which the rule may hold. Where an early iterate's
/// algebraic error sits where η^NNDD does not see it, it shows in η^FE instead, which then
/// exceeds η^glo: the punch of examples/punch-nonmatching (level 3, node to node) at κ = 0.01
/// stopped at iteration 6 with η^FE 554, η^glo 391 (ratio 2.0), where the converged iterate
/// (iteration 11) has η^FE 147 = η^glo (ratio 0.998); the converged ratio is 0.96–1.0 on the
/// examples. η^FE is then no guide to the mesh's error (nor the sizes it asks for).
pub const CONSISTENT_SPLIT: f64 = 1.1;

/// The rule and its state: κ, the η^FE of the last full estimate, the cheap checks made (the
/// state a restart point carries).
#[derive(Clone, Debug)]
pub struct BalancedRule {
    /// κ under `-nndd_stop balanced`; `None` under another stopping rule (the state is kept
    /// all the same, for the restart points).
    ratio: Option<f64>,
    /// The cheap check applies: η^NNDD of the discrete problem (`-nndd_eta_nndd discrete`).
    cheap: bool,
    /// The η^FE of the last full estimate (before any, of the first check).
    last_fe: Option<f64>,
    /// The cheap checks that failed: (iteration, η^NNDD).
    checks: Vec<(usize, f64)>,
}

impl BalancedRule {
    /// The rule of the stopping rule `stop` (κ when balanced) and the η^NNDD `variant`.
    pub fn new(stop: &StopRule, variant: NnddVariant) -> BalancedRule {
        BalancedRule {
            ratio: match stop {
                StopRule::Balanced { ratio } => Some(*ratio),
                _ => None,
            },
            cheap: variant == NnddVariant::Discrete,
            last_fe: None,
            checks: Vec::new(),
        }
    }

    /// The rule continued from a restart point's state.
    pub fn resumed(self, last_fe: Option<f64>, checks: Vec<(usize, f64)>) -> BalancedRule {
        BalancedRule {
            last_fe,
            checks,
            ..self
        }
    }

    /// The η^FE of the last full estimate.
    pub fn last_fe(&self) -> Option<f64> {
        self.last_fe
    }

    /// The cheap checks that failed: (iteration, η^NNDD).
    pub fn checks(&self) -> &[(usize, f64)] {
        &self.checks
    }

    /// Before the fields of `it` are formed (they cost a solve per body): whether the rule may
    /// hold, by the cheap η^NNDD against κ η^FE once an η^FE is known. True where the check
    /// cannot tell: under another rule, the density η^NNDD, before any η^FE, or a body without
    /// its interface operators (whose η^NNDD needs the fields). Collective.
    pub fn may_hold(
        &mut self,
        est: &Estimator,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
    ) -> Result<bool, EstimateError> {
        let (Some(kappa), true, Some(fe)) = (self.ratio, self.cheap, self.last_fe) else {
            return Ok(true);
        };
        if !est.eta_nndd_without_fields(bodies) {
            return Ok(true);
        }
        let nndd = est.eta_nndd(bodies, it)?;
        Ok(self.check(it.iteration, nndd, kappa * fe))
    }

    /// With the fields of `it` formed, before its full estimate: whether the rule may hold, by
    /// the cheap η^NNDD against κ η^FE (the first check computes η^FE alone). True under
    /// another rule or the density η^NNDD. Collective; `Err(Stopped)` for a stop signal.
    pub fn may_hold_with_fields(
        &mut self,
        est: &Estimator,
        bodies: [Option<&Body>; 2],
        it: &Iterate,
    ) -> Result<bool, EstimateError> {
        let (Some(kappa), true) = (self.ratio, self.cheap) else {
            return Ok(true);
        };
        let fe = match self.last_fe {
            Some(fe) => fe,
            None => *self.last_fe.insert(est.eta_fe(bodies, it)?),
        };
        let nndd = est.eta_nndd(bodies, it)?;
        Ok(self.check(it.iteration, nndd, kappa * fe))
    }

    /// After a full estimate `rec`: its η^FE kept for the next checks; whether the rule holds,
    /// η^NNDD ≤ κ η^FE with the split consistent, (η^FE² + η^NNDD²)/η^glo² ≤
    /// [`CONSISTENT_SPLIT`] (the paper's (25)).
    pub fn holds(&mut self, rec: &EstimateRecord) -> bool {
        self.last_fe = Some(rec.eta_fe);
        self.ratio.is_some_and(|kappa| {
            rec.eta_nndd <= kappa * rec.eta_fe && rec.eta_ratio <= CONSISTENT_SPLIT
        })
    }

    /// The checks' η^NNDD into the history, at their iterations.
    pub fn attach_checks(&self, history: &mut [IterationRecord]) {
        for &(iteration, nndd) in &self.checks {
            if let Some(h) = history.iter_mut().find(|h| h.iteration == iteration) {
                h.eta_nndd = Some(nndd);
            }
        }
    }

    /// A cheap check at `iteration`: η^NNDD = `nndd` against `bound` = κ η^FE, kept when it
    /// fails.
    fn check(&mut self, iteration: usize, nndd: f64, bound: f64) -> bool {
        if nndd > bound {
            self.checks.push((iteration, nndd));
            return false;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_check_is_kept_and_attached() {
        let balanced = StopRule::Balanced { ratio: 0.1 };
        let mut rule = BalancedRule::new(&balanced, NnddVariant::Discrete);
        assert!(!rule.check(3, 0.5, 0.1));
        assert!(rule.check(4, 0.1, 0.1));
        assert_eq!(rule.checks(), &[(3, 0.5)]);
        let mut history: Vec<IterationRecord> = [3, 4]
            .map(|iteration| IterationRecord {
                iteration,
                ..Default::default()
            })
            .into();
        rule.attach_checks(&mut history);
        assert_eq!(history[0].eta_nndd, Some(0.5));
        assert_eq!(history[1].eta_nndd, None);
        let resumed = BalancedRule::new(&StopRule::Tol, NnddVariant::Density)
            .resumed(Some(2.0), vec![(1, 3.0)]);
        assert_eq!(resumed.last_fe(), Some(2.0));
        assert_eq!(resumed.checks(), &[(1, 3.0)]);
    }
}
