//! Capability: the controller ends a run that cannot go on with a typed error instead of
//! looping, retrying what a smaller step cannot cure, or dropping attempts from the log.

use mpm_dt::controller::{Controller, ControllerConfig, ControllerError, Decision, Outcome};
use mpm_dt::limit::{Judgement, LimitError, Proposal, RejectCause, Verdict};
use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::Scenario;
use mpm_dt::stability::{SoundSpeed, SoundSpeedConfig};
use mpm_dt::{StepError, StepLimit, Stepper, View};

/// How the wrapped solver misbehaves.
#[derive(Clone, Copy, PartialEq)]
enum Fault {
    /// `accept` keeps the old state: time does not advance.
    KeepsTime,
    /// Every trial fails with a non-finite value (a smaller step might help).
    NonFinite,
    /// Every trial fails with a solver-specific error (a smaller step cannot help).
    Other,
    /// The first trial fails with a retryable solver-specific error, the others succeed.
    FailsOnce,
}

struct Faulty {
    inner: ReferenceStepper,
    fault: Fault,
    failed: bool,
}

impl Stepper for Faulty {
    fn time(&self) -> f64 {
        self.inner.time()
    }
    fn step_count(&self) -> u64 {
        self.inner.step_count()
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        match self.fault {
            Fault::KeepsTime => self.inner.try_step(dt),
            Fault::NonFinite => Err(StepError::NonFinite {
                field: "v",
                index: 0,
                t: self.inner.time(),
                step: self.inner.step_count(),
                dt,
            }),
            Fault::Other => Err(StepError::Other("linear solver diverged".into())),
            Fault::FailsOnce if !self.failed => {
                self.failed = true;
                Err(StepError::Failed {
                    message: "Newton did not converge".into(),
                    t: self.inner.time(),
                    step: self.inner.step_count(),
                    dt,
                })
            }
            Fault::FailsOnce => self.inner.try_step(dt),
        }
    }
    fn accept(&mut self) -> Result<(), StepError> {
        if self.fault == Fault::FailsOnce {
            return self.inner.accept();
        }
        // KeepsTime: drop the trial and report success.
        self.inner.reject();
        Ok(())
    }
    fn reject(&mut self) {
        self.inner.reject();
    }
    fn view(&self) -> View<'_> {
        self.inner.view()
    }
    fn trial_view(&self) -> Option<View<'_>> {
        self.inner.trial_view()
    }
}

