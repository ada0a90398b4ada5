//! Deferred temporal-error checks of [`super::TemporalError<D>`](super::TemporalError), the
//! same in every dimension (1D [`crate::controller::TemporalError`], 2D/3D
//! [`crate::limits_nd::TemporalErrorNd`]).
//!
//! At a stable step the temporal error is usually far below its tolerance — the paper (its
//! introduction and the close of Section 3, after Steffen et al. \[12\]) notes that spatial
//! errors dominate at stable steps — and checking it reads every particle of both states
//! and the previous rates. So after a checked, accepted step with `dsm ≤ θ`
//! ([`super::TemporalErrorConfig::defer_below`], 0.1) the next trials' checks are
//! deferred: 1 after the first such step, then 2, 4, … up to
//! [`super::TemporalErrorConfig::max_deferred`] (8), each only while the prediction
//! `dsm·(dt/dt_checked)²` (the local error is second order in the step) stays at most θ.
//! A check with `dsm > θ`, and any rejection, ends the deferral: the next trial is checked.
//!
//! A deferred trial is accepted by the limit without reading the particles (its judgement
//! carries `dsm_predicted`, no `dsm`); the history stays, and the next check spans the
//! deferred steps: with `gap` their total length, the rates `r` at the midpoints of their
//! steps give
//!
//! ```text
//! d²u_p/dt² ≈ (r_p − r_p^{prev}) / (dt/2 + gap + dt₋/2)
//! ```
//!
//! the every-step form when `gap = 0`: the second derivative *averaged* over up to
//! `max_deferred + 2` steps, and the field scales of the weights are the last checked
//! step's (if the fields shrank since, the test is that much looser).
//!
//! **What this gives up.** The error of a deferred step is not measured. A second
//! derivative that jumps by more than `1/θ` within the deferral (an impact starting
//! mid-way) is seen at the next check, up to `max_deferred` steps late and diluted by the
//! span, and not rejected before; a short event that starts and ends inside a deferral may
//! not be seen at all. Non-finite values in a trial are still caught on every step by the
//! controller's own scan of the trial, before any limit judges it. The controller's filter
//! is not fed on a deferred step; the next check enters its history as if it followed the
//! last checked step (filters with step-ratio terms take that ratio across the deferred
//! steps). `max_deferred: 0` checks every trial, as the paper's controller does.

use super::TemporalErrorConfig;
use crate::limit::metric;
use crate::limit::{Judgement, Metrics, Verdict};
use serde::{Deserialize, Serialize};

/// Checks deferred in a row at most, by default ([`super::TemporalErrorConfig`]).
pub const DEFAULT_MAX_DEFERRED: u32 = 8;

/// How many of the trials after a checked step skip their check, and how much time the
/// deferred ones took (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Deferral {
    /// The checked step's `dsm` (finite: a non-finite one is stored as `f64::MAX`).
    pub dsm: f64,
    /// Checks deferred after it (0, 1, 2, 4, … up to `max_deferred`).
    pub interval: u32,
    /// Of those, the ones still to come.
    pub left: u32,
    /// Time from the end of the checked step to the start of the next trial: the deferred
    /// steps accepted since (0 when the next trial follows the checked step).
    #[serde(default)]
    pub gap: f64,
}

/// The trial whose check was deferred: its start time and step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeferredTrial {
    /// Start time of the trial.
    pub t: f64,
    /// Its step.
    pub dt: f64,
}

impl DeferredTrial {
    /// The judgement of a deferred trial: accepted, with its predicted `dsm` (no `dsm`, so
    /// the controller's filter is not fed).
    pub fn judgement(predicted: f64) -> Judgement {
        let mut metrics = Metrics::new();
        metrics.insert(metric::DSM_PREDICTED.to_string(), predicted);
        Judgement {
            verdict: Verdict::Accept,
            metrics,
        }
    }

    /// Whether the trial starting at `t` with step `dt` is this one (bit for bit).
    pub fn is(&self, t: f64, dt: f64) -> bool {
        self.t.to_bits() == t.to_bits() && self.dt.to_bits() == dt.to_bits()
    }
}

