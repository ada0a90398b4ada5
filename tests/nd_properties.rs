//! Capability: the d-dimensional reference solver conserves momentum to round-off on
//! periodic boxes, a rejected trial restores its state bit for bit (property test), and a
//! bad scenario is a typed error naming the field.

use mpm_dt::nd::scenario::{ScenarioError, ScenarioNd};
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::{Boundary, Dim, Dimension, Stepper, ViewNd};
use proptest::prelude::*;

/// A jittered periodic layout with seeded random velocities.
fn layout<const D: usize>(cells: usize, shape: ShapeNd, seed: u64) -> SolverNd<D> {
    let grid = GridNd::<D>::new([Boundary::Periodic; D], [cells; D], [1.0; D]);
    let material = MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1.0, material);
    let mut s = seed;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for p in 0..particles.len() {
        for a in 0..D {
            particles.x[p][a] += 0.3 * particles.domain[p][a] * next();
            particles.v[p][a] = 0.01 * next();
        }
    }
    SolverNd::new(grid, shape, particles, Vector::<D>::zeros()).unwrap()
}

fn momentum_is_conserved<const D: usize>(shape: ShapeNd)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut s = layout::<D>(6, shape, 7);
    let p0 = s.momentum();
    let scale: f64 = s
        .view()
        .v
        .iter()
        .zip(s.view().mass)
        .map(|(v, m)| v.norm() * m)
        .sum();
    for _ in 0..50 {
        s.try_step(0.02).unwrap();
        s.accept().unwrap();
    }
    let drift = (s.momentum() - p0).norm();
    assert!(
        drift <= 1e-13 * scale,
        "{D}D {shape:?}: momentum drift {drift:e} against scale {scale:e}"
    );
    // Something moved: the test is not vacuous.
    assert!((s.view().x[0] - layout::<D>(6, shape, 7).view().x[0]).norm() > 0.0);
}

#[test]
fn momentum_is_conserved_to_round_off_in_2d_and_3d() {
    for shape in [ShapeNd::Gimp, ShapeNd::Linear, ShapeNd::BSpline2] {
        momentum_is_conserved::<2>(shape);
        momentum_is_conserved::<3>(shape);
    }
}

fn bits<const D: usize>(s: &SolverNd<D>) -> Vec<u64>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let v = s.view();
    let mut out = vec![v.t.to_bits(), v.step];
    for field in [v.x, v.v, v.node_velocity, v.node_acceleration] {
        out.extend(field.iter().flat_map(|x| x.iter().map(|c| c.to_bits())));
    }
    for field in [v.sigma, v.f] {
        out.extend(field.iter().flat_map(|x| x.iter().map(|c| c.to_bits())));
    }
    out.extend(v.node_mass.iter().map(|m| m.to_bits()));
    v.weights
        .with_row(0, |_, s, _| out.extend(s.iter().map(|w| w.to_bits())));
    out
}

/// Runs `ops` (dt, accept?) on `s`; checks each rejection restores the state bit for bit
/// and returns the accepted steps.
fn run_ops<const D: usize>(s: &mut SolverNd<D>, ops: &[(f64, bool)]) -> Vec<f64>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut accepted = Vec::new();
    for &(dt, keep) in ops {
        let before = bits(s);
        if s.try_step(dt).is_err() {
            assert_eq!(before, bits(s), "a failed trial changed the state");
            continue;
        }
        if keep {
            s.accept().unwrap();
            accepted.push(dt);
        } else {
            s.reject();
            assert_eq!(before, bits(s), "a rejection did not restore the state");
        }
    }
    accepted
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    #[test]
    fn rejected_trials_restore_the_state_bit_for_bit(
        ops in proptest::collection::vec((0.001f64..0.3, any::<bool>()), 1..12),
        seed in 0u64..1000,
    ) {
        let mut s2 = layout::<2>(4, ShapeNd::Gimp, seed);
        let accepted = run_ops(&mut s2, &ops);
        // Replaying only the accepted steps gives the same bits.
        let mut replay = layout::<2>(4, ShapeNd::Gimp, seed);
        for dt in &accepted {
            replay.try_step(*dt).unwrap();
            replay.accept().unwrap();
        }
        prop_assert_eq!(bits(&s2), bits(&replay));
        let mut s3 = layout::<3>(3, ShapeNd::BSpline2, seed);
        run_ops(&mut s3, &ops);
    }
}

fn build_error(json: &str) -> ScenarioError {
    let s = match ScenarioNd::from_json(json) {
        Ok(s) => s,
        Err(e) => return e,
    };
    match s.dim {
        3 => s.build::<3>().expect_err("an error"),
        _ => s.build::<2>().expect_err("an error"),
    }
}

#[test]
fn bad_scenarios_are_typed_errors_naming_the_field() {
    let cases = [
        (r#"{"dim": 2, "youngs_modulus": -1.0}"#, "youngs_modulus"),
        (r#"{"dim": 2, "poisson_ratio": 0.5}"#, "poisson_ratio"),
        (r#"{"dim": 2, "density": 0.0}"#, "density"),
        (r#"{"dim": 2, "cells": [4, 4, 4]}"#, "cells"),
        (r#"{"dim": 3, "length": [1.0, 1.0]}"#, "length"),
        (r#"{"dim": 2, "gravity": [0.0]}"#, "gravity"),
        (r#"{"dim": 2, "shape": "cubic"}"#, "cubic"),
        (r#"{"dim": 2, "colour": "red"}"#, "colour"),
        (
            r#"{"dim": 2, "boundary": "fixed", "particles": {"positions": [[0.5, 1.5]]}}"#,
            "outside",
        ),
        (
            r#"{"dim": 2, "particles": {"positions": [[0.5, 0.5]], "masses": [1.0, 2.0]}}"#,
            "mass",
        ),
        (
            r#"{"dim": 2, "boundary": "fixed", "shape": "bspline2"}"#,
            "bspline2",
        ),
        (
            r#"{"dim": 2, "initial": {"plane_wave": {"amplitude": 0.1, "wave_vector": [1, 0], "direction": [1, 1]}}}"#,
            "direction",
        ),
        (
            r#"{"dim": 2, "particles": {"bodies": [{"ball": {"center": [0.5, 0.5], "radius": -1}}]}}"#,
            "radius",
        ),
    ];
    for (json, needle) in cases {
        let e = build_error(json);
        let msg = e.to_string();
        assert!(msg.contains(needle), "{json}: {msg}");
    }
    // A NaN cannot be written in JSON; in code it is refused by the solver's setup.
    let grid = GridNd::<2>::new([Boundary::Periodic; 2], [4, 4], [1.0, 1.0]);
    let mut particles = ParticlesNd::uniform(
        &grid,
        [1, 1],
        1.0,
        MaterialNd::LinearElastic {
            youngs_modulus: 1.0,
            poisson_ratio: 0.0,
        },
    );
    particles.v[3][1] = f64::NAN;
    let e = SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<2>::zeros()).unwrap_err();
    assert!(e.to_string().contains("invalid v"), "{e}");
}