fn faulty(fault: Fault) -> Faulty {
    let scenario = Scenario::from_json(r#"{"cells": 16, "t_end": 0.25}"#).unwrap();
    Faulty {
        inner: scenario.build().unwrap(),
        fault,
        failed: false,
    }
}

fn sound() -> Vec<Box<dyn StepLimit>> {
    vec![Box::new(
        SoundSpeed::new(SoundSpeedConfig { alpha: 0.5 }).unwrap(),
    )]
}

#[test]
fn a_stepper_that_keeps_its_time_ends_the_run_with_no_progress() {
    let mut s = faulty(Fault::KeepsTime);
    let mut c = Controller::new(ControllerConfig::default(), sound()).unwrap();
    // One call must fail: run_until would otherwise loop for ever.
    let err = c.step(&mut s, 1.0).unwrap_err();
    assert!(
        matches!(err, ControllerError::NoProgress { t, t_after, .. } if t == 0.0 && t_after == 0.0),
        "{err}"
    );
    let err = c.run_until(&mut s, 1.0, &mut |_| {}).unwrap_err();
    assert!(matches!(err, ControllerError::NoProgress { .. }), "{err}");
}

#[test]
fn run_until_an_end_not_after_t_is_invalid() {
    let mut s = faulty(Fault::KeepsTime);
    let mut c = Controller::new(ControllerConfig::default(), sound()).unwrap();
    for t_end in [0.0, -1.0, f64::NAN] {
        let err = c.run_until(&mut s, t_end, &mut |_| {}).unwrap_err();
        assert!(matches!(err, ControllerError::InvalidEnd { .. }), "{err}");
    }
    assert_eq!(c.stats().accepted + c.stats().rejected, 0);
}

#[test]
fn every_attempt_of_a_failed_step_reaches_the_callback() {
    let mut s = faulty(Fault::NonFinite);
    let config = ControllerConfig::default();
    let max = config.max_consecutive_rejections;
    let mut c = Controller::new(config, sound()).unwrap();
    let mut seen: Vec<Decision> = Vec::new();
    let err = c
        .run_until(&mut s, 1.0, &mut |d| seen.push(d.clone()))
        .unwrap_err();
    let ControllerError::TooManyRejections { count, .. } = &err else {
        panic!("expected TooManyRejections, got {err}");
    };
    assert_eq!(*count, max);
    assert_eq!(seen.len(), max as usize, "one callback per attempt");
    assert!(seen.iter().all(|d| d.outcome == Outcome::Rejected));
    assert_eq!(
        seen.iter().map(|d| d.attempt).collect::<Vec<_>>(),
        (1..=max).collect::<Vec<_>>()
    );
    // The message names the cause as logged, and the stepper's own words.
    let msg = err.to_string();
    assert!(msg.contains("non_finite"), "{msg}");
    assert!(!msg.contains("Some("), "{msg}");
}

#[test]
fn a_retryable_solver_failure_is_retried_with_a_smaller_step() {
    let mut s = faulty(Fault::FailsOnce);
    let mut c = Controller::new(ControllerConfig::default(), sound()).unwrap();
    let mut seen: Vec<Decision> = Vec::new();
    c.run_until(&mut s, 0.25, &mut |d| seen.push(d.clone()))
        .unwrap();
    assert!((s.time() - 0.25).abs() < 1e-12);
    let first = &seen[0];
    assert_eq!(first.outcome, Outcome::Rejected);
    assert_eq!(first.cause, Some(RejectCause::NonFinite));
    assert_eq!(first.rejected_by.as_deref(), Some("stepper"));
    assert!(first.message.as_deref().unwrap_or("").contains("Newton"));
    assert_eq!(seen[1].outcome, Outcome::Accepted);
    assert!(seen[1].dt < first.dt);
    assert_eq!(c.stats().rejected, 1);
}

#[test]
fn a_solver_specific_failure_is_not_retried() {
    let mut s = faulty(Fault::Other);
    let mut c = Controller::new(ControllerConfig::default(), sound()).unwrap();
    let mut callbacks = 0;
    let err = c
        .run_until(&mut s, 1.0, &mut |_| callbacks += 1)
        .unwrap_err();
    match &err {
        ControllerError::Stepper {
            source: StepError::Other(m),
            ..
        } => assert_eq!(m, "linear solver diverged"),
        other => panic!("expected the stepper's own error, got {other}"),
    }
    assert_eq!(callbacks, 0, "no rejected attempt was made");
    assert!(err.to_string().contains("linear solver diverged"));
}

#[test]
fn error_messages_print_numbers_short() {
    let err = ControllerError::InvalidEnd {
        t: 1e300,
        t_end: -1.234_567_890_123_456_7e-300,
    };
    let msg = err.to_string();
    assert!(msg.len() < 80, "{msg}");
    assert!(msg.contains("1e300"), "{msg}");
    let step = StepError::Inverted {
        index: 3,
        det_f: 1.0 / 3.0,
        t: 2e200,
        step: 7,
        dt: 1e-200,
    };
    let msg = step.to_string();
    assert!(msg.len() < 120, "{msg}");
    assert!(msg.contains("2e200") && msg.contains("1e-200"), "{msg}");
}

/// A limit that reports growing energy on every other trial (a scheme the limits do not
/// keep stable at any step), and accepts the others.
struct GrowsEveryOtherTrial {
    trials: u32,
}

impl StepLimit for GrowsEveryOtherTrial {
    fn name(&self) -> &str {
        "grows"
    }
    fn propose(&mut self, _state: &View<'_>) -> Result<Proposal, LimitError> {
        Ok(Proposal::no_opinion())
    }
    fn judge(&mut self, _b: &View<'_>, _a: &View<'_>, _dt: f64) -> Result<Judgement, LimitError> {
        self.trials += 1;
        let verdict = if self.trials % 2 == 1 {
            Verdict::Reject {
                cause: RejectCause::Growth,
                suggested_dt: None,
            }
        } else {
            Verdict::Accept
        };
        Ok(Judgement {
            verdict,
            metrics: Default::default(),
        })
    }
}

#[test]
fn growth_that_persists_ends_the_run_instead_of_shrinking_the_step_for_ever() {
    // The reference solver itself, not misbehaving.
    let mut s = faulty(Fault::KeepsTime).inner;
    let mut config = ControllerConfig::default();
    config.growth.min_safety_scale = 0.5;
    let mut limits = sound();
    limits.push(Box::new(GrowsEveryOtherTrial { trials: 0 }));
    let mut c = Controller::new(config, limits).unwrap();
    let err = c.run_until(&mut s, 1.0, &mut |_| {}).unwrap_err();
    // 0.9⁶ = 0.53 ≥ 0.5 > 0.9⁷: the seventh detection stops the run, after six accepted
    // steps, with the stepper on the last accepted state.
    let ControllerError::GrowthPersists {
        t,
        step,
        detections,
        safety_scale,
        min_safety_scale,
    } = err
    else {
        panic!("expected GrowthPersists, got {err}");
    };
    assert_eq!((detections, step), (7, 6));
    assert!(
        (safety_scale - 0.9f64.powi(6)).abs() < 1e-12,
        "{safety_scale}"
    );
    assert_eq!(min_safety_scale.to_bits(), 0.5f64.to_bits());
    assert_eq!(s.step_count(), 6);
    assert_eq!(s.time().to_bits(), t.to_bits());
    assert_eq!(c.stats().growth_events, 7);
    let msg = err.to_string();
    assert!(
        msg.contains("min_safety_scale") && msg.contains("detected 7 times"),
        "{msg}"
    );

    // The floor is validated; 0 never stops.
    for bad in [1.0, -0.1, f64::NAN] {
        let mut config = ControllerConfig::default();
        config.growth.min_safety_scale = bad;
        assert!(Controller::new(config, sound()).is_err(), "{bad}");
    }
}

/// The reductions of a run on two processes, seen from the one whose growth monitor is
/// quiet: the other process reports, at every trial, a growth detection that takes its
/// safety below the floor (the third flag of the verdict's agreement).
#[derive(Debug)]
struct OtherProcessGrowthPersists;

impl mpm_dt::reduce::Reduce for OtherProcessGrowthPersists {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        2
    }
    fn min_and_any(&self, value: f64, flag: bool) -> (f64, bool) {
        (value, flag)
    }
    fn any_flags(&self, flags: &mut [bool]) {
        // [fatal, rejected, growth past the floor]: the other process rejected, for good.
        if let [_, rejected, stop] = flags {
            *rejected = true;
            *stop = true;
        }
    }
    fn sum(&self, _values: &mut [f64]) {}
    fn exchange(
        &self,
        _to: Option<usize>,
        from: Option<usize>,
        _tag: u16,
        send: &[f64],
    ) -> Option<Vec<f64>> {
        from.map(|_| send.to_vec())
    }
}

#[test]
fn every_process_stops_when_growth_persists_on_one() {
    let mut s = faulty(Fault::KeepsTime).inner;
    let mut c = Controller::new(ControllerConfig::default(), sound())
        .unwrap()
        .with_reduce(std::rc::Rc::new(OtherProcessGrowthPersists));
    let mut seen = Vec::new();
    let err = c
        .run_until(&mut s, 1.0, &mut |d| seen.push(d.clone()))
        .unwrap_err();
    // This process's trial was fine; it stops with the other at once (no retry, whose
    // agreement the other process would never join), on its committed state.
    assert!(
        matches!(err, ControllerError::OtherRank { phase, .. } if phase == "with growth persisting"),
        "{err}"
    );
    assert_eq!(seen.len(), 1, "the one attempt is logged");
    assert_eq!(seen[0].outcome, Outcome::Rejected);
    assert_eq!((s.step_count(), s.time().to_bits()), (0, 0.0f64.to_bits()));
}
