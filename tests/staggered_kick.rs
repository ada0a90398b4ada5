//! The reference 1D solver's opt-in staggered kick (`ReferenceStepper::set_staggered_kick`):
//! at a fixed step it is the same run bit for bit (`(dt + dt)/2 == dt`); after a change of
//! step it kicks over `(dt₋ + dt)/2` and drifts over `dt`.

use mpm_dt::scenario::Scenario;
use mpm_dt::Stepper;

/// The standing wave on a periodic bar of 16 cells with 2 GIMP particles a cell.
const BAR: &str = r#"{"cells": 16, "particles": {"per_cell": 2},
    "initial": {"standing_wave": {"amplitude": 0.01, "mode": 1}}}"#;

/// Positions and velocities after the steps `dts`, with the staggered kick or without.
fn run(dts: &[f64], staggered: bool) -> (Vec<f64>, Vec<f64>) {
    let mut s = Scenario::from_json(BAR).unwrap().build().unwrap();
    s.set_staggered_kick(staggered);
    for &dt in dts {
        s.try_step(dt).unwrap();
        s.accept().unwrap();
    }
    let v = s.view();
    (v.x.to_vec(), v.v.to_vec())
}

#[test]
fn a_fixed_step_is_the_same_run_bit_for_bit() {
    let dts = [1e-3; 20];
    let bits = |(x, v): (Vec<f64>, Vec<f64>)| {
        let mut b: Vec<u64> = x.iter().map(|a| a.to_bits()).collect();
        b.extend(v.iter().map(|a| a.to_bits()));
        b
    };
    assert_eq!(bits(run(&dts, false)), bits(run(&dts, true)));
}

#[test]
fn after_a_change_of_step_the_kick_spans_the_mean_of_the_two_steps() {
    // A rejected trial leaves no trace: the kick follows the last *accepted* step.
    let mut s = Scenario::from_json(BAR).unwrap().build().unwrap();
    s.set_staggered_kick(true);
    for _ in 0..5 {
        s.try_step(1e-3).unwrap();
        s.accept().unwrap();
    }
    s.try_step(7e-3).unwrap();
    s.reject();
    let v0 = s.view().v.to_vec();
    // The next kick's particle accelerations Σ_i S_ip a_i, from a plain kick of 1e-3.
    let mut plain = s.clone();
    plain.set_staggered_kick(false);
    plain.try_step(1e-3).unwrap();
    plain.accept().unwrap();
    let a: Vec<f64> = plain
        .view()
        .v
        .iter()
        .zip(&v0)
        .map(|(v1, v0)| (v1 - v0) / 1e-3)
        .collect();
    s.try_step(3e-3).unwrap();
    s.accept().unwrap();
    let scale = a.iter().fold(0.0_f64, |m, a| m.max(a.abs()));
    assert!(scale > 0.0);
    for ((v1, v0), a) in s.view().v.iter().zip(&v0).zip(&a) {
        // Kicked over (1e-3 + 3e-3)/2 = 2e-3, not 3e-3.
        let kick = (v1 - v0) / a.abs().max(1e-300) * a.signum();
        if a.abs() > 1e-3 * scale {
            assert!((kick - 2e-3).abs() < 1e-9, "kick {kick}");
        }
    }
}

#[test]
fn a_checkpoint_after_a_change_of_step_continues_bit_for_bit() {
    use mpm_dt::mpm::{ReferenceStepper, SolverCheckpoint};
    let mut s = Scenario::from_json(BAR).unwrap().build().unwrap();
    s.set_staggered_kick(true);
    for dt in [1e-3, 1e-3, 2e-3] {
        s.try_step(dt).unwrap();
        s.accept().unwrap();
    }
    let json = serde_json::to_string(&s.checkpoint()).unwrap();
    let saved: SolverCheckpoint = serde_json::from_str(&json).unwrap();
    assert!(saved.staggered_kick);
    assert_eq!(saved.last_dt, Some(2e-3));
    let mut restored = ReferenceStepper::from_checkpoint(saved).unwrap();
    for solver in [&mut s, &mut restored] {
        solver.try_step(3e-3).unwrap();
        solver.accept().unwrap();
    }
    let bits = |s: &ReferenceStepper| -> Vec<u64> {
        let v = s.view();
        v.x.iter().chain(v.v).map(|a| a.to_bits()).collect()
    };
    assert_eq!(bits(&s), bits(&restored));
    // A checkpoint's last step must be a step.
    let mut bad = s.checkpoint();
    bad.last_dt = Some(f64::NAN);
    assert!(ReferenceStepper::from_checkpoint(bad).is_err());
}
