//! The iteration on small operators with known spectra.

use super::*;
use crate::reduce::SingleProcess;

/// `A = tridiag(−1, 2, −1)` on `n` entries (eigenvalues `2 − 2 cos(jπ/(n+1))`), in the
/// Euclidean inner product given.
struct Laplacian<'r>(Inner<'r>);

impl Laplacian<'_> {
    fn product(u: &[f64], y: &mut [f64]) {
        let n = u.len();
        for i in 0..n {
            let left = if i > 0 { u[i - 1] } else { 0.0 };
            let right = if i + 1 < n { u[i + 1] } else { 0.0 };
            y[i] = 2.0 * u[i] - left - right;
        }
    }
}

impl Operator for Laplacian<'_> {
    fn inner(&self) -> Inner<'_> {
        self.0
    }
    fn apply(&mut self, x: &[f64], _bx: &[f64], y: &mut [f64]) {
        Self::product(x, y);
    }
}

/// The same `A B` with the metric `B = diag(b)`.
struct Pencil(Vec<f64>);

impl Operator for Pencil {
    const METRIC: bool = true;
    fn inner(&self) -> Inner<'_> {
        Inner::local()
    }
    fn apply(&mut self, _x: &[f64], bx: &[f64], y: &mut [f64]) {
        Laplacian::product(bx, y);
    }
    fn metric(&mut self, x: &[f64], y: &mut [f64]) {
        for ((y, x), b) in y.iter_mut().zip(x).zip(&self.0) {
            *y = b * x;
        }
    }
}

fn start(n: usize) -> Vec<f64> {
    (0..n).map(|k| 1.0 + 0.3 * ((k * 37 % 11) as f64)).collect()
}

fn largest<O: Operator>(op: &mut O, n: usize, orth: Orthogonalise) -> Outcome {
    let q = start(n);
    let mut bq = Vec::new();
    let norm = norm(op, &q, &mut bq);
    let mut work = Work::default();
    work.start(n, &q, O::METRIC.then_some(&bq[..]), norm);
    let mut rule = Settle::new(1e-12, 1e-14, (3, 0), 1e-14, f64::NAN);
    run(op, &mut work, n, n, orth, &mut rule).expect("a value")
}

#[test]
fn the_top_ritz_value_converges_from_below_on_a_laplacian() {
    let n = 40;
    let exact = 2.0 - 2.0 * (n as f64 * std::f64::consts::PI / (n as f64 + 1.0)).cos();
    for orth in [Orthogonalise::Local, Orthogonalise::Full] {
        let mut op = Laplacian(Inner::local());
        let top = largest(&mut op, n, orth);
        assert!(
            top.theta <= exact * (1.0 + 1e-12),
            "{orth:?}: {}",
            top.theta
        );
        assert!(
            (top.theta - exact).abs() <= 1e-9 * exact,
            "{orth:?}: {}",
            top.theta
        );
    }
}

#[test]
fn a_metric_gives_the_pencils_top_eigenvalue() {
    let n = 30;
    let b: Vec<f64> = (0..n).map(|i| 0.5 + 0.5 * ((i % 7) as f64) / 7.0).collect();
    // Dense `B^{1/2} A B^{1/2}`, similar to `A B`.
    let dense = nalgebra::DMatrix::from_fn(n, n, |i, j| {
        let a = match i.abs_diff(j) {
            0 => 2.0,
            1 => -1.0,
            _ => 0.0,
        };
        b[i].sqrt() * a * b[j].sqrt()
    });
    let exact = dense.symmetric_eigenvalues().max();
    let top = largest(&mut Pencil(b), n, Orthogonalise::Full);
    assert!(
        (top.theta - exact).abs() <= 1e-9 * exact,
        "{} {exact}",
        top.theta
    );
}

/// Entries held twice (a ghost copy) count once through the owned mask and the reduction.
#[test]
fn an_owned_mask_counts_ghost_copies_once() {
    let reduce = SingleProcess;
    let (a, b) = ([1.0, 2.0, 3.0, 3.0], [4.0, 5.0, 6.0, 6.0]);
    let owned = [true, true, true, false];
    let inner = Inner::over(&reduce, &owned);
    assert!(inner.is_reduced());
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&[inner.dot(&a, &b)]), bits(&[32.0]));
    assert_eq!(bits(&inner.dots(&[&a, &b], &b)), bits(&[32.0, 77.0]));
    assert_eq!(bits(&[Inner::local().dot(&a[..3], &b[..3])]), bits(&[32.0]));
}
