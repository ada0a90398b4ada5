//! Local errors that do not vanish with the step: an impulse, not a truncation error.
//!
//! The estimate of eqs 20/23 and 28, `le_u,p = dt²/2·|d²u_p/dt²|`, assumes a smooth motion:
//! halving the step quarters it. Where a solver *projects* velocities — a wall or floor
//! that zeroes the normal component of a nodal velocity (mpm88's walls, a sticky
//! boundary), a contact rule — a particle's velocity jumps by `Δv` within one step
//! whatever the step, its rate `(v^{n+1} − v^n)/dt` is `Δv/dt`, the estimated second
//! derivative `Δv/dt²`, and `le_v ≈ |Δv|/2`: independent of `dt`. No step makes it
//! smaller, and a controller that keeps cutting the step to reach it stalls. Measured on
//! mpm88's jelly resting on its floor at `tol = 3·10⁻⁵`: the velocity part stayed at
//! `dsm_v ≈ 1.3–2.6` from `dt = 3.4·10⁻⁴` down to `5·10⁻⁸` s; 9 613 rejections and 24 960
//! steps to t = 0.2 (1 246 steps at `tol = 10⁻⁴`).
//!
//! **The test** (the step-size response an order-2 estimate must show; Hairer, Nørsett &
//! Wanner treat a discontinuity the same way: the estimate stops following the step). When
//! a trial this limit rejected is retried from the same state with a step shorter by
//! `q = dt/dt_rejected ≤ 0.7`, each part of the norm, `dsm_v` and `dsm_σ`, should have
//! fallen by about `q²`. A part that is still above 1 and fell by less than `q` (slower
//! than first order; less than `√q` for a velocity part that holds the first-order
//! velocity lag, `TemporalErrorConfig::lag`, which itself falls by `q`) is not a
//! truncation error: it is **excluded** from the norm,
//! `dsm = sqrt(Σ_{kept parts} dsm_u² / 2)`, and stays excluded on the following checks
//! until it passes on its own (`dsm_u ≤ 1`) at a step at least as long as the rejected
//! one it was found at — the contact has ended (a short step passes without the contact
//! having ended: particles meet a wall now and then, not at every step) — and for at most
//! [`EXCLUDED_CHECKS`] checks, after which it counts again and a retry tests it anew. The excluded parts are
//! reported in the metric `dsm_excluded` (1 velocity, 2 stress, 3 both); `dsm_v` and
//! `dsm_sigma` stay the parts as estimated.
//!
//! What it gives up: while the velocity part is excluded, the smooth velocity errors of
//! the particles away from the contact are not judged either (the parts are norms over all
//! particles); the stress part, and the stability limit and growth monitor, still are. A
//! smooth run never triggers it: its parts fall like `q²` on a retry.

use super::limit::Estimate;
use serde::{Deserialize, Serialize};

/// The largest `dt/dt_rejected` of a retry for which the response is tested: a shorter
/// step by at least 30 % tells `q` (first order) from `q²` (second) apart by 30 % or more.
const TESTED_SHRINK: f64 = 0.7;

/// Checks for which a part found not to vanish stays excluded at most; then it counts
/// again, and a retry tests it anew (one rejection in `EXCLUDED_CHECKS + 1` checks while
/// the contact lasts, and at most this many checks without the part where it has ended).
/// The checks are not deferred meanwhile: the deferral follows the estimate with every
/// part in it, which is above 1.
pub const EXCLUDED_CHECKS: u32 = 8;

/// A trial this limit rejected: its start time's bits, its step and its parts.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rejected {
    t: u64,
    dt: f64,
    parts: [f64; 2],
}

/// The state of the test (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NonSmooth {
    /// The last trial rejected (mid-step state: cleared when a trial passes).
    #[serde(skip)]
    rejected: Option<Rejected>,
    /// Parts (velocity, stress) found not to vanish with the step, excluded until they
    /// pass on their own at a step as long as the rejected one they were found at.
    pub excluded: [bool; 2],
    /// That rejected step, per part.
    pub found_at: [f64; 2],
    /// Checks left before an excluded part counts again ([`EXCLUDED_CHECKS`]).
    pub checks_left: [u32; 2],
}

impl NonSmooth {
    /// The estimate to judge the trial from time `t` with step `dt` by: `e` itself where no
    /// part is excluded (bit for bit), else `e` with the excluded parts left out of `dsm`.
    pub fn judge(&mut self, t: f64, dt: f64, e: &Estimate) -> Estimate {
        self.judge_lagged(t, dt, e, false)
    }

    /// [`Self::judge`] where the velocity part holds the first-order velocity lag
    /// (`lagged`, [`super::TemporalErrorConfig::lag`]): a smooth velocity part then falls
    /// by `q` to `q²` on a retry, so it is taken as impulsive only when it fell by less
    /// than `√q` (an impulse does not fall at all).
    #[allow(clippy::needless_range_loop)] // `k` indexes five per-part arrays
    pub fn judge_lagged(&mut self, t: f64, dt: f64, e: &Estimate, lagged: bool) -> Estimate {
        let parts = [e.dsm_v, e.dsm_sigma];
        if e.dsm.is_nan() {
            self.rejected = None;
            return *e;
        }
        for k in 0..2 {
            self.checks_left[k] = self.checks_left[k].saturating_sub(1);
            if (parts[k] <= 1.0 && dt >= self.found_at[k]) || self.checks_left[k] == 0 {
                self.excluded[k] = false;
                self.found_at[k] = 0.0;
                self.checks_left[k] = 0;
            }
        }
        if let Some(r) = self.rejected.filter(|r| r.t == t.to_bits() && dt < r.dt) {
            let q = dt / r.dt;
            if q <= TESTED_SHRINK {
                let slowest = [if lagged { q.sqrt() } else { q }, q];
                for k in 0..2 {
                    if parts[k] > 1.0 && parts[k] >= slowest[k] * r.parts[k] {
                        self.excluded[k] = true;
                        self.found_at[k] = r.dt;
                        self.checks_left[k] = EXCLUDED_CHECKS;
                    }
                }
            }
        }
        let judged = self.effective(e);
        self.rejected = (judged.dsm > 1.0).then_some(Rejected {
            t: t.to_bits(),
            dt,
            parts,
        });
        judged
    }

