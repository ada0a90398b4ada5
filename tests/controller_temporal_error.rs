//! The TemporalError limit (eqs 20–30): its `dsm` scales as dt² and its second time
//! derivative matches the standing wave's `d²v/dt² = −ω² v`.

mod common;

use common::MockStepper;
use mpm_dt::controller::{metric, TemporalError, TemporalErrorConfig};
use mpm_dt::limit::StepLimit;
use mpm_dt::{Shape, Stepper};

fn judge_metrics(s: &mut MockStepper, limit: &mut TemporalError, dt: f64) -> (f64, f64) {
    s.try_step(dt).unwrap();
    let j = limit
        .judge(&s.view(), &s.trial_view().unwrap(), dt)
        .unwrap();
    s.reject();
    (j.metrics["dsm"], j.metrics["dsm_v"])
}

/// Least-squares slope of log(y) against log(x).
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let num: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let den: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    num / den
}

#[test]
fn dsm_is_second_order_in_dt_first_step_and_history() {
    let dts = [1e-3, 5e-4, 2.5e-4, 1.25e-4];
    // First step: estimate from the views' nodal fields.
    let mut first = Vec::new();
    // Later steps: estimate from the previous accepted step's rates.
    let mut later = Vec::new();
    for &dt in &dts {
        let mut s = MockStepper::standing_wave(32, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
        // Every trial checked (no deferral): each judgement carries its `dsm`.
        let mut l = TemporalError::new(TemporalErrorConfig {
            max_deferred: 0,
            ..TemporalErrorConfig::default()
        })
        .unwrap();
        first.push(judge_metrics(&mut s, &mut l, dt).0);
        s.try_step(dt).unwrap();
        l.accepted(&s.view(), &s.trial_view().unwrap(), dt);
        s.accept().unwrap();
        later.push(judge_metrics(&mut s, &mut l, dt).0);
    }
    let p1 = slope(&dts, &first);
    let p2 = slope(&dts, &later);
    assert!((p1 - 2.0).abs() < 0.15, "first-step order {p1}: {first:?}");
    assert!((p2 - 2.0).abs() < 0.15, "history order {p2}: {later:?}");
}

#[test]
fn second_derivative_matches_the_standing_wave() {
    // v = A c sin(2πx) cos(ωt), ω = 2πc: d²v/dt² = −ω² v at t = 0. With weights
    // w_p = atol_rel‖v‖∞ + rtol|v_p| the expected dsm_v follows in closed form.
    let (a, dt) = (1e-2, 1e-3);
    let cfg = TemporalErrorConfig {
        max_deferred: 0,
        rtol: 0.1,
        atol_rel: Some(0.1),
        ..TemporalErrorConfig::default()
    };
    let mut s = MockStepper::standing_wave(64, 2, 1.0, a, Shape::Gimp, 0.0, 1);
    let v0 = s.committed.fields.v.clone();
    let mut l = TemporalError::new(cfg.clone()).unwrap();
    s.try_step(dt).unwrap();
    l.accepted(&s.view(), &s.trial_view().unwrap(), dt);
    let v1 = s.trial_view().unwrap().v.to_vec();
    s.accept().unwrap();
    let (_, dsm_v) = judge_metrics(&mut s, &mut l, dt);
    let omega = 2.0 * std::f64::consts::PI;
    let vmax = v0.iter().chain(&v1).fold(0.0_f64, |m, v| m.max(v.abs()));
    let n = v0.len();
    let sum: f64 = (0..n)
        .map(|p| {
            let le = 0.5 * dt * dt * omega * omega * v1[p].abs();
            let w = cfg.atol_rel() * vmax + cfg.rtol * v1[p].abs();
            (le / w).powi(2)
        })
        .sum();
    let expect = (sum / n as f64).sqrt();
    assert!(
        (dsm_v / expect - 1.0).abs() < 0.05,
        "dsm_v {dsm_v} expected {expect}"
    );
}

#[test]
fn balancing_loosens_the_tolerance_where_the_spatial_error_is_large() {
    // A coarse jittered bar: the spatial error of eqs 33/44 is large, so κ × spatial error
    // dominates the weights and dsm falls as κ grows.
    let dt = 0.02;
    let dsm_for = |balance: Option<f64>| {
        let cfg = TemporalErrorConfig {
            max_deferred: 0,
            rtol: 1e-5,
            atol_rel: Some(1e-5),
            balance,
            ..TemporalErrorConfig::default()
        };
        let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.6, 4);
        let mut l = TemporalError::new(cfg).unwrap();
        // One accepted step so that σ ≠ 0 and the history estimate is used.
        s.try_step(dt).unwrap();
        l.accepted(&s.view(), &s.trial_view().unwrap(), dt);
        s.accept().unwrap();
        judge_metrics(&mut s, &mut l, dt).0
    };
    let plain = dsm_for(None);
    let k1 = dsm_for(Some(1.0));
    let k10 = dsm_for(Some(10.0));
    assert!(plain > 1.0, "plain dsm {plain}");
    assert!(k1 < 0.5 * plain, "κ = 1: {k1} vs plain {plain}");
    assert!(k10 < k1, "κ = 10: {k10} vs κ = 1: {k1}");
    assert!(TemporalError::new(TemporalErrorConfig {
        balance: Some(-1.0),
        ..TemporalErrorConfig::default()
    })
    .is_err());
}

