//! The crate's one Lanczos iteration: the largest eigenvalue of a self-adjoint operator
//! from a few products with it.
//!
//! # The operators
//!
//! The stability limits' critical steps are `√(2/λ)` (or the full map's `√(2/λ*)`) of the
//! largest eigenvalue of a symmetric positive semi-definite operator. Every Lanczos
//! estimate of it runs this iteration (the 1D tracker also serves power-pass values
//! certified by an `LDLᵀ` inertia test, and the verification tools have dense paths):
//!
//! * the 1D tracker ([`crate::stability::lambda_max`]): eq 56's
//!   `B = diag(√(E V)) Dᵀ M D diag(√(E V))` on the particles (or its nodal form `C`), in
//!   the Euclidean inner product;
//! * the d-dimensional limit ([`crate::limits_nd::stiffness`]): eq 56's
//!   `A = M^{-1/2} K M^{-1/2}` on the active nodal components, in the Euclidean inner
//!   product summed over the processes of a split run (a [`crate::reduce::Reduce`]);
//! * the full map from the nodes ([`crate::stability::nodal_full_map`]): `A_s B` with
//!   `B = I − Q_s/2` symmetric positive definite, self-adjoint in the `B` inner product
//!   `⟨x, y⟩_B = (B x)ᵀ y` (a *metric*, `Operator::METRIC`).
//!
//! An `Operator` gives the products and its `Inner` product: the Euclidean one over
//! this process's entries, completed by [`crate::reduce::Reduce::sum`] over the processes
//! when the vectors are split (each process then holds the same scalars, takes the same
//! decisions and returns the same value).
//!
//! # The iteration
//!
//! From a unit start `q_0` (`⟨q_0, q_0⟩ = 1`), for `k = 0, 1, …`:
//!
//! ```text
//! w = Op q_k,   α_k = ⟨q_k, w⟩,   w ← w − α_k q_k − β_{k−1} q_{k−1} (orthogonalised),
//! β_k = ⟨w, w⟩^{1/2},   q_{k+1} = w / β_k,
//! ```
//!
//! and the tridiagonal `T_k` (diagonal `α`, off-diagonal `β`) has the top Ritz pair
//! `(θ_k, y)`: `θ_k` is the largest eigenvalue of `T_k` (`top_ritz`), the Ritz vector
//! `x = Σ_j y_j q_j` (`Work::ritz_vector`), its residual `‖Op x − θ_k x‖ = β_k |y_k|`.
//!
//! **From below.** `θ_k` is the largest Rayleigh quotient `⟨x, Op x⟩/⟨x, x⟩` over the
//! Krylov space `span(q_0 … q_k)` (Courant–Fischer in the iteration's inner product, where
//! `Op` is self-adjoint), so it never exceeds `λmax` and grows with `k`: every Ritz value
//! is a lower bound, and it converges from below — fast where the top eigenvalue is
//! separated, `0 ≤ λmax − θ_k ≤ r_k²/g` with `r_k` the residual and `g` the gap. A mode
//! with no component in `q_0` is invisible: the callers' starts (checkerboards with noise,
//! warm starts blended with them) give every mode a component.
//!
//! **Orthogonality** (`Orthogonalise`): in floating point the `q_j` lose orthogonality
//! as Ritz values converge. `Orthogonalise::Local` (the 1D tracker, `O(n)` per
//! iteration) runs the three-term recurrence and re-orthogonalises against `q_k`,
//! `q_{k−1}` only: lost orthogonality then only duplicates converged Ritz values (Paige),
//! and the largest still converges to `λmax` from below. `Orthogonalise::Full` (the
//! d-dimensional limit and the full map, `O(k n)` per iteration) subtracts the projections
//! on the whole basis, twice ("twice is enough"): modified Gram–Schmidt on one process,
//! classical (one reduction per pass) when the inner product reduces over processes.
//!
//! **Stopping rule** (`StopRule`): after the Ritz pair of iteration `k`,
//!
//! * the residual bound `β_k |y_k| ≤ tol · θ_k`: some eigenvalue lies within it;
//! * or the Ritz value has settled: it converges long before the residual on a clustered
//!   top of the spectrum (uniform and jittered layouts), and the step needs the value only
//!   — `Monotone` (one step of `θ_k − θ_{k−1} ≤ value_tol · θ_k`, the 1D tracker) or
//!   `Settle` (`|θ_k − θ_{k−1}| ≤ settle · |θ_k|` in several evaluations running, the
//!   d-dimensional limit and the full map);
//! * or `β_k` ≈ 0: the Krylov space is invariant and `θ_k` an eigenvalue;
//! * or the iteration cap.
//!
//! `Settle` can also evaluate the Ritz value on a cadence (every iteration, then every
//! few), since each evaluation is a dense eigenproblem of the iteration's size.