    /// `e` with the excluded parts left out of `dsm` (module docs).
    fn effective(&self, e: &Estimate) -> Estimate {
        if self.excluded == [false; 2] {
            return *e;
        }
        let kept = |k: usize, part: f64| if self.excluded[k] { 0.0 } else { part * part };
        Estimate {
            dsm: ((kept(0, e.dsm_v) + kept(1, e.dsm_sigma)) / 2.0).sqrt(),
            ..*e
        }
    }

    /// The metric `dsm_excluded` (1 velocity, 2 stress, 3 both), where a part is excluded.
    pub fn metric(&self) -> Option<f64> {
        let code = u8::from(self.excluded[0]) + 2 * u8::from(self.excluded[1]);
        (code > 0).then_some(code as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn estimate(dsm_v: f64, dsm_sigma: f64) -> Estimate {
        Estimate {
            dsm: ((dsm_v * dsm_v + dsm_sigma * dsm_sigma) / 2.0).sqrt(),
            dsm_v,
            dsm_sigma,
            count: None,
            v_scale: 1.0,
            sigma_scale: 1.0,
        }
    }

    #[test]
    fn a_part_that_does_not_fall_with_the_step_is_excluded_until_it_passes() {
        let mut n = NonSmooth::default();
        // Rejected at dt = 1: the velocity part 2.0, the stress part 3.0.
        let first = n.judge(0.5, 1.0, &estimate(2.0, 3.0));
        assert!(first.dsm > 1.0);
        assert_eq!(n.metric(), None);
        // Retried at dt = 0.5: the stress part fell like q² (0.75), the velocity part not.
        let retry = n.judge(0.5, 0.5, &estimate(1.9, 0.75));
        assert_eq!(n.metric(), Some(1.0));
        assert_eq!(retry.dsm.to_bits(), (0.75f64 * 0.75 / 2.0).sqrt().to_bits());
        assert!(retry.dsm <= 1.0);
        // It stays excluded on the next step's check while above 1, and while it passes
        // only at steps shorter than the rejected one; it clears at one as long.
        assert!(n.judge(0.6, 0.5, &estimate(1.5, 0.8)).dsm <= 1.0);
        assert_eq!(n.metric(), Some(1.0));
        n.judge(0.7, 0.5, &estimate(0.9, 0.8));
        assert_eq!(n.metric(), Some(1.0));
        let passed = estimate(0.9, 0.8);
        assert_eq!(n.judge(0.8, 1.0, &passed), passed);
        assert_eq!(n.metric(), None);
    }

    #[test]
    fn a_lagged_velocity_part_that_falls_like_the_step_is_kept() {
        let mut n = NonSmooth::default();
        n.judge_lagged(0.0, 1.0, &estimate(4.0, 0.5), true);
        // First order at q = 0.5 (4.0 → 2.0): kept with the lag, excluded without.
        let first_order = estimate(2.0, 0.1);
        assert_eq!(n.judge_lagged(0.0, 0.5, &first_order, true), first_order);
        assert_eq!(n.metric(), None);
        let mut plain = NonSmooth::default();
        plain.judge(0.0, 1.0, &estimate(4.0, 0.5));
        plain.judge(0.0, 0.5, &first_order);
        assert_eq!(plain.metric(), Some(1.0));
        // An impulse (no fall) is excluded either way.
        let mut n = NonSmooth::default();
        n.judge_lagged(0.0, 1.0, &estimate(4.0, 0.5), true);
        n.judge_lagged(0.0, 0.5, &estimate(3.9, 0.1), true);
        assert_eq!(n.metric(), Some(1.0));
    }

    #[test]
    fn smooth_parts_and_untested_retries_are_judged_as_estimated() {
        let mut n = NonSmooth::default();
        n.judge(0.0, 1.0, &estimate(3.0, 3.0));
        // Both parts fell like q² at q = 0.5: nothing excluded, rejected again.
        let smooth = estimate(1.2, 1.3);
        assert_eq!(n.judge(0.0, 0.5, &smooth), smooth);
        // A retry that shrank by less than 30 % tests nothing.
        let close = estimate(1.19, 1.29);
        assert_eq!(n.judge(0.0, 0.4, &close), close);
        assert_eq!(n.metric(), None);
        // Another start time: the rejected trial is not this step's.
        let other = estimate(3.0, 3.0);
        assert_eq!(n.judge(1.0, 0.1, &other), other);
        // A NaN estimate is returned as it is.
        let nan = Estimate {
            dsm: f64::NAN,
            ..estimate(1.0, 1.0)
        };
        assert!(n.judge(1.0, 0.05, &nan).dsm.is_nan());
    }
}
