//! The `Stability` step limit: the tracked eq 56 critical step, checked by eq 58.
//!
//! ```text
//! propose:  dt = safety · dt_eq56,   dt_eq56 = √(2/λmax(B)) = h √(2/(c²_ref λ̂))    (eq 56)
//! judge:    reject if  bound58_W(trial, dt) > 1 + tol                               (eq 58)
//!           or if      dt > (1 + tol) dt_eq56            (a violated stability proposal)
//! ```
//!
//! `λmax(B)` is tracked by [`LambdaMaxTracker`], warm-started from the previous eigenvector at
//! every proposal (so a proposal costs a few `O(nnz)` applications). The eq 58 value is the
//! [`Bound58Reading::Consistent`] reading in the strain-energy norm (default): it is a true
//! lower bound on `ρ(A)`, so a value above 1 *proves* the step's stress amplification
//! unstable — but it stays near 1 while `ρ(A)` grows (see [`mod@super::bound58`]), which is why
//! the proposal, not the bound, does the real work.
//!
//! The eq 58 value is computed on the *trial* state (its stress field, layout and moduli) at
//! the trial's `dt`: the amplification the trial's stress error would see over one more step
//! of the same size. A trial whose stress has no curvature (`Δσ = 0`) carries no information
//! and is not rejected by eq 58.
//!
//! The safety factor can be changed at run time ([`Stability::set_safety`]): the controller's
//! growth monitor lowers it when it sees the slow instability of moving particles.

use super::bound58::{bound58, Bound58Reading};
use super::error::StabilityError;
use super::lambda_max::{LambdaEstimate, LambdaMaxTracker, LanczosConfig};
use super::operator::{Eq56Operator, OperatorBuffers};
use crate::limit::{Judgement, LimitError, Metrics, Proposal, RejectCause, StepLimit, Verdict};
use crate::stepper::View;

/// Settings of [`Stability`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StabilityConfig {
    /// Fraction of `dt_eq56` proposed, in `(0, 1]` (default 0.9). Eq 56 is already
    /// conservative for frozen particles (it ignores the velocity half of the state: up to
    /// ~8 % below the exact frozen critical step); the margin covers moving particles.
    pub safety: f64,
    /// Relative tolerance of the eq 58 test and of the proposal check (default `1e-6`).
    pub tol: f64,
    /// Which reading of eq 58 judges trials (default [`Bound58Reading::Consistent`]).
    pub reading: Bound58Reading,
    /// The Lanczos settings of the λmax tracker.
    pub lanczos: LanczosConfig,
}

impl Default for StabilityConfig {
    fn default() -> Self {
        Self {
            safety: 0.9,
            tol: 1e-6,
            reading: Bound58Reading::Consistent,
            lanczos: LanczosConfig::default(),
        }
    }
}

fn check_safety(safety: f64) -> Result<(), StabilityError> {
    if safety > 0.0 && safety <= 1.0 {
        Ok(())
    } else {
        Err(StabilityError::InvalidConfig {
            field: "safety",
            value: safety,
            reason: "must be in (0, 1]",
        })
    }
}

/// The stability limit (eqs 56 and 58).
#[derive(Clone, Debug, Default)]
pub struct Stability {
    config: StabilityConfig,
    tracker: LambdaMaxTracker,
    buffers: OperatorBuffers,
}

impl Stability {
    /// The limit with the given settings (validated).
    pub fn new(config: StabilityConfig) -> Result<Self, StabilityError> {
        check_safety(config.safety)?;
        if !(config.tol >= 0.0 && config.tol.is_finite()) {
            return Err(StabilityError::InvalidConfig {
                field: "tol",
                value: config.tol,
                reason: "must be non-negative and finite",
            });
        }
        Ok(Self {
            config,
            tracker: LambdaMaxTracker::new(config.lanczos)?,
            buffers: OperatorBuffers::default(),
        })
    }

    /// The settings (with the current safety factor).
    pub fn config(&self) -> StabilityConfig {
        self.config
    }

    /// The current safety factor.
    pub fn safety(&self) -> f64 {
        self.config.safety
    }

    /// Changes the safety factor (must be in `(0, 1]`); the controller's growth monitor
    /// lowers it after detecting growth.
    pub fn set_safety(&mut self, safety: f64) -> Result<(), StabilityError> {
        check_safety(safety)?;
        tracing::debug!(
            old = self.config.safety,
            new = safety,
            "stability safety changed"
        );
        self.config.safety = safety;
        Ok(())
    }

