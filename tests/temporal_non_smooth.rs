//! The temporal error on a jelly that lands on mpm88's floor, at tolerances tight enough
//! for the limit to bind. mpm88's walls zero the velocity of every node in a band three
//! cells thick that moves into the wall, so a landing particle's velocity jumps by an
//! amount no step makes smaller (`temporal::non_smooth`): before that part of the error was
//! excluded, `tol = 3·10⁻⁵` took 20× the steps of `10⁻⁴` on mpm88's scene and `3·10⁻⁶`
//! ended in `StepTooSmall`. The run must reach its end with a bounded number of
//! rejections, tighter tolerances must still take more steps, and the exclusion must be
//! what happened.

#[path = "../examples/mls_mpm/model.rs"]
#[allow(dead_code)]
mod model;
#[path = "../examples/mls_mpm/solver.rs"]
#[allow(dead_code)]
mod solver;
#[path = "../examples/mls_mpm/summary.rs"]
#[allow(dead_code)]
mod summary;

use mpm_dt::controller::{Controller, ControllerConfig, Stats};
use mpm_dt::limits_nd::TransferNd;
use nalgebra::Vector2;
use solver::{MlsMpm, Model};

/// A small mpm88 jelly: 576 particles on a 24 × 24 lattice, jittered (seeded), in
/// `[0.3, 0.5]²` of a 32² grid, falling at 1 under gravity onto the floor.
fn jelly() -> MlsMpm {
    let mut state = 88u64;
    let mut jitter = || {
        // A linear congruential generator: a fixed, seeded sequence in [−0.5, 0.5).
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let spacing = 0.2 / 24.0;
    let x: Vec<Vector2<f64>> = (0..24 * 24)
        .map(|k| {
            let (i, j) = ((k % 24) as f64, (k / 24) as f64);
            Vector2::new(
                0.3 + spacing * (i + 0.5 + 0.5 * jitter()),
                0.3 + spacing * (j + 0.5 + 0.5 * jitter()),
            )
        })
        .collect();
    let v = vec![Vector2::new(0.0, -1.0); x.len()];
    let model = Model::Jelly {
        youngs_modulus: 400.0,
        poisson_ratio: 0.2,
    };
    MlsMpm::new(32, model, 1.0, Vector2::new(0.0, -9.8), x, v)
}

/// Runs the jelly to t = 0.3 at `tol`: the statistics and the decisions that excluded a
/// part of the error.
fn run(tol: f64) -> (Stats, usize) {
    let mut config = ControllerConfig {
        gravity: Some(vec![0.0, -9.8]),
        ..ControllerConfig::default()
    };
    config.stability_nd.transfer = TransferNd::Apic { inertia: 0.25 };
    config.temporal.rtol = tol;
    config.temporal.atol_rel = Some(tol);
    let mut c = Controller::<2>::standard(config).unwrap();
    let mut s = jelly();
    let mut excluding = 0;
    c.run_until(&mut s, 0.3, &mut |d| {
        excluding += usize::from(
            d.limits
                .iter()
                .any(|l| l.metrics.contains_key("dsm_excluded")),
        );
    })
    .unwrap_or_else(|e| panic!("tol {tol}: {e}"));
    (c.stats().clone(), excluding)
}

#[test]
fn a_jelly_landing_on_mpm88s_floor_reaches_its_end_at_tight_tolerances() {
    let mut steps = Vec::new();
    let mut excluded = 0;
    for tol in [1e-4, 1e-5, 1e-6] {
        let (stats, excluding) = run(tol);
        eprintln!(
            "tol {tol}: {} steps, {} rejected, dt_min {:?}, {excluding} decisions excluding a part",
            stats.accepted, stats.rejected, stats.dt_min
        );
        assert!(2 * stats.rejected <= stats.accepted, "tol {tol}: {stats:?}");
        steps.push(stats.accepted);
        excluded += excluding;
    }
    assert!(steps.windows(2).all(|w| w[1] > w[0]), "{steps:?}");
    assert!(excluded > 0, "the landing excluded no part of the error");
}
