//! A bounded record of a controlled run's decisions, for the dt plot and the closing half
//! step: memory stays constant however long the run (accepted steps are decimated, keeping
//! every `stride`-th, with `stride` doubling whenever the record fills up).

use mpm_dt::controller::{bound, Decision, Outcome};

/// Most points kept.
const CAPACITY: usize = 4000;

/// One recorded attempt.
#[derive(Clone, Debug)]
pub struct Point {
    /// Time of the committed state.
    pub t: f64,
    /// The attempted step.
    pub dt: f64,
    /// Accepted (else rejected).
    pub accepted: bool,
    /// The step was shortened to land on `t_end`.
    pub landing: bool,
    /// Each limit's proposal on the first attempt, by index into [`DtHistory::names`].
    pub proposals: Vec<(usize, f64)>,
    /// The step-size filter's proposal, if any.
    pub filter: Option<f64>,
}

/// The bounded record (module docs).
#[derive(Debug, Default)]
pub struct DtHistory {
    /// Names of the limits that proposed a step.
    pub names: Vec<String>,
    /// The kept points, in time order.
    pub points: Vec<Point>,
    stride: u64,
    accepted_seen: u64,
    /// Half the last accepted step not shortened to land on `t_end`.
    pub closing_half_step: Option<f64>,
}

impl DtHistory {
    /// An empty record.
    pub fn new() -> Self {
        Self {
            stride: 1,
            ..Self::default()
        }
    }

    /// Records one attempt.
    pub fn record(&mut self, d: &Decision) {
        let accepted = d.outcome == Outcome::Accepted;
        let landing = d.binding == bound::T_END;
        if accepted && !landing {
            self.closing_half_step = Some(0.5 * d.dt);
        }
        if accepted {
            self.accepted_seen += 1;
            // Keep every stride-th accepted step, and always the landing step.
            if !landing && !(self.accepted_seen - 1).is_multiple_of(self.stride) {
                return;
            }
        }
        let mut proposals = Vec::new();
        if d.attempt == 1 {
            for l in &d.limits {
                if let Some(p) = l.proposal {
                    let i = match self.names.iter().position(|n| n == &l.name) {
                        Some(i) => i,
                        None => {
                            self.names.push(l.name.clone());
                            self.names.len() - 1
                        }
                    };
                    proposals.push((i, p));
                }
            }
        }
        self.points.push(Point {
            t: d.t,
            dt: d.dt,
            accepted,
            landing,
            proposals,
            filter: if d.attempt == 1 { d.filter_dt } else { None },
        });
        if self.points.len() >= CAPACITY {
            // Halve the accepted points (rejections are rare and all kept while they fit).
            let mut k = 0u64;
            self.points.retain(|p| {
                if !p.accepted || p.landing {
                    return true;
                }
                k += 1;
                k % 2 == 1
            });
            self.stride *= 2;
            if self.points.len() >= CAPACITY {
                self.points.drain(..CAPACITY / 2);
            }
        }
    }
}
