//! The settings of the growth monitor ([`super::Growth`]), shared by every dimension.

use crate::config_error::{check, ConfigError};
use serde::{Deserialize, Serialize};

/// What the monitor watches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum GrowthIndicator {
    /// Checkerboard share of the nodal accelerations.
    Checkerboard,
    /// Total (kinetic + strain) energy.
    Energy,
}

/// Settings of the growth monitor ([`super::Growth`]; in 2D/3D
/// [`crate::controller::Controller::standard`] takes `window`, `windows` and `energy_tol`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GrowthConfig {
    /// Whether [`crate::controller::Controller::with_default_limits`] installs the monitor
    /// (default true).
    pub enabled: bool,
    /// The indicator (default checkerboard).
    pub indicator: GrowthIndicator,
    /// Accepted steps per window (default 25).
    pub window: u32,
    /// Number of consecutive window maxima compared (default 4, at least 2).
    pub windows: u32,
    /// Required ratio last/first of those maxima (default 1.5; use a value near 1, e.g.
    /// 1.05, for the energy indicator).
    pub factor: f64,
    /// Indicator values below this are noise and never trigger (default 1e-10; a share for
    /// the checkerboard, an energy for the energy indicator).
    pub floor: f64,
    /// Factor applied to the stability safety on detection (default 0.9, in (0, 1)).
    pub safety_factor: f64,
    /// Lowest factor the detections may lower the safety to, in `[0, 1)` (default 0.1): a
    /// detection that would go below it ends the run with
    /// [`crate::controller::ControllerError::GrowthPersists`] instead of letting it crawl on ever
    /// smaller steps. At the default `safety_factor` the 21st detection lowers the safety
    /// to 0.9²¹ ≈ 0.109 and the 22nd ends the run. Stale or frozen-particle `λmax` estimates
    /// are off by tens of per cent (a safety of 0.5 covers them); a run still growing at a
    /// tenth of its proposed steps is not one the limits control. `0` never stops.
    pub min_safety_scale: f64,
    /// With the checkerboard indicator, a detection also needs the total energy (the
    /// [`GrowthIndicator::Energy`] value) to confirm it: its maximum over the last of the
    /// compared windows must exceed that over the first by this relative amount (default
    /// 0.01; 0 switches the confirmation off). See the [module docs](super).
    pub energy_confirm: f64,
    /// 2D/3D only ([`super::GrowthNd`], an energy monitor): a rise of the
    /// mechanical energy over `windows × window` accepted steps by more than this fraction
    /// of the kinetic plus elastic energy at their start is growth (default 0.1).
    pub energy_tol: f64,
}

impl Default for GrowthConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            indicator: GrowthIndicator::Checkerboard,
            window: 25,
            windows: 4,
            factor: 1.5,
            floor: 1e-10,
            safety_factor: 0.9,
            min_safety_scale: 0.1,
            energy_confirm: 0.01,
            energy_tol: 0.1,
        }
    }
}

impl GrowthConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check(
            "growth.window",
            f64::from(self.window),
            self.window >= 1,
            ">= 1",
        )?;
        check(
            "growth.windows",
            f64::from(self.windows),
            self.windows >= 2,
            ">= 2",
        )?;
        check(
            "growth.factor",
            self.factor,
            self.factor.is_finite() && self.factor > 1.0,
            "finite and > 1",
        )?;
        check(
            "growth.floor",
            self.floor,
            self.floor.is_finite() && self.floor >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "growth.energy_confirm",
            self.energy_confirm,
            self.energy_confirm.is_finite() && self.energy_confirm >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "growth.energy_tol",
            self.energy_tol,
            self.energy_tol.is_finite() && self.energy_tol > 0.0,
            "finite and > 0",
        )?;
        check(
            "growth.min_safety_scale",
            self.min_safety_scale,
            (0.0..1.0).contains(&self.min_safety_scale),
            "in [0, 1)",
        )?;
        check(
            "growth.safety_factor",
            self.safety_factor,
            self.safety_factor > 0.0 && self.safety_factor < 1.0,
            "in (0, 1)",
        )
    }
}
