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

use mpm_dt::controller::{Controller, ControllerConfig};

#[path = "common/config_sweep.rs"]
mod config_sweep;
use config_sweep::{with, Run};
#[path = "common/shared_changes_nd.rs"]
mod shared_changes_nd;
use shared_changes_nd::{REJECTING, SHARED_CHANGES, T_END, UNSTABLE};

#[path = "common/jitter.rs"]
mod jitter;
#[path = "common/moving_block.rs"]
mod moving_block;
use moving_block::moving_block as block;

/// The standard 2D controller of `c` (its own `gravity` goes to the growth monitor) on the
/// block under the body force `gravity`, to `t_end`.
fn run(c: &ControllerConfig, gravity: [f64; 2], t_end: f64) -> Run {
    let mut controller = Controller::<2>::standard(c.clone()).unwrap();
    let mut solver = block(gravity);
    Run::of(|record| controller.run_until(&mut solver, t_end, record))
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