mod inner;
mod ritz;
mod stop;
#[cfg(test)]
mod tests;

pub(crate) use inner::{dot, reduced_dots, Inner};
pub(crate) use ritz::top_ritz;
pub(crate) use stop::{Monotone, Settle, StopRule, Verdict};

/// A self-adjoint operator of the iteration and its inner product (module docs).
pub(crate) trait Operator {
    /// Whether the inner product is `⟨x, y⟩_B = (B x)ᵀ y` of a metric `B`
    /// ([`Self::metric`]) rather than the Euclidean one.
    const METRIC: bool = false;
    /// The Euclidean inner product of the vectors (over the processes where they are split).
    fn inner(&self) -> Inner<'_>;
    /// `y = Op x`; `bx = B x` with a metric, `x` itself without (overwrites `y`).
    fn apply(&mut self, x: &[f64], bx: &[f64], y: &mut [f64]);
    /// `y = B x` (called only with [`Self::METRIC`]).
    fn metric(&mut self, _x: &[f64], _y: &mut [f64]) {}
    /// Whether `xbx = ⟨x, x⟩_B` shows `B` is not positive definite as the operator knows it
    /// (a `true` ends the iteration with [`Breakdown::Indefinite`]; never by default).
    fn indefinite(&self, _x: &[f64], _xbx: f64) -> bool {
        false
    }
}

/// How the new direction is orthogonalised (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Orthogonalise {
    /// The three-term recurrence and one classical Gram–Schmidt pass against `q_k` and
    /// `q_{k−1}`, fused into two passes over the vectors (Euclidean inner products only).
    Local,
    /// Twice against the whole basis: modified Gram–Schmidt on one process, classical
    /// (one reduction per pass) when the inner product reduces over processes.
    Full,
}

/// Why an iteration ended without a value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Breakdown {
    /// The stopping rule found a non-finite Ritz value at `iteration`.
    NonFinite { iteration: usize, value: f64 },
    /// The metric gave an `⟨w, w⟩_B` that shows it indefinite at `iteration` ([`Operator::indefinite`]).
    Indefinite { iteration: usize, value: f64 },
}

/// The last top Ritz pair of a run.
#[derive(Clone, Debug)]
pub(crate) struct Outcome {
    /// The largest Ritz value `θ` of the last evaluation.
    pub theta: f64,
    /// Its coordinates in the basis.
    pub y: Vec<f64>,
    /// Its residual bound `β_k |y_k|`.
    pub residual: f64,
    /// Products with the operator.
    pub applications: usize,
    /// Whether the stopping rule (not the iteration cap) ended the run.
    pub converged: bool,
}

/// The basis and scratch of the iteration, reusable from run to run (scratch only).
#[derive(Debug, Default)]
pub(crate) struct Work {
    /// `q_0, q_1, …` (allocations beyond the current run's are kept for the next).
    basis: Vec<Vec<f64>>,
    /// `B q_0, B q_1, …` with a metric.
    metric_basis: Vec<Vec<f64>>,
    w: Vec<f64>,
    bw: Vec<f64>,
}

/// `vectors[k] = from / scale` (length `n`), growing `vectors` as needed.
fn set_scaled(vectors: &mut Vec<Vec<f64>>, k: usize, n: usize, from: &[f64], scale: f64) {
    while vectors.len() <= k {
        vectors.push(Vec::new());
    }
    vectors[k].resize(n, 0.0);
    for (q, x) in vectors[k].iter_mut().zip(from) {
        *q = x / scale;
    }
}

