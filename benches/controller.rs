//! Cost of the controller per accepted step relative to a plain step of the reference solver
//! (`try_step` + `accept`): standing wave, GIMP, 2 particles per cell, periodic, 10³ and 10⁴
//! particles. The controller runs the stability limit (tracked λmax of eq 56, eq 58 check),
//! the temporal error limit and the growth monitor; `controller_sound_speed_only` replaces the
//! stability limit by the cheap sound-speed limit to isolate the controller's own cost, and
//! `plain_with_views` adds to the plain step the construction of the views the limits read.
//! Compare the entries of one size within one run.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::limit::StepLimit;
use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::stability::{SoundSpeed, SoundSpeedConfig, Stability, StabilityConfig};
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

fn controller() -> Controller {
    let stability = match Stability::new(StabilityConfig {
        safety: 0.95,
        ..StabilityConfig::default()
    }) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    };
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(stability)];
    match Controller::with_default_limits(ControllerConfig::default(), limits) {
        Ok(c) => c,
        Err(e) => panic!("{e}"),
    }
}

/// The controller's own limits only (temporal error, growth monitor) with the cheap
/// sound-speed limit setting dt: isolates the controller's cost from the stability limit's.
fn light_controller() -> Controller {
    let sound = match SoundSpeed::new(SoundSpeedConfig { alpha: 0.5 }) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    };
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(sound)];
    match Controller::with_default_limits(ControllerConfig::default(), limits) {
        Ok(c) => c,
        Err(e) => panic!("{e}"),
    }
}

fn bench_controller(c: &mut Criterion) {
    let mut group = c.benchmark_group("controller_overhead");
    for particles in [1_000usize, 10_000] {
        group.throughput(Throughput::Elements(particles as u64));
        let mut s = stepper(particles);
        let dt = 0.6 * s.grid().h;
        group.bench_function(BenchmarkId::new("plain", particles), |b| {
            b.iter(|| {
                if let Err(e) = s.try_step(black_box(dt)) {
                    panic!("step failed: {e}");
                }
                let _ = s.accept();
            })
        });
        // A plain step that also builds both views (weights S, D of the trial state): the
        // part of the controller's cost that is the solver's observer data.
        let mut s = stepper(particles);
        group.bench_function(BenchmarkId::new("plain_with_views", particles), |b| {
            b.iter(|| {
                if let Err(e) = s.try_step(black_box(dt)) {
                    panic!("step failed: {e}");
                }
                if let Some(v) = s.trial_view() {
                    black_box(v.weights.n_particles());
                }
                black_box(s.view().weights.n_particles());
                let _ = s.accept();
            })
        });
        let mut s = stepper(particles);
        let mut ctl = controller();
        group.bench_function(BenchmarkId::new("controller", particles), |b| {
            b.iter(|| match ctl.step(&mut s, f64::INFINITY) {
                Ok(d) => black_box(d.len()),
                Err(e) => panic!("controller failed: {e}"),
            })
        });
        let mut s = stepper(particles);
        let mut ctl = light_controller();
        group.bench_function(
            BenchmarkId::new("controller_sound_speed_only", particles),
            |b| {
                b.iter(|| match ctl.step(&mut s, f64::INFINITY) {
                    Ok(d) => black_box(d.len()),
                    Err(e) => panic!("controller failed: {e}"),
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench_controller);
criterion_main!(benches);
