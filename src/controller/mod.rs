//! The adaptive controller: picks every `dt`, checks every trial, accepts or rejects it, and
//! says why.
//!
//! ```text
//! dt = min( each limit's proposal,                 (SoundSpeed eq 49, Stability eqs 56–58, user limits)
//!           safety · filter(dsm history),          (TemporalError eqs 20–30, Söderlind filter)
//!           dt_max,  t_end − t,
//!           max_growth · dt_prev   (1 · dt_prev right after a rejected attempt),
//!           η · dt_rejected        (on a retry) )
//! dt = dt_prev   if a limit's proposal binds and dt_prev < dt ≤ hold_growth · dt_prev
//! ```
//!
//! Per attempt: every limit proposes from the committed state, the stepper computes a trial,
//! the controller checks the trial is finite and every limit judges it; all accept ⇒
//! accept, any rejects ⇒ reject and retry with `η · dt` where `η = safety · dsm^(−1/(p+1))`
//! for an error-test failure, the limit's suggestion for other causes (or
//! `reject_shrink`), clamped to `[min_shrink, max_shrink_first]` on the first rejection and
//! `[min_shrink, max_shrink_repeated]` from the second on (SUNDIALS' rules, see
//! [`ControllerConfig`]). A limit's proposal may still bind below `min_shrink`: `dt` never
//! exceeds any limit's proposal. After `max_consecutive_rejections` rejections of one step
//! the run ends with [`ControllerError::TooManyRejections`], carrying the last
//! [`Decision`].
//!
//! Every attempt yields a [`Decision`], emitted as an INFO `tracing` event inside one
//! `step` span per step (DEBUG events carry each limit's proposal and verdict), counted in
//! [`Stats`] and handed back to the caller. The library installs no subscriber.
//!
//! ```no_run
//! use mpm_dt::controller::{Controller, ControllerConfig};
//! # fn demo(stepper: &mut dyn mpm_dt::Stepper) -> Result<(), mpm_dt::controller::ControllerError> {
//! let mut controller = Controller::with_default_limits(ControllerConfig::default(), vec![])?;
//! controller.run_until(stepper, 1.0, &mut |d| println!("{}", d.to_json_line()))?;
//! println!("{:?}", controller.stats());
//! # Ok(()) }
//! ```

mod checkpoint;
mod config;
mod decision;
mod filter;
mod growth;
mod scaled;
mod stats;
mod temporal_error;
mod temporal_kernels;

pub use checkpoint::{Checkpoint, ControllerCheckpoint, ControllerState, LimitCheckpoint};
pub use config::{ConfigError, ControllerConfig};
pub use decision::{bound, metric, Decision, LimitRecord, Outcome};
pub use filter::{FilterPreset, SoderlindFilter, DSM_FLOOR};
pub use growth::{
    checkerboard_share, total_energy, GrowthConfig, GrowthIndicator, GrowthMonitor, GROWTH,
};
pub(crate) use growth::{particle_energy, sum_energy_lanes, ENERGY_LANES};
pub use scaled::SafetyScaled;
pub use stats::Stats;
pub use temporal_error::{TemporalError, TemporalErrorConfig, TEMPORAL_ERROR};

use crate::limit::{LimitError, RejectCause, StepLimit, Verdict};
use crate::stepper::{StepError, Stepper, View};

