//! Phase 5 of an attempt: the agreed outcome carried out — the trial committed and the
//! filter told, or the trial dropped, the safety lowered after growth, and the retry's
//! step chosen.

use super::super::{bound, metric, Controller, ControllerError, Decision};
use crate::dimension::{Dim, Dimension};
use crate::limit::RejectCause;
use crate::stepper::Stepper;

impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// Commits the accepted trial of `decision` (from `t`) and records its step and `dsm`
    /// for the next proposal; `after_rejection` forbids the next step to grow.
    pub(super) fn commit(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        decision: &Decision,
        last_step: bool,
        after_rejection: bool,
    ) -> Result<(), ControllerError> {
        let (t, dt) = (decision.t, decision.dt);
        stepper
            .accept()
            .map_err(|source| ControllerError::Stepper { t, source })?;
        let t_after = stepper.time();
        let tolerance = 1e-6 * dt + 8.0 * f64::EPSILON * (t + dt).abs();
        if t_after.is_nan() || t_after <= t || (t_after - (t + dt)).abs() > tolerance {
            return Err(ControllerError::NoProgress { t, dt, t_after });
        }
        let accuracy_bound = decision.binding == bound::FILTER || decision.filter_dt.is_none();
        if let Some(e) = decision.dsm {
            if accuracy_bound {
                self.state.filter.record(dt, e);
            } else {
                self.state.filter.restart(dt, e);
            }
        }
        self.state.dt_prev = Some(dt);
        self.state.prev_landed = last_step;
        self.state.no_growth_next = after_rejection;
        Ok(())
    }

    /// Drops the rejected trial of `decision` (cause `c`, the `rejections`-th in a row)
    /// and returns the retry's cap on `dt`: the filter's retry factor after an error-test
    /// failure, else the limits' `suggested` step or `reject_shrink`, clamped to the
    /// shrink bounds and agreed over the processes. A growth detection lowers every
    /// limit's safety; `growth_stop` (agreed) or too many rejections end the run.
    pub(super) fn retry(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        decision: Decision,
        c: RejectCause,
        rejections: u32,
        suggested: Option<f64>,
        growth_stop: (bool, bool),
    ) -> Result<(f64, Decision), ControllerError> {
        let (t, dt, step) = (decision.t, decision.dt, decision.step);
        stepper.reject();
        for limit in self.limits.iter_mut() {
            limit.rejected(dt, c);
        }
        let (any_growth_stop, mine) = growth_stop;
        if any_growth_stop {
            // The energy keeps growing however far the safety is lowered: stop with the
            // reason rather than crawl on ever smaller steps.
            return Err(if mine {
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
        if rejections >= self.config.max_consecutive_rejections {
            return Err(ControllerError::TooManyRejections {
                count: rejections,
                t,
                last: Box::new(decision),
            });
        }
        let eta = match (c, decision.dsm) {
            (RejectCause::Error, Some(e)) => self.config.safety * self.state.filter.retry_factor(e),
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
        Ok((self.reduce.min_and_any(eta * dt, false).0, decision))
    }
}

/// The largest `dsm` the limits reported for a trial, if any.
pub(super) fn dsm_of(records: &[super::super::LimitRecord]) -> Option<f64> {
    records
        .iter()
        .filter_map(|r| r.metrics.get(metric::DSM).copied())
        .reduce(f64::max)
}
