//! The controller's overhead: one accepted step with every limit on versus the bare
//! reference step, on the same stepper in the same run.
//!
//! ```text
//! cargo bench --bench controller -- --warm-up-time 1 --measurement-time 3
//! ```
//!
//! Set-up: standing wave (amplitude 0.01 c), GIMP, 2 particles per cell, periodic, at
//! 10³ … 10⁶ particles. The controller is `Controller::standard` with the default
//! configuration (as `examples/compare.rs` runs it): `SoundSpeed` with `α = 1` as a cap,
//! `Stability` (eq 56, safety 0.95, default certified λmax tracking), the temporal error limit and the
//! growth monitor. The per-limit sub-benches use `Stability` at its own default safety 0.95
//! (the safety does not change its cost).
//!
//! Groups:
//! - `controller_step/{bare,controlled}/N`: `try_step + accept` at the controller's last
//!   step (without the nodal stiffness accumulation and the pass summary, which only the
//!   controller asks for)
//!   versus `Controller::step` (the stepper's pass with `K_N`, every limit's `propose`, the
//!   trial, every limit's `judge`, the accept and the limits' `accepted` hooks). Throughput is in particles. The
//!   overhead ratio is `controlled / bare`. `controlled_without_summary` is the same
//!   controller on the solver declining the pass summary (`Stepper::provide_summary`), so
//!   that every limit scans its views, as a stepper without one. `bare_with_view` adds building the trial's
//!   `View` (lazily computed `S`, `D`, tangent modulus, density, node activity), which any
//!   limit that reads the trial forces.
//! - `limit_propose/NAME` and `limit_judge/NAME` at 10⁵ particles: each limit's share of
//!   the overhead (propose alternating between two states one step apart, judge of one trial
//!   against the committed state). `stability_every_step` is the stability limit with
//!   `Tracking::Lanczos(Refresh::every_step())` (a Lanczos update at every proposal, the
//!   previous default), for comparison with the default certified tracking, whose `propose`
//!   here is mostly the served one-pass path (an anchor every 20 proposals). The stepper
//!   was driven by the controller first, so its views carry `K_N` as in a controlled run.
//!
//! The λmax tracker's own cost (operator build, one application, warm update) is in
//! `benches/stability.rs`; the estimators' in `benches/estimators.rs`.
#![allow(missing_docs)]

#[path = "../tests/common/without_summary.rs"]
mod without_summary;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mpm_dt::controller::{
    Controller, ControllerConfig, GrowthConfig, GrowthMonitor, TemporalError, TemporalErrorConfig,
};
use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::stability::{
    Refresh, SoundSpeed, SoundSpeedConfig, Stability, StabilityConfig, Tracking,
};
use mpm_dt::{Boundary, Grid, Shape, StepLimit, Stepper};
use std::hint::black_box;
use std::time::Duration;
use without_summary::WithoutSummary;

fn stepper(particles: usize) -> ReferenceStepper {
    let ppc = 2;
    let grid = Grid::new(Boundary::Periodic, particles / ppc, 1.0);
    let wave = StandingWave::new(1e-2, 1.0, 1.0, 1.0, 1.0);
    let init = wave.uniform_particles(&grid, ppc);
    let material = Material::LinearElastic {
        youngs_modulus: 1.0,
    };
    match ReferenceStepper::new(grid, Shape::Gimp, material, init) {
        Ok(s) => s,
        Err(e) => panic!("bench set-up failed: {e}"),
    }
}

fn stability() -> Stability {
    match Stability::new(StabilityConfig::default()) {
        Ok(l) => l,
        Err(e) => panic!("bench set-up failed: {e}"),
    }
}

fn sound_speed_cap() -> SoundSpeed {
    match SoundSpeed::new(SoundSpeedConfig { alpha: 1.0 }) {
        Ok(l) => l,
        Err(e) => panic!("bench set-up failed: {e}"),
    }
}

/// [`controller`] warmed up (filter history, λmax tracker) on 5 real steps of `s`.
fn warmed_controller(s: &mut dyn Stepper) -> Controller {
    let mut ctl = controller();
    for _ in 0..5 {
        if let Err(e) = ctl.step(s, f64::INFINITY) {
            panic!("controller failed: {e}");
        }
    }
    ctl
}

/// One accepted controlled step of `s` per iteration, as `name/particles`.
fn bench_controlled(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    particles: usize,
    ctl: &mut Controller,
    s: &mut dyn Stepper,
) {
    group.bench_function(BenchmarkId::new(name, particles), |b| {
        b.iter(|| match ctl.step(s, f64::INFINITY) {
            Ok(d) => black_box(d),
            Err(e) => panic!("controller failed: {e}"),
        })
    });
}

/// The standard controller with its default configuration (what `examples/compare.rs` runs).
fn controller() -> Controller {
    match Controller::standard(ControllerConfig::default()) {
        Ok(c) => c,
        Err(e) => panic!("bench set-up failed: {e}"),
    }
}

