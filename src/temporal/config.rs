//! [`TemporalErrorConfig`]: the tolerances of the temporal error limit
//! ([`crate::controller::TemporalError`], module docs of `temporal_error`) and its deferral settings.

use super::deferral::DEFAULT_MAX_DEFERRED;
use crate::config_error::{check, ConfigError};
use serde::{Deserialize, Serialize};

/// Tolerances of [`crate::controller::TemporalError`]. Units: `atol_v` is a velocity, `atol_sigma` a stress;
/// `rtol` and `atol_rel` are dimensionless.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TemporalErrorConfig {
    /// Whether [`crate::controller::Controller::with_default_limits`] installs the limit (default true).
    pub enabled: bool,
    /// Relative tolerance on each particle's value (default 0.05).
    pub rtol: f64,
    /// Tolerance relative to the field's largest magnitude `‖u‖_∞`; `None` (the default)
    /// follows `rtol` ([`Self::atol_rel`]), so that `rtol` alone dials the accuracy. A
    /// particle's weight is `atol_rel·‖u‖_∞ + rtol·|u_p|`: with a fixed `atol_rel` floor,
    /// tightening `rtol` alone changed nothing where `|u_p|` is below `‖u‖_∞` — most
    /// particles of a wave or of two bodies in contact (measured in `docs/accuracy.md`).
    pub atol_rel: Option<f64>,
    /// Absolute velocity tolerance \[velocity\] (default 0).
    pub atol_v: f64,
    /// Absolute stress tolerance \[stress\] (default 0).
    pub atol_sigma: f64,
    /// Balancing factor κ (default `None`: off). When set, each particle's weights grow by
    /// κ × the spatial local error of the same step from Section 4: `dt |Σ_i S_ip Ea_i|`
    /// for the velocity (the spatial part of eqs 20/23, `Ea_i` by eq 33) and `|leσ_p|` of
    /// eq 44 for the stress. The temporal error is then only required to stay below κ times
    /// the spatial one where that is larger than the plain tolerance (Steffen, Kirby &
    /// Berzins 2010: a temporal error far below the spatial one buys nothing).
    pub balance: Option<f64>,
    /// The **velocity lag** (default `None`: off). When set to `κ_lag`, the velocity part
    /// of `dsm` also holds, per particle, `κ_lag · dt/2 · |a_p|` — in 1D `a_p = Σ_i S_ip a_i`
    /// of the trial state (eq 21, the next kick's acceleration, gathered from the nodal
    /// field), in 2D/3D `a_p = (v_p^{n+1} − v_p^n)/dt` (eq 22, the step's) —, weighed by the same `w_v,p` as `le_v,p`:
    /// `dsm_v² = (1/N) Σ_p [(le_v,p/w_v,p)² + (κ_lag dt/2 |a_p| / w_v,p)²]`. The USL step is
    /// symplectic Euler: `v_p` lags the synchronised velocity (`v_p + dt/2 · a_p`,
    /// [`crate::synchronized_velocity`]) by `dt/2 · |a_p|`, an error of **first** order in
    /// `dt` that the second-order local errors of eqs 20, 23 and 28 do not contain, and
    /// that dominates the error of a well-resolved smooth motion (docs/accuracy.md).
    /// Being first order, it makes the step proportional to the tolerance where it binds.
    /// A velocity part that includes it is taken as impulsive by
    /// [`super::non_smooth`] only when a retry cuts it by less than `√q` (instead of `q`).
    pub lag: Option<f64>,
    /// Trials in a row whose check may be deferred while the error is far below its
    /// tolerance (default 8; [`super::deferral`]). 0 checks every trial, as the paper's
    /// controller does.
    pub max_deferred: u32,
    /// Deferral threshold θ (default 0.1): a check is deferred only while the last measured
    /// `dsm`, scaled by `(dt/dt_measured)²`, is at most θ.
    pub defer_below: f64,
}

impl Default for TemporalErrorConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            rtol: 0.05,
            atol_rel: None,
            atol_v: 0.0,
            atol_sigma: 0.0,
            balance: None,
            lag: None,
            max_deferred: DEFAULT_MAX_DEFERRED,
            defer_below: 0.1,
        }
    }
}

impl TemporalErrorConfig {
    /// The tolerance relative to `‖u‖_∞`: `atol_rel` when set, else `rtol`.
    pub fn atol_rel(&self) -> f64 {
        self.atol_rel.unwrap_or(self.rtol)
    }

    /// Checks the tolerances: all finite and non-negative, and not all zero.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (field, v) in [
            ("temporal.rtol", self.rtol),
            ("temporal.atol_rel", self.atol_rel()),
            ("temporal.atol_v", self.atol_v),
            ("temporal.atol_sigma", self.atol_sigma),
        ] {
            check(field, v, v.is_finite() && v >= 0.0, "finite and >= 0")?;
        }
        for (field, k) in [
            ("temporal.balance", self.balance),
            ("temporal.lag", self.lag),
        ] {
            if let Some(k) = k {
                check(field, k, k.is_finite() && k > 0.0, "finite and > 0")?;
            }
        }
        check(
            "temporal.defer_below",
            self.defer_below,
            (0.0..1.0).contains(&self.defer_below),
            "in [0, 1)",
        )?;
        check(
            "temporal.rtol",
            self.rtol,
            self.rtol + self.atol_rel() > 0.0,
            "> 0 when atol_rel = 0 (atol_rel follows rtol unless set)",
        )
    }
}
