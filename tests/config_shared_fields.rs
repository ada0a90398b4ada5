//! Capability: every field of the controller config that applies in every dimension is
//! reachable from the JSON config and changes what a controlled 2D run does. Each field is
//! set against a base config in which it is consulted (`tests/config_dimensions.rs` does
//! the same for the 2D/3D-only `stability_nd` and growth fields): the decision logs of the
//! two runs (each attempt's outcome, step, binding bound, rejection cause and measured
//! temporal error) and how the runs ended must differ, or the run must end with the error
//! the field names.
//!
//! The same sweep in the other dimensions: `tests/config_shared_fields_3d.rs` (3D, with
//! the growth monitor's settings) and `tests/config_shared_fields_1d.rs` (1D, on bases
//! where the 1D limits consult each field); the 1D-only fields change a 1D run in
//! `tests/config_one_d_fields.rs`, the `stability_nd` settings a 3D run in
//! `tests/config_stability_nd_3d.rs`. Fields that do not apply in a dimension are refused
//! there: `tests/config_dimensions.rs`, and `tests/controller_standard.rs` for `gravity`.

use mpm_dt::controller::{Controller, ControllerConfig, ControllerError, Decision};

fn config(json: &str) -> ControllerConfig {
    ControllerConfig::from_json(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

#[path = "common/jitter.rs"]
mod jitter;
#[path = "common/moving_block.rs"]
mod moving_block;
use moving_block::moving_block as block;

/// What a controlled run did: one line per attempt, then how the run ended.
#[derive(Debug, PartialEq)]
struct Run {
    log: Vec<String>,
    end: String,
}

impl Run {
    fn rejections(&self) -> usize {
        self.log
            .iter()
            .filter(|l| l.starts_with("Rejected"))
            .count()
    }
}

/// The standard 2D controller of `c` (its own `gravity` goes to the growth monitor) on the
/// block under the body force `gravity`, to `t_end`.
fn run(c: &ControllerConfig, gravity: [f64; 2], t_end: f64) -> Run {
    let mut controller = Controller::<2>::standard(c.clone()).unwrap();
    let mut solver = block(gravity);
    let mut log = Vec::new();
    let mut record = |d: &Decision| {
        log.push(format!(
            "{:?} {:e} {} {:?} {:?}",
            d.outcome,
            d.dt,
            d.binding,
            d.cause,
            d.dsm.map(|e| format!("{e:e}"))
        ));
    };
    let end = match controller.run_until(&mut solver, t_end, &mut record) {
        Ok(_) => "finished".to_string(),
        Err(ControllerError::StepTooSmall { .. }) => "StepTooSmall".to_string(),
        Err(ControllerError::TooManyRejections { count, .. }) => {
            format!("TooManyRejections({count})")
        }
        Err(ControllerError::GrowthPersists { detections, .. }) => {
            format!("GrowthPersists({detections})")
        }
        Err(e) => format!("error: {e}"),
    };
    Run { log, end }
}

const T_END: f64 = 2.0;

/// A base where the temporal error limit (through the filter) sets the steps.
const ACCURATE: &str = r#""temporal": {"rtol": 1e-3}"#;

/// A base whose first step is far too large for a tight tolerance: rejected by the temporal
/// error (once; its retry is accepted).
macro_rules! rejecting {
    () => {
        r#""temporal": {"rtol": 1e-4}, "dt_initial": 0.05"#
    };
}
const REJECTING: &str = rejecting!();

/// A base that grows (the stability limit off, 1.7 times the sound-speed step, as in
/// `every_growth_setting_changes_a_2d_run`): growth rejections, which suggest no step.
macro_rules! unstable {
    () => {
        r#""stability": null, "sound_speed": {"alpha": 1.7}, "temporal": {"enabled": false}"#
    };
}
const UNSTABLE: &str = unstable!();

/// `max_shrink_repeated` acts only from the second consecutive rejection of one step: the
/// temporal retry after `dt_initial` is accepted, but on the growing base with
/// `reject_shrink` 0.95 the retry after a step the stepper fails (a non-finite state) is
/// rejected again, and the next retry is clamped to it.
///
/// `(changed, base)`: the bodies of two configs `{…}`, the changed one setting the field
/// against a base where it is consulted.
const SHARED_CHANGES: [(&str, &str); 24] = [
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
            unstable!(),
            r#", "reject_shrink": 0.95, "max_shrink_repeated": 0.5"#
        ),
        concat!(unstable!(), r#", "reject_shrink": 0.95"#),
    ),
    (concat!(unstable!(), r#", "reject_shrink": 0.3"#), UNSTABLE),
    (r#""temporal": {"rtol": 1e-3}, "filter": "i""#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3}, "order": 2"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "enabled": false}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-2}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "atol_rel": 1e-5}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "atol_v": 0.1}"#, ACCURATE),
    (r#""temporal": {"rtol": 1e-3, "atol_sigma": 0.1}"#, ACCURATE),
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
        r#""max_consecutive_rejections": 1, "temporal": {"rtol": 1e-4}, "dt_initial": 0.05"#,
        REJECTING,
    ),
    (
        concat!(unstable!(), r#", "growth": {"min_safety_scale": 0.95}"#),
        UNSTABLE,
    ),
];

fn with(fields: &str) -> ControllerConfig {
    config(&format!("{{{fields}}}"))
}

#[test]
fn every_shared_field_changes_a_2d_run() {
    for (changed, base) in SHARED_CHANGES {
        let reference = run(&with(base), [0.0; 2], T_END);
        let other = run(&with(changed), [0.0; 2], T_END);
        assert!(reference.log.len() > 5, "too short a run: {{{base}}}");
        assert_ne!(
            other, reference,
            "{{{changed}}} changed nothing against {{{base}}}"
        );
    }
}

/// The fields whose change ends the run name their error.
#[test]
fn the_ending_fields_end_the_run_with_their_error() {
    assert_eq!(run(&with(""), [0.0; 2], T_END).end, "finished");
    assert_eq!(
        run(&with(r#""dt_min": 1.0"#), [0.0; 2], T_END).end,
        "StepTooSmall"
    );
    assert_eq!(run(&with(REJECTING), [0.0; 2], T_END).end, "finished");
    assert_eq!(
        run(
            &with(&format!(r#"{REJECTING}, "max_consecutive_rejections": 1"#)),
            [0.0; 2],
            T_END
        )
        .end,
        "TooManyRejections(1)"
    );
    assert_eq!(run(&with(UNSTABLE), [0.0; 2], T_END).end, "finished");
    assert!(run(&with(UNSTABLE), [0.0; 2], T_END).rejections() > 0);
    assert_eq!(
        run(
            &with(&format!(
                r#"{UNSTABLE}, "growth": {{"min_safety_scale": 0.95}}"#
            )),
            [0.0; 2],
            T_END
        )
        .end,
        "GrowthPersists(1)"
    );
    // Twice in a row, so that the second retry is clamped to `max_shrink_repeated`.
    let twice = run(
        &with(&format!(r#"{UNSTABLE}, "reject_shrink": 0.95"#)),
        [0.0; 2],
        T_END,
    );
    let consecutive = twice
        .log
        .windows(2)
        .filter(|w| w[0].starts_with("Rejected") && w[1].starts_with("Rejected"))
        .count();
    assert!(consecutive > 0, "no step rejected twice in a row");
}

/// The body force of `gravity`: the growth monitor counts its potential energy, so a
/// falling block under the same config without it reads its rising kinetic energy as
/// growth.
#[test]
fn gravity_changes_a_2d_run() {
    let base = r#""growth": {"window": 5}"#;
    let g = [0.0, -1.0];
    let reference = run(&with(base), g, 2.0);
    let other = run(&with(&format!(r#"{base}, "gravity": [0.0, -1.0]"#)), g, 2.0);
    assert_ne!(other, reference);
}
