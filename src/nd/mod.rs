//! Two and three dimensions: the grid, the weights and the state view of a d-dimensional
//! MPM solver (`D = 2, 3`).
//!
//! Notation: particle `p`, node `i`, axis `a`; `S_ip` the weight and `∇S_ip` its gradient.
//! Weights are tensor products of the 1D functions per axis,
//! `S_ip = Π_a s_a(x_p,a − X_i,a)` and `∂_a S_ip = s'_a Π_{b≠a} s_b`.

mod grid;
mod view;
mod weights;

pub use grid::GridNd;
pub use view::ViewNd;
pub use weights::{WeightsNd, WeightsNdError};

use nalgebra::{SMatrix, SVector};

/// A d-vector (positions, velocities, weight gradients).
pub type Vector<const D: usize> = SVector<f64, D>;
/// A d×d tensor (stress, deformation gradient, velocity gradient).
pub type Tensor<const D: usize> = SMatrix<f64, D, D>;
