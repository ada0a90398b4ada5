//! Capability: every field of the controller config that applies in every dimension
//! changes what a controlled 1D run does — the 1D sweep of `tests/config_shared_fields.rs`
//! (which sweeps 2D, and explains the method): each field is set against a base config in
//! which it is consulted, and the decision logs of the two runs (each attempt's outcome,
//! step, binding bound, rejection cause and measured temporal error) and how the runs ended
//! must differ, or the run must end with the error the field names. The growth monitor's
//! shared settings (`window`, `windows`, `safety_factor`) are swept too. The layout is the
//! reference solver's standing wave on a periodic bar of 16 cells (a scenario).
//!
//! Some bases differ from the 2D ones because the 1D limits are consulted differently:
//! the 1D stability limit caps the first step below `dt_initial`, so the rejecting base
//! uses `rtol` 1e-3 (a modest `dsm`, whose retry factor `max_shrink_first` and `min_shrink`
//! clamp); the 1D growth monitor suggests its retry step (the lowered safety), so
//! `reject_shrink` and `max_shrink_repeated` are swept on a base whose steps the stepper
//! fails (a non-finite state; with `reject_shrink` 0.95 the first retry, clamped to
//! `max_shrink_first`, fails too), and the slowly growing base runs at 0.85 times the
//! sound-speed step (at 1.7 the bar fails outright instead of growing).
//!
//! Refusals are tested elsewhere: `gravity` in 1D by `tests/controller_standard.rs`, the
//! 2D/3D-only fields (`stability_nd.*`, `growth.energy_tol`) in 1D by
//! `tests/config_dimensions.rs`, which also checks that the 1D-only fields are accepted.
//! The 1D-only fields are swept in 1D by `tests/config_one_d_fields.rs`.

use mpm_dt::controller::{Controller, ControllerConfig};

#[path = "common/config_sweep.rs"]
mod config_sweep;
use config_sweep::{with, Run};
use mpm_dt::scenario::Scenario;

/// The standing wave (linear elastic, `A` = 0.01, mode 1) on a periodic bar of 16 cells
/// with 2 GIMP particles a cell.
const BAR: &str = r#"{"cells": 16, "particles": {"per_cell": 2},
    "initial": {"standing_wave": {"amplitude": 0.01, "mode": 1}}}"#;

/// The standard 1D controller of `c` on the bar, to `T_END`.
fn run(c: &ControllerConfig) -> Run {
    let mut controller = Controller::<1>::standard(c.clone()).unwrap();
    let mut solver = Scenario::from_json(BAR).unwrap().build().unwrap();
    Run::of(|record| controller.run_until(&mut solver, T_END, record))
}

/// Eight periods of the wave (the slowly growing base is detected after about five).
const T_END: f64 = 8.0;

/// A base where the temporal error limit (through the filter) sets the steps.
const ACCURATE: &str = r#""temporal": {"rtol": 1e-3}"#;

/// A base whose first step (`dt_initial`, capped by the stability limit) is too large for
/// the tolerance: rejected by the temporal error at `dsm` ≈ 9 (once; its retry is
/// accepted).
macro_rules! rejecting {
    () => {
        r#""temporal": {"rtol": 1e-3}, "dt_initial": 0.05"#
    };
}
const REJECTING: &str = rejecting!();

/// A base that grows slowly (the stability limit off, 0.85 times the sound-speed step):
/// one growth detection, whose retry the monitor suggests.
macro_rules! unstable {
    () => {
        r#""stability": null, "sound_speed": {"alpha": 0.85}, "temporal": {"enabled": false}"#
    };
}
const UNSTABLE: &str = unstable!();

/// A base whose steps the stepper fails (the stability limit off, 1.7 times the
/// sound-speed step): rejections that suggest no step.
macro_rules! failing {
    () => {
        r#""stability": null, "sound_speed": {"alpha": 1.7}, "temporal": {"enabled": false}"#
    };
}
const FAILING: &str = failing!();

