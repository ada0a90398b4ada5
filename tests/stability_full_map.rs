//! The frozen-particle full map: exact at one particle per cell, and eq 56 is conservative.

mod stability_common;

use mpm_dt::stability::{FullMap, FullMapConfig};
use mpm_dt::Shape;
use stability_common::*;

fn dt56(fx: &Fixture) -> f64 {
    dense_dt56(&fx.view())
}

fn dt_full(fx: &Fixture, start: f64) -> f64 {
    FullMap::new(&fx.view())
        .unwrap()
        .critical_dt(start, FullMapConfig::default())
        .unwrap()
}

/// One particle per cell, uniform and periodic (both shapes): the full map's critical step
/// equals eq 56's. Near clamped ends or with jitter it does not (the nodal velocity of eq 17
/// and the particle velocity no longer share eigenvectors); eq 56 is then below the full map.
#[test]
fn one_particle_per_cell_matches_eq56() {
    for shape in [Shape::Gimp, Shape::Linear] {
        let fx = Fixture::new(periodic(12, 1.0), shape, uniform(12, 1.0, 1), 1.0, 1.0);
        let a = dt56(&fx);
        let b = dt_full(&fx, 0.5 * a);
        assert!((b - a).abs() < 1e-5 * a, "{shape:?}: full {b} eq56 {a}");
        for (name, fx) in [
            (
                "fixed uniform",
                Fixture::new(fixed(12, 1.0), shape, uniform(12, 1.0, 1), 1.0, 1.0),
            ),
            (
                "periodic jittered",
                Fixture::new(
                    periodic(12, 1.0),
                    shape,
                    jittered(12, 1.0, 1, 0.6, 3),
                    1.0,
                    1.0,
                ),
            ),
        ] {
            let a = dt56(&fx);
            let b = dt_full(&fx, 0.5 * a);
            eprintln!("{shape:?} 1 ppc {name}: full/eq56 = {:.4}", b / a);
            assert!(a <= b * (1.0 + 1e-6));
        }
    }
}

/// Below the critical step the spectral radius stays at 1 (within the tolerance) and above it
/// it grows.
#[test]
fn spectral_radius_crosses_one_at_the_critical_step() {
    let fx = Fixture::new(
        periodic(10, 1.0),
        Shape::Gimp,
        jittered(10, 1.0, 2, 0.7, 5),
        1.0,
        1.0,
    );
    let map = FullMap::new(&fx.view()).unwrap();
    let dc = map
        .critical_dt(0.5 * dt56(&fx), FullMapConfig::default())
        .unwrap();
    for f in [0.2, 0.6, 0.9, 0.999] {
        let r = map.spectral_radius(f * dc).unwrap();
        assert!(r <= 1.0 + 1e-6, "ρ({f} dt_c) = {r}");
    }
    let r = map.spectral_radius(1.01 * dc).unwrap();
    assert!(r > 1.0 + 1e-3, "ρ(1.01 dt_c) = {r}");
}

/// eq 56 ≤ full map on uniform, jittered and small-mass layouts, fixed and periodic, GIMP and
/// linear, at 2 and 4 particles per cell; and not by more than 10 %.
#[test]
fn eq56_is_conservative_by_at_most_ten_percent() {
    let mut worst: f64 = 1.0;
    for shape in [Shape::Gimp, Shape::Linear] {
        for (name, x) in [
            ("uniform2", uniform(10, 1.0, 2)),
            ("uniform4", uniform(8, 1.0, 4)),
            ("jitter2", jittered(10, 1.0, 2, 0.8, 11)),
            ("small_mass", small_mass(10, 1.0, 4)),
        ] {
            let cells = if name == "uniform4" { 8 } else { 10 };
            for grid in [periodic(cells, 1.0), fixed(cells, 1.0)] {
                let fx = Fixture::new(grid.clone(), shape, x.clone(), 1.0, 1.0);
                let a = dt56(&fx);
                let b = dt_full(&fx, 0.5 * a);
                assert!(
                    a <= b * (1.0 + 1e-6),
                    "{shape:?} {name} {:?}: eq56 {a} > full {b}",
                    grid.boundary
                );
                worst = worst.max(b / a);
                assert!(b / a < 1.10, "{shape:?} {name}: full/eq56 = {}", b / a);
            }
        }
    }
    eprintln!("largest full/eq56 ratio: {worst:.4}");
}
