//! The Söderlind digital filter that maps the history of scaled local error estimates
//! `dsm` (from [`super::TemporalError`], eqs 20–30) to the next step:
//!
//! ```text
//! h' = h_n · ε_n^(−k₁/(p+1)) · ε_{n−1}^(−k₂/(p+1)) · ε_{n−2}^(−k₃/(p+1))
//!          · (h_n/h_{n−1})^k₄ · (h_{n−1}/h_{n−2})^k₅ ,      ε = max(dsm, 10⁻¹⁰)
//! ```
//!
//! exactly as SUNDIALS' `SUNAdaptController_Soderlind` (G. Söderlind, *Digital filters in
//! adaptive time-stepping*, ACM TOMS 29, 2003): with less history than the filter needs it
//! falls back to the I controller (first step) and the two-term form (second step). The
//! presets carry SUNDIALS' coefficients ([`FilterPreset::coefficients`]).
//!
//! **Where the filter lives.** As in SUNDIALS the filter belongs to the controller, not to
//! the error estimate: [`super::TemporalError`] only measures `dsm` (a judgement), the
//! controller owns the step history, applies the safety factor and the growth/shrink caps,
//! and decides whether a step's `dsm` may enter the history at all. A step whose size was
//! set by a non-accuracy limit (stability, sound speed, `dt_max`) says nothing about how the
//! error responds to the step size; feeding it would wind the filter up (tiny `dsm` at a
//! capped step ⇒ ever larger proposals) and makes the step oscillate at the stability
//! boundary. Such steps *reset* the history to that latest estimate instead
//! ([`SoderlindFilter::restart`]), so the proposal is the elementary one from the latest
//! `dsm` and carries no stale ratios.

use super::config::{check, ConfigError};
use serde::{Deserialize, Serialize};

/// Floor of `ε` (SUNDIALS' `TINY`), so that `dsm = 0` gives a finite (large) proposal.
pub const DSM_FLOOR: f64 = 1e-10;

/// A filter: a SUNDIALS preset or explicit coefficients `[k1, k2, k3, k4, k5]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum FilterPreset {
    /// Elementary (deadbeat) controller: `k = [1, 0, 0, 0, 0]`.
    I,
    /// PI: `k = [0.8, −0.31, 0, 0, 0]` (SUNDIALS `SUNAdaptController_PI`).
    Pi,
    /// PID: `k = [0.58, −0.21, 0.1, 0, 0]` (SUNDIALS `SUNAdaptController_PID`, ARKODE's
    /// default).
    Pid,
    /// Gustafsson's explicit controller: `k = [0.635, −0.268, 0, 0, 0]`.
    ExpGus,
    /// Gustafsson's implicit controller: `k = [1.93, −0.95, 0, 1, 0]`.
    ImpGus,
    /// H211 (Söderlind 2003): `k = [0.25, 0.25, 0, −0.25, 0]`.
    H211,
    /// H0211: `k = [0.5, 0.5, 0, −0.5, 0]`.
    H0211,
    /// H0321 (SUNDIALS' Söderlind default): `k = [1.25, 0.5, −0.75, 0.25, 0.75]`.
    H0321,
    /// H312: `k = [0.125, 0.25, 0.125, −0.375, −0.125]`.
    H312,
    /// Explicit coefficients `[k1, k2, k3, k4, k5]`.
    Custom([f64; 5]),
}

impl FilterPreset {
    /// The five Söderlind coefficients of the preset.
    pub fn coefficients(&self) -> [f64; 5] {
        match *self {
            FilterPreset::I => [1.0, 0.0, 0.0, 0.0, 0.0],
            FilterPreset::Pi => [0.8, -0.31, 0.0, 0.0, 0.0],
            FilterPreset::Pid => [0.58, -0.21, 0.1, 0.0, 0.0],
            FilterPreset::ExpGus => [0.635, -0.268, 0.0, 0.0, 0.0],
            FilterPreset::ImpGus => [1.93, -0.95, 0.0, 1.0, 0.0],
            FilterPreset::H211 => [0.25, 0.25, 0.0, -0.25, 0.0],
            FilterPreset::H0211 => [0.5, 0.5, 0.0, -0.5, 0.0],
            FilterPreset::H0321 => [1.25, 0.5, -0.75, 0.25, 0.75],
            FilterPreset::H312 => [0.125, 0.25, 0.125, -0.375, -0.125],
            FilterPreset::Custom(k) => k,
        }
    }

    /// Checks custom coefficients are finite and `k1 > 0` (else the filter cannot react to
    /// the error at all).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let k = self.coefficients();
        for v in k {
            check("filter", v, v.is_finite(), "finite coefficients")?;
        }
        check("filter", k[0], k[0] > 0.0, "k1 > 0")
    }
}

/// The filter's memory: the last three accepted (step, ε) pairs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SoderlindFilter {
    /// Coefficients `[k1..k5]`.
    pub k: [f64; 5],
    /// Global order `p` of the integrator.
    pub order: u32,
    /// `(h, ε)` of the most recent accepted steps, newest first (at most 3).
    pub history: Vec<(f64, f64)>,
}

impl SoderlindFilter {
    /// A filter with no history.
    pub fn new(preset: FilterPreset, order: u32) -> Self {
        Self {
            k: preset.coefficients(),
            order,
            history: Vec::new(),
        }
    }

    /// Records an accepted step `h` with error `dsm` (SUNDIALS `updateh`).
    pub fn record(&mut self, h: f64, dsm: f64) {
        self.history.insert(0, (h, dsm.max(DSM_FLOOR)));
        self.history.truncate(3);
    }

    /// Forgets the history and keeps only `(h, dsm)`: used when a non-accuracy limit set
    /// the step (see the module docs).
    pub fn restart(&mut self, h: f64, dsm: f64) {
        self.history.clear();
        self.record(h, dsm);
    }

    /// Forgets everything.
    pub fn reset(&mut self) {
        self.history.clear();
    }

    /// Whether at least one estimate has been recorded.
    pub fn has_history(&self) -> bool {
        !self.history.is_empty()
    }

    /// The factor `h'/h_n` the filter proposes from its history (no safety factor, no
    /// caps); `None` without history.
    pub fn factor(&self) -> Option<f64> {
        let ord = f64::from(self.order + 1);
        let [k1, k2, k3, k4, k5] = self.k;
        let (h0, e0) = *self.history.first()?;
        let mut eta = e0.powf(-k1 / ord);
        if let Some(&(h1, e1)) = self.history.get(1) {
            eta *= e1.powf(-k2 / ord) * (h0 / h1).powf(k4);
            if let Some(&(h2, e2)) = self.history.get(2) {
                eta *= e2.powf(-k3 / ord) * (h1 / h2).powf(k5);
            }
        }
        Some(eta)
    }

    /// The step the filter proposes after the newest recorded step, `h_n · factor`
    /// (no safety factor, no caps); `None` without history.
    pub fn proposal(&self) -> Option<f64> {
        let (h0, _) = *self.history.first()?;
        self.factor().map(|f| h0 * f)
    }

    /// The elementary shrink factor for a rejected step with error `dsm`:
    /// `dsm^(−1/(p+1))` (the I controller, as SUNDIALS uses on error-test failures).
    pub fn retry_factor(&self, dsm: f64) -> f64 {
        dsm.max(DSM_FLOOR).powf(-1.0 / f64::from(self.order + 1))
    }
}
