//! The controller's time-stepping error responds to its tolerance: on a small 1D standing
//! wave and on the 416-particle colliding disks, tightening the temporal tolerance
//! (`rtol = atol_rel = tol`) over the range where the temporal error limit binds makes the
//! error against a converged-step run fall at every step of the range, and by a factor
//! over the range. The runs and the error measures are those of the `work_precision`
//! example (docs/accuracy.md), shared by path; every run is deterministic.
//!
//! Above the tolerances tested the limit does not bind on these scenes (the stability
//! limit does; the error stays that of the stability-limited step) — docs/accuracy.md.

#[allow(dead_code)]
#[path = "../examples/work_precision/measure.rs"]
mod measure;
#[allow(dead_code)]
#[path = "../examples/mls_mpm/model.rs"]
mod model;
#[allow(dead_code)]
#[path = "../examples/mls_mpm/mpm88.rs"]
mod mpm88;
#[allow(dead_code)]
#[path = "../examples/work_precision/runs.rs"]
mod runs;
#[allow(dead_code)]
#[path = "../examples/work_precision/scene.rs"]
mod scene;
#[allow(dead_code)]
#[path = "../examples/mls_mpm/solver.rs"]
mod solver;
#[allow(dead_code)]
#[path = "../examples/mls_mpm/summary.rs"]
mod summary;

use measure::{errors, Errors};
use runs::Policy;
use scene::Scene;

/// The controller's errors at each of `tols` against the fixed rule at `alpha_ref`.
fn controller_errors(path: &str, alpha_ref: f64, tols: &[f64]) -> Vec<Errors> {
    controller_errors_of(Scene::open(path).expect("scene"), alpha_ref, tols)
}

/// [`controller_errors`] of a scene already opened.
fn controller_errors_of(scene: Scene, alpha_ref: f64, tols: &[f64]) -> Vec<Errors> {
    let reference = scene.run(Policy::Fixed(alpha_ref)).expect("reference");
    assert!(reference.failure.is_none(), "{:?}", reference.failure);
    tols.iter()
        .map(|&t| {
            let end = scene.run(Policy::Controller(Some(t))).expect("run");
            assert!(end.failure.is_none(), "tol {t}: {:?}", end.failure);
            errors(&end, &reference, scene.particles, &scene.scales).expect("errors")
        })
        .collect()
}

/// Each measure falls at every tightening, and by at least `factor` over the range.
fn assert_monotone(errs: &[Errors], factor: f64) {
    for k in 0..3 {
        let e: Vec<f64> = errs.iter().map(|e| e.named()[k].1).collect();
        let name = errs[0].named()[k].0;
        for w in e.windows(2) {
            assert!(w[1] < w[0], "{name} error did not fall: {e:?}");
        }
        let (first, last) = (e[0], e[e.len() - 1]);
        assert!(
            first >= factor * last,
            "{name} error fell by {:.2}× only: {e:?}",
            first / last
        );
    }
}

#[test]
fn wave_1d_error_falls_as_the_tolerance_tightens() {
    // 80 particles, to t = 1 (one period): `scenarios/vibrating_bar.json`. The response of
    // so short a run is a staircase (a few more steps at each tightening): with the one
    // field-scale rule of `temporal::scales` the velocity error is 7.4e-4 at 1e-3 and
    // 7.2e-4 at 3e-4 (with the 1D limit's former `max(new, previous)` scales: 1.1e-3 and
    // 7.4e-4), so the range reaches 1e-5 for its 4×.
    let errs = controller_errors(
        "scenarios/vibrating_bar.json",
        0.0125,
        &[1e-3, 3e-4, 1e-4, 3e-5, 1e-5],
    );
    assert_monotone(&errs, 4.0);
}

#[test]
fn colliding_disks_error_falls_as_the_tolerance_tightens() {
    // 416 particles, to t = 2 (through the impact).
    let errs = controller_errors(
        "scenarios/accuracy/colliding_disks_t2.json",
        0.00625,
        &[1e-3, 3e-4, 1e-4, 3e-5, 1e-5],
    );
    assert_monotone(&errs, 3.0);
}

#[test]
fn wave_1d_with_the_lag_and_the_staggered_kick_error_falls_as_the_tolerance_tightens() {
    // 1 000 particles, to t = 0.2 (`scenarios/accuracy/wave_1d_lag.json`): the temporal
    // limit with the velocity lag (`temporal.lag = 1`, first order: the step follows the
    // tolerance) and the reference solver's staggered kick (no position drift from the
    // step changes). Without the two, nothing changes over this range; below it the
    // reference (its own change 5.5e-5 in velocity) no longer resolves the errors.
    let mut scene = Scene::open("scenarios/accuracy/wave_1d_lag.json").expect("scene");
    scene.staggered_kick = true;
    let errs = controller_errors_of(scene, 0.0125, &[1e-3, 3e-4, 1e-4]);
    assert_monotone(&errs, 3.5);
}
