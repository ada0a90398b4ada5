//! The settings of the 1D stability limit ([`super::BandedEq56`], [`crate::stability::Stability`]):
//! [`StabilityConfig`] and how `λmax` is tracked, [`Tracking`].

use super::Refresh;
use crate::stability::bound58::Bound58Reading;
use crate::stability::certified::CertifiedConfig;
use crate::stability::error::StabilityError;
use crate::stability::lambda_max::LanczosConfig;

/// Settings of the 1D [`Stability`](crate::stability::Stability) limit.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StabilityConfig {
    /// Fraction of `dt_eq56` proposed, in `(0, 1]` (default 0.95, the same as the
    /// controller's standard limits and the 2D/3D limit, so that a limit built by hand or a
    /// config's `"stability"` object that leaves the safety out keeps it). Eq 56 is already
    /// conservative for frozen particles (it ignores the velocity half of the state: up to
    /// ~8 % below the exact frozen critical step); the margin covers moving particles.
    pub safety: f64,
    /// Relative tolerance of the eq 58 test and of the proposal check (default `1e-6`).
    pub tol: f64,
    /// Which reading of eq 58 judges trials (default [`Bound58Reading::Consistent`]).
    pub reading: Bound58Reading,
    /// The Lanczos settings of the λmax iteration.
    pub lanczos: LanczosConfig,
    /// How λmax is tracked (default [`Tracking::Certified`]; see [`super`]).
    pub tracking: Tracking,
    /// Eq 58 is evaluated on the trial of every `bound58_every`-th proposal (default 50;
    /// 1 checks every trial, 0 never). See "Cost" in [`super`] for why it is not
    /// checked at every step by default.
    pub bound58_every: u32,
}

/// How the 1D [`Stability`](crate::stability::Stability) limit follows `λmax` from step to step ([`super`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Tracking {
    /// A Rayleigh quotient and a power step per proposal (one pass over the nodes), certified
    /// by an `LDLᵀ` inertia test every 20 proposals or when it looks stale, with Lanczos only
    /// when a certificate fails ([`crate::stability::CertifiedTracker`]). The default.
    Certified(CertifiedConfig),
    /// The Lanczos Ritz value (a lower bound on `λmax`), recomputed as [`Refresh`] says.
    Lanczos(Refresh),
}

impl Default for Tracking {
    fn default() -> Self {
        Self::Certified(CertifiedConfig::default())
    }
}

impl Default for StabilityConfig {
    fn default() -> Self {
        Self {
            safety: 0.95,
            tol: 1e-6,
            reading: Bound58Reading::Consistent,
            lanczos: LanczosConfig::default(),
            tracking: Tracking::default(),
            bound58_every: 50,
        }
    }
}

/// Checks a safety factor: in `(0, 1]`.
pub(crate) fn check_safety(safety: f64) -> Result<(), StabilityError> {
    if safety > 0.0 && safety <= 1.0 {
        Ok(())
    } else {
        Err(StabilityError::InvalidConfig {
            field: "safety",
            value: safety,
            reason: "must be in (0, 1]",
        })
    }
}
