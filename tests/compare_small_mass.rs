//! Capability: on a linear-hat layout with near-empty nodes (`scenarios/suite/linear_small_mass.json`)
//! a fixed multiplier of the sound-speed step blows up even at α = 0.3, while the controller
//! with the eq 56 `Stability` limit recomputing λmax at every step runs to `t_end`
//! (README "Performance"; `examples/compare.rs` measures the same thing).
//!
//! Blow-up: stepper error, non-finite velocity, `F ≤ 0`, or total energy above 10× its start.

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::Scenario;
use mpm_dt::stability::{
    Refresh, SoundSpeed, SoundSpeedConfig, Stability, StabilityConfig, Tracking,
};
use mpm_dt::{StepLimit, Stepper};

const SCENARIO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/scenarios/suite/linear_small_mass.json"
);

fn blown_up(s: &ReferenceStepper, e0: f64) -> bool {
    let view = s.view();
    view.v.iter().any(|v| !v.is_finite())
        || view.f.iter().any(|&f| !(f.is_finite() && f > 0.0))
        || {
            let e = s.total_energy();
            !e.is_finite() || e > 10.0 * e0
        }
}

#[test]
fn fixed_alpha_0_3_blows_up_on_small_nodal_masses() {
    let scenario = Scenario::from_file(SCENARIO).expect("suite scenario parses");
    let mut s = scenario.build().expect("scenario builds");
    let e0 = s.total_energy();
    let limit = SoundSpeed::new(SoundSpeedConfig { alpha: 0.3 }).expect("valid alpha");
    let mut blew_up = false;
    while s.time() < scenario.t_end && s.step_count() < 10_000 {
        let dt = limit
            .dt(&s.view())
            .expect("valid view")
            .min(scenario.t_end - s.time());
        if s.try_step(dt).and_then(|()| s.accept()).is_err() || blown_up(&s, e0) {
            blew_up = true;
            break;
        }
    }
    assert!(blew_up, "alpha = 0.3 survived to t = {}", s.time());
    assert!(
        s.time() < 0.1 * scenario.t_end,
        "blew up late: t = {}",
        s.time()
    );
}

#[test]
fn controller_with_every_step_lambda_max_survives_small_nodal_masses() {
    let scenario = Scenario::from_file(SCENARIO).expect("suite scenario parses");
    let mut s = scenario.build().expect("scenario builds");
    let e0 = s.total_energy();
    let stability = Stability::new(StabilityConfig {
        tracking: Tracking::Lanczos(Refresh::every_step()),
        ..StabilityConfig::default()
    })
    .expect("valid config");
    let cap = SoundSpeed::new(SoundSpeedConfig { alpha: 1.0 }).expect("valid alpha");
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(stability), Box::new(cap)];
    let mut controller =
        Controller::with_default_limits(ControllerConfig::default(), limits).expect("controller");
    while s.time() < scenario.t_end {
        let decisions = controller
            .step(&mut s, scenario.t_end)
            .expect("controller step");
        if decisions.is_empty() {
            break;
        }
        assert!(!blown_up(&s, e0), "blew up at t = {}", s.time());
    }
    assert!(s.time() >= scenario.t_end * (1.0 - 1e-12));
    // It is not a trivially small step: the mean step is above 0.1 h/c (h = 1/64, c = 1).
    let mean = s.time() / s.step_count() as f64;
    assert!(mean > 0.1 / 64.0, "mean dt {mean}");
}
