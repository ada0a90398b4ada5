//! The summaries `simulate` prints: the controller's statistics, a failed run's message and
//! the element bound's tightness at the refreshes.

use mpm_dt::controller::{Decision, Stats};
use serde_json::{json, Value};

/// The controller's statistics as JSON.
pub(crate) fn stats_summary(stats: &Stats) -> Value {
    json!({
        "steps_accepted": stats.accepted,
        "steps_rejected": stats.rejected,
        "dt_min": stats.dt_min,
        "dt_min_chosen": stats.dt_min_chosen,
        "dt_mean": stats.dt_mean(),
        "dt_max": stats.dt_max,
        "binding": stats.binding,
    })
}

/// A failed controlled run's message: the error and, if there was one, the last rejection's
/// limit and message.
pub(crate) fn failure_message(
    e: impl std::fmt::Display,
    last_rejection: Option<&Decision>,
) -> String {
    let why = last_rejection
        .map(|d| {
            format!(
                "; last rejection by {} ({})",
                d.rejected_by.as_deref().unwrap_or("?"),
                d.message.as_deref().unwrap_or("no message")
            )
        })
        .unwrap_or_default();
    format!("{e}{why}")
}

/// The element bound over the Lanczos value at the refreshes as `[min, median, max]`, or
/// null without a refresh.
pub(crate) fn bound_ratio_summary(bound_ratios: &[f64]) -> Value {
    match bound_ratios.iter().copied().reduce(f64::min) {
        Some(lo) => json!([
            lo,
            crate::common::repeats::median(bound_ratios),
            bound_ratios.iter().copied().fold(lo, f64::max)
        ]),
        None => json!(null),
    }
}
