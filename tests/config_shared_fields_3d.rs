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

use mpm_dt::controller::{Controller, ControllerConfig, ControllerError, Decision};
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::Boundary;

#[path = "common/jitter.rs"]
mod jitter;

fn config(json: &str) -> ControllerConfig {
    ControllerConfig::from_json(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

fn with(fields: &str) -> ControllerConfig {
    config(&format!("{{{fields}}}"))
}

/// A jittered neo-Hookean GIMP block (2×2×2 particles a cell) moving across a periodic
/// 4×4×4 grid of the unit cube, with a shear in each direction, under the body force
/// `gravity`.
fn block(gravity: [f64; 3]) -> SolverNd<3> {
    let grid = GridNd::<3>::new([Boundary::Periodic; 3], [4; 3], [1.0; 3]);
    let material = MaterialNd::NeoHookean {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2; 3], 1.0, material);
    // The velocities follow the unjittered positions.
    let x0 = particles.x.clone();
    jitter::jitter(&mut particles, 0.3, 7);
    let wave = |s: f64| 0.1 * (2.0 * std::f64::consts::PI * s).sin();
    for (v, x) in particles.v.iter_mut().zip(&x0) {
        v[0] = 0.2 + wave(x[1]);
        v[1] = wave(x[2]);
        v[2] = wave(x[0]);
    }
    SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<3>::from(gravity)).unwrap()
}

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

/// The standard 3D controller of `c` (its own `gravity` goes to the growth monitor) on the
/// block under the body force `gravity`, to `t_end`.
fn run(c: &ControllerConfig, gravity: [f64; 3], t_end: f64) -> Run {
    let mut controller = Controller::<3>::standard(c.clone()).unwrap();
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

/// A base that grows (the stability limit off, 1.7 times the sound-speed step): growth
/// rejections, which suggest no step.
macro_rules! unstable {
    () => {
        r#""stability": null, "sound_speed": {"alpha": 1.7}, "temporal": {"enabled": false}"#
    };
}
const UNSTABLE: &str = unstable!();

/// `(changed, base)`: the bodies of two configs `{…}`, the changed one setting the field
/// against a base where it is consulted (the 2D file's list). `max_shrink_repeated`: on
/// the growing base with `reject_shrink` 0.95 the retry after a growth rejection is
/// rejected for growth again, and the next retry is clamped to it.
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
