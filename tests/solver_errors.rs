//! Bad particle data are typed `SetupError`s; failing trial steps are typed `StepError`s
//! that leave the committed state untouched.

use mpm_dt::mpm::{Material, ParticleInit, ReferenceStepper, SetupError};
use mpm_dt::problems::StandingWave;
use mpm_dt::{Boundary, Grid, Shape, StepError, Stepper};

fn good(grid: &Grid) -> ParticleInit {
    StandingWave::new(0.01, 1.0, 1.0, 1.0, grid.length()).uniform_particles(grid, 2)
}

const E1: Material = Material::LinearElastic {
    youngs_modulus: 1.0,
};

#[test]
fn bad_particle_data_are_setup_errors() {
    let grid = Grid::new(Boundary::Periodic, 8, 1.0);
    type Edit = fn(&mut ParticleInit);
    type Expected = fn(&SetupError) -> bool;
    let cases: [(&str, Edit, Expected); 9] = [
        (
            "short v",
            |p| {
                p.v.pop();
            },
            |e| matches!(e, SetupError::Length { field: "v", .. }),
        ),
        (
            "long width",
            |p| p.width.push(0.1),
            |e| matches!(e, SetupError::Length { field: "width", .. }),
        ),
        (
            "NaN x",
            |p| p.x[3] = f64::NAN,
            |e| {
                matches!(
                    e,
                    SetupError::NonFinite {
                        field: "x",
                        index: 3,
                        ..
                    }
                )
            },
        ),
        (
            "infinite sigma",
            |p| p.sigma[0] = f64::INFINITY,
            |e| matches!(e, SetupError::NonFinite { field: "sigma", .. }),
        ),
        (
            "zero F",
            |p| p.f[2] = 0.0,
            |e| {
                matches!(
                    e,
                    SetupError::NonPositive {
                        field: "f",
                        index: 2,
                        ..
                    }
                )
            },
        ),
        (
            "negative mass",
            |p| p.mass[1] = -1.0,
            |e| matches!(e, SetupError::NonPositive { field: "mass", .. }),
        ),
        (
            "width above h",
            |p| p.width[4] = 0.2,
            |e| matches!(e, SetupError::WidthExceedsSpacing { index: 4, .. }),
        ),
        (
            "x at L on a ring",
            |p| p.x[5] = 1.0,
            |e| matches!(e, SetupError::OutOfDomain { index: 5, .. }),
        ),
        (
            "no particles",
            |p| *p = ParticleInit::default(),
            |e| matches!(e, SetupError::NoParticles),
        ),
    ];
    for (name, edit, is_expected) in cases {
        let mut p = good(&grid);
        edit(&mut p);
        match ReferenceStepper::new(grid.clone(), Shape::Gimp, E1, p) {
            Ok(_) => panic!("case `{name}` accepted"),
            Err(e) => assert!(is_expected(&e), "case `{name}`: {e:?}"),
        }
    }
    let bad_e = Material::NeoHookean {
        youngs_modulus: f64::NAN,
    };
    assert!(matches!(
        ReferenceStepper::new(grid.clone(), Shape::Gimp, bad_e, good(&grid)),
        Err(SetupError::Material { .. })
    ));
    let tiny_ring = Grid::new(Boundary::Periodic, 2, 1.0);
    assert!(matches!(
        ReferenceStepper::new(tiny_ring.clone(), Shape::Gimp, E1, good(&tiny_ring)),
        Err(SetupError::Grid { .. })
    ));
}

/// Runs until a step fails; returns the error and checks that the state was untouched.
fn first_failure(s: &mut ReferenceStepper, dt: f64, max_steps: usize) -> StepError {
    for _ in 0..max_steps {
        let before: Vec<u64> = s
            .view()
            .x
            .iter()
            .chain(s.view().v)
            .map(|x| x.to_bits())
            .collect();
        let (t, n) = (s.time(), s.step_count());
        match s.try_step(dt) {
            Ok(()) => s.accept().unwrap(),
            Err(e) => {
                let after: Vec<u64> = s
                    .view()
                    .x
                    .iter()
                    .chain(s.view().v)
                    .map(|x| x.to_bits())
                    .collect();
                assert_eq!(before, after);
                assert_eq!((s.time().to_bits(), s.step_count()), (t.to_bits(), n));
                assert!(s.trial_view().is_none());
                return e;
            }
        }
    }
    panic!("no failure in {max_steps} steps");
}

#[test]
fn invalid_dt_is_refused() {
    let grid = Grid::new(Boundary::Periodic, 8, 1.0);
    let mut s = ReferenceStepper::new(grid.clone(), Shape::Gimp, E1, good(&grid)).unwrap();
    for dt in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(s.try_step(dt), Err(StepError::InvalidDt { .. })),
            "dt = {dt}"
        );
    }
    assert_eq!(s.accept(), Err(StepError::NoTrial));
}

