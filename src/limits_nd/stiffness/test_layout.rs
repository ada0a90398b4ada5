//! The products' test layout: a walled, sheared neo-Hookean GIMP block after one step.

use crate::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use crate::{Boundary, Stepper};

/// `cells × cells` walled cells, 2×2 particles per cell, a shear flow, one step taken.
pub(super) fn sheared_block(cells: usize) -> SolverNd<2> {
    let grid = GridNd::<2>::new([Boundary::Fixed; 2], [cells, cells], [1.0, 1.0]);
    let material = MaterialNd::NeoHookean {
        youngs_modulus: 1e4,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2, 2], 1000.0, material);
    for p in 0..particles.len() {
        let x = particles.x[p];
        particles.v[p][0] = 0.3 * (x[1] - 0.5);
    }
    let mut s = SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<2>::zeros())
        .expect("a valid set-up");
    s.try_step(1e-4).and_then(|_| s.accept()).expect("a step");
    s
}
