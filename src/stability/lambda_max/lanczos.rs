//! The Lanczos iteration of [`super::LambdaMaxTracker`] and the top Ritz pair of its
//! tridiagonal matrix.

use super::{dot, LambdaEstimate, LanczosConfig, SymmetricOperator, Work};
use crate::stability::error::StabilityError;
use crate::stability::operator::Eq56Operator;
use nalgebra::{DMatrix, SymmetricEigen};

/// Lanczos (local re-orthogonalisation) from `start`; returns the estimate and the unit
/// Ritz vector (written into `start`'s allocation).
pub(super) fn lanczos<O: SymmetricOperator + ?Sized>(
    op: &O,
    mut start: Vec<f64>,
    config: LanczosConfig,
    warm: bool,
    work: &mut Work,
) -> Result<(LambdaEstimate, Vec<f64>), StabilityError> {
    let n = op.dim();
    let mut norm = dot(&start, &start).sqrt();
    if !(norm.is_finite() && norm > 0.0) {
        start = op.checkerboard_start();
        norm = dot(&start, &start).sqrt();
    }
    let max_iter = config.max_iter.min(n.max(1));
    let Work {
        basis, w, nodes, ..
    } = work;
    w.resize(n, 0.0);
    let ensure = |basis: &mut Vec<Vec<f64>>, k: usize| {
        while basis.len() <= k {
            basis.push(Vec::new());
        }
        basis[k].resize(n, 0.0);
    };
    ensure(basis, 0);
    for (q, s) in basis[0].iter_mut().zip(&start) {
        *q = s / norm;
    }
    let mut alpha: Vec<f64> = Vec::new();
    let mut beta: Vec<f64> = Vec::new();
    let mut best = (0.0, vec![1.0], f64::INFINITY);
    let mut applications = 0;
    let mut converged = false;
    for k in 0..max_iter {
        op.apply(&basis[k], w, nodes);
        applications += 1;
        let a = dot(&basis[k], w);
        alpha.push(a);
        // The three-term recurrence `w ← w − α q_k − β q_{k−1}` and a local
        // re-orthogonalisation against the same two vectors (classical Gram–Schmidt, repeated
        // once), fused into two passes: O(n) per iteration. Loss of global orthogonality only
        // duplicates converged Ritz values (Paige); the largest Ritz value still converges to
        // λmax from below.
        let b_prev = if k > 0 { beta[k - 1] } else { 0.0 };
        let q_prev: &[f64] = if k > 0 { &basis[k - 1] } else { &basis[k] };
        let qk = &basis[k];
        let (mut c_k, mut c_prev) = (0.0, 0.0);
        for ((wi, qi), pi) in w.iter_mut().zip(qk).zip(q_prev) {
            *wi -= a * qi + b_prev * pi;
            c_k += qi * *wi;
            c_prev += pi * *wi;
        }
        if k == 0 {
            c_prev = 0.0;
        }
        let mut norm2 = 0.0;
        for ((wi, qi), pi) in w.iter_mut().zip(qk).zip(q_prev) {
            *wi -= c_k * qi + c_prev * pi;
            norm2 += *wi * *wi;
        }
        let b = norm2.sqrt();
        let (theta, y) = top_ritz(&alpha, &beta);
        let theta = theta.max(0.0);
        let residual = b * y.last().map_or(0.0, |v| v.abs());
        let previous = best.0;
        best = (theta, y, residual);
        if !theta.is_finite() {
            return Err(StabilityError::InvalidField {
                field: "lambda_max",
                index: k,
                value: theta,
            });
        }
        let stagnated = k >= 1 && theta - previous <= config.value_tol * theta;
        if residual <= config.tol * theta
            || stagnated
            || b <= f64::EPSILON * theta.max(f64::MIN_POSITIVE)
        {
            converged = true;
            break;
        }
        if k + 1 < max_iter {
            beta.push(b);
            ensure(basis, k + 1);
            for (q, wi) in basis[k + 1].iter_mut().zip(w.iter()) {
                *q = wi / b;
            }
        }
    }
    let (theta, y, residual) = best;
    let mut x = start;
    x.resize(n, 0.0);
    x.iter_mut().for_each(|v| *v = 0.0);
    for (yj, q) in y.iter().zip(basis.iter()) {
        for (xi, qi) in x.iter_mut().zip(q) {
            *xi += yj * qi;
        }
    }
    let nx = dot(&x, &x).sqrt();
    if nx > 0.0 {
        x.iter_mut().for_each(|v| *v /= nx);
    }
    let est = LambdaEstimate {
        lambda_b: theta,
        lambda_hat: op.normalised(theta),
        dt_eq56: Eq56Operator::critical_dt(theta),
        residual: if theta > 0.0 { residual / theta } else { 0.0 },
        applications,
        converged,
        warm,
    };
    Ok((est, x))
}

/// Largest eigenpair of the symmetric tridiagonal matrix with diagonal `alpha` and
/// off-diagonal `beta` (`beta.len() == alpha.len() − 1`); the Lanczos iterations of both
/// the 1D tracker and the d-dimensional limit ([`crate::limits_nd`]) read it.
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
