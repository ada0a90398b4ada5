//! [`Decision`]: the record of one attempted step — what every limit proposed and judged,
//! which bound set `dt`, and what happened. Serialized as one JSON line per attempt by the
//! examples (`--log-json`), emitted as a `tracing` event by the controller.
//!
//! JSON has no infinity: a limit with no opinion (`dt = ∞`) is written as `null`
//! (`Option::None`), and non-finite metrics are dropped from the record.

use crate::limit::{Metrics, RejectCause, Verdict};
use serde::{Deserialize, Serialize};

pub use crate::limit::metric;

/// Names of the bounds on `dt` that are not limits.
pub mod bound {
    /// The Söderlind filter's accuracy proposal (from [`super::metric::DSM`]).
    pub const FILTER: &str = "filter";
    /// The configured `dt_max`.
    pub const DT_MAX: &str = "dt_max";
    /// The time left to `t_end`.
    pub const T_END: &str = "t_end";
    /// The growth cap `max_growth · dt_prev` (and "no growth after a rejection").
    pub const GROWTH_CAP: &str = "growth_cap";
    /// The hold rule: a step that could grow by a factor in `(1, hold_growth]` keeps the
    /// previous step ([`crate::controller::ControllerConfig::hold_growth`]).
    pub const HOLD: &str = "hold";
    /// The shrink rule of a retry after a rejection.
    pub const RETRY: &str = "retry";
    /// The configured `dt_initial`.
    pub const DT_INITIAL: &str = "dt_initial";
    /// Another process's step, smaller than this one's (the global minimum of
    /// [`crate::reduce`]).
    pub const OTHER_RANK: &str = "other_rank";
}

/// Whether the attempt was accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// The trial became the committed state.
    Accepted,
    /// The trial was discarded; the committed state is unchanged.
    Rejected,
}

/// One limit's part in a decision.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LimitRecord {
    /// The limit's name.
    pub name: String,
    /// Its proposal; `None` when it had no opinion (infinite).
    pub proposal: Option<f64>,
    /// Its verdict on the trial; `None` when the trial was not judged (the stepper failed
    /// or the state was not finite).
    pub verdict: Option<Verdict>,
    /// Metrics from `propose` and `judge` (finite values only; judge wins on a clash).
    pub metrics: Metrics,
}

/// The record of one attempted step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// Accepted steps before this attempt (the `n` of `tⁿ`).
    pub step: u64,
    /// Attempt number for this step, from 1.
    pub attempt: u32,
    /// Time of the committed state.
    pub t: f64,
    /// The step attempted.
    pub dt: f64,
    /// Every limit's proposal, verdict and metrics, in the controller's order.
    pub limits: Vec<LimitRecord>,
    /// The filter's proposal (with safety factor), if it had history.
    pub filter_dt: Option<f64>,
    /// What bound `dt`: a limit's name or one of [`bound`].
    pub binding: String,
    /// The eq 58 value, if a limit reported it.
    pub bound58: Option<f64>,
    /// λmax of `D*F` (eq 56), if a limit reported it.
    pub lambda_max: Option<f64>,
    /// The scaled temporal error, if a limit reported it.
    pub dsm: Option<f64>,
    /// Accepted or rejected.
    pub outcome: Outcome,
    /// Why it was rejected (`None` when accepted).
    pub cause: Option<RejectCause>,
    /// The limit that rejected, or `"stepper"` / `"state"` for a failed or non-finite
    /// trial.
    pub rejected_by: Option<String>,
    /// The stepper's error message when the trial failed.
    pub message: Option<String>,
}

impl Decision {
    /// The first value of metric `key` among the limits' records.
    pub fn metric(&self, key: &str) -> Option<f64> {
        self.limits.iter().find_map(|l| l.metrics.get(key).copied())
    }

    /// One JSON line (no trailing newline).
    pub fn to_json_line(&self) -> String {
        // Serializing plain data with string keys cannot fail.
        serde_json::to_string(self).unwrap_or_default()
    }
}
