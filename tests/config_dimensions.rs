//! Capability: one controller config means the same in every dimension. A field that does
//! not apply in the run's dimension is refused with an error naming it; every 2D/3D
//! setting of the stability and growth limits is reachable from the JSON config and
//! changes what a 2D run does.

use mpm_dt::controller::{ConfigError, Controller, ControllerConfig, ControllerError};

#[path = "common/jitter.rs"]
mod jitter;
#[path = "common/moving_block.rs"]
mod moving_block;
#[path = "common/opt_in.rs"]
mod opt_in;
#[path = "common/stability_log.rs"]
mod stability_log;
use moving_block::moving_block;
use opt_in::OptIn;
use stability_log::stability_log;

/// `{"<outer>": {"<inner>": value}}` parsed and validated (no dimension yet).
fn config(json: &str) -> ControllerConfig {
    ControllerConfig::from_json(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

/// The field a dimension check refused, if it did.
fn refused(result: Result<(), ControllerError>) -> Option<&'static str> {
    match result {
        Err(ControllerError::Config(ConfigError::NotInDimension { field, .. })) => Some(field),
        Err(e) => panic!("unexpected error {e}"),
        Ok(()) => None,
    }
}

fn try_2d(c: ControllerConfig) -> Result<(), ControllerError> {
    Controller::<2>::standard(c).map(|_| ())
}

fn try_3d(c: ControllerConfig) -> Result<(), ControllerError> {
    Controller::<3>::standard(c).map(|_| ())
}

fn try_1d(c: ControllerConfig) -> Result<(), ControllerError> {
    Controller::<1>::standard(c).map(|_| ())
}

const ONE_D_ONLY: [(&str, &str); 10] = [
    (r#"{"stability": {"tol": 1e-5}}"#, "stability.tol"),
    (
        r#"{"stability": {"reading": "paper"}}"#,
        "stability.reading",
    ),
    (
        r#"{"stability": {"lanczos": {"max_iter": 30}}}"#,
        "stability.lanczos",
    ),
    (
        r#"{"stability": {"tracking": {"lanczos": {}}}}"#,
        "stability.tracking",
    ),
    (
        r#"{"stability": {"bound58_every": 3}}"#,
        "stability.bound58_every",
    ),
    (r#"{"growth": {"indicator": "energy"}}"#, "growth.indicator"),
    (r#"{"growth": {"factor": 2.0}}"#, "growth.factor"),
    (r#"{"growth": {"floor": 1e-6}}"#, "growth.floor"),
    (
        r#"{"growth": {"energy_confirm": 0.0}}"#,
        "growth.energy_confirm",
    ),
    (r#"{"temporal": {"balance": 1.0}}"#, "temporal.balance"),
];

const ND_ONLY: [(&str, &str); 15] = [
    (
        r#"{"stability_nd": {"refresh_cells": 0.05}}"#,
        "stability_nd.refresh_cells",
    ),
    (
        r#"{"stability_nd": {"refresh_mass": 1e-6}}"#,
        "stability_nd.refresh_mass",
    ),
    (
        r#"{"stability_nd": {"refresh_modulus": 1e-4}}"#,
        "stability_nd.refresh_modulus",
    ),
    (
        r#"{"stability_nd": {"refresh_diagonal": 1e-6}}"#,
        "stability_nd.refresh_diagonal",
    ),
    (
        r#"{"stability_nd": {"max_age": 1}}"#,
        "stability_nd.max_age",
    ),
    (r#"{"stability_nd": {"tol": 0.2}}"#, "stability_nd.tol"),
    (
        r#"{"stability_nd": {"max_iter": 2}}"#,
        "stability_nd.max_iter",
    ),
    (
        r#"{"stability_nd": {"margin": 1.5}}"#,
        "stability_nd.margin",
    ),
    (
        r#"{"stability_nd": {"transfer": {"apic": {"inertia": 0.25}}}}"#,
        "stability_nd.transfer",
    ),
    (
        r#"{"stability_nd": {"bound_slack": 10.0}}"#,
        "stability_nd.bound_slack",
    ),
    (
        r#"{"stability_nd": {"bound_slack": 10.0, "bound_age": 1}}"#,
        "stability_nd.bound_slack",
    ),
    (
        r#"{"stability_nd": {"product_cost": 100.0}}"#,
        "stability_nd.product_cost",
    ),
    (
        r#"{"stability_nd": {"bound_drift": -1.0}}"#,
        "stability_nd.bound_drift",
    ),
    (
        r#"{"stability_nd": {"full_map": true}}"#,
        "stability_nd.full_map",
    ),
    (r#"{"growth": {"energy_tol": 0.01}}"#, "growth.energy_tol"),
];

#[test]
fn one_d_settings_are_refused_in_2d_and_3d_and_accepted_in_1d() {
    for (json, field) in ONE_D_ONLY {
        assert_eq!(refused(try_2d(config(json))), Some(field), "{json} in 2D");
        assert_eq!(refused(try_3d(config(json))), Some(field), "{json} in 3D");
        assert_eq!(refused(try_1d(config(json))), None, "{json} in 1D");
    }
}

#[test]
fn two_and_three_d_settings_are_refused_in_1d_and_accepted_in_2d() {
    for (json, field) in ND_ONLY {
        assert_eq!(refused(try_1d(config(json))), Some(field), "{json} in 1D");
        assert_eq!(refused(try_2d(config(json))), None, "{json} in 2D");
        assert_eq!(refused(try_3d(config(json))), None, "{json} in 3D");
    }
}

#[test]
fn the_shared_safety_is_not_a_stability_nd_field_and_a_contradicting_one_is_refused() {
    let err = ControllerConfig::from_json(r#"{"stability_nd": {"safety": 0.5}}"#).unwrap_err();
    assert!(err.to_string().contains("safety"), "{err}");
    let mut c = ControllerConfig::default();
    c.stability_nd.safety = 0.5;
    match try_2d(c) {
        Err(ControllerError::Config(ConfigError::Inconsistent { field, .. })) => {
            assert_eq!(field, "stability_nd.safety")
        }
        other => panic!("expected a contradiction, got {other:?}"),
    }
}

#[test]
fn out_of_range_stability_nd_fields_name_their_path() {
    for (json, field) in [
        (
            r#"{"stability_nd": {"refresh_cells": 0}}"#,
            "stability_nd.refresh_cells",
        ),
        (r#"{"stability_nd": {"tol": 1.5}}"#, "stability_nd.tol"),
        (
            r#"{"stability_nd": {"max_iter": 1}}"#,
            "stability_nd.max_iter",
        ),
        (r#"{"growth": {"energy_tol": -1}}"#, "growth.energy_tol"),
        (
            r#"{"stability_nd": {"full_map": true, "transfer": {"apic": {"inertia": 0.25}}}}"#,
            "stability_nd.full_map",
        ),
    ] {
        match ControllerConfig::from_json(json) {
            Err(ConfigError::OutOfRange { field: f, .. }) => assert_eq!(f, field, "{json}"),
            other => panic!("{json}: expected out of range, got {other:?}"),
        }
    }
}

/// The moving block (`common/moving_block.rs`), as the reference solver or opting in with
/// the element bound from its "own pass" (the library's function).
fn block(opt_in: bool) -> OptIn {
    OptIn {
        solver: moving_block([0.0, 0.0]),
        on: opt_in,
    }
}

/// What a controlled run of the block did: every decision's step, outcome and the
/// stability limit's numbers (λmax, refreshes, Lanczos products, bound proposals).
fn run(c: &ControllerConfig, opt_in: bool, t_end: f64) -> Vec<String> {
    stability_log(c, &mut block(opt_in), t_end)
}

/// Each 2D/3D stability setting, set against a config where it is consulted: the mass and
/// diagonal settings act between the motion guard's refreshes, the bound's age in bound
/// mode, the cost model where the stepper supplies the bound. The moduli and diagonal
/// thresholds, the raw bound's slack, age and cost model act with the calibrated bound
/// off (`bound_drift` −1; with it on, `bound_drift` takes their place), and so does the
/// motion guard's distance: under the calibrated bound it only says when the generic path
/// looks at the bound again, which changes the steps only where the bound has risen.
const STABILITY_CHANGES: [(&str, &str); 15] = [
    (
        r#"{"refresh_cells": 0.05, "bound_drift": -1.0}"#,
        r#"{"bound_drift": -1.0}"#,
    ),
    (r#"{"refresh_mass": 1e-6}"#, "{}"),
    (
        r#"{"refresh_modulus": 1e-4, "bound_drift": -1.0}"#,
        r#"{"bound_drift": -1.0}"#,
    ),
    (
        r#"{"refresh_mass": 1e-6, "refresh_diagonal": 1e-6, "bound_drift": -1.0}"#,
        r#"{"refresh_mass": 1e-6, "bound_drift": -1.0}"#,
    ),
    (r#"{"max_age": 1}"#, "{}"),
    (r#"{"tol": 0.2}"#, "{}"),
    (r#"{"max_iter": 2}"#, "{}"),
    (r#"{"margin": 1.5}"#, "{}"),
    (r#"{"transfer": {"apic": {"inertia": 0.25}}}"#, "{}"),
    (
        r#"{"bound_slack": 10.0, "bound_drift": -1.0}"#,
        r#"{"bound_drift": -1.0}"#,
    ),
    (
        r#"{"bound_slack": 10.0, "bound_age": 1, "bound_drift": -1.0}"#,
        r#"{"bound_slack": 10.0, "bound_drift": -1.0}"#,
    ),
    (
        r#"{"product_cost": 0.0, "bound_drift": -1.0}"#,
        r#"{"bound_drift": -1.0}"#,
    ),
    (r#"{"bound_drift": 0.001}"#, "{}"),
    (r#"{"bound_age": 2}"#, "{}"),
    (r#"{"full_map": true}"#, "{}"),
];

#[test]
fn every_stability_nd_setting_changes_a_2d_run() {
    let nd = |fields: &str| config(&format!(r#"{{"stability_nd": {fields}}}"#));
    for (changed, base) in STABILITY_CHANGES {
        // The cost model weighs Lanczos against a bound the stepper supplies.
        // (0 switches it off; the default steps on this block's bound, `B/λ` 3.8–4.1.)
        let opt_in = changed.contains("product_cost");
        let reference = run(&nd(base), opt_in, 2.0);
        assert!(
            reference.len() > 20,
            "too short a run to tell: {}",
            reference.len()
        );
        assert_ne!(
            run(&nd(changed), opt_in, 2.0),
            reference,
            "{changed} changed nothing against {base}"
        );
    }
}

/// The 2D/3D growth settings change when growth is detected: a run without the stability
/// limit at 1.7 times the sound-speed step (about 1.2 times the frozen-particle critical
/// step) grows, and the monitor's window, span, tolerance and safety factor move the
/// detections.
#[test]
fn every_growth_setting_changes_a_2d_run() {
    let unstable =
        r#""stability": null, "sound_speed": {"alpha": 1.7}, "temporal": {"enabled": false}"#;
    let with = |growth: &str| config(&format!(r#"{{{unstable}, "growth": {growth}}}"#));
    for (changed, base) in [
        (r#"{"window": 5}"#, "{}"),
        (r#"{"windows": 2}"#, "{}"),
        (r#"{"energy_tol": 5.0}"#, "{}"),
        (r#"{"safety_factor": 0.5}"#, "{}"),
    ] {
        let reference = run(&with(base), false, 20.0);
        assert!(
            reference.iter().any(|d| d.starts_with("Rejected")),
            "no growth detected with {base}: the comparison would be vacuous"
        );
        assert_ne!(
            run(&with(changed), false, 20.0),
            reference,
            "growth {changed} changed nothing against {base}"
        );
    }
}

/// A 2D scenario file whose controller object sets a 1D-only field is refused when read,
/// naming the field.
#[test]
fn a_2d_scenario_with_a_1d_setting_is_refused_naming_it() {
    use mpm_dt::nd::scenario::ScenarioNd;
    let text = r#"{"dim": 2, "cells": [8, 8], "t_end": 0.1,
                   "controller": {"stability": {"bound58_every": 3}}}"#;
    let err = ScenarioNd::from_json(text)
        .and_then(|s| s.controller_config())
        .unwrap_err()
        .to_string();
    assert!(err.contains("stability.bound58_every"), "{err}");
    let fine = r#"{"dim": 2, "cells": [8, 8], "t_end": 0.1,
                   "controller": {"stability_nd": {"refresh_cells": 0.25}}}"#;
    let c = ScenarioNd::from_json(fine)
        .unwrap()
        .controller_config()
        .unwrap();
    assert_eq!(c.stability_nd.refresh_cells.to_bits(), 0.25f64.to_bits());
}
