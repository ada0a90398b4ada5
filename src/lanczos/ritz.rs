//! The top eigenpair of the iteration's tridiagonal matrix.

use nalgebra::{DMatrix, SymmetricEigen};

/// Largest eigenpair `(θ, y)` of the symmetric tridiagonal matrix with diagonal `alpha` and
/// off-diagonal `beta` (`beta.len() == alpha.len() − 1`): the top Ritz value and its
/// coordinates in the Lanczos basis.
pub(crate) fn top_ritz(alpha: &[f64], beta: &[f64]) -> (f64, Vec<f64>) {
    let k = alpha.len();
    let t = DMatrix::from_fn(k, k, |i, j| {
        if i == j {
            alpha[i]
        } else if i + 1 == j {
            beta[i]
        } else if j + 1 == i {
            beta[j]
        } else {
            0.0
        }
    });
    let eig = SymmetricEigen::new(t);
    let (imax, &theta) =
        eig.eigenvalues
            .iter()
            .enumerate()
            .fold((0, &f64::NEG_INFINITY), |acc, (i, v)| {
                if *v > *acc.1 {
                    (i, v)
                } else {
                    acc
                }
            });
    (
        theta,
        eig.eigenvectors.column(imax).iter().copied().collect(),
    )
}
