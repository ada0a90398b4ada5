//! The door check's cost against a bare step (`try_step` + `accept`) of the reference
//! solvers, side by side in one run: rounds that time a few steps, then the check of the
//! committed view (its contents part, O(particles × stencil); and its shape part, O(1)),
//! interleaved so that both see the same machine load. Prints the medians over the rounds
//! and the median, min and max of the per-round ratio check / step.
//!
//! `cargo bench --bench view_check` (`-- --quick` for fewer rounds).

use mpm_dt::nd::ShapeNd;
use mpm_dt::scenario::Scenario;
use mpm_dt::{Dim, Dimension, StateView, Stepper};
use std::hint::black_box;
use std::time::Instant;

mod common;

/// Seconds per call of `f`, over `reps` calls.
fn per_call(reps: usize, mut f: impl FnMut()) -> f64 {
    let start = Instant::now();
    for _ in 0..reps {
        f();
    }
    start.elapsed().as_secs_f64() / reps as f64
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Computes a view's deferred weights (1D), untimed: one check of its contents.
fn force_weights<const D: usize>(s: &dyn Stepper<D>)
where
    Dim<D>: Dimension,
{
    if D == 1 {
        black_box(s.view().check_contents()).expect("valid view");
    }
}

fn compare<const D: usize>(label: &str, s: &mut dyn Stepper<D>, dt: f64, rounds: usize)
where
    Dim<D>: Dimension,
{
    let (mut step, mut contents, mut shape, mut ratio) = (vec![], vec![], vec![], vec![]);
    for _ in 0..rounds {
        let t_step = per_call(3, || {
            s.try_step(black_box(dt)).expect("step");
            s.accept().expect("accept");
        });
        // Deferred 1D weights are computed by the first limit that reads them, not by
        // the check: computed here, untimed.
        black_box(s.view().check_shape()).expect("valid view");
        force_weights(s);
        let t_contents = per_call(3, || {
            black_box(s.view().check_contents()).expect("valid view");
        });
        let t_shape = per_call(1000, || {
            black_box(s.view().check_shape()).expect("valid view");
        });
        step.push(t_step);
        contents.push(t_contents);
        shape.push(t_shape);
        ratio.push(t_contents / t_step);
    }
    let (lo, hi) = ratio
        .iter()
        .fold((f64::MAX, 0.0_f64), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    let step = median(&mut step);
    println!(
        "{label:<28} step {:>9.3} ms | contents {:>8.3} ms = {:>5.1} % of a step (rounds {:.1}–{:.1} %) | shape {:>6.3} µs = {:.4} %",
        step * 1e3,
        median(&mut contents) * 1e3,
        100.0 * median(&mut ratio),
        100.0 * lo,
        100.0 * hi,
        median(&mut shape) * 1e6,
        100.0 * median(&mut shape) / step,
    );
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let rounds = if quick { 3 } else { 11 };
    for shape in [ShapeNd::Gimp, ShapeNd::BSpline2] {
        // 158² cells × 4 ≈ 10⁵ particles; half the sound-speed step.
        let mut s = common::solver::<2>(158, shape);
        let dt = 0.5 * s.grid().h_min() / common::MATERIAL.p_modulus().sqrt();
        compare::<2>(&format!("2D {shape:?} 1e5"), &mut s, dt, rounds);
        // 23³ cells × 8 ≈ 10⁵ particles.
        let mut s = common::solver::<3>(23, shape);
        let dt = 0.5 * s.grid().h_min() / common::MATERIAL.p_modulus().sqrt();
        compare::<3>(&format!("3D {shape:?} 1e5"), &mut s, dt, rounds);
    }
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/gimp_uniform_1e5.json"
    );
    let scenario = Scenario::from_file(path).expect("scenario");
    let mut s = scenario.build().expect("solver");
    let dt = 0.5 * s.view().grid.h / scenario.youngs_modulus.sqrt();
    compare::<1>("1D GIMP 1e5", &mut s, dt, rounds);
}
