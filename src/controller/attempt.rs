//! One accepted step of the [`Controller`]: proposals, the trial, the verdicts, accept or
//! reject and retry (the rules are in the module docs of [`super`]).

mod judge;
mod outcome;
mod propose;

use super::{bound, metric, Controller, ControllerError, Decision, Outcome};
use crate::dimension::{Dim, Dimension};
use crate::limit::RejectCause;
use crate::stepper::Stepper;

/// Relative tolerance under which `t` counts as having reached `t_end`.
pub(super) fn reached(t: f64, t_end: f64) -> bool {
    t >= t_end
        || (t_end.is_finite() && (t_end - t) <= 4.0 * f64::EPSILON * t_end.abs().max(t.abs()))
}

/// What a bound on `dt` is: one of the controller's limits (by position) or one of the
/// named [`bound`]s. Kept as this small value while the bounds are compared; the name is
/// copied into a `String` once, for the decision.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum BoundName {
    /// The limit at this position in the controller's list.
    Limit(usize),
    /// A bound that is not a limit ([`bound`]).
    Named(&'static str),
}

/// Priority of rejection causes when several limits reject one trial.
pub(super) fn cause_rank(c: RejectCause) -> u8 {
    match c {
        RejectCause::NonFinite => 0,
        RejectCause::Stability => 1,
        RejectCause::Growth => 2,
        RejectCause::Error => 3,
        _ => 4,
    }
}

impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// Whether some limit's next proposal reads the stepper's `K_N`
    /// ([`crate::StepLimit::reads_nodal_stiffness`]).
    fn reads_nodal_stiffness(&self) -> bool {
        self.limits.iter().any(|l| l.reads_nodal_stiffness())
    }

    /// Advances one accepted step towards `t_end` (never past it), retrying rejected
    /// attempts; hands every attempt's decision to `on_decision` as it is made. Each
    /// attempt: the door (the committed view checked), proposals and the step
    /// ([`propose`]), the trial and the verdicts ([`judge`]), the processes' agreement on
    /// the outcome, the decision, and the outcome carried out ([`outcome`]).
    pub(super) fn advance(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        t_end: f64,
        on_decision: &mut dyn FnMut(&Decision),
    ) -> Result<(), ControllerError> {
        let t = stepper.time();
        if t_end.is_nan() || reached(t, t_end) {
            return Err(ControllerError::InvalidEnd { t, t_end });
        }
        let step = stepper.step_count();
        let span = tracing::info_span!("step", step, t);
        let _enter = span.enter();
        // K_N on the committed state when the coming proposal reads it (cheap to repeat: a
        // stepper that already has it keeps it; one that switches it on computes it for
        // this state).
        if self.reads_nodal_stiffness() {
            stepper.provide_nodal_stiffness(true);
        }
        // The same for the pass summary (`crate::pass_summary`).
        stepper.provide_summary(true);
        // A limit serving on the element bound reads K_N only on some states: the stepper
        // is then told before every trial whether the next proposal reads it. Without such
        // a limit the stepper hears nothing more than the call above.
        let on_demand = self.limits.iter().any(|l| l.reads_element_bound());
        // Arrays on demand (`super::on_demand`): loaded only when a call reads them.
        self.arrays_on_demand = self.ask_arrays_on_demand(stepper);
        if on_demand {
            stepper.provide_element_bound(true);
        }
        let mut last: Option<Decision> = None;
        let mut retry_cap: Option<f64> = None;
        let mut rejections: u32 = 0;
        loop {
            let attempt = rejections + 1;
            // A retry proposes on the committed state again, whose K_N the last trial's
            // request may have skipped.
            if on_demand && rejections > 0 && self.reads_nodal_stiffness() {
                stepper.provide_nodal_stiffness(true);
            }
            // 0. The door: the committed view is checked before any limit reads it.
            let view = self.committed_view(stepper, attempt, t)?;
            self.check_committed(&view, attempt)?;
            // 1–2. Proposals from the committed state; the step, agreed.
            let mut proposals = self.propose(&view, t);
            // The view borrows the stepper; a dimension's view type may have drop glue, so
            // end the borrow before the trial.
            drop(view);
            // K_N on the trial's state exactly when the next proposal reads it.
            if on_demand {
                stepper.provide_nodal_stiffness_on_trials(self.reads_nodal_stiffness());
            }
            self.add_named_bounds(&mut proposals, retry_cap, t, t_end - t);
            let chosen = self.choose_step(&mut proposals, t, t_end, &mut last)?;
            let dt = chosen.dt;
            // 3. The trial and the verdicts.
            let mut verdicts = self.judge_trial(stepper, dt, t, &mut proposals.records);
            // 4. The processes agree on the verdict.
            let (growth_stop_anywhere, growth_stop) =
                self.agree_on_verdict(stepper, &mut verdicts, dt, t)?;
            let records = proposals.records;
            let decision = Decision {
                step,
                attempt,
                t,
                dt,
                filter_dt: proposals.filter_dt,
                binding: chosen.binding,
                bound58: records
                    .iter()
                    .find_map(|r| r.metrics.get(metric::BOUND58).copied()),
                lambda_max: records
                    .iter()
                    .find_map(|r| r.metrics.get(metric::LAMBDA_MAX).copied()),
                dsm: outcome::dsm_of(&records),
                limits: records,
                outcome: if verdicts.cause.is_none() {
                    Outcome::Accepted
                } else {
                    Outcome::Rejected
                },
                cause: verdicts.cause,
                rejected_by: verdicts.rejected_by,
                message: verdicts.message,
            };
            self.state.stats.record(&decision);
            emit(&decision);
            on_decision(&decision);
            // 5. The outcome carried out.
            let Some(c) = verdicts.cause else {
                return self.commit(stepper, &decision, chosen.last_step, rejections > 0);
            };
            rejections += 1;
            let growth = (growth_stop_anywhere, growth_stop);
            let (cap, decision) =
                self.retry(stepper, decision, c, rejections, verdicts.suggested, growth)?;
            retry_cap = Some(cap);
            last = Some(decision);
        }
    }

    /// Phase 4: the processes agree on the verdict — any fatal failure ends the run
    /// everywhere, any rejection rejects everywhere — and the limits hear of an accepted
    /// trial. A growth detection that would take the safety below its floor ends the run
    /// (`GrowthConfig::min_safety_scale`); agreed with the rest, so that every process
    /// stops at the same trial. Returns whether some process and whether this one stops
    /// for growth.
    fn agree_on_verdict(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        verdicts: &mut judge::Verdicts,
        dt: f64,
        t: f64,
    ) -> Result<(bool, bool), ControllerError> {
        let growth_stop = verdicts.cause == Some(RejectCause::Growth)
            && self.state.safety_scale * self.config.growth.safety_factor
                < self.config.growth.min_safety_scale;
        let mut flags = [
            verdicts.fatal.is_some(),
            verdicts.cause.is_some(),
            growth_stop,
        ];
        self.reduce.any_flags(&mut flags);
        if flags[0] {
            stepper.reject();
            return Err(verdicts.fatal.take().unwrap_or(ControllerError::OtherRank {
                t,
                phase: "in its trial",
            }));
        }
        if flags[1] && verdicts.cause.is_none() {
            verdicts.cause = Some(RejectCause::OtherRank);
            verdicts.rejected_by = Some(bound::OTHER_RANK.to_string());
        }
        if verdicts.cause.is_none() {
            self.load_to_accept(stepper, dt, t)?;
            let before = stepper.view();
            if let Some(after) = stepper.trial_view() {
                for limit in self.limits.iter_mut() {
                    limit.accepted(&before, &after, dt);
                }
            }
        }
        Ok((flags[2], growth_stop))
    }
}

