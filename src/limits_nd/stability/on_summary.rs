//! Proposals on a summary-only view: the stability limit of a stepper that hands over its
//! arrays on demand ([`crate::Stepper::provide_arrays_on_demand`]).
//!
//! Between Lanczos refreshes the calibrated bound ([`crate::limits_nd::bound_tracking`])
//! proposes `λ ≈ λ_ref · max(r, B/B_ref)` from the stepper's element bound `B`, where `r`
//! is the layout guard's factor: the growth of the particles' P-wave moduli and of the
//! light nodes' diagonal since the refresh. The guard reads every particle's moduli and
//! the nodal masses, so on a stepper that hands over only its summary it runs **on a
//! cadence**, as SUNDIALS' LSRKStep re-estimates its spectral radius every 25 steps: on
//! every state whose arrays are loaded anyway (a temporal-error check, the door check)
//! and at least every [`SUMMARY_CHECK_EVERY`]th proposal (the limit then asks for the
//! arrays). In between, a proposal takes the last check's factor `r` with the current
//! `B/B_ref`:
//!
//! ```text
//! λ = λ_ref · max(r_last, B/B_ref)
//! ```
//!
//! What this gives up against the guard at every step: a particle whose modulus grows by
//! more than `bound_drift` (50 %) between two checks without moving the bound is seen up
//! to `SUMMARY_CHECK_EVERY − 1` steps late (the bound `B` itself, a maximum over the
//! particles, still moves the proposal at once). Bound mode (stepping on `B` itself,
//! FLIP) needs no arrays at all. Everything else — a refresh, a bound that drifted past
//! `bound_drift`, `bound_age` or `max_age` reached, no bound in the summary — needs the
//! arrays, and the limit says so ([`crate::StepLimit::reads_arrays`]).

use super::GuardedEq56;
use crate::limit::LimitError;
use crate::limits_nd::bound_tracking::view_supplies_bound;
use crate::nd::ViewNd;

/// Proposals at most between two checks of the layout guard on a stepper that hands over
/// its arrays on demand (module docs).
pub const SUMMARY_CHECK_EVERY: u32 = 8;

/// What the proposals on summary-only views carry from the last full check.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub(crate) struct OnSummary {
    /// The guard's factor `r ≥ 1` at the last check (moduli and diagonal growth).
    growth: f64,
    /// Proposals on summary-only views since that check.
    unchecked: u32,
}

impl Default for OnSummary {
    fn default() -> Self {
        Self {
            growth: 1.0,
            unchecked: 0,
        }
    }
}

impl OnSummary {
    /// The guard's factor at the last check.
    pub(crate) fn growth(&self) -> f64 {
        self.growth
    }

    /// A full check found the factor `growth`.
    pub(crate) fn checked(&mut self, growth: f64) {
        self.growth = growth;
        self.unchecked = 0;
    }
}

impl<const D: usize> GuardedEq56<D> {
    /// The element bound of a summary-only view, when it is a positive number.
    fn summary_bound(view: &ViewNd<'_, D>) -> Option<f64> {
        view.summary
            .and_then(|s| s.element_bound)
            .filter(|b| b.is_finite() && *b > 0.0)
    }

    /// Whether the next proposal on `view` (summary-only) can be made without the arrays:
    /// bound mode with a usable bound, or the calibrated bound within its drift, its ages
    /// and the guard's cadence (module docs).
    pub(super) fn serves_on_summary(&self, view: &ViewNd<'_, D>) -> bool {
        let (Some(bound), Some(_)) = (Self::summary_bound(view), self.tracked.lambda) else {
            return false;
        };
        if self.tracked.age >= self.config.bound_age {
            return false;
        }
        if self.tracked.tracking.active {
            return true;
        }
        view_supplies_bound(view)
            && self.calibrating()
            && self.tracked.age < self.config.max_age
            && self.tracked.on_summary.unchecked < SUMMARY_CHECK_EVERY
            && self
                .tracked
                .tracking
                .calibrated_scale(bound, self.config.bound_drift)
                .is_some()
    }

    /// The calibrated proposal's `λ` on a summary-only view (module docs); an error where
    /// [`Self::serves_on_summary`] does not hold (the controller then should have loaded
    /// the arrays).
    pub(super) fn summary_lambda(&mut self, view: &ViewNd<'_, D>) -> Result<f64, LimitError> {
        let cached = self.tracked.lambda.filter(|_| self.serves_on_summary(view));
        let scale = Self::summary_bound(view).and_then(|b| {
            self.tracked
                .tracking
                .calibrated_scale(b, self.config.bound_drift)
        });
        let (Some(cached), Some(scale)) = (cached, scale) else {
            return Err(LimitError::Other {
                limit: super::STABILITY.to_string(),
                message: "a refresh needs the state's arrays, but the view holds only its \
                          summary"
                    .to_string(),
            });
        };
        self.tracked.on_summary.unchecked += 1;
        self.tracked.tracking.calibrated_proposals += 1;
        Ok(cached * self.tracked.on_summary.growth.max(scale))
    }
}
