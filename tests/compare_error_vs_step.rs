//! Why issue 6's "≥ 1.6× fewer steps than α = 0.4 **at equal or better final error**" cannot
//! hold on the uniform GIMP layouts of the suite, for any step policy: there the final
//! velocity error of the reference solver *rises linearly with the step*.
//!
//! The USL step of the paper is first order in time through its grid velocity (eqs 19, 24:
//! the velocity that drives `σ` and `x` is `v_i + dt a_i`, with `v_i` the eq 17 projection
//! of the particle velocities; `src/synchronized_velocity.rs`, "What it does not fix"), and it
//! dissipates energy at a rate proportional to `dt` (the known USL behaviour; Bardenhagen,
//! "Energy conservation error in the material point method for solid mechanics", J. Comput.
//! Phys. 180, 2002). So a run with a longer mean step has a larger error, whoever chooses
//! the step: a fixed α taking as many steps as mpm-dt ends with the same error
//! (README "Performance").
//!
//! This test pins both facts on `scenarios/suite/gimp_uniform_ppc2.json` with fixed
//! multipliers of the sound-speed step, run as `examples/compare.rs` runs them: the
//! synchronised final velocity error increases with α, by first-order increments, and the
//! energy drift is proportional to α. `α = 0.64` is the largest mean step that takes
//! 1.6× fewer steps than `α = 0.4`.

use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::Scenario;
use mpm_dt::stability::{SoundSpeed, SoundSpeedConfig};
use mpm_dt::Stepper;

const SCENARIO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/scenarios/suite/gimp_uniform_ppc2.json"
);

/// Final synchronised velocity error (L∞, `ℓ` = half the last regular step) and relative
/// energy drift of a run at a fixed multiplier `alpha` of the sound-speed step.
fn run(scenario: &Scenario, alpha: f64) -> (f64, f64) {
    let limit = SoundSpeed::new(SoundSpeedConfig { alpha }).expect("valid alpha");
    let mut s: ReferenceStepper = scenario.build().expect("scenario builds");
    let x0 = s.view().x.to_vec();
    let e0 = s.total_energy();
    let t_end = scenario.t_end;
    let mut half_step = 0.0;
    while t_end - s.time() > 1e-12 * t_end {
        let dt = limit.dt(&s.view()).expect("valid view");
        let remaining = t_end - s.time();
        if dt <= remaining {
            half_step = 0.5 * dt;
        }
        s.try_step(dt.min(remaining))
            .and_then(|()| s.accept())
            .expect("a stable run");
    }
    let wave = scenario.exact_solution().expect("a standing-wave scenario");
    let (sync, _raw) = wave.velocity_errors(&x0, &s.view(), half_step);
    let drift = (s.total_energy() - e0) / e0;
    (sync.expect("valid half step"), drift)
}

#[test]
fn the_final_error_rises_linearly_with_the_step_on_uniform_gimp() {
    let scenario = Scenario::from_file(SCENARIO).expect("suite scenario parses");
    let alphas = [0.1, 0.2, 0.4, 0.64];
    let runs: Vec<(f64, f64)> = alphas.iter().map(|&a| run(&scenario, a)).collect();
    let err: Vec<f64> = runs.iter().map(|r| r.0).collect();
    let drift: Vec<f64> = runs.iter().map(|r| r.1).collect();
    eprintln!("alpha {alphas:?}\nerror {err:?}\ndrift {drift:?}");

    // The error increases with the step; the largest mean step that takes 1.6× fewer steps
    // than α = 0.4 is already worse than α = 0.4.
    for k in 0..alphas.len() - 1 {
        assert!(
            err[k] < err[k + 1],
            "error at α = {} ({:e}) not below α = {} ({:e})",
            alphas[k],
            err[k],
            alphas[k + 1],
            err[k + 1]
        );
    }
    // First-order increments: doubling the step from 0.2 to 0.4 adds about twice what
    // doubling it from 0.1 to 0.2 added (2 for a first-order term, 4 for a second-order one).
    let growth = (err[2] - err[1]) / (err[1] - err[0]);
    assert!(
        (1.3..3.0).contains(&growth),
        "error increments grow by {growth} per doubling of the step"
    );
    // The energy is dissipated in proportion to the step (USL, first order).
    for k in 0..2 {
        let ratio = drift[k + 1] / drift[k];
        assert!(
            drift[k] < 0.0,
            "α = {}: energy drift {}",
            alphas[k],
            drift[k]
        );
        assert!(
            (1.8..2.2).contains(&ratio),
            "energy drift α = {} → {}: ratio {ratio}, not ≈ 2",
            alphas[k],
            alphas[k + 1]
        );
    }
}