/// `⟨q, q⟩^{1/2}` in the operator's inner product; `bq` receives `B q` with a metric.
pub(crate) fn norm<O: Operator>(op: &mut O, q: &[f64], bq: &mut Vec<f64>) -> f64 {
    if O::METRIC {
        bq.resize(q.len(), 0.0);
        op.metric(q, bq);
        op.inner().dot(q, bq).sqrt()
    } else {
        op.inner().dot(q, q).sqrt()
    }
}

impl Work {
    /// Sets the start `q_0 = q / norm` (and `B q_0 = bq / norm` with a metric), `n` long.
    pub(crate) fn start(&mut self, n: usize, q: &[f64], bq: Option<&[f64]>, norm: f64) {
        set_scaled(&mut self.basis, 0, n, q, norm);
        if let Some(bq) = bq {
            set_scaled(&mut self.metric_basis, 0, n, bq, norm);
        }
    }

    /// The unit Ritz vector `Σ_j y_j q_j / ⟨·,·⟩^{1/2}` (`n` long) in `x`'s allocation.
    pub(crate) fn ritz_vector(
        &self,
        y: &[f64],
        inner: Inner<'_>,
        mut x: Vec<f64>,
        n: usize,
    ) -> Vec<f64> {
        x.resize(n, 0.0);
        x.iter_mut().for_each(|v| *v = 0.0);
        for (yj, q) in y.iter().zip(self.basis.iter()) {
            for (xi, qi) in x.iter_mut().zip(q) {
                *xi += yj * qi;
            }
        }
        let nx = inner.dot(&x, &x).sqrt();
        if nx > 0.0 {
            x.iter_mut().for_each(|v| *v /= nx);
        }
        x
    }
}

/// The Lanczos iteration (module docs) from the unit start set by [`Work::start`], on
/// vectors of length `n`, for at most `max_iter` products.
pub(crate) fn run<O: Operator, S: StopRule>(
    op: &mut O,
    work: &mut Work,
    n: usize,
    max_iter: usize,
    orthogonalise: Orthogonalise,
    stop: &mut S,
) -> Result<Outcome, Breakdown> {
    assert!(
        !(O::METRIC && orthogonalise == Orthogonalise::Local),
        "the local recurrence is Euclidean"
    );
    work.w.resize(n, 0.0);
    if O::METRIC {
        work.bw.resize(n, 0.0);
    }
    let (mut alpha, mut beta) = (Vec::<f64>::new(), Vec::<f64>::new());
    let mut last = Outcome {
        theta: 0.0,
        y: vec![1.0],
        residual: f64::INFINITY,
        applications: 0,
        converged: false,
    };
    for k in 0..max_iter {
        let b = expand(op, work, k, (&mut alpha, &beta), orthogonalise)?;
        let final_iteration = k + 1 == max_iter;
        if !stop.skip(k, b, final_iteration) {
            let (theta, y) = top_ritz(&alpha, &beta);
            let residual = b * y.last().copied().unwrap_or(0.0).abs();
            let verdict = stop.verdict(k, theta, residual, b);
            last = Outcome {
                theta,
                y,
                residual,
                applications: k + 1,
                converged: false,
            };
            match verdict {
                Verdict::Continue => {}
                Verdict::Stop => {
                    last.converged = true;
                    return Ok(last);
                }
                Verdict::NonFinite(value) => {
                    return Err(Breakdown::NonFinite {
                        iteration: k,
                        value,
                    })
                }
            }
        }
        if !final_iteration {
            beta.push(b);
            set_scaled(&mut work.basis, k + 1, n, &work.w, b);
            if O::METRIC {
                set_scaled(&mut work.metric_basis, k + 1, n, &work.bw, b);
            }
        }
    }
    Ok(last)
}

