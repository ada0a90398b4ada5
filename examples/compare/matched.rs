//! The fixed rule taking as many steps as mpm-dt (module docs of `compare`).

use crate::{run_fixed, PolicyResult, Reference};
use mpm_dt::scenario::Scenario;
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::Stepper;

/// The fixed rule with mpm-dt's step count (module docs of `compare`): its row, and the synchronised
/// errors of every sampled multiplier that took exactly that many steps.
pub(crate) struct Matched {
    pub(crate) result: PolicyResult,
    /// `(α, velocity_error_linf)` of the runs with exactly mpm-dt's step count.
    pub(crate) same_count: Vec<(f64, Option<f64>)>,
}

/// Offsets (in units of `1/N`, `N` mpm-dt's step count) of the multipliers sampled around
/// one that hit the count, `k/8` for `k = ±1 … ±12`: the multipliers with `N` steps span
/// about `α/N`, and the first hit may lie at either end.
const SPREAD: [f64; 24] = {
    let mut s = [0.0; 24];
    let mut k = 0;
    while k < 12 {
        s[2 * k] = -((k + 1) as f64) / 8.0;
        s[2 * k + 1] = (k + 1) as f64 / 8.0;
        k += 1;
    }
    s
};

/// The fixed multiplier taking as many steps as `ours` (module docs of `compare`): `Ok(None)` when `ours`
/// blew up or took no step. The search runs at most 16 multipliers: the first guess from
/// mpm-dt's mean step and the sound-speed step at `t = 0`, proportional corrections
/// (steps ∝ 1/α) until the target is bracketed, then bisection. A run that blows up bounds α
/// from above like one with too few steps. The row is the closest stable run from above
/// (at least mpm-dt's step count); when one hits the count `N` exactly, the multipliers
/// `α (1 + x/N)`, `x` in [`SPREAD`], are run too and the row is the most accurate of those
/// with the same count. With no stable run at or above the count, the row is the first run that
/// blew up.
pub(crate) fn run_matched(
    scenario: &Scenario,
    reference: &Reference<'_>,
    ours: &PolicyResult,
) -> Result<Option<Matched>, String> {
    let (target, Some(dt_mean)) = (ours.steps, ours.dt_mean) else {
        return Ok(None);
    };
    if ours.blew_up || target == 0 {
        return Ok(None);
    }
    let start = scenario.build().map_err(|e| e.to_string())?;
    let unit = SoundSpeed::unit_step(&start.view()).map_err(|e| e.to_string())?;
    let mut alpha = dt_mean / unit;
    // Steps fall as α grows: `more` took more steps than the target (stable), `fewer` took
    // fewer or blew up.
    let (mut more, mut fewer): (Option<f64>, Option<f64>) = (None, None);
    let mut best: Option<(f64, PolicyResult)> = None;
    let mut first_blowup: Option<(f64, PolicyResult)> = None;
    let mut hit = None;
    for _ in 0..16 {
        if !(alpha.is_finite() && alpha > 0.0) {
            return Err(format!("no valid multiplier to try (α = {alpha})"));
        }
        let r = run_fixed(scenario, reference, alpha)?;
        let (steps, blew_up) = (r.steps, r.blew_up);
        if blew_up {
            fewer = Some(fewer.map_or(alpha, |f: f64| f.min(alpha)));
            if first_blowup.is_none() {
                first_blowup = Some((alpha, r));
            }
        } else {
            if steps == target {
                hit = Some(alpha);
            }
            // Keep the run closest to the target from above (at least mpm-dt's count).
            if steps >= target && best.as_ref().is_none_or(|(_, b)| steps < b.steps) {
                best = Some((alpha, r));
            }
            if hit.is_some() {
                break;
            }
            if steps > target {
                more = Some(more.map_or(alpha, |m: f64| m.max(alpha)));
            } else {
                fewer = Some(fewer.map_or(alpha, |f: f64| f.min(alpha)));
            }
        }
        alpha = match (more, fewer) {
            (Some(m), Some(f)) => {
                let mid = 0.5 * (m + f);
                if !(m < mid && mid < f) {
                    break; // the bracket has collapsed: no multiplier hits the count
                }
                mid
            }
            // A blow-up has no step count to correct by.
            _ if blew_up => 0.5 * alpha,
            _ => alpha * steps as f64 / target as f64,
        };
    }
    let mut same_count = Vec::new();
    if let Some(a0) = hit {
        if let Some((_, r)) = best.as_ref() {
            same_count.push((a0, r.velocity_error_linf));
        }
        for k in SPREAD {
            let a = a0 * (1.0 + k / target as f64);
            let r = run_fixed(scenario, reference, a)?;
            if r.blew_up || r.steps != target {
                continue;
            }
            same_count.push((a, r.velocity_error_linf));
            let better = match (&best, r.velocity_error_linf) {
                (Some((_, b)), Some(e)) => b.velocity_error_linf.is_none_or(|be| e < be),
                _ => false,
            };
            if better {
                best = Some((a, r));
            }
        }
    }
    Ok(best.or(first_blowup).map(|(alpha, mut result)| {
        result.policy = format!("matched alpha={alpha:.4}");
        Matched { result, same_count }
    }))
}
