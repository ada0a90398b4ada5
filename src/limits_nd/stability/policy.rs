//! Which policy the stability limit proposes from between Lanczos refreshes: the
//! calibrated bound, bound mode or the cached value ([`super::super::bound_tracking`]).

use super::StabilityNd;
use crate::limits_nd::bound_tracking::view_supplies_bound;
use crate::limits_nd::transfer::TransferNd;
use crate::nd::ViewNd;

impl<const D: usize> StabilityNd<D> {
    /// Whether the calibrated bound is on (`bound_drift ≥ 0`; under APIC only after a
    /// refresh and while no refresh has met a particle without shear stiffness,
    /// [`crate::limits_nd::bound_tracking`] "Under APIC").
    pub(super) fn calibrating(&self) -> bool {
        self.config.bound_drift >= 0.0
            && match self.config.transfer {
                TransferNd::Flip => true,
                TransferNd::Apic { .. } => self.refreshes > 0 && !self.tracking.fluid_seen,
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
        self.tracking
            .threshold(self.config.bound_slack, self.config.product_cost, supplied)
    }

    /// In bound mode ([`crate::limits_nd::bound_tracking`]), the current state's element bound, while
    /// it is finite and the last Lanczos run is younger than `bound_age`; `None` ends
    /// bound mode (a refresh follows).
    pub(super) fn bound_proposal(&mut self, view: &ViewNd<'_, D>) -> Option<f64> {
        if !self.tracking.active || self.lambda.is_none() {
            return None;
        }
        if self.age >= self.config.bound_age {
            self.tracking.active = false;
            return None;
        }
        let bound = self
            .tracking
            .bound_of(view, Self::agreement(&*self.reduce, view));
        if bound.is_finite() && bound > 0.0 {
            Some(bound)
        } else {
            self.tracking.active = false;
            None
        }
    }

    /// Records whether a refreshed view holds a particle without shear stiffness
    /// (`μ_t ≤ 0`, or not a number), on any process: under APIC that ends the calibrated
    /// bound and the transfer's gain for the run ([`super::super::bound_tracking`], "Under
    /// APIC"). One pass over
    /// `μ_t` at a refresh, on APIC runs only, until one is met.
    pub(super) fn note_fluid(&mut self, view: &ViewNd<'_, D>) {
        if self.config.transfer == TransferNd::Flip || self.tracking.fluid_seen {
            return;
        }
        // `μ_t ≤ 0` or not a number.
        let mine = view.lame_mu.iter().any(|&mu| mu.is_nan() || mu <= 0.0);
        let (_, any) = Self::agreement(&*self.reduce, view).min_and_any(0.0, mine);
        if any {
            // The raw-bound policy from here on, without the calibration's leftovers: its
            // reference and the scale of the last re-anchoring (generic path).
            self.tracking.fluid_seen = true;
            self.tracking.reference = None;
            self.tracking.scale = 0.0;
        }
    }
}
