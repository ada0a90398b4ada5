//! The certified λmax tracker (`CertifiedTracker`, the `Stability` limit's default): at every
//! step of moving layouts (GIMP jittered, both boundaries; linear hats collapsing to a small
//! nodal mass; random layouts by proptest) its Rayleigh quotient is a lower bound on the dense
//! λmax, every certified value is an upper bound within the margin of the truth, and a
//! served value is (measured, asserted with slack) neither far above nor far below it; anchors are rare when
//! particles move little, and a Ritz value that misses the top is caught by the certificate
//! and repaired.

mod stability_common;

use mpm_dt::stability::{
    CertifiedConfig, CertifiedTracker, Eq56Operator, LanczosConfig, NodalOperator, Stability,
    StabilityConfig,
};
use mpm_dt::{Grid, Shape, StepLimit};
use proptest::prelude::*;
use stability_common::*;

/// What following a sequence of states measured.
struct Followed {
    /// Proposals that ran an `LDLᵀ` certificate.
    certified: usize,
    /// Mean applications of `C` per step (Lanczos only runs at anchors whose quotient failed).
    applications: f64,
    /// Smallest served value over the dense λmax (1 would be exact; below 1 is optimistic).
    worst_served: f64,
}

/// Follows `steps` states produced by `mv` and checks, at every one, against the dense λmax:
/// the Rayleigh quotient is a lower bound, a certified value an upper bound, and every value
/// at most `(1 + margin)` above the truth.
fn follow(
    fx: &mut Fixture,
    config: CertifiedConfig,
    steps: usize,
    mut mv: impl FnMut(&mut Fixture, usize),
) -> Followed {
    let mut tracker = CertifiedTracker::new(config, LanczosConfig::default()).unwrap();
    let mut op = NodalOperator::default();
    let (mut certified, mut applications) = (0, 0);
    let mut worst_served = f64::INFINITY;
    let mut worst_loose = 0.0_f64;
    for step in 0..steps {
        mv(fx, step);
        fx.refresh();
        let view = fx.view();
        let c = tracker.update(&view, &mut op).unwrap();
        let dense = Eq56Operator::new(&view)
            .unwrap()
            .dense_lambda_max()
            .unwrap();
        let value = c.estimate.lambda_b;
        assert!(
            c.rayleigh <= dense * (1.0 + 1e-10),
            "step {step}: Rayleigh quotient {} > dense {dense}",
            c.rayleigh
        );
        if c.certified {
            assert!(
                value >= dense,
                "step {step}: certified {value} < dense {dense}"
            );
            certified += 1;
        } else {
            worst_served = worst_served.min(value / dense);
        }
        // A certified value is bisected to within the margin of the truth; a served one is
        // the anchor's certified ratio times its quotient, re-certified when the quotient
        // rises under a loose ratio (measured: at most 0.16 % above; 3.3 % before that
        // trigger existed).
        let loosest = if c.certified {
            (1.0 + config.margin) * (1.0 + 1e-9)
        } else {
            1.01
        };
        assert!(
            value <= loosest * dense,
            "step {step}: value {value} too loose against dense {dense} (certified {})",
            c.certified
        );
        worst_loose = worst_loose.max(value / dense);
        applications += c.estimate.applications;
    }
    println!("largest value / dense λmax: {worst_loose:.5}");
    Followed {
        certified,
        applications: applications as f64 / steps as f64,
        worst_served,
    }
}

#[test]
fn bracket_holds_on_moving_gimp_layouts() {
    for (fixed_ends, provide) in [(false, false), (true, false), (false, true), (true, true)] {
        let cells = 64;
        let grid = grid_of(fixed_ends, cells);
        let x0 = jittered(cells, 1.0, 2, 0.6, 9);
        let x0 = if fixed_ends {
            // Keep clear of the clamped ends.
            x0.into_iter().map(|x| 0.05 + 0.9 * x).collect::<Vec<f64>>()
        } else {
            x0
        };
        let mut fx = Fixture::new(grid, Shape::Gimp, x0, 1.0, 1.0).with_stiffness(provide);
        let h = fx.grid.h;
        let steps = 200;
        let f = follow(&mut fx, CertifiedConfig::default(), steps, |fx, _| {
            for (p, x) in fx.x.iter_mut().enumerate() {
                *x += 1e-3 * h * (2.0 * std::f64::consts::PI * p as f64 / 40.0).sin();
            }
        });
        println!(
            "GIMP jittered, fixed ends {fixed_ends}, stepper's K_N {provide}: {} certificates \
             in {steps} steps, {:.2} applications of C per step, worst served/dense {:.6}",
            f.certified, f.applications, f.worst_served
        );
        // A Lanczos update per step took 2–4 applications (README "Stability"); here Lanczos
        // runs only when a certificate of the served value fails.
        assert!(
            f.applications <= 1.0,
            "{} applications of C per step: the served path is not saving work",
            f.applications
        );
        // A stale mode may hide up to `drop_tol` = 2 % of λmax (dt 1 % high) before the
        // tracker re-anchors (measured: 2.0 %).
        assert!(
            f.worst_served >= 0.97,
            "served value {} of the dense λmax",
            f.worst_served
        );
    }
}

