//! Spatial convergence of the d-dimensional reference solver on plane P and S standing
//! waves (`nd::problems::PlaneWave`), uniform layouts of 2 particles per cell per axis,
//! GIMP and quadratic B-splines, in 2D and 3D.
//!
//! The error is `max_p |v_p − v(X_p, t)| / (A c)` at phase `ωt = π/4` against the exact
//! solution at the initial positions (the amplitude `A = 10⁻⁶` keeps particle motion out
//! of it). As in the 1D test (`tests/convergence.rs`) the `O(dt)` error of the symplectic
//! Euler step is removed by Richardson extrapolation of runs at `dt` and `dt/2`,
//! `v = 2 v(dt/2) − v(dt)`. The order is the least-squares slope of `log e` against
//! `log h` over `h, h/2, h/4`; it must be at least 1.8.

use mpm_dt::nd::problems::PlaneWave;
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::{Boundary, Dim, Dimension, Stepper, ViewNd};

const AMPLITUDE: f64 = 1e-6;

fn material() -> MaterialNd {
    MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: 0.25,
    }
}

/// Velocities at `t_end` after steps of `dt`.
fn run<const D: usize>(
    cells: usize,
    shape: ShapeNd,
    k: [f64; D],
    d: Vector<D>,
    dt: f64,
    t_end: f64,
) -> (Vec<Vector<D>>, Vec<Vector<D>>, PlaneWave<D>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let grid = GridNd::<D>::new([Boundary::Periodic; D], [cells; D], [1.0; D]);
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1.0, material());
    let wave = PlaneWave::new(&grid, material(), 1.0, AMPLITUDE, k, d).unwrap();
    for p in 0..particles.len() {
        particles.v[p] = wave.velocity(&particles.x[p], 0.0);
    }
    let x0 = particles.x.clone();
    let mut s = SolverNd::new(grid, shape, particles, Vector::<D>::zeros()).unwrap();
    let steps = (t_end / dt).round() as usize;
    for _ in 0..steps {
        s.try_step(dt).unwrap();
        s.accept().unwrap();
    }
    assert!((s.time() - t_end).abs() < 1e-12);
    (s.view().v.to_vec(), x0, wave)
}

fn error<const D: usize>(cells: usize, shape: ShapeNd, k: [f64; D], d: Vector<D>) -> f64
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let probe = PlaneWave::new(
        &GridNd::<D>::new([Boundary::Periodic; D], [cells; D], [1.0; D]),
        material(),
        1.0,
        AMPLITUDE,
        k,
        d,
    )
    .unwrap();
    let t_end = std::f64::consts::FRAC_PI_4 / probe.omega();
    let h = 1.0 / cells as f64;
    // A step count that divides t_end, near 0.2 h / c_p.
    let c_p = material().p_modulus().sqrt();
    let n = (t_end / (0.2 * h / c_p)).ceil();
    let dt = t_end / n;
    let (v1, x0, wave) = run(cells, shape, k, d, dt, t_end);
    let (v2, _, _) = run(cells, shape, k, d, dt / 2.0, t_end);
    let scale = AMPLITUDE * wave.speed;
    v1.iter()
        .zip(&v2)
        .zip(&x0)
        .map(|((a, b), x)| ((b * 2.0 - a) - wave.velocity(x, t_end)).amax() / scale)
        .fold(0.0, f64::max)
}

fn order<const D: usize>(base: usize, shape: ShapeNd, k: [f64; D], d: Vector<D>) -> (f64, [f64; 3])
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let cells = [base, 2 * base, 4 * base];
    let e: [f64; 3] = std::array::from_fn(|i| error(cells[i], shape, k, d));
    let xs: Vec<f64> = cells.iter().map(|&c| (1.0 / c as f64).ln()).collect();
    let ys: Vec<f64> = e.iter().map(|e| e.ln()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / 3.0, ys.iter().sum::<f64>() / 3.0);
    let slope = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| (x - mx) * (y - my))
        .sum::<f64>()
        / xs.iter().map(|x| (x - mx) * (x - mx)).sum::<f64>();
    (slope, e)
}

fn check<const D: usize>(label: &str, base: usize, shape: ShapeNd, k: [f64; D], d: Vector<D>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let (slope, e) = order(base, shape, k, d);
    eprintln!(
        "{label}: errors {:.3e} {:.3e} {:.3e}, order {slope:.3}",
        e[0], e[1], e[2]
    );
    assert!(slope >= 1.8, "{label}: order {slope:.3} (errors {e:?})");
}

#[test]
fn plane_p_and_s_waves_converge_at_second_order_in_2d() {
    for shape in [ShapeNd::Gimp, ShapeNd::BSpline2] {
        check(
            &format!("2D P {shape:?}"),
            8,
            shape,
            [1.0, 1.0],
            Vector::<2>::new(1.0, 1.0),
        );
        check(
            &format!("2D S {shape:?}"),
            8,
            shape,
            [1.0, 1.0],
            Vector::<2>::new(1.0, -1.0),
        );
    }
}

#[test]
fn plane_p_wave_converges_at_second_order_in_3d_gimp() {
    let d = Vector::<3>::new(1.0, 1.0, 0.0);
    check("3D P Gimp", 8, ShapeNd::Gimp, [1.0, 1.0, 0.0], d);
}

#[test]
fn plane_s_wave_converges_at_second_order_in_3d_gimp() {
    let d = Vector::<3>::new(0.0, 1.0, 0.0);
    check("3D S Gimp", 8, ShapeNd::Gimp, [1.0, 0.0, 1.0], d);
}

#[test]
fn plane_p_wave_converges_at_second_order_in_3d_bspline() {
    let d = Vector::<3>::new(1.0, 1.0, 0.0);
    check("3D P BSpline2", 8, ShapeNd::BSpline2, [1.0, 1.0, 0.0], d);
}

#[test]
fn plane_s_wave_converges_at_second_order_in_3d_bspline() {
    let d = Vector::<3>::new(0.0, 1.0, 0.0);
    check("3D S BSpline2", 8, ShapeNd::BSpline2, [1.0, 0.0, 1.0], d);
}
