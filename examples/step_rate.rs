//! Particle-steps per second of the reference solver's bare step by the process's CPU
//! time (user + system), which a busy machine's time slicing does not inflate.
//! The set-up of `benches/step_nd.rs` (periodic unit box, 2 particles per cell per axis,
//! a small plane wave), one warm-up step, then STEPS timed steps:
//!
//! ```text
//! cargo run --release --example step_rate -- DIM SHAPE CELLS STEPS [THREADS]
//! ```
//!
//! With `--summary` each step also sums the totals a controller reads from it
//! ([`Stepper::provide_summary`]: energies, element bound, speed-of-sound step).
//!
//! With THREADS the solver steps on that many threads ([`SolverNd::set_threads`]; 0: the
//! calling thread, the default); the rate is then also given per wall-clock second, which
//! is the figure that counts for threads (CPU time adds up over them).

use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::{Boundary, Dim, Dimension, Stepper, ViewNd};

/// CPU time this process's threads have run, from `/proc/self/task/*/schedstat`
/// (nanoseconds on a CPU, summed over the threads alive now: the solver's pool lives as
/// long as the solver).
fn cpu_seconds() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    let ns: f64 = tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|text| text.split_whitespace().next()?.parse::<f64>().ok())
        .sum();
    ns * 1e-9
}

fn run<const D: usize>(shape: ShapeNd, cells: usize, steps: usize, threads: usize, summary: bool)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let material = MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let grid = GridNd::<D>::new([Boundary::Periodic; D], [cells; D], [1.0; D]);
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1.0, material);
    for p in 0..particles.len() {
        particles.v[p][0] = 1e-3 * (2.0 * std::f64::consts::PI * particles.x[p][0]).sin();
    }
    let mut s = match SolverNd::new(grid, shape, particles, Vector::<D>::zeros()) {
        Ok(s) => s,
        Err(e) => return eprintln!("set-up failed: {e}"),
    };
    if let Err(e) = s.set_threads(Some(threads)) {
        return eprintln!("{e}");
    }
    // The totals a controller reads from the step (energies, element bound, sound speed).
    s.provide_summary(summary);
    // Half the sound-speed step h/c_p, as `benches/step_nd.rs`.
    let dt = 0.5 * s.grid().h_min() / material.p_modulus().sqrt();
    let step = |s: &mut SolverNd<D>| s.try_step(dt).and_then(|_| s.accept());
    if let Err(e) = step(&mut s) {
        return eprintln!("step failed: {e}");
    }
    let (c0, w0) = (cpu_seconds(), std::time::Instant::now());
    for _ in 0..steps {
        if let Err(e) = step(&mut s) {
            return eprintln!("step failed: {e}");
        }
    }
    let (cpu, wall) = (cpu_seconds() - c0, w0.elapsed().as_secs_f64());
    let n = (s.n_particles() * steps) as f64;
    println!(
        "{D}D {shape:?} {} particles, {} thread(s){}: {:.2} M/s by CPU time, {:.2} M/s by wall",
        s.n_particles(),
        s.threads(),
        if summary { ", summary" } else { "" },
        n / cpu / 1e6,
        n / wall / 1e6
    );
}

fn main() -> std::process::ExitCode {
    const USAGE: &str =
        "usage: step_rate DIM(2|3) SHAPE(gimp|linear|bspline2) CELLS STEPS [THREADS] [--summary]";
    let mut a: Vec<String> = std::env::args().skip(1).collect();
    let summary = a.iter().any(|v| v == "--summary");
    a.retain(|v| v != "--summary");
    let shape = match a.get(1).map(String::as_str) {
        Some("gimp") => ShapeNd::Gimp,
        Some("linear") => ShapeNd::Linear,
        Some("bspline2") => ShapeNd::BSpline2,
        _ => {
            eprintln!("{USAGE}");
            return std::process::ExitCode::from(2);
        }
    };
    let number = |k: usize| {
        a.get(k)
            .and_then(|v| v.parse::<usize>().ok())
            .filter(|&v| v > 0)
    };
    let (Some(cells), Some(steps)) = (number(2), number(3)) else {
        eprintln!("{USAGE}");
        return std::process::ExitCode::from(2);
    };
    let threads = match a.get(4).map(|v| v.parse::<usize>()) {
        None => 0,
        Some(Ok(t)) => t,
        Some(Err(_)) => {
            eprintln!("{USAGE}");
            return std::process::ExitCode::from(2);
        }
    };
    match a.first().map(String::as_str) {
        Some("2") => run::<2>(shape, cells, steps, threads, summary),
        Some("3") => run::<3>(shape, cells, steps, threads, summary),
        _ => {
            eprintln!("{USAGE}");
            return std::process::ExitCode::from(2);
        }
    }
    std::process::ExitCode::SUCCESS
}
