//! The nodal form `C = M^{1/2} K_N M^{1/2}` of the eq 56 operator: the same λmax as the
//! particle form `B` (dense, to round-off) on random layouts, both shapes and boundaries,
//! small nodal masses and per-particle moduli; its Gershgorin bound is an upper bound; the
//! warm-started nodal tracker follows moving particles in few applications.

mod stability_common;

use mpm_dt::stability::{
    Eq56Operator, LambdaMaxTracker, LanczosConfig, NodalOperator, SymmetricOperator,
};
use mpm_dt::{Grid, Shape};
use proptest::prelude::*;
use stability_common::*;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn tight() -> LanczosConfig {
    LanczosConfig {
        tol: 1e-10,
        value_tol: 0.0,
        restart_every: 0,
        restart_iter: 20,
        max_iter: 400,
    }
}

/// Dense λmax of the nodal operator, assembled column by column from `apply`.
fn dense_nodal_lambda_max(op: &NodalOperator) -> f64 {
    let n = op.dim();
    let mut c = faer::Mat::<f64>::zeros(n, n);
    let (mut e, mut y, mut work) = (vec![0.0; n], vec![0.0; n], Vec::new());
    for j in 0..n {
        e.iter_mut().for_each(|v| *v = 0.0);
        e[j] = 1.0;
        op.apply(&e, &mut y, &mut work);
        for i in 0..n {
            c[(i, j)] = y[i];
        }
    }
    for i in 0..n {
        for j in 0..n {
            assert!(
                (c[(i, j)] - c[(j, i)]).abs() <= 1e-12 * c[(i, i)].abs().max(c[(j, j)].abs()),
                "C not symmetric at ({i}, {j})"
            );
        }
    }
    let ev = c.self_adjoint_eigenvalues(faer::Side::Lower).unwrap();
    *ev.last().unwrap()
}

fn check_layout(fx: &Fixture) {
    let view = fx.view();
    let particle = Eq56Operator::new(&view).unwrap();
    let nodal = NodalOperator::new(&view).unwrap();
    let lb = particle.dense_lambda_max().unwrap();
    let lc = dense_nodal_lambda_max(&nodal);
    assert!(rel(lc, lb) < 1e-10, "dense: nodal {lc} vs particle {lb}");
    let est = LambdaMaxTracker::new(tight())
        .unwrap()
        .update(&nodal)
        .unwrap();
    assert!(
        rel(est.lambda_b, lb) < 1e-8,
        "Lanczos nodal {} vs dense {lb}",
        est.lambda_b
    );
    assert!(rel(est.lambda_hat, particle.normalised(lb)) < 1e-8);
    let g = nodal.gershgorin_bound();
    assert!(g >= lb * (1.0 - 1e-12), "Gershgorin {g} < λmax {lb}");
}

fn grid(fixed_ends: bool, cells: usize) -> Grid {
    if fixed_ends {
        fixed(cells, 1.0)
    } else {
        periodic(cells, 1.0)
    }
}

#[test]
fn nodal_lambda_equals_particle_lambda_on_named_layouts() {
    for shape in [Shape::Gimp, Shape::Linear] {
        for fixed_ends in [false, true] {
            for ppc in [1, 2, 4] {
                let x = jittered(12, 1.0, ppc, 0.8, 3 + ppc as u64);
                check_layout(&Fixture::new(grid(fixed_ends, 12), shape, x, 2.0, 5.0));
                let x = uniform(12, 1.0, ppc);
                check_layout(&Fixture::new(grid(fixed_ends, 12), shape, x, 2.0, 5.0));
            }
            let x = small_mass(16, 1.0, 5);
            check_layout(&Fixture::new(grid(fixed_ends, 16), shape, x, 1.0, 1.0));
        }
    }
}