/// `(changed, base)`: the bodies of two configs `{…}`, the changed one setting the field
/// against a base where it is consulted.
const SHARED_CHANGES: [(&str, &str); 28] = [
    (r#""dt_initial": 0.01"#, ""),
    (r#""dt_max": 0.02"#, ""),
    (r#""temporal": {"rtol": 1e-3}, "safety": 0.5"#, ACCURATE),
    (
        r#""dt_initial": 1e-4, "max_growth": 1.1"#,
        r#""dt_initial": 1e-4"#,
    ),
    (concat!(unstable!(), r#", "hold_growth": 1.0"#), UNSTABLE),
    (
        concat!(
            rejecting!(),
            r#", "max_shrink_repeated": 0.5, "min_shrink": 0.3"#
        ),
        concat!(rejecting!(), r#", "max_shrink_repeated": 0.5"#),
    ),
    (
        concat!(rejecting!(), r#", "max_shrink_first": 0.15"#),
        REJECTING,
    ),
    (
        concat!(
            failing!(),
            r#", "reject_shrink": 0.95, "max_shrink_repeated": 0.5"#
        ),
        concat!(failing!(), r#", "reject_shrink": 0.95"#),
    ),
    (concat!(failing!(), r#", "reject_shrink": 0.3"#), FAILING),
    (r#""temporal": {"rtol": 1e-3}, "filter": "i""#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3}, "order": 2"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "enabled": false}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-2}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "atol_rel": 1e-5}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "atol_v": 0.1}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "atol_sigma": 0.1}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "lag": 1.0}"#, ACCURATE),
    (
        r#""temporal": {"rtol": 0.5, "max_deferred": 0}"#,
        r#""temporal": {"rtol": 0.5}"#,
    ),
    (
        r#""temporal": {"rtol": 0.5, "defer_below": 0.0}"#,
        r#""temporal": {"rtol": 0.5}"#,
    ),
    (r#""sound_speed": {"alpha": 0.3}"#, ""),
    (r#""stability": {"safety": 0.5}"#, ""),
    (
        concat!(unstable!(), r#", "growth": {"enabled": false}"#),
        UNSTABLE,
    ),
    (r#""dt_min": 1.0"#, ""),
    (
        concat!(rejecting!(), r#", "max_consecutive_rejections": 1"#),
        REJECTING,
    ),
    (
        concat!(unstable!(), r#", "growth": {"min_safety_scale": 0.95}"#),
        UNSTABLE,
    ),
    (
        concat!(unstable!(), r#", "growth": {"window": 5}"#),
        UNSTABLE,
    ),
    (
        concat!(unstable!(), r#", "growth": {"windows": 2}"#),
        UNSTABLE,
    ),
    (
        concat!(unstable!(), r#", "growth": {"safety_factor": 0.5}"#),
        UNSTABLE,
    ),
];

#[test]
fn every_shared_field_changes_a_1d_run() {
    let mut unchanged = Vec::new();
    for (changed, base) in SHARED_CHANGES {
        let reference = run(&with(base));
        assert!(reference.log.len() > 5, "too short a run: {{{base}}}");
        if run(&with(changed)) == reference {
            unchanged.push(format!("{{{changed}}} against {{{base}}}"));
        }
    }
    assert!(unchanged.is_empty(), "changed nothing: {unchanged:#?}");
}

/// The bases reject for the reason they stand for, and the fields whose change ends the
/// run name their error.
#[test]
fn the_bases_reject_as_described_and_the_ending_fields_end_the_1d_run() {
    assert_eq!(run(&with("")).end, "finished");
    assert_eq!(run(&with(r#""dt_min": 1.0"#)).end, "StepTooSmall");
    let rejecting = run(&with(REJECTING));
    assert_eq!(rejecting.end, "finished");
    assert_eq!(rejecting.rejections_by("Error"), 1);
    let once = format!(r#"{REJECTING}, "max_consecutive_rejections": 1"#);
    assert_eq!(run(&with(&once)).end, "TooManyRejections(1)");
    let unstable = run(&with(UNSTABLE));
    assert_eq!(unstable.end, "finished");
    assert!(unstable.rejections_by("Growth") > 0);
    let persists = format!(r#"{UNSTABLE}, "growth": {{"min_safety_scale": 0.95}}"#);
    assert_eq!(run(&with(&persists)).end, "GrowthPersists(1)");
    let failing = run(&with(FAILING));
    assert_eq!(failing.end, "finished");
    assert!(failing.rejections_by("NonFinite") > 0);
    // Twice in a row, so that the second retry is clamped to `max_shrink_repeated`.
    let twice = run(&with(&format!(r#"{FAILING}, "reject_shrink": 0.95"#)));
    let consecutive = twice
        .log
        .windows(2)
        .filter(|w| w[0].starts_with("Rejected") && w[1].starts_with("Rejected"))
        .count();
    assert!(consecutive > 0, "no step rejected twice in a row");
}