    /// The last λmax estimate (from the last proposal).
    pub fn last_estimate(&self) -> Option<LambdaEstimate> {
        self.tracker.last()
    }

    /// The tracker (e.g. to read the eigenvector).
    pub fn tracker(&self) -> &LambdaMaxTracker {
        &self.tracker
    }

    /// Updates λmax for `state` and returns the estimate.
    pub fn estimate(&mut self, state: &View<'_>) -> Result<LambdaEstimate, StabilityError> {
        let op = Eq56Operator::new_in(state, std::mem::take(&mut self.buffers))?;
        let est = self.tracker.update(&op);
        self.buffers = op.into_buffers();
        est
    }
}

/// What [`StepLimit::save_state`] stores: the safety factor and the tracker's warm start.
#[derive(serde::Serialize, serde::Deserialize)]
struct SavedState {
    safety: f64,
    tracker: super::lambda_max::TrackerState,
}

impl StepLimit for Stability {
    fn name(&self) -> &str {
        "stability"
    }

    /// Multiplies the safety factor by `factor` (ignored unless `0 < factor ≤ 1`).
    fn scale_safety(&mut self, factor: f64) {
        if factor > 0.0 && factor <= 1.0 {
            let new = self.config.safety * factor;
            tracing::debug!(old = self.config.safety, new, "stability safety scaled");
            self.config.safety = new;
        }
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        serde_json::to_value(SavedState {
            safety: self.config.safety,
            tracker: self.tracker.state(),
        })
        .ok()
    }

    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        let saved: SavedState =
            serde_json::from_value(state.clone()).map_err(|e| LimitError::Other {
                limit: "stability".into(),
                message: format!("cannot restore state: {e}"),
            })?;
        check_safety(saved.safety).map_err(|e| e.into_limit_error("stability", f64::NAN))?;
        self.config.safety = saved.safety;
        self.tracker.restore(saved.tracker);
        Ok(())
    }

    fn propose(&mut self, state: &View<'_>) -> Result<Proposal, LimitError> {
        let est = self
            .estimate(state)
            .map_err(|e| e.into_limit_error("stability", state.t))?;
        let dt = self.config.safety * est.dt_eq56;
        let mut metrics = Metrics::new();
        metrics.insert("lambda_max".into(), est.lambda_hat);
        metrics.insert("dt_eq56".into(), est.dt_eq56);
        metrics.insert("lanczos_applications".into(), est.applications as f64);
        metrics.insert("lanczos_residual".into(), est.residual);
        metrics.insert("safety".into(), self.config.safety);
        tracing::debug!(
            t = state.t,
            lambda_max = est.lambda_hat,
            dt_eq56 = est.dt_eq56,
            dt,
            applications = est.applications,
            "stability proposal"
        );
        Ok(Proposal { dt, metrics })
    }

    fn judge(
        &mut self,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        let est = match self.tracker.last() {
            Some(e) => e,
            None => self
                .estimate(before)
                .map_err(|e| e.into_limit_error("stability", before.t))?,
        };
        let b = bound58(after, dt, self.config.reading)
            .map_err(|e| e.into_limit_error("stability", after.t))?;
        let mut metrics = Metrics::new();
        metrics.insert("lambda_max".into(), est.lambda_hat);
        metrics.insert("dt_eq56".into(), est.dt_eq56);
        let mut reject = dt > (1.0 + self.config.tol) * est.dt_eq56;
        if let Some(b) = b {
            metrics.insert("bound58".into(), b.value_energy);
            metrics.insert("bound58_euclidean".into(), b.value);
            reject |= b.value_energy > 1.0 + self.config.tol;
        }
        tracing::debug!(
            t = before.t,
            dt,
            dt_eq56 = est.dt_eq56,
            bound58 = b.map(|b| b.value_energy),
            reject,
            "stability judgement"
        );
        let verdict = if reject {
            Verdict::Reject {
                cause: RejectCause::Stability,
                suggested_dt: Some(self.config.safety * est.dt_eq56),
            }
        } else {
            Verdict::Accept
        };
        Ok(Judgement { verdict, metrics })
    }
}
