//! Adversarial mock steppers: the controller either progresses or ends with a typed error
//! within its rejection limit — never an endless loop, never a panic, never a non-finite
//! accepted state.

mod common;

use common::{all_finite, AlwaysVeto, MockStepper, RandomError, SoundSpeedMock};
use mpm_dt::controller::{Controller, ControllerConfig, ControllerError, Outcome};
use mpm_dt::limit::{RejectCause, StepLimit};
use mpm_dt::{Shape, Stepper};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn sound(alpha: f64) -> Box<dyn StepLimit> {
    Box::new(SoundSpeedMock {
        alpha,
        safety_scale: 1.0,
    })
}

/// A stepper failing with its own error (`StepError::Other`) ends the run at once: a smaller
/// step cannot cure it. (Until 0.1 the controller retried it seven times with shrinking
/// steps and ended with `TooManyRejections`; see the CHANGELOG.)
#[test]
fn always_failing_stepper_ends_with_its_own_error() {
    let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
    s.faults.always_fail = true;
    let mut c = Controller::new(ControllerConfig::default(), vec![sound(0.5)]).unwrap();
    let mut seen = Vec::new();
    let err = c
        .run_until(&mut s, 1.0, &mut |d| seen.push(d.clone()))
        .unwrap_err();
    match err {
        ControllerError::Stepper {
            source: mpm_dt::StepError::Other(message),
            ..
        } => assert!(message.contains("always fails")),
        e => panic!("unexpected error {e}"),
    }
    assert!(seen.is_empty());
    assert_eq!(c.stats().rejected, 0);
    assert_eq!(c.stats().accepted, 0);
    assert_eq!(s.time().to_bits(), 0.0f64.to_bits());
}

#[test]
fn user_veto_ends_with_typed_error() {
    let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
    let mut c = Controller::new(
        ControllerConfig::default(),
        vec![sound(0.5), Box::new(AlwaysVeto)],
    )
    .unwrap();
    let err = c.run_until(&mut s, 1.0, &mut |_| {}).unwrap_err();
    assert!(
        matches!(err, ControllerError::TooManyRejections { count: 7, .. }),
        "{err}"
    );
    assert_eq!(
        c.stats().rejected_by_cause.get(&RejectCause::UserVeto),
        Some(&7)
    );
}

#[test]
fn nan_above_a_threshold_is_rejected_and_stepped_around() {
    // The stepper "blows up" (NaN) for dt above 0.6 h/c; the limit proposes 0.9 h/c. The
    // controller must reject, shrink, and finish with every accepted state finite.
    let mut s = MockStepper::standing_wave(16, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 3);
    let h = s.grid.h;
    s.faults.nan_above_dt = Some(0.6 * h);
    let mut c = Controller::new(ControllerConfig::default(), vec![sound(0.9)]).unwrap();
    let mut n_rej = 0;
    c.run_until(&mut s, 0.5, &mut |d| {
        if d.outcome == Outcome::Rejected {
            n_rej += 1;
            assert_eq!(d.cause, Some(RejectCause::NonFinite));
        }
    })
    .unwrap();
    assert!(all_finite(&s));
    assert!(n_rej >= 1);
    assert!((s.time() - 0.5).abs() < 1e-12);
    // Accepted steps never exceed the unstable threshold.
    assert!(c.stats().dt_max.unwrap() <= 0.6 * h);
}

#[test]
fn random_nan_and_infinity_never_reach_an_accepted_state() {
    for seed in 0..6 {
        let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.4, seed);
        s.faults.nan_probability = 0.3;
        s.faults.inf_probability = 0.2;
        let mut c =
            Controller::with_default_limits(ControllerConfig::default(), vec![sound(0.5)]).unwrap();
        let mut steps = 0;
        loop {
            if s.time() >= 0.3 - 1e-12 {
                break;
            }
            match c.step(&mut s, 0.3) {
                Ok(_) => assert!(all_finite(&s), "seed {seed}: non-finite accepted"),
                Err(e) => {
                    assert!(
                        matches!(
                            e,
                            ControllerError::TooManyRejections { .. }
                                | ControllerError::StepTooSmall { .. }
                        ),
                        "{e}"
                    );
                    break;
                }
            }
            steps += 1;
            assert!(steps < 100_000, "endless loop");
        }
        assert!(all_finite(&s));
    }
}

