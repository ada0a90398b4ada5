//! A jittered, neo-Hookean GIMP block moving across a periodic 8×8 grid: the motion
//! guard, the moduli and the nodal masses all change (the config tests' layout).

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
    let mut s: u64 = 7;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for p in 0..particles.len() {
        let x = particles.x[p];
        for a in 0..2 {
            particles.x[p][a] += 0.3 * particles.domain[p][a] * next();
        }
        particles.v[p][0] = 0.2 + 0.1 * (2.0 * std::f64::consts::PI * x[1]).sin();
        particles.v[p][1] = 0.1 * (2.0 * std::f64::consts::PI * x[0]).sin();
    }
    SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<2>::from(gravity)).unwrap()
}
