//! A run restarted from a JSON checkpoint of the reference solver continues bit for bit.

use mpm_dt::mpm::{ReferenceStepper, SetupError, SolverCheckpoint};
use mpm_dt::scenario::Scenario;
use mpm_dt::Stepper;

fn bits(s: &ReferenceStepper) -> Vec<u64> {
    let v = s.view();
    let mut out = vec![v.t.to_bits(), v.step];
    for f in [
        v.x,
        v.v,
        v.sigma,
        v.f,
        v.volume0,
        v.mass,
        v.node_mass,
        v.node_velocity,
        v.node_acceleration,
    ] {
        out.extend(f.iter().map(|x| x.to_bits()));
    }
    out
}

#[test]
fn restarted_runs_are_bit_identical() {
    let texts = [
        r#"{"cells": 16, "particles": {"per_cell": 3}}"#,
        r#"{"cells": 12, "boundary": "fixed", "shape": "linear", "material": "neo_hookean",
            "initial": {"standing_wave": {"amplitude": 0.05, "mode": 0.5}}}"#,
        r#"{"cells": 4, "particles": {"positions": [0.01, 0.2, 0.33, 0.5, 0.61, 0.9, 0.99]}}"#,
    ];
    for text in texts {
        let scenario = Scenario::from_json(text).unwrap();
        let mut straight = scenario.build().unwrap();
        let dt = 0.3 * straight.grid().h / scenario.wave_speed();
        for k in 0..37 {
            straight.try_step(dt * (1.0 + 0.01 * k as f64)).unwrap();
            straight.accept().unwrap();
        }
        // A pending trial is not part of the checkpoint.
        straight.try_step(0.5 * dt).unwrap();
        let json = serde_json::to_string(&straight.checkpoint()).unwrap();
        straight.reject();
        let cp: SolverCheckpoint = serde_json::from_str(&json).unwrap();
        let mut restarted = ReferenceStepper::from_checkpoint(cp).unwrap();
        assert_eq!(bits(&straight), bits(&restarted), "{text}: restored state");
        for k in 0..25 {
            for s in [&mut straight, &mut restarted] {
                s.try_step(dt * (1.0 - 0.01 * k as f64)).unwrap();
                s.accept().unwrap();
            }
        }
        assert_eq!(bits(&straight), bits(&restarted), "{text}: continued run");
    }
}

#[test]
fn a_bad_checkpoint_is_a_setup_error() {
    let s = Scenario::default().build().unwrap();
    let mut cp = s.checkpoint();
    cp.t = f64::NAN;
    assert!(matches!(
        ReferenceStepper::from_checkpoint(cp.clone()),
        Err(SetupError::Time { .. })
    ));
    cp.t = 0.0;
    cp.particles.mass.pop();
    assert!(matches!(
        ReferenceStepper::from_checkpoint(cp),
        Err(SetupError::Length { field: "mass", .. })
    ));
}
