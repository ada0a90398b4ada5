//! What the 2D/3D stability limit keeps between proposals, [`TrackedNd`], which a controller
//! checkpoint saves ([`StepLimit::save_state`](crate::limit::StepLimit::save_state), beside
//! the safety as lowered after growth, [`crate::stability::limit`]): the tracked `λmax` and
//! its Ritz vector (the next refresh's warm start), the layout guard's references at the
//! last refresh, the calibrated bound's state, and the counters. Restored, the limit
//! proposes bit for bit what it would have proposed had the run gone on; without it a
//! restarted run would start Lanczos cold and take other steps.
//!
//! JSON keeps every `f64` and `f32` bit-exact (serde_json's `float_roundtrip`). The
//! positions at the refresh are stored flat (`D` single-precision numbers a particle).

use super::on_summary::OnSummary;
use crate::limits_nd::bound_tracking::BoundTracking;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The tracked state of [`super::GuardedEq56`] (module docs): held by the rule and saved as
/// it is, so its fields are listed once.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TrackedNd<const D: usize> {
    /// The tracked bound on `λmax(M⁻¹K)`, once computed.
    pub(super) lambda: Option<f64>,
    /// The Ritz vector of the last refresh (the next one's warm start).
    pub(super) ritz: Vec<f64>,
    /// Positions at the refresh relative to the grid's origin, in single precision
    /// ([`super::guard`]); stored flat.
    #[serde(serialize_with = "flat", deserialize_with = "unflat")]
    pub(super) x_ref: Vec<[f32; D]>,
    /// `(V(dλ_t + 2μ_t), Vμ_t)` per particle at the refresh.
    pub(super) moduli_ref: Vec<(f64, f64)>,
    /// Smallest active nodal mass at the refresh.
    pub(super) mass_ref: f64,
    /// `max diag(A)` at the refresh ([`crate::limits_nd::stiffness::diagonal_argmax`]).
    pub(super) diag_ref: f64,
    /// Growth of `max diag(A)` accepted without a refresh since the last one (≥ 1).
    pub(super) diag_growth: f64,
    /// `1 + p` of the scheme's transfer on the tracked top mode (1 for FLIP; `λmax/λ*`
    /// with [`crate::limits_nd::StabilityNdConfig::full_map`]).
    pub(super) gain: f64,
    /// Proposals since the last refresh.
    pub(super) age: u32,
    /// Lanczos refreshes so far.
    pub(super) refreshes: u64,
    /// Products with `K` so far.
    pub(super) applications: u64,
    /// When proposals use the element bound instead ([`crate::limits_nd::bound_tracking`]).
    pub(super) tracking: BoundTracking,
    /// Lanczos products of the last refresh when it was warm-started (a cold start's are
    /// not what tracking costs).
    pub(super) last_products: Option<u64>,
    /// What proposals on summary-only views carry from the last check
    /// ([`super::on_summary`]).
    pub(super) on_summary: OnSummary,
}

impl<const D: usize> Default for TrackedNd<D> {
    /// Nothing tracked yet.
    fn default() -> Self {
        Self {
            lambda: None,
            ritz: Vec::new(),
            x_ref: Vec::new(),
            moduli_ref: Vec::new(),
            mass_ref: 0.0,
            diag_ref: 0.0,
            diag_growth: 1.0,
            gain: 1.0,
            age: 0,
            refreshes: 0,
            applications: 0,
            tracking: BoundTracking::default(),
            last_products: None,
            on_summary: OnSummary::default(),
        }
    }
}

/// The positions written as `D` numbers a particle, one flat list.
fn flat<S: Serializer, const D: usize>(x: &[[f32; D]], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(x.iter().flatten())
}

/// The positions read from a flat list: refused unless it holds `D` numbers a particle.
fn unflat<'de, De: Deserializer<'de>, const D: usize>(d: De) -> Result<Vec<[f32; D]>, De::Error> {
    let flat = Vec::<f32>::deserialize(d)?;
    if !flat.len().is_multiple_of(D) {
        return Err(serde::de::Error::custom("x_ref: not D numbers a particle"));
    }
    Ok(flat
        .chunks_exact(D)
        .map(|c| std::array::from_fn(|a| c[a]))
        .collect())
}

impl<const D: usize> TrackedNd<D> {
    /// Whether a restored state belongs together: one moduli pair for each particle of
    /// `x_ref`, a finite positive `λmax` when one is tracked, a finite positive gain, and
    /// growth factors (the light nodes' diagonal, the guard's) at least 1. Else what is
    /// wrong.
    pub(super) fn check(&self) -> Result<(), &'static str> {
        if self.moduli_ref.len() != self.x_ref.len() {
            return Err("moduli_ref: not one pair for each particle of x_ref");
        }
        if self.lambda.is_some_and(|l| !(l.is_finite() && l > 0.0)) {
            return Err("lambda: not a finite positive number");
        }
        let at_least_one = |x: f64| x.is_finite() && x >= 1.0;
        let in_range = self.gain.is_finite()
            && self.gain > 0.0
            && at_least_one(self.diag_growth)
            && at_least_one(self.on_summary.growth());
        if !in_range {
            return Err("gain, diag_growth or the guard's factor: out of range");
        }
        Ok(())
    }

    /// Bytes of the per-particle and per-node arrays held (their capacities).
    pub(super) fn memory_bytes(&self) -> usize {
        self.x_ref.capacity() * std::mem::size_of::<[f32; D]>()
            + self.moduli_ref.capacity() * std::mem::size_of::<(f64, f64)>()
            + self.ritz.capacity() * std::mem::size_of::<f64>()
    }
}