#[test]
fn bracket_follows_a_linear_hat_collapse() {
    // Particles slide into a configuration with a node of ≤ 2 % of the typical mass: λmax
    // grows by orders of magnitude and the bound must follow it from above at every step.
    let cells = 32;
    let (start, end) = collapse_layouts(cells);
    for provide in [false, true] {
        let mut fx = Fixture::new(periodic(cells, 1.0), Shape::Linear, start.clone(), 1.0, 1.0)
            .with_stiffness(provide);
        let steps = 120;
        let f = follow(&mut fx, CertifiedConfig::default(), steps + 1, |fx, s| {
            let a = s as f64 / steps as f64;
            fx.x = interpolate(&start, &end, a);
        });
        println!(
            "linear-hat collapse (stepper's K_N {provide}): {} certificates in {} steps, \
             worst served/dense {:.6}",
            f.certified,
            steps + 1,
            f.worst_served
        );
        // Issue 4 asks dt_eq56 within 2 % of the dense value through the collapse: λ within
        // 2 % keeps dt within 1 %.
        assert!(
            f.worst_served >= 0.98,
            "served value {} of the dense λmax",
            f.worst_served
        );
        let m = &fx.node_mass;
        assert!(m[11] / m[(11 + cells / 2) % cells] <= 0.02);
    }
}

#[test]
fn the_stability_limit_follows_the_exact_eq56_step_through_a_collapse() {
    // The default `Stability` (certified tracking) on the collapsing linear-hat layout: every
    // certified proposal is at most `safety · dt_eq56` of its own state, every served one at
    // most 1 % above it (measured: 0.11 %, inside the safety factor's 5 %), and none more
    // than 1 % below it.
    let cells = 32;
    let (start, end) = collapse_layouts(cells);
    for provide in [false, true] {
        let mut fx = Fixture::new(periodic(cells, 1.0), Shape::Linear, start.clone(), 1.0, 1.0)
            .with_stiffness(provide);
        let mut limit = Stability::new(StabilityConfig::default()).unwrap();
        let safety = limit.safety();
        let steps = 200;
        let mut worst = 0.0_f64;
        for s in 0..=steps {
            let a = s as f64 / steps as f64;
            fx.x = interpolate(&start, &end, a);
            fx.refresh();
            let view = fx.view();
            let p = limit.propose(&view).unwrap();
            let exact = safety * dense_dt56(&view);
            let certified = p.metrics["lambda_certified"] > 0.0;
            let cap = if certified { 1.0 } else { 1.01 };
            worst = worst.max(p.dt / exact);
            assert!(
                p.dt <= cap * exact,
                "step {s}: proposed {} > {exact} (certified {certified})",
                p.dt
            );
            assert!(
                p.dt >= 0.99 * exact,
                "step {s}: proposed {} ≪ {exact}",
                p.dt
            );
        }
        println!(
            "collapse under the Stability limit (stepper's K_N {provide}): largest proposal / \
         (safety·dt_eq56) {worst:.5}"
        );
    }
}

