//! The empirical critical step (bisection on real runs) against the frozen full map and eq 56:
//! `dt_eq56 ≤ dt_full_map ≤ dt_empirical(A = 10⁻⁴)·1.01`, and full map and empirical agree
//! within 1 %, on uniform, jittered and small-mass layouts, GIMP and linear hats.

mod stability_common;

use mpm_dt::mpm::{Material, ParticleInit, ReferenceStepper};
use mpm_dt::stability::{
    EmpiricalConfig, Eq56Operator, FullMap, FullMapConfig, Protocol, SoundSpeed,
};
use mpm_dt::{Grid, Shape, Stepper};
use stability_common::*;

fn layout(grid: &Grid, x: Vec<f64>) -> ParticleInit {
    let n = x.len();
    let vol = grid.length() / n as f64;
    ParticleInit {
        x,
        v: vec![0.0; n],
        sigma: vec![0.0; n],
        f: vec![1.0; n],
        volume0: vec![vol; n],
        mass: vec![vol; n],
        width: vec![vol; n],
    }
}

fn check(name: &str, grid: Grid, shape: Shape, x: Vec<f64>) {
    let material = Material::LinearElastic {
        youngs_modulus: 1.0,
    };
    let init = layout(&grid, x);
    let config = EmpiricalConfig {
        rel_tol: 2e-3,
        ..EmpiricalConfig::default()
    };
    let protocol = Protocol::new(grid.clone(), shape, material, &init, config).unwrap();
    let s = ReferenceStepper::new(grid, shape, material, protocol.initial().clone()).unwrap();
    let view = s.view();
    let op = Eq56Operator::new(&view).unwrap();
    let d56 = Eq56Operator::critical_dt(op.dense_lambda_max().unwrap());
    let d49 = SoundSpeed::dt_eq49(&view).unwrap();
    let full = FullMap::new(&view)
        .unwrap()
        .critical_dt(0.5 * d56, FullMapConfig::default())
        .unwrap();
    let emp = protocol.critical_dt(0.5 * d49, 1.5 * d49).unwrap();
    eprintln!(
        "{name} {shape:?}: eq49 {:.4} eq56 {:.4} full {:.4} empirical {:.4} (×h/c; {} runs)",
        1.0,
        d56 / d49,
        full / d49,
        emp.dt() / d49,
        emp.runs
    );
    assert!(
        d56 <= full * (1.0 + 1e-6),
        "{name}: eq56 {d56} > full {full}"
    );
    assert!(
        full <= emp.dt_unstable * 1.01,
        "{name}: full {full} > 1.01 × empirical {:?}",
        emp
    );
    assert!(
        (full - emp.dt()).abs() <= 0.01 * full,
        "{name}: full {full} vs empirical {:?}",
        emp
    );
}

#[test]
fn gimp_uniform() {
    check(
        "uniform ppc2",
        periodic(16, 1.0),
        Shape::Gimp,
        uniform(16, 1.0, 2),
    );
}

#[test]
fn gimp_jittered() {
    check(
        "jittered ppc2",
        periodic(16, 1.0),
        Shape::Gimp,
        jittered(16, 1.0, 2, 0.8, 4),
    );
}

#[test]
fn gimp_small_mass() {
    check(
        "small mass",
        periodic(16, 1.0),
        Shape::Gimp,
        small_mass(16, 1.0, 5),
    );
}

#[test]
fn linear_uniform() {
    check(
        "uniform ppc2",
        periodic(16, 1.0),
        Shape::Linear,
        uniform(16, 1.0, 2),
    );
}

#[test]
fn linear_jittered() {
    check(
        "jittered ppc2",
        periodic(16, 1.0),
        Shape::Linear,
        jittered(16, 1.0, 2, 0.8, 4),
    );
}

#[test]
fn linear_small_mass() {
    check(
        "small mass",
        periodic(16, 1.0),
        Shape::Linear,
        small_mass(16, 1.0, 5),
    );
}

#[test]
fn fixed_ends_gimp() {
    check(
        "fixed ends ppc2",
        fixed(16, 1.0),
        Shape::Gimp,
        uniform(16, 1.0, 2),
    );
}

/// The monotonicity scan reports exactly the unstable steps below a larger stable one.
#[test]
fn the_scan_names_unstable_steps_below_a_stable_one() {
    use mpm_dt::stability::{scan_monotone, SCAN_POINTS};
    // Stable up to 1, except a window [0.8, 0.85): a light node's resonance, say.
    let stable = |dt: f64| Ok::<_, ()>(dt <= 1.0 && !(0.8..0.85).contains(&dt));
    let scan = scan_monotone(1.0, stable).unwrap();
    assert_eq!(scan.tried.len(), 2 * SCAN_POINTS + 1);
    let expected: Vec<f64> = scan
        .tried
        .iter()
        .map(|&(dt, _)| dt)
        .filter(|dt| (0.8..0.85).contains(dt))
        .collect();
    assert!(
        !expected.is_empty(),
        "the window falls between the scan's steps"
    );
    assert_eq!(scan.unstable_below_stable, expected);
    assert!(!scan.is_monotone());
    // A monotone limit: nothing reported, steps above it unstable.
    let scan = scan_monotone(1.0, |dt| Ok::<_, ()>(dt <= 1.1)).unwrap();
    assert!(scan.is_monotone());
    assert!(scan.tried.iter().any(|&(dt, s)| dt > 1.1 && !s));
}
