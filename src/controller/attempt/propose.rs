//! Phases 1–2 of an attempt: every limit proposes from the committed state, the named
//! bounds join them, the smallest wins (held within the hold band), and the processes
//! agree on it.

use super::super::{bound, Controller, ControllerError, Decision, LimitRecord};
use super::BoundName;
use crate::dimension::{Dim, Dimension};

/// What the limits and the controller's own bounds say before a trial.
pub(super) struct Proposals {
    /// One record per limit that proposed (its proposal and metrics; verdicts come later).
    pub records: Vec<LimitRecord>,
    /// Every finite bound on `dt`, limits first, in the order they win ties.
    pub bounds: Vec<(BoundName, f64)>,
    /// The first error before the trial, held until the processes have agreed.
    pub pre_error: Option<ControllerError>,
    /// The filter's proposal times the safety, when it has one.
    pub filter_dt: Option<f64>,
}

/// The step an attempt tries.
pub(super) struct Chosen {
    /// The step.
    pub dt: f64,
    /// What bound it: a limit's name or one of [`bound`]'s.
    pub binding: String,
    /// Whether it lands on `t_end`.
    pub last_step: bool,
}

impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// Phase 1: every limit's proposal from the committed `view` at time `t`. After an
    /// error the remaining limits still propose (their reductions must run on every
    /// process); the first error is kept.
    pub(super) fn propose(&mut self, view: &<Dim<D> as Dimension>::View<'_>, t: f64) -> Proposals {
        let mut records = Vec::with_capacity(self.limits.len());
        let mut bounds: Vec<(BoundName, f64)> = Vec::with_capacity(self.limits.len() + 5);
        let mut pre_error: Option<ControllerError> = None;
        for (index, limit) in self.limits.iter_mut().enumerate() {
            let p = match limit.propose(view) {
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
        Proposals {
            records,
            bounds,
            pre_error,
            filter_dt: None,
        }
    }

    /// The controller's own bounds after the limits': the filter, `dt_max`, the growth cap
    /// (or `dt_initial` on the first step), the retry cap after a rejection, and the time
    /// left to `t_end` (`remaining`).
    pub(super) fn add_named_bounds(
        &self,
        p: &mut Proposals,
        retry_cap: Option<f64>,
        t: f64,
        remaining: f64,
    ) {
        p.filter_dt = self
            .state
            .filter
            .proposal()
            .map(|h| self.config.safety * h)
            .filter(|h| h.is_finite() && *h > 0.0);
        if let Some(h) = p.filter_dt {
            p.bounds.push((BoundName::Named(bound::FILTER), h));
        }
        if let Some(m) = self.config.dt_max {
            p.bounds.push((BoundName::Named(bound::DT_MAX), m));
        }
        if let Some(prev) = self.state.dt_prev {
            let g = if self.state.no_growth_next {
                1.0
            } else {
                self.config.max_growth
            };
            p.bounds
                .push((BoundName::Named(bound::GROWTH_CAP), g * prev));
        } else if let Some(d0) = self.config.dt_initial {
            p.bounds.push((BoundName::Named(bound::DT_INITIAL), d0));
        }
        if let Some(r) = retry_cap {
            p.bounds.push((BoundName::Named(bound::RETRY), r));
        }
        if p.bounds.is_empty() && p.pre_error.is_none() {
            p.pre_error = Some(ControllerError::NoInitialStep { t });
        }
        p.bounds.push((BoundName::Named(bound::T_END), remaining));
    }

    /// Phase 2: the smallest bound (first listed on a tie), held at the previous step
    /// within the hold band, agreed over the processes and kept within `t_end`; an error
    /// held from phase 1 or a step too small to take ends the run (`last` is the previous
    /// attempt's decision, for the error).
    pub(super) fn choose_step(
        &self,
        p: &mut Proposals,
        t: f64,
        t_end: f64,
        last: &mut Option<Decision>,
    ) -> Result<Chosen, ControllerError> {
        let (mut binding_of, mut dt) = (BoundName::Named(""), f64::INFINITY);
        for &(name, b) in &p.bounds {
            if b < dt {
                dt = b;
                binding_of = name;
            }
        }
        // Hold the previous step when a limit's proposal binds and would let it grow only
        // within the hold band (ControllerConfig::hold_growth). Not when a named bound (the
        // filter, smooth by design; dt_max; t_end; …) ties with it, and not a previous step
        // that was shortened to land on an end time.
        if let (Some(prev), false) = (self.state.dt_prev, self.state.prev_landed) {
            let by_limit = matches!(binding_of, BoundName::Limit(_))
                && !p.bounds.iter().any(|&(name, b)| {
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
        // The processes agree: the smallest step of all, or the end of the run if any of
        // them failed.
        let failed = p.pre_error.is_some();
        let local_dt = if failed { f64::INFINITY } else { dt };
        let (global_dt, any_failed) = self.reduce.min_and_any(local_dt, failed);
        if any_failed {
            return Err(p.pre_error.take().unwrap_or(ControllerError::OtherRank {
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
        // A step that cannot move `t` (below 64 ulps of t) is as fatal as one below dt_min
        // (SUNDIALS: "t + h = t").
        let stalls = dt < 64.0 * f64::EPSILON * t.abs();
        if dt.is_nan() || dt <= 0.0 || ((dt < self.config.dt_min || stalls) && !last_step) {
            return Err(ControllerError::StepTooSmall {
                dt,
                dt_min: self.config.dt_min,
                t,
                binding,
                last: last.take().map(Box::new),
            });
        }
        Ok(Chosen {
            dt,
            binding,
            last_step,
        })
    }
}
