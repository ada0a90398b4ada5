//! Cost of the eq 33 estimate `Ea_i` read from a solver's view, with the paper's recovery
//! (eq 17 map + eqs 42/43) and with least-squares recovery, beside one reference step of the
//! same state: standing wave, GIMP, 2 particles per cell, periodic.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mpm_dt::estimators::particle_to_node::stress_divergence_error_with;
use mpm_dt::estimators::Recovery;
use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::{Boundary, Grid, Shape, Stepper};
use std::hint::black_box;
use std::time::Duration;

fn stepper(particles: usize) -> ReferenceStepper {
    let ppc = 2;
    let grid = Grid::new(Boundary::Periodic, particles / ppc, 1.0);
    let wave = StandingWave::new(1e-3, 1.0, 1.0, 1.0, 1.0);
    let init = wave.uniform_particles(&grid, ppc);
    let material = Material::LinearElastic {
        youngs_modulus: 1.0,
    };
    let mut s = match ReferenceStepper::new(grid.clone(), Shape::Gimp, material, init) {
        Ok(s) => s,
        Err(e) => panic!("bench set-up failed: {e}"),
    };
    // A few steps so that the stress is non-zero.
    for _ in 0..5 {
        if let Err(e) = s.try_step(0.5 * grid.h) {
            panic!("step failed: {e}");
        }
        let _ = s.accept();
    }
    s
}

fn bench_estimators(c: &mut Criterion) {
    let mut group = c.benchmark_group("estimators");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    for particles in [10_000usize, 100_000] {
        let mut s = stepper(particles);
        let dt = 0.5 / (particles / 2) as f64;
        group.throughput(Throughput::Elements(particles as u64));
        for (name, recovery) in [
            ("ea_mapped", Recovery::Mapped),
            ("ea_least_squares", Recovery::LeastSquares),
        ] {
            group.bench_with_input(BenchmarkId::new(name, particles), &recovery, |b, &r| {
                b.iter(
                    || match stress_divergence_error_with(&s.view(), black_box(r)) {
                        Ok(e) => e,
                        Err(e) => panic!("estimate failed: {e}"),
                    },
                )
            });
        }
        group.bench_with_input(BenchmarkId::new("step", particles), &dt, |b, &dt| {
            b.iter(|| {
                if let Err(e) = s.try_step(black_box(dt)) {
                    panic!("step failed: {e}");
                }
                s.reject();
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_estimators);
criterion_main!(benches);
