//! The rule of thumb the controller is compared with, on the d-dimensional solver:
//! `dt = α · min_a h_a/(c_p + |v_a|)`, re-evaluated on every committed state, the last step
//! clamped to `t_end`.

use mpm_dt::nd::SolverNd;
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use std::time::Instant;

/// How a fixed-rule run ended.
pub struct FixedRun<const D: usize> {
    /// The solver at the end of the run.
    pub solver: SolverNd<D>,
    /// Wall time of the run.
    pub wall_s: f64,
    /// Why it blew up: a failed trial, or the energy non-finite or above 10× its start.
    pub blew_up: Option<String>,
}

/// Whether the energy `e` is non-finite or above 10× `e0`.
pub fn energy_grew(e: f64, e0: f64) -> bool {
    !e.is_finite() || e > 10.0 * e0.max(f64::MIN_POSITIVE)
}

/// Runs the rule with multiplier `alpha` to `t_end`. What a fixed-rule code pays per step
/// is the rule itself: the energy check (not part of the rule) runs every 50 steps and at
/// the end.
pub fn run_alpha<const D: usize>(mut s: SolverNd<D>, alpha: f64, t_end: f64) -> FixedRun<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let e0 = s.total_energy();
    let start = Instant::now();
    let mut blew_up = None;
    while s.time() < t_end * (1.0 - 1e-14) {
        let dt = match SoundSpeed::unit_step(&s.view()) {
            Ok(u) => (alpha * u).min(t_end - s.time()),
            Err(e) => {
                blew_up = Some(e.to_string());
                break;
            }
        };
        if let Err(e) = s.try_step(dt).and_then(|_| s.accept()) {
            blew_up = Some(e.to_string());
            break;
        }
        if s.step_count() % 50 == 0 && energy_grew(s.total_energy(), e0) {
            blew_up = Some(format!("energy above 10x at t = {:.4e}", s.time()));
            break;
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    let e = s.total_energy();
    if blew_up.is_none() && energy_grew(e, e0) {
        blew_up = Some(format!("energy {e:.3e} from {e0:.3e}"));
    }
    FixedRun {
        solver: s,
        wall_s,
        blew_up,
    }
}