fn bench_overhead(c: &mut Criterion) {
    let mut group = c.benchmark_group("controller_step");
    for particles in [1_000usize, 10_000, 100_000, 1_000_000] {
        if particles >= 100_000 {
            group.sample_size(10);
        }
        let mut s = stepper(particles);
        let mut ctl = warmed_controller(&mut s);
        group.throughput(Throughput::Elements(particles as u64));
        bench_controlled(&mut group, "controlled", particles, &mut ctl, &mut s);
        {
            let mut w = WithoutSummary(stepper(particles));
            let mut ctl = warmed_controller(&mut w);
            let id = "controlled_without_summary";
            bench_controlled(&mut group, id, particles, &mut ctl, &mut w);
        }
        let dt = ctl.state().dt_prev.unwrap_or(0.5 * s.grid().h);
        // The bare step without the nodal stiffness and the pass summary the controller
        // asked the stepper for: the overhead counts them.
        s.provide_nodal_stiffness(false);
        s.provide_summary(false);
        group.bench_function(BenchmarkId::new("bare", particles), |b| {
            b.iter(|| {
                if let Err(e) = s.try_step(black_box(dt)).and_then(|()| s.accept()) {
                    panic!("step failed: {e}");
                }
            })
        });
        // The bare step plus building the trial's `View` (the lazily computed S, D, tangent
        // modulus, density and node activity that every limit reading a view forces).
        group.bench_function(BenchmarkId::new("bare_with_view", particles), |b| {
            b.iter(|| {
                if let Err(e) = s.try_step(black_box(dt)) {
                    panic!("step failed: {e}");
                }
                black_box(s.trial_view().map(|v| v.weights.s_of(0).len()));
                if let Err(e) = s.accept() {
                    panic!("accept failed: {e}");
                }
            })
        });
    }
    group.finish();
}

/// Every limit of the controlled run, labelled, plus the stability limit recomputing λmax at
/// every step (`Tracking::Lanczos(Refresh::every_step())`, the previous default).
fn all_limits() -> Vec<(&'static str, Box<dyn StepLimit>)> {
    let temporal = match TemporalError::new(TemporalErrorConfig::default()) {
        Ok(l) => l,
        Err(e) => panic!("bench set-up failed: {e}"),
    };
    let growth = match GrowthMonitor::new(GrowthConfig::default()) {
        Ok(l) => l,
        Err(e) => panic!("bench set-up failed: {e}"),
    };
    let every_step = match Stability::new(StabilityConfig {
        tracking: Tracking::Lanczos(Refresh::every_step()),
        ..StabilityConfig::default()
    }) {
        Ok(l) => l,
        Err(e) => panic!("bench set-up failed: {e}"),
    };
    vec![
        ("stability", Box::new(stability())),
        ("stability_every_step", Box::new(every_step)),
        ("sound_speed", Box::new(sound_speed_cap())),
        ("temporal_error", Box::new(temporal)),
        ("growth", Box::new(growth)),
    ]
}

fn bench_limits(c: &mut Criterion) {
    let particles = 100_000;
    let mut s = stepper(particles);
    // Advance a few steps with the controller so the state is not the initial one.
    let mut ctl = controller();
    for _ in 0..5 {
        if let Err(e) = ctl.step(&mut s, f64::INFINITY) {
            panic!("controller failed: {e}");
        }
    }
    let dt = ctl.state().dt_prev.unwrap_or(0.5 * s.grid().h);
    let mut limits = all_limits();
    let mut group = c.benchmark_group("limit_propose");
    group.sample_size(20);
    // Propose alternates between the committed state and the trial one step ahead, so the
    // λmax tracker does a warm update on a changed state each time, as in a run.
    if let Err(e) = s.try_step(dt) {
        panic!("step failed: {e}");
    }
    for (name, limit) in limits.iter_mut() {
        let name = *name;
        let before = s.view();
        let Some(after) = s.trial_view() else {
            panic!("no trial after try_step");
        };
        let mut flip = false;
        group.bench_function(name, |b| {
            b.iter(|| {
                flip = !flip;
                let v = if flip { &after } else { &before };
                match limit.propose(v) {
                    Ok(p) => black_box(p),
                    Err(e) => panic!("propose failed: {e}"),
                }
            })
        });
    }
    group.finish();
    let mut group = c.benchmark_group("limit_judge");
    group.sample_size(20);
    for (name, limit) in limits.iter_mut() {
        let name = *name;
        let before = s.view();
        let Some(after) = s.trial_view() else {
            panic!("no trial after try_step");
        };
        if let Err(e) = limit.propose(&before) {
            panic!("propose failed: {e}");
        }
        // One accepted step of history (the temporal error limit's steady-state path; without
        // it, it takes its first-step path).
        limit.accepted(&before, &after, dt);
        if let Err(e) = limit.propose(&before) {
            panic!("propose failed: {e}");
        }
        group.bench_function(name, |b| {
            b.iter(|| match limit.judge(&before, &after, dt) {
                Ok(j) => black_box(j),
                Err(e) => panic!("judge failed: {e}"),
            })
        });
    }
    group.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
}

criterion_group! {
    name = benches;
    config = config();
    targets = bench_overhead, bench_limits
}
criterion_main!(benches);
