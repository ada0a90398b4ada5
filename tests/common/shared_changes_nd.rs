//! The shared config fields' changes and their bases for the 2D and 3D sweeps
//! (`tests/config_shared_fields.rs`, `tests/config_shared_fields_3d.rs`): the same bases
//! serve both blocks.

#![allow(dead_code)] // each sweep uses its part

/// The runs' end.
pub const T_END: f64 = 2.0;

/// A base where the temporal error limit (through the filter) sets the steps.
pub const ACCURATE: &str = r#""temporal": {"rtol": 1e-3}"#;

/// A base whose first step is far too large for a tight tolerance: rejected by the temporal
/// error (once; its retry is accepted).
macro_rules! rejecting {
    () => {
        r#""temporal": {"rtol": 1e-4}, "dt_initial": 0.05"#
    };
}
pub const REJECTING: &str = rejecting!();

/// A base that grows (the stability limit off, 1.7 times the sound-speed step, as in
/// `every_growth_setting_changes_a_2d_run`): growth rejections, which suggest no step.
macro_rules! unstable {
    () => {
        r#""stability": null, "sound_speed": {"alpha": 1.7}, "temporal": {"enabled": false}"#
    };
}
pub const UNSTABLE: &str = unstable!();

/// `max_shrink_repeated` acts only from the second consecutive rejection of one step: the
/// temporal retry after `dt_initial` is accepted, but on the growing base with
/// `reject_shrink` 0.95 the retry is rejected again (after a step the stepper fails, in
/// 2D; for growth, in 3D), and the next retry is clamped to it.
///
/// `(changed, base)`: the bodies of two configs `{…}`, the changed one setting the field
/// against a base where it is consulted.
pub const SHARED_CHANGES: [(&str, &str); 25] = [
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
        r#""max_consecutive_rejections": 1, "temporal": {"rtol": 1e-4}, "dt_initial": 0.05"#,
        REJECTING,
    ),
    (
        concat!(unstable!(), r#", "growth": {"min_safety_scale": 0.95}"#),
        UNSTABLE,
    ),
];