#[test]
fn smallest_periodic_grids_wrap_correctly() {
    // 3 and 4 cells: the distance-2 coupling wraps onto the distance-1 neighbour (3 cells) or
    // onto itself from both sides (4 cells).
    for cells in [3, 4, 5] {
        for shape in [Shape::Gimp, Shape::Linear] {
            let x = jittered(cells, 1.0, 2, 0.9, 11);
            check_layout(&Fixture::new(periodic(cells, 1.0), shape, x, 1.0, 1.0));
        }
    }
}

#[test]
fn per_particle_moduli_and_volumes() {
    let mut fx = Fixture::new(
        periodic(10, 1.0),
        Shape::Gimp,
        jittered(10, 1.0, 3, 0.6, 5),
        1.0,
        1.0,
    );
    for (p, (e, f)) in fx.modulus.iter_mut().zip(fx.f.iter_mut()).enumerate() {
        *e = 1.0 + (p % 7) as f64;
        *f = 0.8 + 0.05 * (p % 5) as f64;
    }
    check_layout(&fx);
}

#[test]
fn warm_nodal_updates_follow_moving_particles() {
    // 64 cells, GIMP, 2 per cell, particles moving ~10⁻³ h per step: the warm nodal tracker
    // stays within 10⁻⁴ of the dense value and needs few applications per step.
    let cells = 64;
    let mut fx = Fixture::new(
        periodic(cells, 1.0),
        Shape::Gimp,
        jittered(cells, 1.0, 2, 0.6, 9),
        1.0,
        1.0,
    );
    let h = fx.grid.h;
    let mut tracker = LambdaMaxTracker::new(LanczosConfig::default()).unwrap();
    let mut applications = Vec::new();
    for step in 0..60 {
        for (p, x) in fx.x.iter_mut().enumerate() {
            *x += 1e-3 * h * (2.0 * std::f64::consts::PI * p as f64 / 40.0).sin();
        }
        fx.refresh();
        let view = fx.view();
        let nodal = NodalOperator::new(&view).unwrap();
        let est = tracker.update(&nodal).unwrap();
        let dense = Eq56Operator::new(&view)
            .unwrap()
            .dense_lambda_max()
            .unwrap();
        assert!(
            rel(est.lambda_b, dense) < 1e-4,
            "step {step}: {} vs {dense}",
            est.lambda_b
        );
        if step > 0 {
            applications.push(est.applications);
        }
    }
    let mean = applications.iter().sum::<usize>() as f64 / applications.len() as f64;
    println!(
        "nodal warm start: mean {mean:.2} applications per update (max {})",
        applications.iter().max().unwrap()
    );
    assert!(mean <= 5.0, "mean {mean}");
}

#[test]
fn bad_state_gives_typed_errors() {
    let mut fx = Fixture::new(periodic(8, 1.0), Shape::Gimp, uniform(8, 1.0, 2), 1.0, 1.0);
    fx.modulus[3] = 0.0;
    assert!(NodalOperator::new(&fx.view()).is_err());
    fx.modulus[3] = 1.0;
    fx.f[2] = f64::NAN;
    assert!(NodalOperator::new(&fx.view()).is_err());
    fx.f[2] = 1.0;
    fx.node_active.iter_mut().for_each(|a| *a = false);
    assert!(NodalOperator::new(&fx.view()).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E), ..ProptestConfig::default() })]

    /// Random layouts: nodal and particle λmax agree to round-off.
    #[test]
    fn nodal_equals_particle_on_random_layouts(
        cells in 3usize..20,
        ppc in 1usize..5,
        amp in 0.0f64..1.0,
        seed in 0u64..1000,
        gimp in any::<bool>(),
        fixed_ends in any::<bool>(),
    ) {
        let shape = if gimp { Shape::Gimp } else { Shape::Linear };
        let x = jittered(cells, 1.0, ppc, amp, seed);
        check_layout(&Fixture::new(grid(fixed_ends, cells), shape, x, 1.5, 3.0));
    }
}
