//! Two and three dimensions: the grid, the weights and the state view of a d-dimensional
//! MPM solver (`D = 2, 3`).
//!
//! Notation: particle `p`, node `i`, axis `a`; `S_ip` the weight and `∇S_ip` its gradient.
//! Weights are tensor products of the 1D functions per axis,
//! `S_ip = Π_a s_a(x_p,a − X_i,a)` and `∂_a S_ip = s'_a Π_{b≠a} s_b`.

pub mod factor_metric;
pub mod factors;
pub mod fields;
mod grid;
pub(crate) mod kernels;
pub(crate) mod shape;
mod view;
mod view_weights;
mod weights;

pub use fields::INACTIVE_MASS_RATIO;
pub use grid::GridNd;
pub use shape::{AxisStencil, ShapeNd};
pub use view::{NodalHalo, SplitNd, SummaryNd, ViewNd};
pub use view_weights::ViewWeightsNd;
pub use weights::WeightsNd;

// The 2D/3D reference solver, its scenarios and exact problems live in the test bench
// (`src/testbench/nd/`); their public paths stay here.
#[cfg(feature = "reference")]
pub use crate::testbench::nd::{
    problems, scenario, MaterialNd, ParticlesNd, SetupError, SolverNd, ThreadsError, MIN_SLAB_CELLS,
};

use nalgebra::{SMatrix, SVector};

/// A d-vector (positions, velocities, weight gradients).
pub type Vector<const D: usize> = SVector<f64, D>;
/// A d×d tensor (stress, deformation gradient, velocity gradient).
pub type Tensor<const D: usize> = SMatrix<f64, D, D>;

/// `det(m)` of a small `D×D` tensor (closed form for `D ≤ 3`, elimination otherwise;
/// nalgebra's `determinant` needs type-level dimensions a const generic cannot give).
#[inline]
pub fn det<const D: usize>(m: &Tensor<D>) -> f64 {
    match D {
        1 => m[(0, 0)],
        2 => m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)],
        3 => {
            m[(0, 0)] * (m[(1, 1)] * m[(2, 2)] - m[(1, 2)] * m[(2, 1)])
                - m[(0, 1)] * (m[(1, 0)] * m[(2, 2)] - m[(1, 2)] * m[(2, 0)])
                + m[(0, 2)] * (m[(1, 0)] * m[(2, 1)] - m[(1, 1)] * m[(2, 0)])
        }
        _ => {
            let mut a = *m;
            let mut det = 1.0;
            for c in 0..D {
                let piv = (c..D)
                    .max_by(|&i, &j| a[(i, c)].abs().total_cmp(&a[(j, c)].abs()))
                    .unwrap_or(c);
                if a[(piv, c)] == 0.0 {
                    return 0.0;
                }
                if piv != c {
                    a.swap_rows(piv, c);
                    det = -det;
                }
                det *= a[(c, c)];
                for r in c + 1..D {
                    let f = a[(r, c)] / a[(c, c)];
                    for k in c..D {
                        a[(r, k)] -= f * a[(c, k)];
                    }
                }
            }
            det
        }
    }
}
