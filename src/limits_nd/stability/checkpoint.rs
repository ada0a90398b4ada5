//! What [`StabilityNd`] keeps between proposals, for a controller checkpoint
//! ([`StepLimit::save_state`](crate::limit::StepLimit::save_state)): the tracked `λmax`
//! and its Ritz vector (the next refresh's warm start), the layout guard's references at the
//! last refresh, the calibrated bound's state, the safety as lowered after growth, and the
//! counters. Restored, the limit proposes bit for bit what it would have proposed had the
//! run gone on; without it a restarted run would start Lanczos cold and take other steps.
//!
//! JSON keeps every `f64` and `f32` bit-exact (serde_json's `float_roundtrip`). The
//! positions at the refresh are stored flat (`D` single-precision numbers a particle).

use super::on_summary::OnSummary;
use super::StabilityNd;
use crate::limit::LimitError;
use crate::limits_nd::bound_tracking::BoundTracking;
use serde::{Deserialize, Serialize};

/// The saved state (module docs).
#[derive(Serialize, Deserialize)]
pub(super) struct SavedNd {
    safety: f64,
    lambda: Option<f64>,
    ritz: Vec<f64>,
    x_ref: Vec<f32>,
    moduli_ref: Vec<(f64, f64)>,
    mass_ref: f64,
    diag_ref: f64,
    diag_growth: f64,
    gain: f64,
    age: u32,
    refreshes: u64,
    applications: u64,
    tracking: BoundTracking,
    last_products: Option<u64>,
    on_summary: OnSummary,
}

impl<const D: usize> StabilityNd<D> {
    /// The limit's state for a checkpoint (module docs).
    pub(super) fn saved(&self) -> Option<serde_json::Value> {
        serde_json::to_value(SavedNd {
            safety: self.safety,
            lambda: self.lambda,
            ritz: self.ritz.clone(),
            x_ref: self.x_ref.iter().flatten().copied().collect(),
            moduli_ref: self.moduli_ref.clone(),
            mass_ref: self.mass_ref,
            diag_ref: self.diag_ref,
            diag_growth: self.diag_growth,
            gain: self.gain,
            age: self.age,
            refreshes: self.refreshes,
            applications: self.applications,
            tracking: self.tracking.clone(),
            last_products: self.last_products,
            on_summary: self.on_summary,
        })
        .ok()
    }

    /// Restores [`Self::saved`]'s state; a state that does not read, or whose positions
    /// are not `D` numbers a particle with one moduli pair each, whose safety is not in
    /// `(0, the configured one]`, whose `λmax` is not finite and positive, or whose growth
    /// factors are below 1, is a [`LimitError::Restore`] naming the limit (the limit is
    /// left as it was).
    pub(super) fn restore(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        let error = |source: serde_json::Error| LimitError::Restore {
            limit: super::STABILITY.to_string(),
            source: source.into(),
        };
        let saved: SavedNd = serde_json::from_value(state.clone()).map_err(error)?;
        let invalid = |what: &str| error(serde::de::Error::custom(what));
        if !saved.x_ref.len().is_multiple_of(D) {
            return Err(invalid("x_ref: not D numbers a particle"));
        }
        if saved.moduli_ref.len() != saved.x_ref.len() / D {
            return Err(invalid(
                "moduli_ref: not one pair for each particle of x_ref",
            ));
        }
        if !(saved.safety > 0.0 && saved.safety <= self.config.safety) {
            return Err(invalid("safety: not in (0, the configured safety]"));
        }
        if saved.lambda.is_some_and(|l| !(l.is_finite() && l > 0.0)) {
            return Err(invalid("lambda: not a finite positive number"));
        }
        let at_least_one = |x: f64| x.is_finite() && x >= 1.0;
        let in_range = saved.gain.is_finite()
            && saved.gain > 0.0
            && at_least_one(saved.diag_growth)
            && at_least_one(saved.on_summary.growth());
        if !in_range {
            return Err(invalid(
                "gain, diag_growth or the guard's factor: out of range",
            ));
        }
        self.safety = saved.safety;
        self.lambda = saved.lambda;
        self.ritz = saved.ritz;
        self.x_ref = saved
            .x_ref
            .chunks_exact(D)
            .map(|c| std::array::from_fn(|a| c[a]))
            .collect();
        self.moduli_ref = saved.moduli_ref;
        self.mass_ref = saved.mass_ref;
        self.diag_ref = saved.diag_ref;
        self.diag_growth = saved.diag_growth;
        self.gain = saved.gain;
        self.age = saved.age;
        self.refreshes = saved.refreshes;
        self.applications = saved.applications;
        self.tracking = saved.tracking;
        self.last_products = saved.last_products;
        self.on_summary = saved.on_summary;
        Ok(())
    }
}