/// Why the controller stopped.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ControllerError {
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// One step was rejected `count` times in a row.
    #[error("{count} consecutive rejections at t = {t} (last dt = {}, cause {:?})", last.dt, last.cause)]
    TooManyRejections {
        /// Rejections in a row.
        count: u32,
        /// Time of the committed state.
        t: f64,
        /// The last decision.
        last: Box<Decision>,
    },
    /// The step would fall below `dt_min`, or be too small to advance `t` in floating
    /// point (below 64 ulps of `t`).
    #[error("step {dt} too small (dt_min = {dt_min}) at t = {t} (bound by {binding})")]
    StepTooSmall {
        /// The step the rules gave.
        dt: f64,
        /// The configured floor.
        dt_min: f64,
        /// Time of the committed state.
        t: f64,
        /// What bound the step.
        binding: String,
        /// The last decision of this step, if any attempt was made.
        last: Option<Box<Decision>>,
    },
    /// Nothing bounds the first step: no limit proposes one and `dt_initial` is unset.
    #[error("no initial step at t = {t}: no limit proposes a step and dt_initial is not set")]
    NoInitialStep {
        /// Time of the committed state.
        t: f64,
    },
    /// A limit proposed a step that is not a positive number.
    #[error("limit {limit} proposed dt = {dt} at t = {t}")]
    InvalidProposal {
        /// The limit.
        limit: String,
        /// Its proposal.
        dt: f64,
        /// Time of the committed state.
        t: f64,
    },
    /// A limit failed to evaluate.
    #[error("at t = {t}: {source}")]
    Limit {
        /// Time of the committed state.
        t: f64,
        /// The limit's error.
        source: LimitError,
    },
    /// The stepper failed in a way a smaller step cannot fix.
    #[error("at t = {t}: {source}")]
    Stepper {
        /// Time of the committed state.
        t: f64,
        /// The stepper's error.
        source: StepError,
    },
    /// `t_end` is not after the stepper's time, or not a number.
    #[error("t_end = {t_end} is not after t = {t}")]
    InvalidEnd {
        /// Time of the committed state.
        t: f64,
        /// The requested end.
        t_end: f64,
    },
    /// A checkpoint does not fit the controller's limits.
    #[error("cannot restore checkpoint: {message}")]
    Restore {
        /// What does not fit.
        message: String,
    },
}

/// The adaptive controller. Owns its config, limits, filter and statistics; drives any
/// `&mut dyn Stepper`.
pub struct Controller {
    config: ControllerConfig,
    limits: Vec<Box<dyn StepLimit>>,
    state: ControllerState,
}

impl std::fmt::Debug for Controller {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Controller")
            .field("config", &self.config)
            .field(
                "limits",
                &self.limits.iter().map(|l| l.name()).collect::<Vec<_>>(),
            )
            .field("state", &self.state)
            .finish()
    }
}

