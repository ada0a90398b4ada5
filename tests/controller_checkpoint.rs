//! Checkpoint/restart: a run restarted from a JSON checkpoint continues bit-identically.

mod common;

use common::{Fields, MockStepper, SoundSpeedMock};
use mpm_dt::controller::{Checkpoint, Controller, ControllerConfig, GrowthMonitor, TemporalError};
use mpm_dt::limit::StepLimit;
use mpm_dt::Shape;

fn limits(config: &ControllerConfig) -> Vec<Box<dyn StepLimit>> {
    vec![
        Box::new(SoundSpeedMock {
            alpha: 0.6,
            safety_scale: 1.0,
        }),
        Box::new(TemporalError::new(config.temporal.clone()).unwrap()),
        Box::new(GrowthMonitor::new(config.growth.clone()).unwrap()),
    ]
}

#[test]
fn restarted_run_is_bit_identical() {
    let mut config = ControllerConfig::default();
    // Tight tolerance so the filter (with history) sets dt and rejections happen.
    config.temporal.rtol = 1e-4;
    config.temporal.atol_rel = Some(1e-4);
    let mut s = MockStepper::standing_wave(16, 2, 1.0, 1e-2, Shape::Gimp, 0.3, 9);
    let mut c = Controller::new(config.clone(), limits(&config)).unwrap();
    c.run_until(&mut s, 0.1, &mut |_| {}).unwrap();
    assert!(c.state().filter.has_history());

    let json = serde_json::to_string(&Checkpoint {
        controller: c.checkpoint(),
        stepper: s.committed.fields.clone(),
    })
    .unwrap();

    let mut straight = Vec::new();
    c.run_until(&mut s, 0.3, &mut |d| straight.push(d.to_json_line()))
        .unwrap();

    let cp: Checkpoint<Fields> = serde_json::from_str(&json).unwrap();
    let mut s2 = MockStepper::from_fields(s.grid.clone(), Shape::Gimp, 1.0, cp.stepper, 9);
    let mut c2 = Controller::restore(cp.controller, limits(&config)).unwrap();
    let mut restarted = Vec::new();
    c2.run_until(&mut s2, 0.3, &mut |d| restarted.push(d.to_json_line()))
        .unwrap();

    assert!(!straight.is_empty());
    assert_eq!(straight, restarted);
    let (a, b) = (&s.committed.fields, &s2.committed.fields);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.x), bits(&b.x));
    assert_eq!(bits(&a.v), bits(&b.v));
    assert_eq!(bits(&a.sigma), bits(&b.sigma));
    assert_eq!(a.t.to_bits(), b.t.to_bits());
    assert_eq!(c.stats(), c2.stats());
}

#[test]
fn restore_rejects_mismatched_limits() {
    let config = ControllerConfig::default();
    let c = Controller::new(config.clone(), limits(&config)).unwrap();
    let cp = c.checkpoint();
    assert!(Controller::restore(cp.clone(), vec![]).is_err());
    let mut wrong = limits(&config);
    wrong.swap(1, 2);
    assert!(Controller::restore(cp, wrong).is_err());
}

/// A limit's saved state that does not read back ends the restore with the JSON reader's
/// error kept as the source, through the limit's error to the controller's.
#[test]
fn unreadable_limit_state_keeps_its_source() {
    use mpm_dt::controller::ControllerError;
    use mpm_dt::limit::LimitError;
    use std::error::Error;
    let mut config = ControllerConfig::default();
    config.temporal.rtol = 1e-4;
    let mut s = MockStepper::standing_wave(16, 2, 1.0, 1e-2, Shape::Gimp, 0.3, 9);
    let mut c = Controller::new(config.clone(), limits(&config)).unwrap();
    c.run_until(&mut s, 0.05, &mut |_| {}).unwrap();
    for (k, name) in [(1, "temporal_error"), (2, "growth")] {
        let mut cp = c.checkpoint();
        assert_eq!(cp.limits[k].name, name);
        cp.limits[k].state = Some(serde_json::json!({"not": "a saved state"}));
        let err = Controller::restore(cp, limits(&config)).unwrap_err();
        let ControllerError::Restore {
            source: Some(LimitError::Restore { limit, source }),
            ..
        } = &err
        else {
            panic!("{err:?}");
        };
        assert_eq!(limit, name);
        assert!(source.get().is_data(), "{source}");
        let chain = err.source().and_then(|e| e.source()).map(|e| e.to_string());
        assert_eq!(chain, Some(source.to_string()), "{err}");
    }
}

