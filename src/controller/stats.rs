//! Run statistics: accepted steps, rejections by cause, which bound set `dt` how often, and
//! the range of accepted steps.

use super::decision::{bound, Decision, Outcome};
use crate::limit::RejectCause;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Counters of a controller run. Serializable (part of a checkpoint and of the examples'
/// `--json` summary).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Accepted steps.
    pub accepted: u64,
    /// Rejected attempts, all causes.
    pub rejected: u64,
    /// Rejected attempts by cause (`error`, `stability`, `growth`, `non_finite`,
    /// `user_veto`).
    pub rejected_by_cause: BTreeMap<RejectCause, u64>,
    /// Accepted steps by what bound their `dt` (limit name or a [`super::bound`] name).
    pub binding: BTreeMap<String, u64>,
    /// Smallest accepted step, the last step of a run (cut to land on `t_end`) included;
    /// `None` before the first. See [`Self::dt_min_chosen`] for the smallest step the
    /// limits chose.
    pub dt_min: Option<f64>,
    /// Smallest accepted step that was not cut to land on `t_end` (binding other than
    /// [`bound::T_END`]): the smallest step the limits and the controller's own
    /// rules chose. `None` before the first such step (a run of one step that lands on
    /// `t_end` has none). Absent from checkpoints written before it existed (read as
    /// `None`, then filled from the next step on).
    #[serde(default)]
    pub dt_min_chosen: Option<f64>,
    /// Largest accepted step; `None` before the first.
    pub dt_max: Option<f64>,
    /// Sum of accepted steps (for the mean).
    pub dt_sum: f64,
    /// Growth events (slow instability detected; stability safety lowered).
    pub growth_events: u64,
}

impl Stats {
    /// Counts one decision.
    pub fn record(&mut self, d: &Decision) {
        match d.outcome {
            Outcome::Accepted => {
                self.accepted += 1;
                // Counted without cloning the name once it has an entry.
                match self.binding.get_mut(d.binding.as_str()) {
                    Some(count) => *count += 1,
                    None => {
                        self.binding.insert(d.binding.clone(), 1);
                    }
                }
                self.dt_min = Some(self.dt_min.map_or(d.dt, |m| m.min(d.dt)));
                if d.binding != bound::T_END {
                    self.dt_min_chosen = Some(self.dt_min_chosen.map_or(d.dt, |m| m.min(d.dt)));
                }
                self.dt_max = Some(self.dt_max.map_or(d.dt, |m| m.max(d.dt)));
                self.dt_sum += d.dt;
            }
            Outcome::Rejected => {
                self.rejected += 1;
                if let Some(c) = d.cause {
                    *self.rejected_by_cause.entry(c).or_insert(0) += 1;
                    if c == RejectCause::Growth {
                        self.growth_events += 1;
                    }
                }
            }
        }
    }

    /// Mean accepted step; `None` before the first.
    pub fn dt_mean(&self) -> Option<f64> {
        (self.accepted > 0).then(|| self.dt_sum / self.accepted as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn accepted(dt: f64, binding: &str) -> Decision {
        Decision {
            step: 0,
            attempt: 0,
            t: 0.0,
            dt,
            limits: Vec::new(),
            filter_dt: None,
            binding: binding.into(),
            bound58: None,
            lambda_max: None,
            dsm: None,
            outcome: Outcome::Accepted,
            cause: None,
            rejected_by: None,
            message: None,
        }
    }

    /// `dt_min` counts the last step cut to land on `t_end`; `dt_min_chosen` does not.
    #[test]
    fn the_landing_step_counts_in_dt_min_only() {
        let mut stats = Stats::default();
        stats.record(&accepted(0.5, "stability"));
        stats.record(&accepted(0.3, "hold"));
        assert_eq!(stats.dt_min_chosen, Some(0.3));
        stats.record(&accepted(0.01, bound::T_END));
        assert_eq!(stats.dt_min, Some(0.01));
        assert_eq!(stats.dt_min_chosen, Some(0.3));
        let mut one = Stats::default();
        one.record(&accepted(0.01, bound::T_END));
        assert_eq!((one.dt_min, one.dt_min_chosen), (Some(0.01), None));
    }
}
