//! The certified tracker localises its Lanczos mode on a bar large enough for it (at least
//! 2048 nodes, `CertifiedConfig::localise`, the default): from the cold start the served
//! mode is zero outside a window of 512 nodes, so the served pass skips the rest of the bar
//! from the first step, and every value served stays within the bounds the unwindowed
//! tracker's keep — at or above λmax at anchors, within the quotient-drop tolerance below
//! it between them — against λmax bracketed by `LDLᵀ` inertia tests on the same operator.
//! Without `localise` the same run serves a mode that is non-zero everywhere.

mod stability_common;

use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::stability::{CertifiedConfig, NodalOperator, Stability, StabilityConfig, Tracking};
use mpm_dt::{Boundary, Grid, Shape, StepLimit, Stepper};
use stability_common::jittered;

/// `λmax` of the nodal `C` of `stepper`'s state to `10⁻¹²` relative: bisection on Sylvester
/// inertia tests (`eigenvalues_below`), from the Gershgorin bound down.
fn lambda_max(stepper: &ReferenceStepper) -> f64 {
    let op = NodalOperator::new(&stepper.view()).expect("valid view");
    let (mut lo, mut hi) = (0.0, op.gershgorin_bound() * (1.0 + 1e-12));
    assert!(op.eigenvalues_below(hi));
    while hi - lo > 1e-12 * hi {
        let mid = 0.5 * (lo + hi);
        if op.eigenvalues_below(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// Nodes where the tracked mode is not zero.
fn support(limit: &Stability) -> usize {
    let anchor = limit.certified_tracker().anchor().expect("anchored");
    anchor.z.iter().filter(|&&v| v != 0.0).count()
}

fn follow(boundary: Boundary, jitter: f64, localise: bool) {
    let cells = 2560;
    let grid = Grid::new(boundary, cells, 1.0);
    let wave = StandingWave::new(0.01, 1.0, 1.0, 1.0, 1.0);
    // Two particles per cell, moved by up to `jitter` of their spacing (seeded).
    let init = wave.particle_init(jittered(cells, 1.0, 2, jitter, 7));
    let material = Material::LinearElastic {
        youngs_modulus: 1.0,
    };
    let mut stepper =
        ReferenceStepper::new(grid.clone(), Shape::Gimp, material, init).expect("valid set-up");
    stepper.provide_nodal_stiffness(true);
    stepper.provide_summary(true);
    let config = CertifiedConfig {
        localise,
        ..CertifiedConfig::default()
    };
    let mut limit = Stability::new(StabilityConfig {
        tracking: Tracking::Certified(config),
        ..StabilityConfig::default()
    })
    .expect("valid config");
    let dt = 0.4 * grid.h;
    let case = format!("{boundary:?}, jitter {jitter}, localise {localise}");
    let (mut lowest, mut highest, mut widest) = (f64::INFINITY, 0.0_f64, 0);
    for step in 0..40 {
        let proposal = limit.propose(&stepper.view()).expect("valid state");
        let certified = proposal.metrics.get("lambda_factorisations") != Some(&0.0);
        let anchor = limit.certified_tracker().anchor().expect("anchored");
        let served = anchor.ratio * anchor.last_rayleigh;
        let truth = lambda_max(&stepper);
        let ratio = served / truth;
        if certified {
            // The anchor's value is certified by an `LDLᵀ` test: an upper bound.
            assert!(
                ratio >= 1.0 - 1e-12,
                "{case}, step {step}: certified {ratio}"
            );
        }
        lowest = lowest.min(ratio);
        highest = highest.max(ratio);
        let nonzero = support(&limit);
        widest = widest.max(nonzero);
        if step == 0 {
            let localised = nonzero <= 512;
            assert_eq!(
                localised, localise,
                "{case}: the cold start's mode is non-zero on {nonzero} nodes"
            );
        }
        stepper.try_step(dt).expect("stable step");
        stepper.accept().expect("trial pending");
    }
    println!(
        "{case}: served / λmax {lowest:.6} … {highest:.6}, widest mode {widest} of {} nodes",
        grid.n_nodes()
    );
    // Between anchors a value is a Rayleigh quotient times the anchor's ratio: below λmax by
    // at most the drop that triggers an anchor, above it by at most the certified margin
    // (the window changes neither bound).
    assert!(
        lowest >= 1.0 - config.drop_tol,
        "{case}: served {lowest} of λmax"
    );
    assert!(
        highest <= 1.0 + 3.0 * config.margin,
        "{case}: served {highest} of λmax"
    );
    // The mode stays localised: power steps widen it by two nodes per step at most, and the
    // flush keeps its tails at zero.
    if localise {
        assert!(
            widest <= 512 + 2 * 40,
            "{case}: the mode spread to {widest} nodes"
        );
    }
}

#[test]
fn the_mode_is_localised_from_the_cold_start_on_a_periodic_bar() {
    follow(Boundary::Periodic, 0.0, true);
    follow(Boundary::Periodic, 0.0, false);
}

#[test]
fn the_mode_is_localised_from_the_cold_start_on_a_jittered_fixed_bar() {
    follow(Boundary::Fixed, 0.4, true);
    follow(Boundary::Fixed, 0.4, false);
}
