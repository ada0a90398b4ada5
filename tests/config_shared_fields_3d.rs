//! Capability: every field of the controller config that applies in every dimension
//! changes what a controlled 3D run does — the 3D sweep of `tests/config_shared_fields.rs`
//! (which sweeps 2D, and explains the method), with the same bases: each field is set
//! against a base config in which it is consulted, and the decision logs of the two runs
//! (each attempt's outcome, step, binding bound, rejection cause and measured temporal
//! error) and how the runs ended must differ, or the run must end with the error the field
//! names. The growth monitor's settings (`window`, `windows`, `safety_factor`, and the
//! 2D/3D-only `energy_tol`) are swept here too, on a longer run of the growing base. The
//! layout is a small jittered neo-Hookean GIMP block moving across a periodic 4×4×4 grid
//! (seeded, so the runs are deterministic).
//!
//! The `stability_nd.*` settings are swept in 3D by `tests/config_stability_nd_3d.rs`.
//! Refusals are tested elsewhere: the 1D-only fields in 3D by `tests/config_dimensions.rs`,
//! a `gravity` of the wrong length by `tests/controller_standard.rs`.

use mpm_dt::controller::{Controller, ControllerConfig};

#[path = "common/config_sweep.rs"]
mod config_sweep;
use config_sweep::{with, Run};
#[path = "common/shared_changes_nd.rs"]
mod shared_changes_nd;
use shared_changes_nd::{REJECTING, SHARED_CHANGES, T_END, UNSTABLE};

#[path = "common/jitter.rs"]
mod jitter;
#[path = "common/moving_block_3d.rs"]
mod moving_block_3d;
use moving_block_3d::moving_block_3d as block;

/// The standard 3D controller of `c` (its own `gravity` goes to the growth monitor) on the
/// block under the body force `gravity`, to `t_end`.
fn run(c: &ControllerConfig, gravity: [f64; 3], t_end: f64) -> Run {
    let mut controller = Controller::<3>::standard(c.clone()).unwrap();
    let mut solver = block(gravity);
    Run::of(|record| controller.run_until(&mut solver, t_end, record))
}

#[test]
fn every_shared_field_changes_a_3d_run() {
    let mut unchanged = Vec::new();
    for (changed, base) in SHARED_CHANGES {
        let reference = run(&with(base), [0.0; 3], T_END);
        assert!(reference.log.len() > 5, "too short a run: {{{base}}}");
        if run(&with(changed), [0.0; 3], T_END) == reference {
            unchanged.push(format!("{{{changed}}} against {{{base}}}"));
        }
    }
    assert!(unchanged.is_empty(), "changed nothing: {unchanged:#?}");
}

/// The growth monitor's settings (`window`, `windows`, `safety_factor` shared with 1D,
/// `energy_tol` 2D/3D only; `tests/config_dimensions.rs` sweeps them in 2D) move the
/// detections of the growing base, which follow one another over a longer run.
#[test]
fn every_growth_setting_changes_a_3d_run() {
    for growth in [
        r#"{"window": 5}"#,
        r#"{"windows": 2}"#,
        r#"{"energy_tol": 5.0}"#,
        r#"{"safety_factor": 0.5}"#,
    ] {
        let reference = run(&with(UNSTABLE), [0.0; 3], 20.0);
        assert!(reference.rejections() > 1, "too few detections to tell");
        let changed = with(&format!(r#"{UNSTABLE}, "growth": {growth}"#));
        assert_ne!(
            run(&changed, [0.0; 3], 20.0),
            reference,
            "growth {growth} changed nothing"
        );
    }
}

/// The fields whose change ends the run name their error.
#[test]
fn the_ending_fields_end_the_3d_run_with_their_error() {
    assert_eq!(run(&with(""), [0.0; 3], T_END).end, "finished");
    assert_eq!(
        run(&with(r#""dt_min": 1.0"#), [0.0; 3], T_END).end,
        "StepTooSmall"
    );
    let rejecting = run(&with(REJECTING), [0.0; 3], T_END);
    assert_eq!(rejecting.end, "finished");
    assert!(rejecting.rejections() > 0);
    let once = format!(r#"{REJECTING}, "max_consecutive_rejections": 1"#);
    assert_eq!(
        run(&with(&once), [0.0; 3], T_END).end,
        "TooManyRejections(1)"
    );
    let unstable = run(&with(UNSTABLE), [0.0; 3], T_END);
    assert_eq!(unstable.end, "finished");
    assert!(unstable.rejections() > 0);
    let persists = format!(r#"{UNSTABLE}, "growth": {{"min_safety_scale": 0.95}}"#);
    assert_eq!(
        run(&with(&persists), [0.0; 3], T_END).end,
        "GrowthPersists(1)"
    );
    // Twice in a row, so that the second retry is clamped to `max_shrink_repeated`.
    let twice = run(
        &with(&format!(r#"{UNSTABLE}, "reject_shrink": 0.95"#)),
        [0.0; 3],
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
fn gravity_changes_a_3d_run() {
    let base = r#""growth": {"window": 5}"#;
    let g = [0.0, 0.0, -1.0];
    let reference = run(&with(base), g, 2.0);
    assert!(reference.log.len() > 5, "too short a run");
    let other = run(
        &with(&format!(r#"{base}, "gravity": [0.0, 0.0, -1.0]"#)),
        g,
        2.0,
    );
    assert_ne!(other, reference);
}
