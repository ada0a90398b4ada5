//! One accepted step of the [`Controller`]: proposals, the trial, the verdicts, accept or
//! reject and retry (the rules are in the module docs of [`super`]).

use super::{bound, metric, Controller, ControllerError, Decision, LimitRecord, Outcome};
use crate::dimension::{Dim, Dimension, StateView};
use crate::fmt_num::Num;
use crate::limit::{RejectCause, Verdict};
use crate::stepper::{StepError, Stepper};

/// Relative tolerance under which `t` counts as having reached `t_end`.
pub(super) fn reached(t: f64, t_end: f64) -> bool {
    t >= t_end
        || (t_end.is_finite() && (t_end - t) <= 4.0 * f64::EPSILON * t_end.abs().max(t.abs()))
}

/// What a bound on `dt` is: one of the controller's limits (by position) or one of the
/// named [`bound`]s. Kept as this small value while the bounds are compared; the name is
/// copied into a `String` once, for the decision.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BoundName {
    /// The limit at this position in the controller's list.
    Limit(usize),
    /// A bound that is not a limit ([`bound`]).
    Named(&'static str),
}

/// Priority of rejection causes when several limits reject one trial.
fn cause_rank(c: RejectCause) -> u8 {
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
    /// Advances one accepted step towards `t_end` (never past it), retrying rejected
    /// attempts; hands every attempt's decision to `on_decision` as it is made.
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
        if self.limits.iter().any(|l| l.reads_nodal_stiffness()) {
            // Cheap to repeat: a stepper that already provides it just keeps its flag.
            stepper.provide_nodal_stiffness(true);
        }
        // The same for the pass summary (`crate::pass_summary`).
        stepper.provide_summary(true);
        let mut last: Option<Decision> = None;
        let mut retry_cap: Option<f64> = None;
        let mut rejections: u32 = 0;
        loop {
            let attempt = rejections + 1;
            // 0. The door: the committed view is checked before any limit reads it.
            let view = stepper.view();
            self.check_committed(&view, attempt)?;
            // 1. Proposals from the committed state.
            let mut records = Vec::with_capacity(self.limits.len());
            let mut bounds: Vec<(BoundName, f64)> = Vec::with_capacity(self.limits.len() + 5);
            // An error before the trial is held until the processes have agreed on the
            // step (`crate::reduce`): every process takes part in every reduction.
            let mut pre_error: Option<ControllerError> = None;
            for (index, limit) in self.limits.iter_mut().enumerate() {
                // After an error the remaining limits still propose (their reductions must
                // run on every process); the first error is kept.
                let p = match limit.propose(&view) {
                    Ok(p) => p,
                    Err(source) => {
                        pre_error.get_or_insert(ControllerError::Limit { t, source });
                        continue;
                    }
                };
                if p.dt.is_nan() || p.dt <= 0.0 {
                    pre_error.get_or_insert(ControllerError::InvalidProposal {
                        limit: limit.name().to_string(),
                        dt: p.dt,
                        t,
                    });
                    continue;
                }
                let mut metrics = p.metrics;
                metrics.retain(|_, v| v.is_finite());
                if p.dt.is_finite() {
                    bounds.push((BoundName::Limit(index), p.dt));
                }
                records.push(LimitRecord {
                    name: limit.name().to_string(),
                    proposal: p.dt.is_finite().then_some(p.dt),
                    verdict: None,
                    metrics,
                });
            }
            // The view borrows the stepper; a dimension's view type may have drop glue, so
            // end the borrow before the trial.
            drop(view);
            let filter_dt = self
                .state
                .filter
                .proposal()
                .map(|h| self.config.safety * h)
                .filter(|h| h.is_finite() && *h > 0.0);
            if let Some(h) = filter_dt {
                bounds.push((BoundName::Named(bound::FILTER), h));
            }
            if let Some(m) = self.config.dt_max {
                bounds.push((BoundName::Named(bound::DT_MAX), m));
            }
            if let Some(prev) = self.state.dt_prev {
                let g = if self.state.no_growth_next {
                    1.0
                } else {
                    self.config.max_growth
                };
                bounds.push((BoundName::Named(bound::GROWTH_CAP), g * prev));
            } else if let Some(d0) = self.config.dt_initial {
                bounds.push((BoundName::Named(bound::DT_INITIAL), d0));
            }
            if let Some(r) = retry_cap {
                bounds.push((BoundName::Named(bound::RETRY), r));
            }
            if bounds.is_empty() && pre_error.is_none() {
                pre_error = Some(ControllerError::NoInitialStep { t });
            }
            let remaining = t_end - t;
            bounds.push((BoundName::Named(bound::T_END), remaining));
            // 2. The smallest bound wins (first listed on a tie).
            let (mut binding_of, mut dt) = (BoundName::Named(""), f64::INFINITY);
            for &(name, b) in &bounds {
                if b < dt {
                    dt = b;
                    binding_of = name;
                }
            }
            // 2b. Hold the previous step when a limit's proposal binds and would let it
            // grow only within the hold band (ControllerConfig::hold_growth). Not when a
            // named bound (the filter, smooth by design; dt_max; t_end; …) ties with it,
            // and not a previous step that was shortened to land on an end time.
            if let (Some(prev), false) = (self.state.dt_prev, self.state.prev_landed) {
                let by_limit = matches!(binding_of, BoundName::Limit(_))
                    && !bounds.iter().any(|&(name, b)| {
                        matches!(name, BoundName::Named(_)) && b.to_bits() == dt.to_bits()
                    });
                if by_limit && dt > prev && dt <= self.config.hold_growth * prev {
                    dt = prev;
                    binding_of = BoundName::Named(bound::HOLD);
                }
            }
            let mut binding = match binding_of {
                BoundName::Limit(i) => self.limits[i].name().to_string(),
                BoundName::Named(name) => name.to_string(),
            };
            // 2c. The processes agree: the smallest step of all, or the end of the run if
            // any of them failed.
            let local_dt = if pre_error.is_some() {
                f64::INFINITY
            } else {
                dt
            };
            let (global_dt, any_failed) = self.reduce.min_and_any(local_dt, pre_error.is_some());
            if any_failed {
                return Err(pre_error.unwrap_or(ControllerError::OtherRank {
                    t,
                    phase: "before its trial",
                }));
            }
            if global_dt < dt {
                dt = global_dt;
                binding = bound::OTHER_RANK.to_string();
            }
            while t + dt > t_end && dt > 0.0 {
                dt = dt.next_down();
            }
            let last_step = binding == bound::T_END;
            // A step that cannot move `t` (below 64 ulps of t) is as fatal as one below
            // dt_min (SUNDIALS: "t + h = t").
            let stalls = dt < 64.0 * f64::EPSILON * t.abs();
            if dt.is_nan() || dt <= 0.0 || ((dt < self.config.dt_min || stalls) && !last_step) {
                return Err(ControllerError::StepTooSmall {
                    dt,
                    dt_min: self.config.dt_min,
                    t,
                    binding,
                    last: last.map(Box::new),
                });
            }
            // 3. The trial.
            let mut cause: Option<RejectCause> = None;
            let mut rejected_by: Option<String> = None;
            let mut message: Option<String> = None;
            let mut suggested: Option<f64> = None;
            let mut limit_error = None;
            let mut fatal: Option<ControllerError> = None;
            match stepper.try_step(dt) {
                // A smaller step can cure these; anything else (an invalid dt, no trial, a
                // solver-specific failure) it cannot, and the run ends at once.
                Err(
                    e @ (StepError::NonFinite { .. }
                    | StepError::OutOfDomain { .. }
                    | StepError::Inverted { .. }
                    | StepError::Failed { .. }),
                ) => {
                    cause = Some(RejectCause::NonFinite);
                    rejected_by = Some("stepper".to_string());
                    message = Some(e.to_string());
                }
                Err(e) => {
                    fatal = Some(ControllerError::Stepper { t, source: e });
                }
                Ok(()) => 'trial: {
                    let before = stepper.view();
                    let Some(after) = stepper.trial_view() else {
                        fatal = Some(ControllerError::Stepper {
                            t,
                            source: StepError::NoTrial,
                        });
                        break 'trial;
                    };
                    if let Some(e) = super::door::check_trial(&after) {
                        fatal = Some(e);
                        break 'trial;
                    }
                    if let Some((field, index, value)) = after.first_nonfinite() {
                        cause = Some(RejectCause::NonFinite);
                        rejected_by = Some("state".to_string());
                        message = Some(format!(
                            "non-finite {field} at particle {index} (value {})",
                            Num(value)
                        ));
                    } else {
                        for (limit, rec) in self.limits.iter_mut().zip(records.iter_mut()) {
                            let j = match limit.judge(&before, &after, dt) {
                                Ok(j) => j,
                                Err(source) => {
                                    limit_error = Some(source);
                                    break;
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
                                let better =
                                    cause.is_none_or(|old| cause_rank(c) < cause_rank(old));
                                if better {
                                    cause = Some(c);
                                    rejected_by = Some(limit.name().to_string());
                                }
                                if let Some(s) = suggested_dt.filter(|s| s.is_finite() && *s > 0.0)
                                {
                                    suggested = Some(suggested.map_or(s, |o: f64| o.min(s)));
                                }
                            }
                            rec.verdict = Some(j.verdict);
                        }
                    }
                }
            }
            if let Some(source) = limit_error {
                fatal = Some(ControllerError::Limit { t, source });
            }
            // 4. The processes agree on the verdict: any fatal failure ends the run
            // everywhere, any rejection rejects everywhere.
            // A growth detection that would take the safety below its floor ends the run
            // (`GrowthConfig::min_safety_scale`); agreed with the rest, so that every
            // process stops at the same trial.
            let growth_stop = cause == Some(RejectCause::Growth)
                && self.state.safety_scale * self.config.growth.safety_factor
                    < self.config.growth.min_safety_scale;
            let mut flags = [fatal.is_some(), cause.is_some(), growth_stop];
            self.reduce.any_flags(&mut flags);
            if flags[0] {
                stepper.reject();
                return Err(fatal.unwrap_or(ControllerError::OtherRank {
                    t,
                    phase: "in its trial",
                }));
            }
            if flags[1] && cause.is_none() {
                cause = Some(RejectCause::OtherRank);
                rejected_by = Some(bound::OTHER_RANK.to_string());
            }
            if cause.is_none() {
                let before = stepper.view();
                if let Some(after) = stepper.trial_view() {
                    for limit in self.limits.iter_mut() {
                        limit.accepted(&before, &after, dt);
                    }
                }
            }
            let dsm = records
                .iter()
                .filter_map(|r| r.metrics.get(metric::DSM).copied())
                .reduce(f64::max);
            let decision = Decision {
                step,
                attempt,
                t,
                dt,
                filter_dt,
                binding,
                bound58: records
                    .iter()
                    .find_map(|r| r.metrics.get(metric::BOUND58).copied()),
                lambda_max: records
                    .iter()
                    .find_map(|r| r.metrics.get(metric::LAMBDA_MAX).copied()),
                dsm,
                limits: records,
                outcome: if cause.is_none() {
                    Outcome::Accepted
                } else {
                    Outcome::Rejected
                },
                cause,
                rejected_by,
                message,
            };
            self.state.stats.record(&decision);
            emit(&decision);
            on_decision(&decision);
            match cause {
                None => {
                    stepper
                        .accept()
                        .map_err(|source| ControllerError::Stepper { t, source })?;
                    let t_after = stepper.time();
                    let tolerance = 1e-6 * dt + 8.0 * f64::EPSILON * (t + dt).abs();
                    if t_after.is_nan() || t_after <= t || (t_after - (t + dt)).abs() > tolerance {
                        return Err(ControllerError::NoProgress { t, dt, t_after });
                    }
                    let accuracy_bound = decision.binding == bound::FILTER || filter_dt.is_none();
                    if let Some(e) = dsm {
                        if accuracy_bound {
                            self.state.filter.record(dt, e);
                        } else {
                            self.state.filter.restart(dt, e);
                        }
                    }
                    self.state.dt_prev = Some(dt);
                    self.state.prev_landed = last_step;
                    self.state.no_growth_next = rejections > 0;
                    return Ok(());
                }
                Some(c) => {
                    stepper.reject();
                    for limit in self.limits.iter_mut() {
                        limit.rejected(dt, c);
                    }
                    if flags[2] {
                        // The energy keeps growing however far the safety is lowered: stop
                        // with the reason rather than crawl on ever smaller steps.
                        return Err(if growth_stop {
                            ControllerError::GrowthPersists {
                                t,
                                step,
                                detections: self.state.stats.growth_events,
                                safety_scale: self.state.safety_scale,
                                min_safety_scale: self.config.growth.min_safety_scale,
                            }
                        } else {
                            ControllerError::OtherRank {
                                t,
                                phase: "with growth persisting",
                            }
                        });
                    }
                    if c == RejectCause::Growth {
                        let f = self.config.growth.safety_factor;
                        for limit in self.limits.iter_mut() {
                            limit.scale_safety(f);
                        }
                        self.state.safety_scale *= f;
                        tracing::warn!(
                            step,
                            t,
                            dt,
                            safety_scale = self.state.safety_scale,
                            "growth detected: stability safety lowered for the rest of the run"
                        );
                    }
                    rejections += 1;
                    if rejections >= self.config.max_consecutive_rejections {
                        return Err(ControllerError::TooManyRejections {
                            count: rejections,
                            t,
                            last: Box::new(decision),
                        });
                    }
                    let eta = match (c, dsm) {
                        (RejectCause::Error, Some(e)) => {
                            self.config.safety * self.state.filter.retry_factor(e)
                        }
                        _ => suggested.map_or(self.config.reject_shrink, |s| s / dt),
                    };
                    let hi = if rejections >= 2 {
                        self.config.max_shrink_repeated
                    } else {
                        self.config.max_shrink_first
                    };
                    let eta = if eta.is_nan() {
                        self.config.min_shrink
                    } else {
                        eta.clamp(self.config.min_shrink, hi)
                    };
                    // The same retry step on every process.
                    retry_cap = Some(self.reduce.min_and_any(eta * dt, false).0);
                    last = Some(decision);
                }
            }
        }
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
