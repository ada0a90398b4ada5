//! A jittered neo-Hookean GIMP block moving across a periodic 4×4×4 grid: the 3D config
//! sweeps' layout (needs `common/jitter.rs` declared beside it as `jitter`).

use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::Boundary;

/// A jittered neo-Hookean GIMP block (2×2×2 particles a cell) moving across a periodic
/// 4×4×4 grid of the unit cube, with a shear in each direction, under the body force
/// `gravity`.
pub fn moving_block_3d(gravity: [f64; 3]) -> SolverNd<3> {
    let grid = GridNd::<3>::new([Boundary::Periodic; 3], [4; 3], [1.0; 3]);
    let material = MaterialNd::NeoHookean {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2; 3], 1.0, material);
    // The velocities follow the unjittered positions.
    let x0 = particles.x.clone();
    super::jitter::jitter(&mut particles, 0.3, 7);
    let wave = |s: f64| 0.1 * (2.0 * std::f64::consts::PI * s).sin();
    for (v, x) in particles.v.iter_mut().zip(&x0) {
        v[0] = 0.2 + wave(x[1]);
        v[1] = wave(x[2]);
        v[2] = wave(x[0]);
    }
    SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<3>::from(gravity)).unwrap()
}
