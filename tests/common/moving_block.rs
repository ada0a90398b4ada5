//! A jittered, neo-Hookean GIMP block moving across a periodic 8×8 grid: the motion
//! guard, the moduli and the nodal masses all change (the config tests' layout;
//! needs `common/jitter.rs` declared beside it as `jitter`).

use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::Boundary;

/// The block under the body force `gravity`.
pub fn moving_block(gravity: [f64; 2]) -> SolverNd<2> {
    let grid = GridNd::<2>::new([Boundary::Periodic; 2], [8, 8], [1.0, 1.0]);
    let material = MaterialNd::NeoHookean {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2, 2], 1.0, material);
    // The velocities follow the unjittered positions.
    let x0 = particles.x.clone();
    super::jitter::jitter(&mut particles, 0.3, 7);
    for (v, x) in particles.v.iter_mut().zip(&x0) {
        v[0] = 0.2 + 0.1 * (2.0 * std::f64::consts::PI * x[1]).sin();
        v[1] = 0.1 * (2.0 * std::f64::consts::PI * x[0]).sin();
    }
    SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<2>::from(gravity)).unwrap()
}