/// Iteration `k` up to `β_k`: `w = Op q_k`, `α_k = ⟨q_k, w⟩` (pushed on `alpha`), `w`
/// orthogonalised, and (with a metric) `B w`; returns `β_k = ⟨w, w⟩^{1/2}`.
fn expand<O: Operator>(
    op: &mut O,
    work: &mut Work,
    k: usize,
    (alpha, beta): (&mut Vec<f64>, &[f64]),
    orthogonalise: Orthogonalise,
) -> Result<f64, Breakdown> {
    let Work {
        basis,
        metric_basis,
        w,
        bw,
    } = work;
    let (q, bq) = if O::METRIC {
        (&basis[k], &metric_basis[k])
    } else {
        (&basis[k], &basis[k])
    };
    op.apply(q, bq, w);
    let a = op.inner().dot(bq, w);
    alpha.push(a);
    let norm2 = match orthogonalise {
        Orthogonalise::Local => {
            let b_prev = if k > 0 { beta[k - 1] } else { 0.0 };
            let q_prev: &[f64] = if k > 0 { &basis[k - 1] } else { &basis[k] };
            Some(recur_local(op.inner(), w, q, q_prev, a, b_prev, k == 0))
        }
        Orthogonalise::Full => {
            full(op.inner(), w, &basis[..=k], &metric_basis[..], O::METRIC);
            None
        }
    };
    if O::METRIC {
        op.metric(w, bw);
        let wbw = op.inner().dot(w, bw);
        if op.indefinite(w, wbw) {
            return Err(Breakdown::Indefinite {
                iteration: k,
                value: wbw,
            });
        }
        return Ok(wbw.sqrt());
    }
    Ok(norm2.unwrap_or_else(|| op.inner().dot(w, w)).sqrt())
}

/// `w ← w − Σ_j ⟨q_j, w⟩ q_j` over `basis`, twice: modified Gram–Schmidt on one process,
/// classical (one reduction per pass) when `inner` reduces. `metric_basis` holds `B q_j`
/// when `metric`.
fn full(
    inner: Inner<'_>,
    w: &mut [f64],
    basis: &[Vec<f64>],
    metric_basis: &[Vec<f64>],
    metric: bool,
) {
    let left = if metric {
        &metric_basis[..basis.len()]
    } else {
        basis
    };
    for _ in 0..2 {
        if inner.is_reduced() {
            let refs: Vec<&[f64]> = left.iter().map(|b| b.as_slice()).collect();
            let cs = inner.dots(&refs, w);
            for (q, c) in basis.iter().zip(cs) {
                w.iter_mut().zip(q).for_each(|(x, y)| *x -= c * y);
            }
        } else {
            for (q, bq) in basis.iter().zip(left) {
                let c = inner.dot(bq, w);
                w.iter_mut().zip(q).for_each(|(x, y)| *x -= c * y);
            }
        }
    }
}

/// `⟨w, w⟩` after `w ← w − α q_k − β q_{k−1}` and a re-orthogonalisation against `q_k`,
/// `q_{k−1}` (`first`: there is no `q_{k−1}`) — [`Orthogonalise::Local`].
fn recur_local(
    inner: Inner<'_>,
    w: &mut [f64],
    qk: &[f64],
    q_prev: &[f64],
    a: f64,
    b_prev: f64,
    first: bool,
) -> f64 {
    match inner.owned() {
        None => fused(inner, w, (qk, q_prev), (a, b_prev), first, |_| true),
        Some(owned) => fused(inner, w, (qk, q_prev), (a, b_prev), first, |i| owned[i]),
    }
}

/// [`recur_local`] over the entries `counted` on this process, its sums completed by
/// `inner`.
#[inline(always)]
fn fused(
    inner: Inner<'_>,
    w: &mut [f64],
    (qk, q_prev): (&[f64], &[f64]),
    (a, b_prev): (f64, f64),
    first: bool,
    counted: impl Fn(usize) -> bool,
) -> f64 {
    // The three-term recurrence `w ← w − α q_k − β q_{k−1}` and a local
    // re-orthogonalisation against the same two vectors (classical Gram–Schmidt, repeated
    // once), fused into two passes: O(n) per iteration.
    let mut c = [0.0, 0.0];
    for (i, ((wi, qi), pi)) in w.iter_mut().zip(qk).zip(q_prev).enumerate() {
        *wi -= a * qi + b_prev * pi;
        if counted(i) {
            c[0] += qi * *wi;
            c[1] += pi * *wi;
        }
    }
    inner.complete(&mut c);
    let [c_k, mut c_prev] = c;
    if first {
        c_prev = 0.0;
    }
    let mut norm2 = [0.0];
    for (i, ((wi, qi), pi)) in w.iter_mut().zip(qk).zip(q_prev).enumerate() {
        *wi -= c_k * qi + c_prev * pi;
        if counted(i) {
            norm2[0] += *wi * *wi;
        }
    }
    inner.complete(&mut norm2);
    norm2[0]
}