#[test]
fn random_error_estimates_progress_or_fail_typed() {
    for seed in 0..8 {
        let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.2, seed);
        let limits: Vec<Box<dyn StepLimit>> = vec![
            sound(0.5),
            Box::new(RandomError {
                rng: ChaCha8Rng::seed_from_u64(seed),
                max: 3.0,
            }),
        ];
        let mut c = Controller::new(ControllerConfig::default(), limits).unwrap();
        let mut attempts = 0u64;
        let r = c.run_until(&mut s, 0.2, &mut |_| attempts += 1);
        match r {
            Ok(_) => assert!((s.time() - 0.2).abs() < 1e-12),
            Err(e) => assert!(
                matches!(
                    e,
                    ControllerError::TooManyRejections { .. }
                        | ControllerError::StepTooSmall { .. }
                ),
                "{e}"
            ),
        }
        assert!(attempts < 1_000_000);
        assert!(all_finite(&s));
    }
}

#[test]
fn sudden_100x_stiffness_jump_is_followed() {
    // E jumps from 1 to 100 (c from 1 to 10) mid-run: the limit's proposal drops 10×, the
    // controller follows immediately (dt never above a proposal) and stays stable.
    let mut s = MockStepper::standing_wave(16, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 5);
    let mut c =
        Controller::with_default_limits(ControllerConfig::default(), vec![sound(0.5)]).unwrap();
    c.run_until(&mut s, 0.25, &mut |_| {}).unwrap();
    let dt_before = c.stats().dt_max.unwrap();
    let e0 = s.energy();
    s.set_youngs(100.0);
    let mut after = Vec::new();
    c.run_until(&mut s, 0.5, &mut |d| after.push(d.clone()))
        .unwrap();
    let first = &after[0];
    assert!(
        first.dt <= 0.5 * s.grid.h / 10.0 * 1.0001,
        "first dt after jump {}",
        first.dt
    );
    assert!(first.dt < 0.2 * dt_before);
    assert!(all_finite(&s));
    // Energy stays bounded (the strain energy at E = 100 of the same stress is smaller).
    assert!(s.energy() < 10.0 * e0, "energy {} vs {}", s.energy(), e0);
    // And back down: the controller grows dt again by at most 10× per step.
    s.set_youngs(1.0);
    let mut back = Vec::new();
    c.run_until(&mut s, 0.75, &mut |d| back.push(d.clone()))
        .unwrap();
    for w in back.windows(2) {
        if w[0].outcome == Outcome::Accepted && w[1].attempt == 1 {
            assert!(w[1].dt <= 10.0 * w[0].dt * (1.0 + 1e-12));
        }
    }
}

#[test]
fn no_initial_step_is_a_typed_error() {
    let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
    let mut c = Controller::with_default_limits(ControllerConfig::default(), vec![]).unwrap();
    let err = c.step(&mut s, 1.0).unwrap_err();
    assert!(
        matches!(err, ControllerError::NoInitialStep { .. }),
        "{err}"
    );
}

#[test]
fn dt_min_is_enforced_with_a_typed_error() {
    let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
    let config = ControllerConfig {
        dt_min: 1.0,
        ..ControllerConfig::default()
    };
    let mut c = Controller::new(config, vec![sound(0.5)]).unwrap();
    let err = c.step(&mut s, 10.0).unwrap_err();
    assert!(
        matches!(err, ControllerError::StepTooSmall { dt_min, .. } if dt_min.to_bits() == 1.0f64.to_bits()),
        "{err}"
    );
}

#[test]
fn t_end_not_after_t_is_a_typed_error() {
    let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
    let mut c = Controller::new(ControllerConfig::default(), vec![sound(0.5)]).unwrap();
    assert!(matches!(
        c.step(&mut s, 0.0),
        Err(ControllerError::InvalidEnd { .. })
    ));
    assert!(matches!(
        c.step(&mut s, f64::NAN),
        Err(ControllerError::InvalidEnd { .. })
    ));
}

#[test]
fn open_ended_steps_with_infinite_t_end() {
    let mut s = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 1);
    let mut c = Controller::new(ControllerConfig::default(), vec![sound(0.5)]).unwrap();
    for _ in 0..5 {
        let d = c.step(&mut s, f64::INFINITY).unwrap();
        assert_eq!(d.last().unwrap().outcome, Outcome::Accepted);
    }
    assert_eq!(s.step_count(), 5);
}
