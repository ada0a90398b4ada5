//! One step (`try_step` + `accept`) of the reference solver: standing wave, GIMP,
//! 2 particles per cell, periodic, 10³ … 10⁶ particles. Throughput is in particles, so
//! criterion reports particle-steps per second.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::{Boundary, Grid, Shape, Stepper};
use std::hint::black_box;

fn stepper(particles: usize) -> ReferenceStepper {
    let ppc = 2;
    let grid = Grid::new(Boundary::Periodic, particles / ppc, 1.0);
    let wave = StandingWave::new(1e-3, 1.0, 1.0, 1.0, 1.0);
    let init = wave.uniform_particles(&grid, ppc);
    let material = Material::LinearElastic {
        youngs_modulus: 1.0,
    };
    match ReferenceStepper::new(grid, Shape::Gimp, material, init) {
        Ok(s) => s,
        Err(e) => panic!("bench set-up failed: {e}"),
    }
}

fn bench_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    for particles in [1_000usize, 10_000, 100_000, 1_000_000] {
        let mut s = stepper(particles);
        // A stable step: half the sound-speed step h/c.
        let dt = 0.5 * s.grid().h;
        group.throughput(Throughput::Elements(particles as u64));
        group.bench_with_input(BenchmarkId::new("gimp_ppc2", particles), &dt, |b, &dt| {
            b.iter(|| {
                if let Err(e) = s.try_step(black_box(dt)) {
                    panic!("step failed: {e}");
                }
                // Keep the state bounded over long benches: accept (swap buffers).
                let _ = s.accept();
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
