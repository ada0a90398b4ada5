//! Run statistics: accepted steps, rejections by cause, which bound set `dt` how often, and
//! the range of accepted steps.

use super::decision::{Decision, Outcome};
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
    /// `None` before the first.
    pub dt_min: Option<f64>,
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
