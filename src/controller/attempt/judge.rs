//! Phase 3 of an attempt: the stepper's trial and every limit's verdict on it.

use super::super::{Controller, ControllerError, LimitRecord};
use super::cause_rank;
use crate::dimension::{Dim, Dimension, StateView};
use crate::fmt_num::Num;
use crate::limit::{RejectCause, Verdict};
use crate::stepper::{StepError, Stepper};

/// What the trial and the limits' verdicts on it came to, on this process.
#[derive(Default)]
pub(super) struct Verdicts {
    /// The most serious rejection cause, if any ([`cause_rank`]).
    pub cause: Option<RejectCause>,
    /// Who rejected: a limit's name, `"stepper"` or `"state"`.
    pub rejected_by: Option<String>,
    /// The stepper's or the state check's message.
    pub message: Option<String>,
    /// The smallest retry step a rejecting limit suggested.
    pub suggested: Option<f64>,
    /// A failure no smaller step can cure: the run ends.
    pub fatal: Option<ControllerError>,
}

impl Verdicts {
    /// The stepper's error on the trial from `t`: a smaller step can cure a non-finite,
    /// inverted or escaped trial and a `Failed` one (a rejection); anything else (an
    /// invalid dt, no trial, a solver-specific failure) it cannot, and the run ends.
    fn stepper_failed(&mut self, e: StepError, t: f64) {
        match e {
            StepError::NonFinite { .. }
            | StepError::OutOfDomain { .. }
            | StepError::Inverted { .. }
            | StepError::Failed { .. } => {
                self.cause = Some(RejectCause::NonFinite);
                self.rejected_by = Some("stepper".to_string());
                self.message = Some(e.to_string());
            }
            e => self.fatal = Some(ControllerError::Stepper { t, source: e }),
        }
    }
}

impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// Phase 3: the trial of `dt` from the committed state at `t`, checked at the door, for
    /// non-finite values, and judged by every limit (verdicts and metrics into `records`).
    pub(super) fn judge_trial(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        dt: f64,
        t: f64,
        records: &mut [LimitRecord],
    ) -> Verdicts {
        let mut v = Verdicts::default();
        match stepper.try_step(dt) {
            Err(e) => v.stepper_failed(e, t),
            Ok(()) => self.judge_state(stepper, dt, t, records, &mut v),
        }
        v
    }

    /// The verdicts on a trial the stepper computed.
    fn judge_state(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        dt: f64,
        t: f64,
        records: &mut [LimitRecord],
        v: &mut Verdicts,
    ) {
        match self.load_to_judge(stepper, dt) {
            // The trial's arrays: its failure is the trial's, as from `try_step`.
            Err((true, e)) => return v.stepper_failed(e, t),
            Err((false, e)) => return v.fatal = Some(ControllerError::Stepper { t, source: e }),
            Ok(()) => {}
        }
        let before = stepper.view();
        let Some(after) = stepper.trial_view() else {
            v.fatal = Some(ControllerError::Stepper {
                t,
                source: StepError::NoTrial,
            });
            return;
        };
        if let Some(e) = super::super::door::check_trial(&after, self.arrays_on_demand) {
            v.fatal = Some(e);
            return;
        }
        if let Some((field, index, value)) = after.first_nonfinite() {
            v.cause = Some(RejectCause::NonFinite);
            v.rejected_by = Some("state".to_string());
            v.message = Some(format!(
                "non-finite {field} at particle {index} (value {})",
                Num(value)
            ));
            return;
        }
        for (limit, rec) in self.limits.iter_mut().zip(records.iter_mut()) {
            let j = match limit.judge(&before, &after, dt) {
                Ok(j) => j,
                Err(source) => {
                    v.fatal = Some(ControllerError::Limit { t, source });
                    return;
                }
            };
            // JSON cannot carry non-finite values; the names are moved.
            rec.metrics
                .extend(j.metrics.into_iter().filter(|(_, v)| v.is_finite()));
            if let Verdict::Reject {
                cause: c,
                suggested_dt,
            } = j.verdict
            {
                if v.cause.is_none_or(|old| cause_rank(c) < cause_rank(old)) {
                    v.cause = Some(c);
                    v.rejected_by = Some(limit.name().to_string());
                }
                if let Some(s) = suggested_dt.filter(|s| s.is_finite() && *s > 0.0) {
                    v.suggested = Some(v.suggested.map_or(s, |o: f64| o.min(s)));
                }
            }
            rec.verdict = Some(j.verdict);
        }
    }
}
