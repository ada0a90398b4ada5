//! Which policy the stability limit proposes from between Lanczos refreshes: the
//! calibrated bound, bound mode or the cached value ([`super::super::bound_tracking`]).

use super::GuardedEq56;
use crate::limits_nd::bound_tracking::view_supplies_bound;
use crate::limits_nd::transfer::TransferNd;
use crate::nd::ViewNd;

impl<const D: usize> GuardedEq56<D> {
    /// Whether the calibrated bound is on (`bound_drift ≥ 0`; under APIC only after a
    /// refresh and while no refresh has met a particle without shear stiffness,
    /// [`crate::limits_nd::bound_tracking`] "Under APIC").
    pub(super) fn calibrating(&self) -> bool {
        self.config.bound_drift >= 0.0
            && match self.config.transfer {
                TransferNd::Flip => true,
                TransferNd::Apic { .. } => {
                    self.tracked.refreshes > 0 && !self.tracked.tracking.fluid_seen
                }
            }
    }

    /// The largest `B/λ` stepped on
    /// ([`crate::limits_nd::bound_tracking::BoundTracking::threshold`]).
    ///
    /// The cost model is applied to FLIP only: under APIC the step carries the transfer's
    /// gain measured on the last refresh's top mode, which says nothing of the modes a
    /// loose bound covers (measured: on the mpm88 fluid, stepping on bounds up to 1.9× the
    /// Lanczos value with that gain was stopped by 22 growth detections; within 1.25× it
    /// runs to the end without a rejection).
    pub(super) fn bound_threshold(&self, view: &ViewNd<'_, D>) -> f64 {
        let supplied = view_supplies_bound(view) && self.config.transfer == TransferNd::Flip;
        self.tracked
            .tracking
            .threshold(self.config.bound_slack, self.config.product_cost, supplied)
    }

    /// In bound mode ([`crate::limits_nd::bound_tracking`]), the current state's element bound, while
    /// it is finite and the last Lanczos run is younger than `bound_age`; `None` ends
    /// bound mode (a refresh follows).
    pub(super) fn bound_proposal(&mut self, view: &ViewNd<'_, D>) -> Option<f64> {
        if !self.tracked.tracking.active || self.tracked.lambda.is_none() {
            return None;
        }
        if self.tracked.age >= self.config.bound_age {
            self.tracked.tracking.active = false;
            return None;
        }
        let bound = self
            .tracked
            .tracking
            .bound_of(view, Self::agreement(&*self.reduce, view));
        if bound.is_finite() && bound > 0.0 {
            Some(bound)
        } else {
            self.tracked.tracking.active = false;
            None
        }
    }

    /// Records whether a refreshed view holds a particle without shear stiffness
    /// (`μ_t ≤ 0`, or not a number), on any process: under APIC that ends the calibrated
    /// bound and the transfer's gain for the run ([`super::super::bound_tracking`], "Under
    /// APIC"). One pass over
    /// `μ_t` at a refresh, on APIC runs only, until one is met.
    pub(super) fn note_fluid(&mut self, view: &ViewNd<'_, D>) {
        if self.config.transfer == TransferNd::Flip || self.tracked.tracking.fluid_seen {
            return;
        }
        // `μ_t ≤ 0` or not a number.
        let mine = view.lame_mu.iter().any(|&mu| mu.is_nan() || mu <= 0.0);
        let (_, any) = Self::agreement(&*self.reduce, view).min_and_any(0.0, mine);
        if any {
            // The raw-bound policy from here on, without the calibration's leftovers: its
            // reference and the scale of the last re-anchoring (generic path).
            self.tracked.tracking.fluid_seen = true;
            self.tracked.tracking.reference = None;
            self.tracked.tracking.scale = 0.0;
        }
    }

    /// After a refresh to `lambda`: whether the element bound is worth a look (it is
    /// `bound` where the caller evaluated it just before), and if so the bound policy's
    /// reference and the calibration taken from it ([`crate::limits_nd::bound_tracking`]).
    pub(super) fn bound_after_refresh(
        &mut self,
        view: &ViewNd<'_, D>,
        lambda: f64,
        bound: Option<f64>,
    ) {
        let threshold = self.bound_threshold(view);
        let look = bound.is_some()
            || self.calibrating()
            || self.config.bound_slack >= 0.0
                && self
                    .tracked
                    .tracking
                    .worth_a_look(threshold, view_supplies_bound(view));
        if look {
            let bound = match bound {
                Some(b) => b,
                None => self
                    .tracked
                    .tracking
                    .bound_of(view, Self::agreement(&*self.reduce, view)),
            };
            self.tracked
                .tracking
                .after_refresh(lambda, bound, threshold);
            if self.calibrating() {
                self.tracked.tracking.calibrate(lambda, bound);
            }
        } else {
            self.tracked.tracking.skipped_refresh();
        }
    }
}
