//! One run of a scene under one step policy, to its end state: the fixed rule
//! `dt = α·h/(c + |v|)` re-evaluated on every committed state, or mpm-dt's standard
//! controller with the scene's config and the temporal tolerance set (module docs of
//! `work_precision`). The same code drives the 1D reference solver, the d-dimensional one
//! and any other `Stepper<D>` (the MLS-MPM scene of `mls_mpm`).

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::sound_speed::{SoundSpeed, SoundSpeedConfig};
use mpm_dt::{Dim, Dimension, Stepper, View, ViewNd};
use serde::Serialize;
use std::time::Instant;

/// A step policy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Policy {
    /// The fixed multiplier `α` of the sound-speed step.
    Fixed(f64),
    /// A constant step (a scene's shipped step), in seconds.
    Shipped(f64),
    /// The controller with `rtol = atol_rel = tol` (`None`: the scene's config as it is).
    Controller(Option<f64>),
}

impl Policy {
    /// The policy's name in tables and JSON.
    pub fn name(&self) -> String {
        match self {
            Policy::Fixed(a) => format!("alpha={a}"),
            Policy::Shipped(dt) => format!("shipped dt={dt}"),
            Policy::Controller(None) => "mpm-dt default".into(),
            Policy::Controller(Some(t)) => format!("mpm-dt tol={t}"),
        }
    }

    /// The controller's config under this policy (`None` for a fixed rule).
    pub fn config(&self, base: &ControllerConfig) -> Option<ControllerConfig> {
        match *self {
            Policy::Controller(tol) => {
                let mut c = base.clone();
                if let Some(t) = tol {
                    c.temporal.rtol = t;
                    c.temporal.atol_rel = Some(t);
                }
                Some(c)
            }
            _ => None,
        }
    }
}

/// The end state of a run: what the error measures compare.
#[derive(Clone, Debug, Default, Serialize)]
pub struct EndState {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected attempts (controller only).
    pub rejected: u64,
    /// Why the run did not reach its end, if it did not.
    pub failure: Option<String>,
    /// Wall time of the stepping loop.
    pub wall_s: f64,
    /// Time reached.
    #[serde(skip)]
    pub t: f64,
    /// Particle positions, `d` numbers per particle.
    #[serde(skip)]
    pub x: Vec<f64>,
    /// Particle velocities, `d` numbers per particle.
    #[serde(skip)]
    pub v: Vec<f64>,
    /// Total energy at the end.
    #[serde(skip)]
    pub energy: f64,
}

/// Energy above this multiple of the initial one counts as a blow-up.
const ENERGY_GROWTH: f64 = 10.0;

/// Drives `s` to `t_end` under `policy`; `controller` builds the controller of a config,
/// `energy` reads a state's total energy (checked every 50 fixed steps and at the end, so
/// that a fixed rule's wall time is the rule's).
pub fn run_nd<const D: usize, S: Stepper<D>>(
    mut s: S,
    policy: Policy,
    t_end: f64,
    base: &ControllerConfig,
    controller: &dyn Fn(ControllerConfig) -> Result<Controller<D>, String>,
    energy: &dyn Fn(&S) -> f64,
) -> Result<EndState, String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let e0 = energy(&s);
    let grew = |e: f64| !e.is_finite() || e > ENERGY_GROWTH * e0.abs().max(f64::MIN_POSITIVE);
    let mut failure = None;
    let mut rejected = 0;
    let start = Instant::now();
    if let Some(config) = policy.config(base) {
        let mut c = controller(config)?;
        if let Err(e) = c.run_until(&mut s, t_end, &mut |_| {}) {
            failure = Some(e.to_string());
        }
        rejected = c.stats().rejected;
    } else {
        while s.time() < t_end * (1.0 - 1e-14) {
            let dt = match policy {
                Policy::Fixed(a) => SoundSpeed::unit_step(&s.view())
                    .map(|u| a * u)
                    .map_err(|e| e.to_string()),
                Policy::Shipped(dt) => Ok(dt),
                Policy::Controller(_) => return Err("a controller policy without config".into()),
            };
            let step = dt.and_then(|dt| {
                let dt = dt.min(t_end - s.time());
                s.try_step(dt)
                    .and_then(|_| s.accept())
                    .map_err(|e| e.to_string())
            });
            if let Err(e) = step {
                failure = Some(e);
                break;
            }
            if s.step_count() % 50 == 0 && grew(energy(&s)) {
                failure = Some(format!("energy above 10x at t = {:.4e}", s.time()));
                break;
            }
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    let e = energy(&s);
    if failure.is_none() && grew(e) {
        failure = Some(format!("energy {e:.3e} from {e0:.3e}"));
    }
    let view = s.view();
    Ok(EndState {
        steps: s.step_count(),
        rejected,
        failure,
        wall_s,
        t: s.time(),
        x: view.x.iter().flat_map(|p| p.iter().copied()).collect(),
        v: view.v.iter().flat_map(|p| p.iter().copied()).collect(),
        energy: e,
    })
}

/// The 1D reference solver's run (its own sound-speed limit and 1D controller), with the
/// staggered kick when `staggered` (`ReferenceStepper::set_staggered_kick`).
pub fn run_1d(
    scenario: &mpm_dt::scenario::Scenario,
    policy: Policy,
    base: &ControllerConfig,
    staggered: bool,
) -> Result<EndState, String> {
    let mut s = scenario.build().map_err(|e| e.to_string())?;
    s.provide_summary(true);
    s.set_staggered_kick(staggered);
    let t_end = scenario.t_end;
    let e0 = s.total_energy();
    let mut failure = None;
    let mut rejected = 0;
    let start = Instant::now();
    if let Some(config) = policy.config(base) {
        let mut c = Controller::standard(config).map_err(|e| e.to_string())?;
        if let Err(e) = c.run_until(&mut s, t_end, &mut |_| {}) {
            failure = Some(e.to_string());
        }
        rejected = c.stats().rejected;
    } else {
        let alpha = match policy {
            Policy::Fixed(a) => a,
            _ => return Err("the 1D scene runs fixed rules and the controller only".into()),
        };
        let limit = SoundSpeed::new(SoundSpeedConfig { alpha }).map_err(|e| e.to_string())?;
        while s.time() < t_end * (1.0 - 1e-14) {
            let step = limit
                .dt(&s.view())
                .map_err(|e| e.to_string())
                .and_then(|dt| {
                    let dt = dt.min(t_end - s.time());
                    s.try_step(dt)
                        .and_then(|_| s.accept())
                        .map_err(|e| e.to_string())
                });
            if let Err(e) = step {
                failure = Some(e);
                break;
            }
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    let e = s.total_energy();
    if failure.is_none() && (!e.is_finite() || e > ENERGY_GROWTH * e0) {
        failure = Some(format!("energy {e:.3e} from {e0:.3e}"));
    }
    let view: View<'_> = s.view();
    Ok(EndState {
        steps: s.step_count(),
        rejected,
        failure,
        wall_s,
        t: s.time(),
        x: view.x.to_vec(),
        v: view.v.to_vec(),
        energy: e,
    })
}
