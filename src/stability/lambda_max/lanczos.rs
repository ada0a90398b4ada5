//! The Lanczos run of [`super::LambdaMaxTracker`]: the crate's iteration
//! ([`crate::lanczos`]) on a [`SymmetricOperator`] in the Euclidean inner product, with
//! the local recurrence and the [`Monotone`] stopping rule (the module docs of
//! [`super`]).

use super::{dot, LambdaEstimate, LanczosConfig, SymmetricOperator, Work};
use crate::lanczos::{self, Breakdown, Inner, Monotone, Orthogonalise};
use crate::stability::error::StabilityError;
use crate::stability::operator::Eq56Operator;

/// A [`SymmetricOperator`] and its scratch as the iteration's operator.
struct Tracked<'o, 'w, O: ?Sized> {
    op: &'o O,
    nodes: &'w mut Vec<f64>,
}

impl<O: SymmetricOperator + ?Sized> lanczos::Operator for Tracked<'_, '_, O> {
    fn inner(&self) -> Inner<'_> {
        Inner::local()
    }

    fn apply(&mut self, x: &[f64], _bx: &[f64], y: &mut [f64]) {
        self.op.apply(x, y, self.nodes);
    }
}

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
        lanczos: basis,
        nodes,
        ..
    } = work;
    basis.start(n, &start, None, norm);
    let mut tracked = Tracked { op, nodes };
    let mut rule = Monotone::new(config.tol, config.value_tol);
    let top = lanczos::run(
        &mut tracked,
        basis,
        n,
        max_iter,
        Orthogonalise::Local,
        &mut rule,
    )
    .map_err(|e| {
        let (Breakdown::NonFinite { iteration, value }
        | Breakdown::Indefinite { iteration, value }) = e;
        StabilityError::InvalidField {
            field: "lambda_max",
            index: iteration,
            value,
        }
    })?;
    let x = basis.ritz_vector(&top.y, Inner::local(), start, n);
    let theta = top.theta.max(0.0);
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

/// `start` and its 2-norm, or the cold start and its norm when `start` is 0 or not finite.
fn usable_start<O: SymmetricOperator + ?Sized>(op: &O, mut start: Vec<f64>) -> (Vec<f64>, f64) {
    let mut norm = dot(&start, &start).sqrt();
    if !(norm.is_finite() && norm > 0.0) {
        start = op.checkerboard_start();
        norm = dot(&start, &start).sqrt();
    }
    (start, norm)
}
