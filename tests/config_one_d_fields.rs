//! Capability: every 1D-only field of the controller config (the 1D stability limit's
//! eq 58 and λmax tracking settings, the checkerboard growth monitor's settings, the
//! temporal error's balance with eq 44) is reachable from the JSON config and changes
//! what a controlled 1D run does: each field is set against a base config in which it is
//! consulted, and the decision logs of the two runs (each attempt's outcome, step, binding
//! bound, rejection cause and measured temporal error) must differ: every setting here
//! moves the steps, not only the limits' internal numbers. The shared fields are swept in
//! 1D by `tests/config_shared_fields_1d.rs`; `tests/config_dimensions.rs` checks that
//! these fields are refused in 2D and 3D.

use mpm_dt::controller::{Controller, ControllerConfig, ControllerError, Decision};
use mpm_dt::scenario::Scenario;

fn with(fields: &str) -> ControllerConfig {
    let json = format!("{{{fields}}}");
    ControllerConfig::from_json(&json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

/// The standing wave (linear elastic, `A` = 0.01, mode 1) on a periodic bar of 16 cells
/// with 2 GIMP particles a cell.
const BAR: &str = r#"{"cells": 16, "particles": {"per_cell": 2},
    "initial": {"standing_wave": {"amplitude": 0.01, "mode": 1}}}"#;

/// The same bar at a large amplitude (`A` = 0.25), where the paper's reading of eq 58
/// rejects trials that eq 56's step allows: the eq 58 settings move the steps here (on
/// [`BAR`] eq 58 stays below 1 and they would not).
const LARGE_BAR: &str = r#"{"cells": 16, "particles": {"per_cell": 2},
    "initial": {"standing_wave": {"amplitude": 0.25, "mode": 1}}}"#;

/// One line per attempt of the standard 1D controller of `c` on the bar to `t_end`, then
/// how the run ended.
fn run(c: &ControllerConfig, t_end: f64) -> Vec<String> {
    run_on(BAR, c, t_end)
}

/// [`run`] on the scenario `bar`.
fn run_on(bar: &str, c: &ControllerConfig, t_end: f64) -> Vec<String> {
    let mut controller = Controller::<1>::standard(c.clone()).unwrap();
    let mut solver = Scenario::from_json(bar).unwrap().build().unwrap();
    let mut log = Vec::new();
    let mut record = |d: &Decision| {
        log.push(format!(
            "{:?} {:e} {} {:?} {:?}",
            d.outcome, d.dt, d.binding, d.cause, d.dsm
        ));
    };
    match controller.run_until(&mut solver, t_end, &mut record) {
        Ok(_) => log.push("finished".to_string()),
        Err(ControllerError::GrowthPersists { detections, .. }) => {
            log.push(format!("GrowthPersists({detections})"))
        }
        Err(e) => panic!("run failed: {e}"),
    }
    log
}

/// A base that grows slowly (the stability limit off, 0.8 times the sound-speed step): the
/// checkerboard share grows by orders of magnitude within the compared windows, and the
/// monitor detects it once the energy confirms it, after about 220 steps. (At 0.85 the
/// growth is so fast that the first comparison detects it whatever `factor` and
/// `energy_confirm` say.)
const UNSTABLE: &str =
    r#""stability": null, "sound_speed": {"alpha": 0.8}, "temporal": {"enabled": false}"#;

/// `(changed, base)`: the bodies of two configs `{…}`, the changed one setting a field of
/// the stability limit or the temporal error against a base where it is consulted (the
/// Lanczos settings where λmax is tracked by Lanczos alone) on [`BAR`].
const LIMIT_CHANGES: [(&str, &str); 3] = [
    (
        r#""stability": {"tracking": {"lanczos": {}}, "lanczos": {"tol": 0.5}}"#,
        r#""stability": {"tracking": {"lanczos": {}}}"#,
    ),
    (r#""stability": {"tracking": {"lanczos": {}}}"#, ""),
    (
        r#""temporal": {"rtol": 1e-3, "balance": 1.0}"#,
        r#""temporal": {"rtol": 1e-3}"#,
    ),
];

/// The eq 58 settings against a base where eq 58 rejects, on [`LARGE_BAR`]: its reading,
/// how often it is evaluated, and its tolerance.
const EQ58_CHANGES: [(&str, &str); 3] = [
    (
        r#""stability": {"reading": "paper", "bound58_every": 1}"#,
        r#""stability": {"bound58_every": 1}"#,
    ),
    (
        r#""stability": {"reading": "paper", "bound58_every": 1}"#,
        r#""stability": {"reading": "paper"}"#,
    ),
    (
        r#""stability": {"reading": "paper", "bound58_every": 1, "tol": 0.5}"#,
        r#""stability": {"reading": "paper", "bound58_every": 1}"#,
    ),
];

#[test]
fn every_one_d_limit_setting_changes_a_1d_run() {
    for (changed, base) in EQ58_CHANGES {
        let reference = run_on(LARGE_BAR, &with(base), 2.0);
        assert!(reference.len() > 5, "too short a run: {{{base}}}");
        assert_ne!(
            run_on(LARGE_BAR, &with(changed), 2.0),
            reference,
            "{{{changed}}} changed nothing against {{{base}}} on the large bar"
        );
    }
    for (changed, base) in LIMIT_CHANGES {
        let reference = run(&with(base), 2.0);
        assert!(reference.len() > 5, "too short a run: {{{base}}}");
        assert_ne!(
            run(&with(changed), 2.0),
            reference,
            "{{{changed}}} changed nothing against {{{base}}}"
        );
    }
}

/// The checkerboard monitor's settings move its detection on the growing base: the
/// energy indicator, a `factor` beyond the
/// share's rise, a `floor` above it, and the energy confirmation switched off.
#[test]
fn every_one_d_growth_setting_changes_a_1d_run() {
    let reference = run(&with(UNSTABLE), 16.0);
    assert!(
        reference.iter().any(|l| l.contains("Some(Growth)")),
        "no growth detected: the comparisons would be vacuous"
    );
    for growth in [
        r#"{"indicator": "energy"}"#,
        r#"{"factor": 1e6}"#,
        r#"{"floor": 1.0}"#,
        r#"{"energy_confirm": 0.0}"#,
    ] {
        let changed = with(&format!(r#"{UNSTABLE}, "growth": {growth}"#));
        assert_ne!(
            run(&changed, 16.0),
            reference,
            "growth {growth} changed nothing"
        );
    }
}
