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
    start: Vec<f64>,
    config: LanczosConfig,
    warm: bool,
    work: &mut Work,
) -> Result<(LambdaEstimate, Vec<f64>), StabilityError> {
    let n = op.dim();
    let (start, norm) = usable_start(op, start);
    let max_iter = config.max_iter.min(n.max(1));
    let Work {
        basis, w, nodes, ..
    } = work;
    w.resize(n, 0.0);
    ensure(basis, 0, n);
    for (q, s) in basis[0].iter_mut().zip(&start) {
        *q = s / norm;
    }
    let top = iterate(op, &config, max_iter, n, basis, w, nodes)?;
    let x = ritz_vector(start, &top.y, basis, n);
    let theta = top.theta;
    let est = LambdaEstimate {
        lambda_b: theta,
        lambda_hat: op.normalised(theta),
        dt_eq56: Eq56Operator::critical_dt(theta),
        residual: if theta > 0.0 {
            top.residual / theta
        } else {
            0.0
        },
        applications: top.applications,
        converged: top.converged,
        warm,
    };
    Ok((est, x))
}

/// The last top Ritz pair `(θ, y)`, its residual bound `β_k |y_k|`, the applications, and
/// whether a test (not the iteration limit) stopped the iteration.
struct Outcome {
    theta: f64,
    y: Vec<f64>,
    residual: f64,
    applications: usize,
    converged: bool,
}

/// `start` and its 2-norm, or the cold start and its norm when `start` is 0 or not finite.
fn usable_start<O: SymmetricOperator + ?Sized>(op: &O, mut start: Vec<f64>) -> (Vec<f64>, f64) {
    let mut norm = dot(&start, &start).sqrt();
    if !(norm.is_finite() && norm > 0.0) {
        start = op.checkerboard_start();
        norm = dot(&start, &start).sqrt();
    }
    (start, norm)
}

/// Grows `basis` to hold vector `k`, of length `n`.
fn ensure(basis: &mut Vec<Vec<f64>>, k: usize, n: usize) {
    while basis.len() <= k {
        basis.push(Vec::new());
    }
    basis[k].resize(n, 0.0);
}

/// The iterations from the unit `basis[0]`: `α_k = q_kᵀ B q_k`, `q_{k+1} = w/β_k`, until
/// the top Ritz pair converges (a non-finite `θ` is an error).
fn iterate<O: SymmetricOperator + ?Sized>(
    op: &O,
    config: &LanczosConfig,
    max_iter: usize,
    n: usize,
    basis: &mut Vec<Vec<f64>>,
    w: &mut [f64],
    nodes: &mut Vec<f64>,
) -> Result<Outcome, StabilityError> {
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
        let b_prev = if k > 0 { beta[k - 1] } else { 0.0 };
        let q_prev: &[f64] = if k > 0 { &basis[k - 1] } else { &basis[k] };
        let b = recur_and_reorthogonalise(w, &basis[k], q_prev, a, b_prev, k == 0);
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
            ensure(basis, k + 1, n);
            for (q, wi) in basis[k + 1].iter_mut().zip(w.iter()) {
                *q = wi / b;
            }
        }
    }
    let (theta, y, residual) = best;
    Ok(Outcome {
        theta,
        y,
        residual,
        applications,
        converged,
    })
}

/// `β_k = ‖w‖₂` after `w ← w − α q_k − β q_{k−1}` and a re-orthogonalisation against
/// `q_k`, `q_{k−1}` (`first`: there is no `q_{k−1}`).
fn recur_and_reorthogonalise(
    w: &mut [f64],
    qk: &[f64],
    q_prev: &[f64],
    a: f64,
    b_prev: f64,
    first: bool,
) -> f64 {
    // The three-term recurrence `w ← w − α q_k − β q_{k−1}` and a local
    // re-orthogonalisation against the same two vectors (classical Gram–Schmidt, repeated
    // once), fused into two passes: O(n) per iteration. Loss of global orthogonality only
    // duplicates converged Ritz values (Paige); the largest Ritz value still converges to
    // λmax from below.
    let (mut c_k, mut c_prev) = (0.0, 0.0);
    for ((wi, qi), pi) in w.iter_mut().zip(qk).zip(q_prev) {
        *wi -= a * qi + b_prev * pi;
        c_k += qi * *wi;
        c_prev += pi * *wi;
    }
    if first {
        c_prev = 0.0;
    }
    let mut norm2 = 0.0;
    for ((wi, qi), pi) in w.iter_mut().zip(qk).zip(q_prev) {
        *wi -= c_k * qi + c_prev * pi;
        norm2 += *wi * *wi;
    }
    norm2.sqrt()
}

/// The unit Ritz vector `Σ_j y_j q_j / ‖Σ_j y_j q_j‖₂` (length `n`), in `x`'s allocation.
fn ritz_vector(mut x: Vec<f64>, y: &[f64], basis: &[Vec<f64>], n: usize) -> Vec<f64> {
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
    x
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
