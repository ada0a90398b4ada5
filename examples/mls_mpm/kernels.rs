//! The quadratic B-spline of mpm88's MLS-MPM, per axis, and the slice casts the solver's
//! view uses.

use mpm_dt::nd::{Tensor, Vector};
use nalgebra::{Matrix2, Vector2};

/// Quadratic B-spline weights and their positions relative to the particle: for each axis
/// the base lattice index `floor(x/h − ½)` and the three weights.
pub(super) fn bspline(x: f64, h: f64) -> (i64, [f64; 3], [f64; 3]) {
    let xi = x / h;
    let base = (xi - 0.5).floor();
    let fx = xi - base;
    let w = [
        0.5 * (1.5 - fx).powi(2),
        0.75 - (fx - 1.0).powi(2),
        0.5 * (fx - 0.5).powi(2),
    ];
    // x_i − x_p in cells for the three nodes.
    let dpos = [-fx, 1.0 - fx, 2.0 - fx];
    (base as i64, w, dpos)
}

/// `Vector2<f64>` is `nd::Vector<2>` (the same nalgebra type).
pub(super) fn vectors(v: &[Vector2<f64>]) -> &[Vector<2>] {
    v
}

/// `Matrix2<f64>` is `nd::Tensor<2>`.
pub(super) fn tensors(v: &[Matrix2<f64>]) -> &[Tensor<2>] {
    v
}