#[test]
fn reference_stepper_restart_is_bit_identical() {
    use mpm_dt::mpm::{ReferenceStepper, SolverCheckpoint};
    use mpm_dt::scenario::Scenario;
    use mpm_dt::Stepper;
    let scenario = Scenario::from_json(
        r#"{"cells": 16, "particles": {"per_cell": 2},
            "initial": {"standing_wave": {"amplitude": 1e-2, "mode": 1}}}"#,
    )
    .unwrap();
    let config = ControllerConfig::default();
    let mut s = scenario.build().unwrap();
    let mut c = Controller::new(config.clone(), limits(&config)).unwrap();
    c.run_until(&mut s, 0.2, &mut |_| {}).unwrap();
    let json = serde_json::to_string(&Checkpoint {
        controller: c.checkpoint(),
        stepper: s.checkpoint(),
    })
    .unwrap();
    let mut straight = Vec::new();
    c.run_until(&mut s, 0.5, &mut |d| straight.push(d.to_json_line()))
        .unwrap();

    let cp: Checkpoint<SolverCheckpoint> = serde_json::from_str(&json).unwrap();
    let mut s2 = ReferenceStepper::from_checkpoint(cp.stepper).unwrap();
    let mut c2 = Controller::restore(cp.controller, limits(&config)).unwrap();
    let mut restarted = Vec::new();
    c2.run_until(&mut s2, 0.5, &mut |d| restarted.push(d.to_json_line()))
        .unwrap();
    assert!(!straight.is_empty());
    assert_eq!(straight, restarted);
    let (a, b) = (s.view(), s2.view());
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(a.x), bits(b.x));
    assert_eq!(bits(a.v), bits(b.v));
    assert_eq!(bits(a.sigma), bits(b.sigma));
    assert_eq!(bits(a.node_acceleration), bits(b.node_acceleration));
    assert_eq!(a.t.to_bits(), b.t.to_bits());
}

/// The same with the standard controller's certified tracker serving on the element bound
/// (`on_bound`): its reference, runs and `K_N` requests are in the checkpoint, and the
/// restored solver's first state carries the same summary and bound.
#[test]
fn restart_serving_on_the_bound_is_bit_identical() {
    use mpm_dt::mpm::{ReferenceStepper, SolverCheckpoint};
    use mpm_dt::scenario::Scenario;
    use mpm_dt::stability::{SoundSpeed, Stability};
    use mpm_dt::Stepper;
    let scenario = Scenario::from_json(
        r#"{"cells": 64, "particles": {"per_cell": 2},
            "initial": {"standing_wave": {"amplitude": 1e-2, "mode": 1}}}"#,
    )
    .unwrap();
    let config = ControllerConfig::from_value(serde_json::json!({
        "stability": {"safety": 0.95, "tracking": {"certified": {"on_bound": true}}}
    }))
    .unwrap();
    let mut s = scenario.build().unwrap();
    let mut c = Controller::standard(config.clone()).unwrap();
    // Stop between two anchors, on a state served on the bound.
    let mut steps = 0;
    while steps < 27 {
        steps += c.step(&mut s, f64::INFINITY).unwrap().len();
    }
    assert!(
        s.view().nodal_stiffness.is_none(),
        "a state served on the bound"
    );
    let json = serde_json::to_string(&Checkpoint {
        controller: c.checkpoint(),
        stepper: s.checkpoint(),
    })
    .unwrap();
    let t_end = s.time() + 60.0 * s.grid().h / scenario.wave_speed();
    let mut straight = Vec::new();
    c.run_until(&mut s, t_end, &mut |d| straight.push(d.to_json_line()))
        .unwrap();

    let cp: Checkpoint<SolverCheckpoint> = serde_json::from_str(&json).unwrap();
    let mut s2 = ReferenceStepper::from_checkpoint(cp.stepper).unwrap();
    let standard: Vec<Box<dyn StepLimit>> = vec![
        Box::new(SoundSpeed::new(config.sound_speed.unwrap()).unwrap()),
        Box::new(Stability::new(config.stability.unwrap()).unwrap()),
        Box::new(TemporalError::new(config.temporal.clone()).unwrap()),
        Box::new(GrowthMonitor::new(config.growth.clone()).unwrap()),
    ];
    let mut c2 = Controller::restore(cp.controller, standard).unwrap();
    let mut restarted = Vec::new();
    c2.run_until(&mut s2, t_end, &mut |d| restarted.push(d.to_json_line()))
        .unwrap();
    assert!(straight.len() > 40);
    assert_eq!(straight, restarted);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(s.view().x), bits(s2.view().x));
}
