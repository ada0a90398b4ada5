//! Set-ups the d-dimensional benches share.

use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::Boundary;

/// The benches' material: linear elastic, `E = 1`, `ν = 0.3`.
pub const MATERIAL: MaterialNd = MaterialNd::LinearElastic {
    youngs_modulus: 1.0,
    poisson_ratio: 0.3,
};

/// A periodic unit box of `cells` cells per axis, 2 particles per cell per axis, with a small
/// plane wave `v_x = 10⁻³ sin 2πx`.
pub fn solver<const D: usize>(cells: usize, shape: ShapeNd) -> SolverNd<D> {
    let grid = GridNd::<D>::new([Boundary::Periodic; D], [cells; D], [1.0; D]);
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1.0, MATERIAL);
    for p in 0..particles.len() {
        particles.v[p][0] = 1e-3 * (2.0 * std::f64::consts::PI * particles.x[p][0]).sin();
    }
    match SolverNd::new(grid, shape, particles, Vector::<D>::zeros()) {
        Ok(s) => s,
        Err(e) => panic!("bench set-up failed: {e}"),
    }
}
