//! The stopping rules of the iteration ([`super`]'s module docs, "Stopping rule").

/// What a stopping rule says of an iteration's top Ritz value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Verdict {
    /// Go on (up to the iteration cap).
    Continue,
    /// A test is met: the run ends converged.
    Stop,
    /// The value (as the rule reads it) is not finite: the run ends with an error.
    NonFinite(f64),
}

/// When the iteration evaluates its Ritz value and when it stops.
pub(crate) trait StopRule {
    /// Whether iteration `k` (with `β_k = beta`; `last`: the cap's) skips its Ritz value
    /// (the evaluation's cadence; never skipped by default).
    fn skip(&self, _k: usize, _beta: f64, _last: bool) -> bool {
        false
    }
    /// The verdict on iteration `k`'s top Ritz value `theta`, its residual bound
    /// `residual = β_k |y_k|` and `beta = β_k`.
    fn verdict(&mut self, k: usize, theta: f64, residual: f64, beta: f64) -> Verdict;
}

/// The 1D tracker's rule ([`crate::stability::lambda_max`]'s module docs), on
/// `θ = max(θ_k, 0)`: stop when `β_k |y_k| ≤ tol · θ`, when the value stagnates
/// (`θ − θ_prev ≤ value_tol · θ`, `k ≥ 1`: Ritz values grow monotonically, so a step that
/// does not raise the value ends the run) or when `β_k ≤ ε · θ`. A non-finite `θ` is an
/// error.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Monotone {
    tol: f64,
    value_tol: f64,
    previous: f64,
}

impl Monotone {
    /// The rule with tolerances `tol` (residual) and `value_tol` (stagnation).
    pub(crate) fn new(tol: f64, value_tol: f64) -> Self {
        Self {
            tol,
            value_tol,
            previous: 0.0,
        }
    }
}

impl StopRule for Monotone {
    fn verdict(&mut self, k: usize, theta: f64, residual: f64, beta: f64) -> Verdict {
        let theta = theta.max(0.0);
        let previous = std::mem::replace(&mut self.previous, theta);
        if !theta.is_finite() {
            return Verdict::NonFinite(theta);
        }
        let stagnated = k >= 1 && theta - previous <= self.value_tol * theta;
        if residual <= self.tol * theta
            || stagnated
            || beta <= f64::EPSILON * theta.max(f64::MIN_POSITIVE)
        {
            Verdict::Stop
        } else {
            Verdict::Continue
        }
    }
}

/// The d-dimensional limit's and the full map's rule: stop when `β_k |y_k| ≤ tol · |θ_k|`,
/// when the value has settled (`|θ_k − θ_prev| ≤ settle · |θ_k|` in `runs` evaluations
/// running, from iteration `min_k` on) or when `β_k ≤ exhausted · |θ_k|` (an invariant
/// Krylov space). With a cadence the value is evaluated at every iteration below `dense`,
/// then at every `every`-th (and at the cap, and where `β_k ≤ exhausted · |θ_prev|`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Settle {
    tol: f64,
    settle: f64,
    runs: usize,
    min_k: usize,
    exhausted: f64,
    /// `(dense, every)`.
    cadence: Option<(usize, usize)>,
    /// The last evaluated value (`previous_start` before the first).
    previous: f64,
    settled_runs: usize,
}

impl Settle {
    /// The rule (type docs); `previous_start` stands for `θ_prev` at the first evaluation.
    pub(crate) fn new(
        tol: f64,
        settle: f64,
        (runs, min_k): (usize, usize),
        exhausted: f64,
        previous_start: f64,
    ) -> Self {
        Self {
            tol,
            settle,
            runs,
            min_k,
            exhausted,
            cadence: None,
            previous: previous_start,
            settled_runs: 0,
        }
    }

    /// The rule evaluating every iteration below `dense`, then every `every`-th.
    pub(crate) fn with_cadence(self, dense: usize, every: usize) -> Self {
        Self {
            cadence: Some((dense, every)),
            ..self
        }
    }
}

impl StopRule for Settle {
    fn skip(&self, k: usize, beta: f64, last: bool) -> bool {
        let Some((dense, every)) = self.cadence else {
            return false;
        };
        let exhausted = beta <= self.exhausted * self.previous.abs();
        k >= dense && k % every != every - 1 && !last && !exhausted
    }

    fn verdict(&mut self, k: usize, theta: f64, residual: f64, beta: f64) -> Verdict {
        let settled = (theta - self.previous).abs() <= self.settle * theta.abs();
        self.settled_runs = if settled { self.settled_runs + 1 } else { 0 };
        self.previous = theta;
        let converged = residual <= self.tol * theta.abs()
            || (k >= self.min_k && self.settled_runs >= self.runs);
        if converged || beta <= self.exhausted * theta.abs() {
            Verdict::Stop
        } else {
            Verdict::Continue
        }
    }
}
