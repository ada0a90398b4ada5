//! One controlled step against one bare step of the d-dimensional reference solver, side by
//! side in one run: the cost of a controlled step in bare steps, the figure the controller's
//! wall time rests on (a run ends in `cost × steps_controlled / steps_rule` of a fixed
//! rule's time).
//!
//! Periodic box, 2 particles per cell per axis, a small plane wave, about 10⁵ particles
//! (2D GIMP; 3D GIMP and quadratic B-splines). Per layout:
//!
//! * `rule` — the fixed rule's step: `SoundSpeed::unit_step` on the committed state, then
//!   `try_step(0.4·unit)` and `accept` (what `simulate --compare` times for α = 0.4);
//! * `controlled` — `Controller::step` with `standard_limits` and the default settings (the
//!   speed-of-sound cap, the tracked eq 56 limit, the temporal error, the growth monitor),
//!   warmed up by a few steps first so that the cold λmax start is not in the samples;
//! * `controlled_no_temporal` — the same with `temporal.enabled = false`, for the temporal
//!   error's share;
//! * `rule-1t`, `controlled-1t`, `rule-2t`, `controlled-2t` — the rule and the controlled
//!   step with the solver's step on 1 and 2 threads of its pool (`SolverNd::set_threads`)
//!   and the limits' passes on as many threads of theirs (`Controller::with_threads`): the
//!   controlled step's cost in bare steps when the solver is threaded.
//!
//! `cargo bench --bench controller_nd`; the ratio `controlled / rule` is the cost of one
//! controlled step in bare steps.

use common::solver;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::nd::{ShapeNd, SolverNd, Vector};
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use std::hint::black_box;

mod common;

/// A controller with the standard limits, warmed up by `warm` steps on `s`.
fn warmed<const D: usize>(
    s: &mut SolverNd<D>,
    temporal: bool,
    threads: Option<usize>,
    warm: usize,
) -> Controller<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut config = ControllerConfig::default();
    config.temporal.enabled = temporal;
    let limits = standard_limits::<D>(&config, Vector::<D>::zeros());
    let mut controller =
        match Controller::<D>::new(config, limits).and_then(|c| c.with_threads(threads)) {
            Ok(c) => c,
            Err(e) => panic!("bench set-up failed: {e}"),
        };
    for _ in 0..warm {
        if let Err(e) = controller.step(s, f64::INFINITY) {
            panic!("warm-up step failed: {e}");
        }
    }
    controller
}

/// The bench's solver, its step on `threads` threads of its pool (`None`: the calling thread).
fn threaded_solver<const D: usize>(
    cells: usize,
    shape: ShapeNd,
    threads: Option<usize>,
) -> SolverNd<D> {
    let mut s = solver::<D>(cells, shape);
    if let Err(e) = s.set_threads(threads) {
        panic!("bench set-up failed: {e}");
    }
    s
}

fn bench<const D: usize>(c: &mut Criterion, cells: usize, shapes: &[ShapeNd])
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut group = c.benchmark_group(format!("controlled_vs_rule_{D}d"));
    group.sample_size(10);
    for &shape in shapes {
        let particles = solver::<D>(cells, shape).n_particles();
        group.throughput(Throughput::Elements(particles as u64));
        let id = |name: &str| BenchmarkId::new(format!("{shape:?}/{name}"), particles);

        let modes = [
            (
                None,
                "",
                &[("controlled", true), ("controlled_no_temporal", false)][..],
            ),
            (Some(1), "-1t", &[("controlled", true)][..]),
            (Some(2), "-2t", &[("controlled", true)][..]),
        ];
        for (threads, suffix, controlled) in modes {
            let mut s = threaded_solver::<D>(cells, shape, threads);
            group.bench_function(id(&format!("rule{suffix}")), |b| {
                b.iter(|| {
                    let unit = match SoundSpeed::unit_step(&s.view()) {
                        Ok(u) => u,
                        Err(e) => panic!("sound speed failed: {e}"),
                    };
                    if let Err(e) = s.try_step(black_box(0.4 * unit)) {
                        panic!("step failed: {e}");
                    }
                    let _ = s.accept();
                })
            });
            for &(name, temporal) in controlled {
                let mut s = threaded_solver::<D>(cells, shape, threads);
                let mut controller = warmed(&mut s, temporal, threads, 5);
                group.bench_function(id(&format!("{name}{suffix}")), |b| {
                    b.iter(|| {
                        if let Err(e) = controller.step(&mut s, f64::INFINITY) {
                            panic!("controlled step failed: {e}");
                        }
                    })
                });
            }
        }
    }
    group.finish();
}

fn bench_controlled(c: &mut Criterion) {
    // 158² cells × 4 ≈ 10⁵ particles in 2D; 23³ cells × 8 ≈ 10⁵ in 3D.
    bench::<2>(c, 158, &[ShapeNd::Gimp]);
    bench::<3>(c, 23, &[ShapeNd::Gimp, ShapeNd::BSpline2]);
}

criterion_group!(benches, bench_controlled);
criterion_main!(benches);