#[test]
fn deferred_checks_in_1d_resume_and_see_the_steps_between() {
    // One trajectory at a fixed step, judged by a deferring limit (the default) and by one
    // that checks every trial.
    let mut s = MockStepper::standing_wave(32, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
    let mut deferring = TemporalError::new(TemporalErrorConfig::default()).unwrap();
    let mut every = TemporalError::new(TemporalErrorConfig {
        max_deferred: 0,
        ..TemporalErrorConfig::default()
    })
    .unwrap();
    let dt = 2e-3;
    let mut checked = Vec::new();
    for step in 0..40 {
        s.try_step(dt).unwrap();
        let (before, after) = (s.view(), s.trial_view().unwrap());
        let all = every.judge(&before, &after, dt).unwrap();
        let some = deferring.judge(&before, &after, dt).unwrap();
        every.accepted(&before, &after, dt);
        deferring.accepted(&before, &after, dt);
        let reference = all.metrics[metric::DSM];
        assert!(reference < 0.1, "step {step}: dsm {reference}");
        match some.metrics.get(metric::DSM) {
            Some(&dsm) => {
                // The span of the deferred steps is centred up to 4.5 steps earlier.
                let rel = (dsm - reference).abs() / reference;
                assert!(rel < 0.2, "step {step}: {dsm} against {reference}");
                checked.push(step);
            }
            None => assert!(some.metrics["dsm_predicted"] <= 0.1, "step {step}"),
        }
        s.accept().unwrap();
    }
    assert_eq!(checked, vec![0, 2, 5, 10, 19, 28, 37]);
    // A rejection ends the deferral: the retry is checked.
    s.try_step(dt).unwrap();
    let (before, after) = (s.view(), s.trial_view().unwrap());
    assert!(deferring
        .judge(&before, &after, dt)
        .unwrap()
        .metrics
        .contains_key("dsm_predicted"));
    s.reject();
    deferring.rejected(dt, mpm_dt::limit::RejectCause::Growth);
    s.try_step(dt).unwrap();
    let (before, after) = (s.view(), s.trial_view().unwrap());
    let retry = deferring.judge(&before, &after, dt).unwrap();
    assert!(
        retry.metrics.contains_key(metric::DSM),
        "{:?}",
        retry.metrics
    );
    deferring.accepted(&before, &after, dt);
    s.accept().unwrap();
    // The schedule starts again at one deferred trial; saved in the middle of it, a
    // restored limit continues it (the next trial is deferred), unless it checks every
    // trial.
    s.try_step(dt).unwrap();
    let (before, after) = (s.view(), s.trial_view().unwrap());
    let saved = deferring.save_state().expect("a history");
    assert_eq!(saved["defer"]["left"].as_u64(), Some(1), "{saved}");
    let mut restored = TemporalError::new(TemporalErrorConfig::default()).unwrap();
    restored.restore_state(&saved).unwrap();
    let j = restored.judge(&before, &after, dt).unwrap();
    assert!(j.metrics.contains_key("dsm_predicted"), "{:?}", j.metrics);
    every.restore_state(&saved).unwrap();
    let j = every.judge(&before, &after, dt).unwrap();
    assert!(j.metrics.contains_key(metric::DSM), "{:?}", j.metrics);
    // A step whose prediction is above 0.1 is checked.
    let dsm = retry.metrics[metric::DSM];
    s.reject();
    let big = dt * (0.2 / dsm).sqrt();
    s.try_step(big).unwrap();
    let j = restored
        .judge(&s.view(), &s.trial_view().unwrap(), big)
        .unwrap();
    assert!(j.metrics.contains_key(metric::DSM), "{:?}", j.metrics);
    // A saved schedule whose checked dsm is negative does not restore.
    let mut bad = saved.clone();
    bad["defer"]["dsm"] = serde_json::json!(-1.0);
    assert!(restored.restore_state(&bad).is_err());
}

/// `rtol` alone dials the accuracy: `atol_rel` follows it unless set, so a config with
/// only `rtol` takes the steps of one with both at that value, and more of them than one
/// that keeps the old fixed floor `atol_rel = 0.05`.
#[test]
fn rtol_alone_tightens_the_limit() {
    use mpm_dt::controller::{Controller, ControllerConfig};
    use mpm_dt::scenario::Scenario;
    let steps = |temporal: &str| {
        let scenario = Scenario::from_json(r#"{"cells": 40, "t_end": 1.0}"#).unwrap();
        let mut solver = scenario.build().unwrap();
        let config =
            ControllerConfig::from_json(&format!(r#"{{"temporal": {temporal}}}"#)).unwrap();
        let mut controller = Controller::standard(config).unwrap();
        let mut dts = Vec::new();
        controller
            .run_until(&mut solver, 1.0, &mut |d| dts.push(d.dt.to_bits()))
            .unwrap();
        dts
    };
    let alone = steps(r#"{"rtol": 3e-5}"#);
    assert_eq!(alone, steps(r#"{"rtol": 3e-5, "atol_rel": 3e-5}"#));
    let floored = steps(r#"{"rtol": 3e-5, "atol_rel": 0.05}"#);
    assert!(
        alone.len() > floored.len(),
        "rtol alone took {} steps, with the 0.05 floor {}",
        alone.len(),
        floored.len()
    );
}
