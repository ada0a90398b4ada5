//! Capability: the temporal local error of eqs 20–30 in 2D/3D (`TemporalErrorNd`) — its
//! `dsm` is second order in the step on a smooth plane wave, zero on a rigid translation,
//! binds the controller's step when its tolerance is tight, rejects a non-finite trial, and
//! a setting it cannot honour (the 1D-only balancing, a restored state whose arrays do not
//! belong together) is a typed error, not ignored.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{bound, metric, Controller, ControllerConfig, Outcome};
use mpm_dt::limit::StepLimit;
use mpm_dt::limits_nd::TemporalErrorNd;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::{SolverNd, Vector};
use mpm_dt::Stepper;

fn plane_wave() -> (SolverNd<2>, ScenarioNd) {
    let scenario = ScenarioNd::from_file(format!(
        "{}/scenarios/nd/plane_p_2d.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .expect("scenario");
    let (solver, _) = scenario.build::<2>().expect("solver");
    (solver, scenario)
}

/// Settings that check every trial (no deferral).
fn every_trial() -> mpm_dt::controller::TemporalErrorConfig {
    mpm_dt::controller::TemporalErrorConfig {
        max_deferred: 0,
        ..Default::default()
    }
}

/// `dsm` of a trial of step `dt` from the solver's committed state (not accepted).
fn dsm_of(limit: &mut TemporalErrorNd<2>, s: &mut SolverNd<2>, dt: f64) -> f64 {
    s.try_step(dt).expect("trial");
    let j = limit
        .judge(&s.view(), &s.trial_view().expect("trial view"), dt)
        .expect("judged");
    s.reject();
    limit.rejected(dt, mpm_dt::limit::RejectCause::Error);
    j.metrics[metric::DSM]
}

#[test]
fn dsm_is_second_order_in_the_step_on_a_plane_wave() {
    let (mut s, _) = plane_wave();
    let mut limit = TemporalErrorNd::<2>::new(every_trial());
    // h/c_p = 0.0625/1.16: steps of 0.01 are well inside the stability limit.
    let dt0 = 0.01;
    for _ in 0..5 {
        s.try_step(dt0).expect("trial");
        let (before, after) = (s.view(), s.trial_view().expect("trial view"));
        limit.judge(&before, &after, dt0).expect("judged");
        limit.accepted(&before, &after, dt0);
        s.accept().expect("accept");
    }
    // From the same state and history: the history form's d²u/dt² does not depend on the
    // step to first order, so dsm = dt²/2·|d²u/dt²|/w scales by 4 when dt doubles.
    let small = dsm_of(&mut limit, &mut s, dt0);
    let large = dsm_of(&mut limit, &mut s, 2.0 * dt0);
    let ratio = large / small;
    assert!(small > 0.0 && small < 1.0, "dsm {small}");
    eprintln!("dsm {small:.3e} → {large:.3e}, ratio {ratio:.3}");
    assert!(
        (3.3..4.7).contains(&ratio),
        "dsm ratio {ratio} ({small} → {large})"
    );
}

#[test]
fn a_rigid_translation_has_no_temporal_error() {
    let (mut s, _) = plane_wave();
    let n = s.view().n_particles();
    let v = vec![Vector::<2>::new(0.3, -0.2); n];
    let sigma = vec![mpm_dt::nd::Tensor::<2>::zeros(); n];
    s.set_velocity_and_stress(&v, &sigma).expect("state set");
    let mut limit = TemporalErrorNd::<2>::new(every_trial());
    for step in 0..3 {
        s.try_step(0.01).expect("trial");
        let (before, after) = (s.view(), s.trial_view().expect("trial view"));
        let j = limit.judge(&before, &after, 0.01).expect("judged");
        limit.accepted(&before, &after, 0.01);
        assert!(
            j.metrics[metric::DSM] < 1e-12,
            "step {step}: {:?}",
            j.metrics
        );
        s.accept().expect("accept");
    }
}

#[test]
fn a_tight_tolerance_binds_the_step() {
    let run = |rtol: f64| {
        let (mut s, scenario) = plane_wave();
        let mut config: ControllerConfig = scenario.controller_config().expect("config");
        config.temporal.rtol = rtol;
        config.temporal.atol_rel = Some(rtol);
        let limits = standard_limits::<2>(&config, Vector::<2>::zeros());
        let mut c = Controller::<2>::new(config, limits).expect("controller");
        let (mut steps, mut by_error) = (0, 0);
        c.run_until(&mut s, 0.3, &mut |d| {
            if d.outcome == Outcome::Accepted {
                steps += 1;
            }
            if d.binding == bound::FILTER || d.rejected_by.as_deref() == Some("temporal_error") {
                by_error += 1;
            }
        })
        .expect("run");
        (steps, by_error)
    };
    let (loose_steps, loose_bound) = run(0.05);
    let (tight_steps, tight_bound) = run(1e-5);
    eprintln!(
        "steps {loose_steps} / {tight_steps}, bound by the error {loose_bound} / {tight_bound}"
    );
    assert_eq!(
        loose_bound, 0,
        "the default tolerance never binds on this wave"
    );
    assert!(tight_bound > 0, "the tight tolerance never bound the step");
    assert!(
        tight_steps > 2 * loose_steps,
        "{tight_steps} steps against {loose_steps}"
    );
}

#[test]
fn balancing_is_reported_as_an_error_in_2d() {
    let (mut s, _) = plane_wave();
    let config = mpm_dt::controller::TemporalErrorConfig {
        balance: Some(1.0),
        ..Default::default()
    };
    let mut limit = TemporalErrorNd::<2>::new(config);
    s.try_step(0.01).expect("trial");
    let err = limit
        .judge(&s.view(), &s.trial_view().expect("trial view"), 0.01)
        .expect_err("balance is 1D only");
    assert!(err.to_string().contains("balance"), "{err}");
}

#[test]
fn a_non_finite_trial_is_rejected() {
    let (mut s, _) = plane_wave();
    // Every trial checked: a deferred check reads nothing, and leaves non-finite values to
    // the controller's own scan of each trial.
    let mut limit = TemporalErrorNd::<2>::new(every_trial());
    // On the first step (the nodal-rate form, which does not read the trial's velocity)
    // and on a later one (the history form).
    for step in 0..2 {
        s.try_step(0.01).expect("trial");
        let (before, after) = (s.view(), s.trial_view().expect("trial view"));
        let mut v = after.v.to_vec();
        v[7][1] = f64::NAN;
        let poisoned = mpm_dt::ViewNd { v: &v, ..after };
        let j = limit.judge(&before, &poisoned, 0.01).expect("judged");
        assert!(
            matches!(j.verdict, mpm_dt::limit::Verdict::Reject { .. }),
            "step {step}: {:?}",
            j.metrics
        );
        limit.rejected(0.01, mpm_dt::limit::RejectCause::NonFinite);
        // The clean trial is accepted and becomes the history.
        let j = limit.judge(&before, &after, 0.01).expect("judged");
        assert!(matches!(j.verdict, mpm_dt::limit::Verdict::Accept));
        limit.accepted(&before, &after, 0.01);
        s.accept().expect("accept");
    }
}

#[test]
fn a_restored_state_must_hold_together() {
    let (mut s, _) = plane_wave();
    let mut limit = TemporalErrorNd::<2>::new(Default::default());
    s.try_step(0.01).expect("trial");
    let (before, after) = (s.view(), s.trial_view().expect("trial view"));
    limit.judge(&before, &after, 0.01).expect("judged");
    limit.accepted(&before, &after, 0.01);
    let saved = limit.save_state().expect("a history");
    let mut fresh = TemporalErrorNd::<2>::new(Default::default());
    fresh.restore_state(&saved).expect("its own state restores");
    let mut cut = saved.clone();
    cut["stress_rate"]
        .as_array_mut()
        .expect("stress rates")
        .truncate(3);
    let err = fresh
        .restore_state(&cut)
        .expect_err("rates of different lengths");
    assert!(err.to_string().contains("restore"), "{err}");
}

#[test]
fn invalid_tolerances_end_the_run_before_a_trial() {
    let (s, _) = plane_wave();
    let config = mpm_dt::controller::TemporalErrorConfig {
        rtol: -1.0,
        ..Default::default()
    };
    let mut limit = TemporalErrorNd::<2>::new(config);
    let err = limit.propose(&s.view()).expect_err("a negative rtol");
    assert!(err.to_string().contains("rtol"), "{err}");
}

#[test]
fn deferred_checks_resume_and_see_the_steps_between() {
    // One trajectory at a fixed step, judged by a deferring limit (the default) and by one
    // that checks every trial.
    let (mut s, _) = plane_wave();
    let mut deferring = TemporalErrorNd::<2>::new(Default::default());
    let mut every = TemporalErrorNd::<2>::new(every_trial());
    let dt = 0.01;
    let mut measured = Vec::new();
    for step in 0..40 {
        s.try_step(dt).expect("trial");
        let (before, after) = (s.view(), s.trial_view().expect("trial view"));
        let all = every.judge(&before, &after, dt).expect("judged");
        let some = deferring.judge(&before, &after, dt).expect("judged");
        every.accepted(&before, &after, dt);
        deferring.accepted(&before, &after, dt);
        let reference = all.metrics[metric::DSM];
        assert!(
            reference < 0.1,
            "step {step}: dsm {reference} (a deferrable wave)"
        );
        match some.metrics.get(metric::DSM) {
            Some(&dsm) => {
                // After deferred steps the second derivative spans them, centred half the
                // span earlier (up to 4.5 steps, 0.07 of the wave's period): on this wave
                // it differs from the every-step one by 1–10 %.
                let rel = (dsm - reference).abs() / reference;
                assert!(rel < 0.2, "step {step}: {dsm} against {reference}");
                measured.push(step);
            }
            None => {
                let predicted = some.metrics["dsm_predicted"];
                assert!(predicted <= 0.1, "step {step}: deferred at {predicted}");
            }
        }
        s.accept().expect("accept");
    }
    // The deferrals after each check double up to 8: 1, 2, 4, 8, 8, 8.
    assert_eq!(measured, vec![0, 2, 5, 10, 19, 28, 37]);
}

#[test]
fn a_rejection_ends_a_deferral_and_a_larger_step_is_checked() {
    let (mut s, _) = plane_wave();
    let mut limit = TemporalErrorNd::<2>::new(Default::default());
    let dt = 0.01;
    let judge = |limit: &mut TemporalErrorNd<2>, s: &mut SolverNd<2>, dt: f64| {
        s.try_step(dt).expect("trial");
        let j = limit
            .judge(&s.view(), &s.trial_view().expect("trial view"), dt)
            .expect("judged");
        j.metrics.get(metric::DSM).copied()
    };
    // Checked, accepted: the next trial of the same step is deferred.
    judge(&mut limit, &mut s, dt).expect("the first trial is checked");
    limit.accepted(&s.view(), &s.trial_view().expect("trial view"), dt);
    s.accept().expect("accept");
    assert!(judge(&mut limit, &mut s, dt).is_none(), "not deferred");
    // Rejected by another limit: the retry is checked.
    s.reject();
    limit.rejected(dt, mpm_dt::limit::RejectCause::Growth);
    let retry = judge(&mut limit, &mut s, dt).expect("deferred after a rejection");
    limit.accepted(&s.view(), &s.trial_view().expect("trial view"), dt);
    s.accept().expect("accept");
    // The schedule starts again at one deferred trial.
    assert!(
        judge(&mut limit, &mut s, dt).is_none(),
        "not deferred after the retry"
    );
    limit.accepted(&s.view(), &s.trial_view().expect("trial view"), dt);
    s.accept().expect("accept");
    let again = judge(&mut limit, &mut s, dt).expect("a second deferral");
    limit.accepted(&s.view(), &s.trial_view().expect("trial view"), dt);
    s.accept().expect("accept");
    // A restored limit that checks every trial defers nothing, whatever the saved schedule.
    let saved = limit.save_state().expect("a history");
    assert!(saved["defer"]["left"].as_u64() > Some(0), "{saved}");
    let mut every = TemporalErrorNd::<2>::new(every_trial());
    every.restore_state(&saved).expect("restored");
    assert!(
        judge(&mut every, &mut s, dt).is_some(),
        "deferred with max_deferred 0"
    );
    s.reject();
    every.rejected(dt, mpm_dt::limit::RejectCause::Growth);
    // A step whose predicted dsm, `dsm·(dt'/dt)²`, is above the threshold is checked.
    let big = dt * (0.2 / again.min(retry)).sqrt();
    assert!(
        judge(&mut limit, &mut s, big).is_some(),
        "deferred at {big}"
    );
}