/// Emits a decision as tracing events: INFO summary, DEBUG per limit and the full record.
/// Fields a decision does not have (`cause` and `rejected_by` of an accepted step, `dsm`,
/// `lambda_max`, `bound58` on a step that did not compute them: `None`) are left out of the
/// event rather than printed as empty strings or NaN.
fn emit(d: &Decision) {
    let outcome = match d.outcome {
        Outcome::Accepted => "accepted",
        Outcome::Rejected => "rejected",
    };
    let cause = d.cause.map(RejectCause::as_str);
    tracing::info!(
        step = d.step,
        attempt = d.attempt,
        t = d.t,
        dt = d.dt,
        outcome,
        cause,
        binding = d.binding.as_str(),
        rejected_by = d.rejected_by.as_deref(),
        dsm = d.dsm,
        lambda_max = d.lambda_max,
        bound58 = d.bound58,
        "{outcome}"
    );
    if tracing::enabled!(tracing::Level::DEBUG) {
        for l in &d.limits {
            tracing::debug!(
                limit = l.name.as_str(),
                proposal = l.proposal,
                verdict = serde_json::to_string(&l.verdict)
                    .unwrap_or_default()
                    .as_str(),
                metrics = serde_json::to_string(&l.metrics)
                    .unwrap_or_default()
                    .as_str(),
                "limit"
            );
        }
        tracing::debug!(decision = d.to_json_line().as_str(), "decision");
    }
}