impl Deferral {
    /// The schedule after a checked, accepted step with `dsm`, following a history whose
    /// schedule was `previous`: the interval doubles (0, 1, 2, 4, … up to `max_deferred`)
    /// while `dsm ≤ defer_below`, and drops to 0 (check every trial) otherwise.
    pub fn after_check(previous: Option<Deferral>, dsm: f64, config: &TemporalErrorConfig) -> Self {
        let (below, max) = (config.defer_below, config.max_deferred);
        let interval = if dsm <= below {
            previous
                .map_or(1, |d| d.interval.saturating_mul(2).max(1))
                .min(max)
        } else {
            0
        };
        Self {
            dsm: if dsm.is_finite() { dsm } else { f64::MAX },
            interval,
            left: interval,
            gap: 0.0,
        }
    }

    /// The predicted `dsm` of a trial of step `dt` when its check may be deferred: a
    /// deferred check is left, deferral is on (`max_deferred > 0`) and
    /// `dsm·(dt/dt_checked)² ≤ defer_below`.
    pub fn predict(&self, dt_checked: f64, dt: f64, config: &TemporalErrorConfig) -> Option<f64> {
        let predicted = self.dsm * (dt / dt_checked).powi(2);
        (config.max_deferred > 0 && self.left > 0 && predicted <= config.defer_below)
            .then_some(predicted)
    }

    /// A deferred trial of step `dt` was accepted.
    pub fn spend(&mut self, dt: f64) {
        self.left = self.left.saturating_sub(1);
        self.gap += dt;
    }

    /// A finite non-negative gap and checked `dsm` (what a restored schedule must hold).
    pub fn consistent(&self) -> bool {
        self.gap.is_finite() && self.gap >= 0.0 && self.dsm >= 0.0
    }

    /// Any rejection: the next trial is checked, and the schedule starts again.
    pub fn reset(&mut self) {
        self.interval = 0;
        self.left = 0;
    }

    /// A restored schedule defers no more than `max`.
    pub fn clamp(&mut self, max: u32) {
        self.interval = self.interval.min(max);
        self.left = self.left.min(max);
    }
}

/// A history of rates that carries the deferral schedule after its step (the 1D and the
/// 2D/3D limits keep different rates, the same schedule).
pub trait Scheduled {
    /// The schedule after the history's step.
    fn schedule(&mut self) -> &mut Deferral;

    /// The schedule after the history's step, read.
    fn deferral(&self) -> Deferral;

    /// The step the history's rates were formed over (the last checked step).
    fn step(&self) -> f64;
}

/// `accepted` of a limit for the trial it last judged: when that trial's check was
/// `deferred` and it is the one accepted (started at `t`, step `dt`), the history stays,
/// one step further back, and the deferred time is added to its gap. Returns whether it
/// was so.
pub(crate) fn spend_deferred<H: Scheduled>(
    history: &mut Option<H>,
    deferred: Option<DeferredTrial>,
    t: f64,
    dt: f64,
) -> bool {
    if !deferred.is_some_and(|d| d.is(t, dt)) {
        return false;
    }
    if let Some(h) = history.as_mut() {
        h.schedule().spend(dt);
    }
    true
}

/// After a checked, accepted step: `new` (that step's rates, its `dsm` in its schedule)
/// becomes the history, with the schedule that follows the check
/// ([`Deferral::after_check`]). Without it the old history is dropped — it would no longer
/// be the last step's — so that the next estimate takes the first-step form. Returns the
/// history replaced, whose arrays the caller reuses.
pub(crate) fn install<H: Scheduled>(
    history: &mut Option<H>,
    new: Option<H>,
    config: &TemporalErrorConfig,
) -> Option<H> {
    match new {
        Some(mut h) => {
            let previous = history.as_mut().map(|o| *o.schedule());
            let dsm = h.schedule().dsm;
            *h.schedule() = Deferral::after_check(previous, dsm, config);
            history.replace(h)
        }
        None => history.take(),
    }
}
