//! Spatial convergence of the reference solver on the standing wave.
//!
//! The velocity error `max_p |v_p − v(X_p, t)| / (A c)` (∞-norm over particles, relative
//! to the velocity amplitude, against the exact solution of `problems::StandingWave` at the
//! initial particle positions `X_p`) is measured at `t = 1/8` (phase π/4, as in Table 1) on
//! `N = 16, 32, 64, 128` cells. The symplectic Euler step is first order in time, so to
//! isolate the *spatial* error the particle velocities of runs at `dt` and `dt/2` are
//! Richardson-extrapolated, `v = 2 v(dt/2) − v(dt)`, which removes the `O(dt)` term and
//! leaves `O(dt²)` (far below the spatial error here). The fitted slope of `log e` against
//! `log h` (least squares over the four resolutions) is the measured order; it must be
//! within 0.15 of 2. The amplitude is tiny (`A = 10⁻⁶`) so the geometric nonlinearity of
//! moving particles (relative size `A`) does not pollute the comparison.
//!
//! With uniform layouts the GIMP domains tile the cells exactly and never straddle a node,
//! so GIMP and linear-hat weights coincide here; they differ on jittered layouts.

use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::{Boundary, Grid, Shape, Stepper};

/// Particle velocities at `t_end` after steps of `dt`, and the initial positions.
fn run(
    wave: &StandingWave,
    grid: &Grid,
    ppc: usize,
    shape: Shape,
    dt: f64,
    t_end: f64,
) -> (Vec<f64>, Vec<f64>) {
    let init = wave.uniform_particles(grid, ppc);
    let x0 = init.x.clone();
    let material = Material::LinearElastic {
        youngs_modulus: 1.0,
    };
    let mut s = ReferenceStepper::new(grid.clone(), shape, material, init).unwrap();
    let steps = (t_end / dt).round() as usize;
    for _ in 0..steps {
        s.try_step(dt).unwrap();
        s.accept().unwrap();
    }
    assert!((s.time() - t_end).abs() < 1e-12);
    (s.view().v.to_vec(), x0)
}

/// Relative ∞-norm velocity error of the time-extrapolated solution on `cells` cells.
fn spatial_error(boundary: Boundary, cells: usize, ppc: usize, shape: Shape) -> f64 {
    let mode = match boundary {
        Boundary::Periodic => 1.0,
        Boundary::Fixed => 0.5,
    };
    let wave = StandingWave::new(1e-6, mode, 1.0, 1.0, 1.0);
    let grid = Grid::new(boundary, cells, 1.0);
    let t_end = 0.125;
    let dt = t_end / 2000.0;
    let (v1, x0) = run(&wave, &grid, ppc, shape, dt, t_end);
    let (v2, _) = run(&wave, &grid, ppc, shape, 0.5 * dt, t_end);
    let amp = wave.amplitude * wave.wave_speed();
    v1.iter()
        .zip(&v2)
        .zip(&x0)
        .map(|((&a, &b), &x)| (2.0 * b - a - wave.velocity(x, t_end)).abs())
        .fold(0.0, f64::max)
        / amp
}

/// Least-squares slope of `log y` against `log x`.
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

#[test]
fn standing_wave_converges_at_second_order_in_space() {
    let cells = [16usize, 32, 64, 128];
    let hs: Vec<f64> = cells.iter().map(|&n| 1.0 / n as f64).collect();
    for (boundary, shape, ppc) in [
        (Boundary::Periodic, Shape::Gimp, 2),
        (Boundary::Periodic, Shape::Gimp, 4),
        (Boundary::Fixed, Shape::Gimp, 2),
        (Boundary::Fixed, Shape::Linear, 3),
    ] {
        let errs: Vec<f64> = cells
            .iter()
            .map(|&n| spatial_error(boundary, n, ppc, shape))
            .collect();
        let order = slope(&hs, &errs);
        eprintln!("{boundary:?} {shape:?} ppc {ppc}: errors {errs:?} order {order:.3}");
        assert!(
            (order - 2.0).abs() <= 0.15,
            "{boundary:?} {shape:?} ppc {ppc}: order {order} (errors {errs:?})"
        );
        // Errors decrease monotonically and are small in absolute terms.
        assert!(errs.windows(2).all(|w| w[1] < w[0]));
        assert!(errs[3] < 1e-3);
    }
}