#[test]
fn a_ritz_value_below_the_top_is_caught_and_repaired() {
    // One Lanczos application per anchor: the Ritz value is a single Rayleigh quotient, well
    // below λmax, so the certificate at (1 + margin)·θ fails and the tracker must fall back
    // to its cold, tight iteration — and still return a rigorous upper bound.
    let cells = 48;
    let fx = Fixture::new(
        periodic(cells, 1.0),
        Shape::Gimp,
        jittered(cells, 1.0, 2, 0.8, 3),
        1.0,
        1.0,
    );
    let view = fx.view();
    let mut op = NodalOperator::default();
    let dense = Eq56Operator::new(&view)
        .unwrap()
        .dense_lambda_max()
        .unwrap();
    let lanczos = LanczosConfig {
        max_iter: 1,
        ..LanczosConfig::default()
    };
    let mut tracker = CertifiedTracker::new(CertifiedConfig::default(), lanczos).unwrap();
    let c = tracker.update(&view, &mut op).unwrap();
    assert!(c.certified);
    assert!(
        c.factorisations >= 2,
        "the one-application Ritz value was certified: {} factorisations",
        c.factorisations
    );
    let value = c.estimate.lambda_b;
    assert!(value >= dense, "{value} < {dense}");
    assert!(value <= dense * (1.0 + 2e-3));
    assert!(c.rayleigh <= dense * (1.0 + 1e-10));
}

#[test]
fn smallest_grids_are_bracketed() {
    // 3 and 4 cells (periodic: as many nodes), where wrapped couplings alias and the served
    // pass declines (fewer than 4 nodes) or has no interior: every step still bracketed.
    for cells in [3, 4, 5] {
        for (shape, provide) in [Shape::Gimp, Shape::Linear]
            .into_iter()
            .flat_map(|s| [(s, false), (s, true)])
        {
            let mut fx = Fixture::new(
                periodic(cells, 1.0),
                shape,
                uniform(cells, 1.0, 2),
                1.0,
                1.0,
            )
            .with_stiffness(provide);
            let h = fx.grid.h;
            follow(&mut fx, CertifiedConfig::default(), 8, |fx, step| {
                for (p, x) in fx.x.iter_mut().enumerate() {
                    *x += 1e-2 * h * ((p + step) as f64).sin();
                }
            });
        }
    }
}

#[test]
fn invalid_settings_are_typed_errors() {
    for config in [
        CertifiedConfig {
            drop_tol: -0.1,
            ..CertifiedConfig::default()
        },
        CertifiedConfig {
            certify_every: 0,
            ..CertifiedConfig::default()
        },
        CertifiedConfig {
            margin: 0.0,
            ..CertifiedConfig::default()
        },
        CertifiedConfig {
            margin: f64::NAN,
            ..CertifiedConfig::default()
        },
    ] {
        assert!(CertifiedTracker::new(config, LanczosConfig::default()).is_err());
    }
}

fn grid_of(fixed_ends: bool, cells: usize) -> Grid {
    if fixed_ends {
        fixed(cells, 1.0)
    } else {
        periodic(cells, 1.0)
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E), ..ProptestConfig::default() })]

    /// Random layouts, shapes, boundaries and per-particle moduli, moved by random small
    /// displacements over a few steps: the bracket holds at every step.
    #[test]
    fn bracket_holds_on_random_moving_layouts(
        cells in 6usize..24,
        ppc in 1usize..4,
        jitter in 0.0f64..0.9,
        seed in 0u64..1000,
        linear in any::<bool>(),
        fixed_ends in any::<bool>(),
        stiff_ratio in 1.0f64..50.0,
        certify_every in 1u32..8,
        provide in any::<bool>(),
    ) {
        let shape = if linear { Shape::Linear } else { Shape::Gimp };
        let x0 = jittered(cells, 1.0, ppc, jitter, seed);
        let x0: Vec<f64> = if fixed_ends {
            x0.into_iter().map(|x| 0.1 + 0.8 * x).collect()
        } else {
            x0
        };
        let mut fx = Fixture::new(grid_of(fixed_ends, cells), shape, x0, 1.0, 1.0);
        for (p, e) in fx.modulus.iter_mut().enumerate() {
            if p % 5 == 0 {
                *e = stiff_ratio;
            }
        }
        let mut fx = fx.with_stiffness(provide);
        let h = fx.grid.h;
        let config = CertifiedConfig { certify_every, ..CertifiedConfig::default() };
        follow(&mut fx, config, 6, |fx, step| {
            for (p, x) in fx.x.iter_mut().enumerate() {
                let phase = (p as f64 * 0.7 + seed as f64 + step as f64).sin();
                *x += 2e-2 * h * phase;
            }
        });
    }
}
