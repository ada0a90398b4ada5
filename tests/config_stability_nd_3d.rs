//! Capability: every 2D/3D setting of the stability limit (`stability_nd.*`) changes what a
//! controlled 3D run does — the 3D sweep of `every_stability_nd_setting_changes_a_2d_run`
//! in `tests/config_dimensions.rs` (same list, same bases, same log: every decision's
//! outcome, step and the stability limit's numbers), on the small jittered block moving
//! across a periodic 4×4×4 grid of `tests/config_shared_fields_3d.rs`. As there, the
//! solver hands over no element bound and no sound-speed step (the generic path), except
//! for the cost model, which weighs Lanczos against a bound the stepper supplies.

use mpm_dt::controller::ControllerConfig;

#[path = "common/jitter.rs"]
mod jitter;
#[path = "common/moving_block_3d.rs"]
mod moving_block_3d;
#[path = "common/opt_in.rs"]
mod opt_in;
#[path = "common/stability_log.rs"]
mod stability_log;
use opt_in::OptIn;
use stability_log::stability_log;

/// The 3D block of `tests/config_shared_fields_3d.rs`, without body force.
fn block() -> mpm_dt::nd::SolverNd<3> {
    moving_block_3d::moving_block_3d([0.0; 3])
}

/// Every decision's outcome, step and the stability limit's numbers (λmax, refreshes,
/// Lanczos products, bound proposals) of a controlled run of the block to `t_end`.
fn run(c: &ControllerConfig, opt_in: bool, t_end: f64) -> Vec<String> {
    stability_log(
        c,
        &mut OptIn {
            solver: block(),
            on: opt_in,
        },
        t_end,
    )
}

/// `(changed, base)`: `stability_nd` objects, the list of `tests/config_dimensions.rs`
/// (whose docs say where each is consulted) but for two entries. `refresh_mass` is set
/// with the calibrated bound off (`bound_drift` −1), as the 2D list sets `refresh_cells`:
/// against the default it did not change this block's steps to `T_END`. The cost model is
/// set to 100 products instead of 0: 0 (the model off) left this block's run unchanged
/// (its bound is about 4.9 times λmax), a dear product changes it.
const STABILITY_CHANGES: [(&str, &str); 15] = [
    (
        r#"{"refresh_cells": 0.05, "bound_drift": -1.0}"#,
        r#"{"bound_drift": -1.0}"#,
    ),
    (
        r#"{"refresh_mass": 1e-6, "bound_drift": -1.0}"#,
        r#"{"bound_drift": -1.0}"#,
    ),
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
        r#"{"product_cost": 100.0, "bound_drift": -1.0}"#,
        r#"{"bound_drift": -1.0}"#,
    ),
    (r#"{"bound_drift": 0.001}"#, "{}"),
    (r#"{"bound_age": 2}"#, "{}"),
    (r#"{"full_map": true}"#, "{}"),
];

/// Eight time units: about as many steps as the 2D test's two on its finer grid.
const T_END: f64 = 8.0;

#[test]
fn every_stability_nd_setting_changes_a_3d_run() {
    let nd = |fields: &str| {
        let json = format!(r#"{{"stability_nd": {fields}}}"#);
        ControllerConfig::from_json(&json).unwrap_or_else(|e| panic!("{json}: {e}"))
    };
    let mut unchanged = Vec::new();
    for (changed, base) in STABILITY_CHANGES {
        let opt_in = changed.contains("product_cost");
        let reference = run(&nd(base), opt_in, T_END);
        assert!(reference.len() > 20, "too short a run: {}", reference.len());
        if run(&nd(changed), opt_in, T_END) == reference {
            unchanged.push(format!("{changed} against {base}"));
        }
    }
    assert!(unchanged.is_empty(), "changed nothing: {unchanged:#?}");
}