#[test]
fn unstable_steps_end_in_a_typed_failure() {
    // Far above the critical step the checkerboard mode grows until a value overflows or
    // a particle inverts; either way a typed error names the particle.
    let grid = Grid::new(Boundary::Periodic, 16, 1.0);
    let mut s = ReferenceStepper::new(grid.clone(), Shape::Gimp, E1, good(&grid)).unwrap();
    let err = first_failure(&mut s, 3.0 * grid.h, 10_000);
    assert!(
        matches!(
            err,
            StepError::Inverted { .. } | StepError::NonFinite { .. }
        ),
        "{err:?}"
    );
}

#[test]
fn a_particle_leaving_a_clamped_bar_is_out_of_domain() {
    let grid = Grid::new(Boundary::Fixed, 8, 1.0);
    let mut p = good(&grid);
    // The last particle flies off to the right, fast.
    let last = p.x.len() - 1;
    p.v.iter_mut().for_each(|v| *v = 0.0);
    p.v[last] = 100.0;
    let mut s = ReferenceStepper::new(grid.clone(), Shape::Gimp, E1, p).unwrap();
    let err = first_failure(&mut s, 1e-3, 100);
    assert!(
        matches!(err, StepError::OutOfDomain { index, .. } if index == last),
        "{err:?}"
    );
}

#[test]
fn compression_to_zero_volume_is_inverted() {
    // Two particles rushing at each other inside one cell pair invert the material.
    let grid = Grid::new(Boundary::Periodic, 4, 1.0);
    let mut p = good(&grid);
    for (v, &x) in p.v.iter_mut().zip(&p.x) {
        *v = if x < 0.5 { 50.0 } else { -50.0 };
    }
    let mut s = ReferenceStepper::new(grid, Shape::Gimp, E1, p).unwrap();
    let err = first_failure(&mut s, 0.01, 1000);
    assert!(matches!(err, StepError::Inverted { .. }), "{err:?}");
}

#[test]
fn a_failed_trial_leaves_nothing_behind() {
    // After a trial that fails (a particle leaves the clamped bar or inverts), the next good step is
    // bit-identical to the same step on a solver that never failed.
    let grid = Grid::new(Boundary::Fixed, 8, 1.0);
    let init = good(&grid);
    let mut failed = ReferenceStepper::new(grid.clone(), Shape::Gimp, E1, init.clone()).unwrap();
    let mut fresh = ReferenceStepper::new(grid.clone(), Shape::Gimp, E1, init).unwrap();
    let err = failed.try_step(1e3).unwrap_err();
    assert!(
        matches!(
            err,
            StepError::OutOfDomain { .. } | StepError::Inverted { .. }
        ),
        "{err:?}"
    );
    for s in [&mut failed, &mut fresh] {
        s.try_step(0.01).unwrap();
        s.accept().unwrap();
    }
    let bits = |s: &ReferenceStepper| -> Vec<u64> {
        let v = s.view();
        [
            v.x,
            v.v,
            v.sigma,
            v.f,
            v.node_mass,
            v.node_velocity,
            v.node_acceleration,
        ]
        .iter()
        .flat_map(|f| f.iter().map(|x| x.to_bits()))
        .collect()
    };
    assert_eq!(bits(&failed), bits(&fresh));
}

#[test]
fn an_infinite_velocity_is_non_finite_not_a_panic() {
    // An overflowing trial (here: an initial velocity near f64::MAX on a clamped bar, so
    // the trial position is infinite) is a typed error, on both boundaries.
    for boundary in [Boundary::Fixed, Boundary::Periodic] {
        let grid = Grid::new(boundary, 8, 1.0);
        let mut p = good(&grid);
        p.v[3] = f64::MAX;
        let mut s = ReferenceStepper::new(grid, Shape::Gimp, E1, p).unwrap();
        let err = s.try_step(10.0).unwrap_err();
        assert!(
            matches!(err, StepError::NonFinite { .. }),
            "{boundary:?}: {err:?}"
        );
    }
}

/// In 2D the out-of-domain error names the axis the particle left along and its
/// coordinate there.
#[test]
fn leaving_a_2d_box_names_the_axis() {
    use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
    let grid = GridNd::<2>::new([Boundary::Fixed; 2], [4, 4], [1.0, 1.0]);
    let material = MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2, 2], 1.0, material);
    for v in particles.v.iter_mut() {
        v[1] = 50.0;
    }
    let mut s = SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<2>::zeros()).unwrap();
    match s.try_step(0.1) {
        Err(StepError::OutOfDomain { axis, x, .. }) => {
            assert_eq!(axis, 1);
            assert!(x > 1.0, "coordinate {x} is inside the box");
        }
        other => panic!("expected OutOfDomain, got {other:?}"),
    }
}
