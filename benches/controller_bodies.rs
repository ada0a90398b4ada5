//! Colliding bodies run to their end time, under the controller and under the fixed rule
//! α = 0.4, side by side in one run: the wall-time ratio a user with colliding bodies sees,
//! and the cost of one controlled step in bare steps on a scene whose particles move.
//!
//! The smooth-wave bench (`controller_nd`) times single steps of a standing layout; on
//! moving bodies the controller's cost comes in bursts (a λmax refresh whenever a particle
//! has moved half a cell), so here one sample is a whole run:
//!
//! * `rule` — α = 0.4's steps to `t_end` (`SoundSpeed::unit_step` on the committed state,
//!   `try_step(0.4·unit)`, `accept`);
//! * `controlled` — `Controller::run_until(t_end)` with the scenario's controller config and
//!   the standard limits.
//!
//! Scenes: the colliding GIMP disks (2D, 416 particles) and spheres (3D, 4 352). Each
//! group's throughput is the run's number of steps, so criterion's `elem/s` is steps per
//! second: `rule`'s over `controlled`'s is the cost of a controlled step in bare steps, the
//! time ratio the run's wall ratio. `cargo bench --bench controller_bodies`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mpm_dt::controller::standard_limits;
use mpm_dt::controller::Controller;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::{SolverNd, Vector};
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use std::hint::black_box;

/// Runs the fixed rule α = 0.4 from `s` to `t_end`; returns the number of steps.
fn rule<const D: usize>(mut s: SolverNd<D>, t_end: f64) -> u64
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut steps = 0;
    while s.time() < t_end {
        let unit = SoundSpeed::unit_step(&s.view()).unwrap_or_else(|e| panic!("{e}"));
        let dt = (0.4 * unit).min(t_end - s.time());
        s.try_step(black_box(dt)).unwrap_or_else(|e| panic!("{e}"));
        s.accept().unwrap_or_else(|e| panic!("{e}"));
        steps += 1;
    }
    steps
}

/// Runs the controller with the scenario's config from `s` to `t_end`; returns the number
/// of accepted steps.
fn controlled<const D: usize>(mut s: SolverNd<D>, scenario: &ScenarioNd) -> u64
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let config = scenario
        .controller_config()
        .unwrap_or_else(|e| panic!("{e}"));
    let gravity = scenario
        .gravity
        .as_ref()
        .map_or(Vector::<D>::zeros(), |g| Vector::<D>::from_column_slice(g));
    let limits = standard_limits::<D>(&config, gravity);
    let mut controller = Controller::<D>::new(config, limits).unwrap_or_else(|e| panic!("{e}"));
    controller
        .run_until(&mut s, scenario.t_end, &mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    controller.stats().accepted
}

fn bench_scene<const D: usize>(c: &mut Criterion, file: &str)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let path = format!("{}/scenarios/nd/{file}", env!("CARGO_MANIFEST_DIR"));
    let scenario = ScenarioNd::from_file(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let (s, _) = scenario
        .build::<D>()
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    let n = s.n_particles();
    let mut group = c.benchmark_group(format!("bodies_{}", file.trim_end_matches(".json")));
    group.sample_size(10);
    let steps_rule = rule(s.clone(), scenario.t_end);
    let steps_controlled = controlled(s.clone(), &scenario);
    eprintln!("{file}: {n} particles, rule α = 0.4 {steps_rule} steps, controller {steps_controlled} steps");
    group.throughput(Throughput::Elements(steps_rule));
    group.bench_function(BenchmarkId::new("rule", n), |b| {
        b.iter(|| rule(s.clone(), scenario.t_end))
    });
    group.throughput(Throughput::Elements(steps_controlled));
    group.bench_function(BenchmarkId::new("controlled", n), |b| {
        b.iter(|| controlled(s.clone(), &scenario))
    });
    group.finish();
}

fn bench_bodies(c: &mut Criterion) {
    bench_scene::<2>(c, "colliding_disks.json");
    bench_scene::<3>(c, "colliding_spheres.json");
}

criterion_group!(benches, bench_bodies);
criterion_main!(benches);
