//! The bracket search of the anchors of [`super::CertifiedTracker`].

/// A zero operator (no stiffness) has λmax = 0: any positive shift certifies it.
pub(super) fn shift(lo: f64, factor: f64) -> f64 {
    if lo > 0.0 {
        lo * factor
    } else {
        f64::MIN_POSITIVE
    }
}

/// The search for a certified bracket `lo ≤ λmax < hi` that both anchor paths share: `test`
/// is an inertia test on the operator at hand (`true`: every eigenvalue is below the
/// shift). A failed test raises `lo` (up to rounding,
/// module docs of [`crate::stability::certificate`]); `hi` only ever comes from a test that passed.
pub(super) struct Bracket<T: Fn(f64) -> bool> {
    test: T,
    margin: f64,
    /// The lower end: a Rayleigh quotient or a failed shift.
    pub(super) lo: f64,
    /// Tests run so far.
    pub(super) factorisations: usize,
}

impl<T: Fn(f64) -> bool> Bracket<T> {
    pub(super) fn new(test: T, margin: f64, lo: f64) -> Self {
        Self {
            test,
            margin,
            lo,
            factorisations: 0,
        }
    }

    /// Tests `mu` (counted): `Some(mu)` when it certifies `λmax < mu`, else `None` with `lo`
    /// raised to `mu` (a failed shift is a lower bound, up to rounding).
    pub(super) fn try_at(&mut self, mu: f64) -> Option<f64> {
        self.factorisations += 1;
        if (self.test)(mu) {
            Some(mu)
        } else {
            self.lo = self.lo.max(mu);
            None
        }
    }

    /// Tries `base (1 + 2^k margin)` for `k` in `ks` (`k = 0`: `base` itself) until one
    /// certifies, raising `lo` to each that fails: the first certified shift, or `None`.
    pub(super) fn grow(&mut self, base: f64, ks: std::ops::RangeInclusive<u32>) -> Option<f64> {
        ks.into_iter().find_map(|k| {
            let factor = if k == 0 {
                1.0
            } else {
                1.0 + self.margin * f64::from(1u32 << k)
            };
            self.try_at(shift(base, factor))
        })
    }

    /// Bisects `[lo, hi]` until `hi ≤ (1 + margin) lo` (at most 64 tests in all), the first
    /// test at `start` when given: the narrowed `hi`.
    pub(super) fn bisect(&mut self, mut hi: f64, start: Option<f64>) -> f64 {
        let mut mu = start.unwrap_or(0.5 * (self.lo + hi));
        while hi > (1.0 + self.margin) * self.lo && self.lo > 0.0 && self.factorisations < 64 {
            if let Some(certified) = self.try_at(mu) {
                hi = certified;
            }
            mu = 0.5 * (self.lo + hi);
        }
        hi
    }
}

/// Shifts tried above a served value that failed its certificate, `r ρ (1 + 2^k margin)` for
/// `k = 1 …` this, before the Lanczos fall-back (module docs of [`super`]).
pub(super) const GROWTH_STEPS: u32 = 4;