/// Relative tolerance under which `t` counts as having reached `t_end`.
fn reached(t: f64, t_end: f64) -> bool {
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

/// The first non-finite value of the trial's `x`, `v`, `σ`, `F` (in that order), if any.
///
/// Runs on every trial: a trusted pass summary is the stepper's guarantee that the trial is
/// finite (`crate::pass_summary`); else a vectorised pass per field confirms the normal
/// case (all finite) and only a failing field is searched element by element for the first
/// bad index.
pub(crate) fn first_nonfinite(view: &View<'_>) -> Option<(&'static str, usize, f64)> {
    if view.trusted_summary().is_some() {
        return None;
    }
    if [view.x, view.v, view.sigma, view.f]
        .into_iter()
        .all(crate::stability::all_finite)
    {
        return None;
    }
    for (name, field) in [
        ("x", view.x),
        ("v", view.v),
        ("sigma", view.sigma),
        ("F", view.f),
    ] {
        if let Some((i, &v)) = field.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Some((name, i, v));
        }
    }
    None
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

impl Controller {
    /// A controller with exactly these limits.
    pub fn new(
        config: ControllerConfig,
        limits: Vec<Box<dyn StepLimit>>,
    ) -> Result<Self, ControllerError> {
        config.validate()?;
        let state = ControllerState {
            dt_prev: None,
            no_growth_next: false,
            prev_landed: false,
            filter: SoderlindFilter::new(config.filter, config.order),
            stats: Stats::default(),
            safety_scale: 1.0,
        };
        Ok(Self {
            config,
            limits,
            state,
        })
    }

    /// A controller with `limits` (e.g. the sound-speed and stability limits, users' own)
    /// followed by the [`TemporalError`] limit and the [`GrowthMonitor`] when the config
    /// enables them.
    pub fn with_default_limits(
        config: ControllerConfig,
        mut limits: Vec<Box<dyn StepLimit>>,
    ) -> Result<Self, ControllerError> {
        config.validate()?;
        if config.temporal.enabled {
            limits.push(Box::new(TemporalError::new(config.temporal.clone())?));
        }
        if config.growth.enabled {
            limits.push(Box::new(GrowthMonitor::new(config.growth.clone())?));
        }
        Self::new(config, limits)
    }

    /// The standard mpm-dt controller: the three limits of the paper — the
    /// [`crate::stability::SoundSpeed`] cap (eq 49 with `|v|`), the
    /// [`crate::stability::Stability`] limit (eqs 56–58, tracked λmax), the [`TemporalError`]
    /// (eqs 20–30) — and the [`GrowthMonitor`], each as `config` enables and sets it.
    /// Users add their own limits with [`Controller::with_default_limits`].
    pub fn standard(config: ControllerConfig) -> Result<Self, ControllerError> {
        config.validate()?;
        let mut limits: Vec<Box<dyn StepLimit>> = Vec::new();
        // Both configs were validated just above, so construction cannot fail; map anyway.
        let invalid = |e: crate::stability::StabilityError| {
            ControllerError::Config(ConfigError::Parse {
                message: e.to_string(),
            })
        };
        if let Some(c) = config.sound_speed {
            limits.push(Box::new(
                crate::stability::SoundSpeed::new(c).map_err(invalid)?,
            ));
        }
        if let Some(c) = config.stability {
            limits.push(Box::new(
                crate::stability::Stability::new(c).map_err(invalid)?,
            ));
        }
        Self::with_default_limits(config, limits)
    }

    /// The configuration.
    pub fn config(&self) -> &ControllerConfig {
        &self.config
    }

    /// Run statistics so far.
    pub fn stats(&self) -> &Stats {
        &self.state.stats
    }

    /// The controller's state (filter, last step, statistics).
    pub fn state(&self) -> &ControllerState {
        &self.state
    }

    /// Names of the limits in order.
    pub fn limit_names(&self) -> Vec<String> {
        self.limits.iter().map(|l| l.name().to_string()).collect()
    }

    /// Saves the controller's state and its limits' states.
    pub fn checkpoint(&self) -> ControllerCheckpoint {
        ControllerCheckpoint {
            config: self.config.clone(),
            state: self.state.clone(),
            limits: self
                .limits
                .iter()
                .map(|l| LimitCheckpoint {
                    name: l.name().to_string(),
                    state: l.save_state(),
                })
                .collect(),
        }
    }

    /// Rebuilds a controller from a checkpoint and freshly constructed limits (same names,
    /// same order as when it was saved); each limit's state is restored.
    pub fn restore(
        checkpoint: ControllerCheckpoint,
        mut limits: Vec<Box<dyn StepLimit>>,
    ) -> Result<Self, ControllerError> {
        checkpoint.config.validate()?;
        if limits.len() != checkpoint.limits.len() {
            return Err(ControllerError::Restore {
                message: format!(
                    "checkpoint has {} limits, {} given",
                    checkpoint.limits.len(),
                    limits.len()
                ),
            });
        }
        for (limit, saved) in limits.iter_mut().zip(&checkpoint.limits) {
            if limit.name() != saved.name {
                return Err(ControllerError::Restore {
                    message: format!("expected limit {}, got {}", saved.name, limit.name()),
                });
            }
            if let Some(s) = &saved.state {
                limit
                    .restore_state(s)
                    .map_err(|e| ControllerError::Restore {
                        message: e.to_string(),
                    })?;
            }
        }
        Ok(Self {
            config: checkpoint.config,
            limits,
            state: checkpoint.state,
        })
    }

    /// Advances until the stepper reaches `t_end`, calling `on_decision` for every attempt.
    pub fn run_until(
        &mut self,
        stepper: &mut dyn Stepper,
        t_end: f64,
        on_decision: &mut dyn FnMut(&Decision),
    ) -> Result<&Stats, ControllerError> {
        if t_end.is_nan() {
            return Err(ControllerError::InvalidEnd {
                t: stepper.time(),
                t_end,
            });
        }
        while !reached(stepper.time(), t_end) {
            for d in self.step(stepper, t_end)? {
                on_decision(&d);
            }
        }
        Ok(&self.state.stats)
    }

    /// Advances one accepted step towards `t_end` (never past it), retrying rejected
    /// attempts. Returns every attempt's decision; the last one is the accepted step.
    pub fn step(
        &mut self,
        stepper: &mut dyn Stepper,
        t_end: f64,
    ) -> Result<Vec<Decision>, ControllerError> {
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
        let mut decisions: Vec<Decision> = Vec::new();
        let mut retry_cap: Option<f64> = None;
        let mut rejections: u32 = 0;
        loop {
            let attempt = rejections + 1;
            // 1. Proposals from the committed state.
            let view = stepper.view();
            let mut records = Vec::with_capacity(self.limits.len());
            let mut bounds: Vec<(BoundName, f64)> = Vec::with_capacity(self.limits.len() + 5);
            for (index, limit) in self.limits.iter_mut().enumerate() {
                let p = limit
                    .propose(&view)
                    .map_err(|source| ControllerError::Limit { t, source })?;
                if p.dt.is_nan() || p.dt <= 0.0 {
                    return Err(ControllerError::InvalidProposal {
                        limit: limit.name().to_string(),
                        dt: p.dt,
                        t,
                    });
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
            if bounds.is_empty() {
                return Err(ControllerError::NoInitialStep { t });
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
            let binding = match binding_of {
                BoundName::Limit(i) => self.limits[i].name().to_string(),
                BoundName::Named(name) => name.to_string(),
            };
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
                    last: decisions.pop().map(Box::new),
                });
            }
            // 3. The trial.
            let mut cause: Option<RejectCause> = None;
            let mut rejected_by: Option<String> = None;
            let mut message: Option<String> = None;
            let mut suggested: Option<f64> = None;
            match stepper.try_step(dt) {
                Err(e @ (StepError::InvalidDt { .. } | StepError::NoTrial)) => {
                    return Err(ControllerError::Stepper { t, source: e });
                }
                Err(e) => {
                    cause = Some(RejectCause::NonFinite);
                    rejected_by = Some("stepper".to_string());
                    message = Some(e.to_string());
                }
                Ok(()) => {
                    let before = stepper.view();
                    let Some(after) = stepper.trial_view() else {
                        return Err(ControllerError::Stepper {
                            t,
                            source: StepError::NoTrial,
                        });
                    };
                    if let Some((field, index, value)) = first_nonfinite(&after) {
                        cause = Some(RejectCause::NonFinite);
                        rejected_by = Some("state".to_string());
                        message = Some(format!(
                            "non-finite {field} at particle {index} (value {value})"
                        ));
                    } else {
                        for (limit, rec) in self.limits.iter_mut().zip(records.iter_mut()) {
                            let j = match limit.judge(&before, &after, dt) {
                                Ok(j) => j,
                                Err(source) => {
                                    stepper.reject();
                                    return Err(ControllerError::Limit { t, source });
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
                        if cause.is_none() {
                            for limit in self.limits.iter_mut() {
                                limit.accepted(&before, &after, dt);
                            }
                        }
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
            match cause {
                None => {
                    stepper
                        .accept()
                        .map_err(|source| ControllerError::Stepper { t, source })?;
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
                    decisions.push(decision);
                    return Ok(decisions);
                }
                Some(c) => {
                    stepper.reject();
                    for limit in self.limits.iter_mut() {
                        limit.rejected(dt, c);
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
                    retry_cap = Some(eta * dt);
                    decisions.push(decision);
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
                verdict = ?l.verdict,
                metrics = ?l.metrics,
                "limit"
            );
        }
        tracing::debug!(decision = d.to_json_line().as_str(), "decision");
    }
}
