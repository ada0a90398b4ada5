//! The speed-of-sound step limit: eq 49 generalised to moving, nonlinear material.
//!
//! ```text
//! dt ≤ α · h / (c_max + ‖v‖_∞),   c_max = max_p √(E_t,p / ρ_p)          (eq 49: α = 1, v = 0)
//! ```
//!
//! Eq 49 reads `E dt²/h² ≤ 1` with `ρ = 1`, i.e. `dt ≤ h/c`. **That is not stable for
//! GIMP update-stress-last**: the exact critical steps measured by [`super::full_map`] and
//! [`super::empirical`] are `0.64–0.83 h/c` depending on the particle layout, and eq 56 gives
//! `h/(√2 c) ≈ 0.707 h/c` on uniform layouts (README "Stability" table). Adding the largest
//! particle speed `‖v‖_∞` (max norm over particles) keeps the rule meaningful when particles
//! are fast compared with the wave speed (particles must not cross more than a fraction of
//! a cell per step).
//!
//! **Default `α = 0.5`.** Measured with `examples/critical_dt` (README "Stability" table,
//! 64 cells): the frozen-particle critical steps of GIMP layouts are `0.69–0.80 h/c` (the
//! smallest with a node of 1.5 % typical mass), and with moving particles (`A = 10⁻²`)
//! `0.73–0.82 h/c`; linear hats on a jittered layout drop to `0.58 h/c` with moving particles.
//! `α = 0.5` keeps a margin of at least 27 % on every GIMP layout and 14 % on the jittered
//! linear-hat one. It does **not** protect linear-hat weights near small nodal masses, where
//! the critical step collapses as `√(m_min/m_typical)` with no change in `c` (0.11 h/c frozen,
//! 0.04 h/c with moving particles at 1.5 % mass): use the [`super::Stability`] limit there.

use super::error::{check_view_speeds, StabilityError};
use crate::limit::{LimitError, Metrics, Proposal, StepLimit};
use crate::stepper::View;

/// Settings of [`SoundSpeed`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SoundSpeedConfig {
    /// The factor `α` (dimensionless, default 0.5; see the module docs for why).
    pub alpha: f64,
}

impl Default for SoundSpeedConfig {
    fn default() -> Self {
        Self { alpha: 0.5 }
    }
}

/// The speed-of-sound limit `dt ≤ α h/(c_max + ‖v‖_∞)` (eq 49 generalised).
#[derive(Clone, Debug, Default)]
pub struct SoundSpeed {
    config: SoundSpeedConfig,
}

impl SoundSpeed {
    /// The limit with factor `config.alpha`, which must be positive and finite.
    pub fn new(config: SoundSpeedConfig) -> Result<Self, StabilityError> {
        if !(config.alpha.is_finite() && config.alpha > 0.0) {
            return Err(StabilityError::InvalidConfig {
                field: "alpha",
                value: config.alpha,
                reason: "must be positive and finite",
            });
        }
        Ok(Self { config })
    }

    /// The settings.
    pub fn config(&self) -> SoundSpeedConfig {
        self.config
    }

    /// `(c_max, ‖v‖_∞)` of a state (wave speed from the tangent modulus and density).
    ///
    /// The view is validated and both maxima are taken in the same pass over the particles
    /// (this runs on every proposal); `c_max` is `√(max_p E_t,p/ρ_p)`, which equals
    /// `max_p` [`View::wave_speed`] bit for bit because `√` is monotone and correctly
    /// rounded.
    pub fn speeds(view: &View<'_>) -> Result<(f64, f64), StabilityError> {
        let (c2, v) = check_view_speeds(view)?;
        Ok((c2.sqrt(), v))
    }

    /// The eq 49 step `h/c_max` (α = 1, particles at rest): the paper's rule as printed.
    pub fn dt_eq49(view: &View<'_>) -> Result<f64, StabilityError> {
        let (c, _) = Self::speeds(view)?;
        Ok(view.grid.h / c)
    }

    /// The limit's step for a state.
    pub fn dt(&self, view: &View<'_>) -> Result<f64, StabilityError> {
        let (c, v) = Self::speeds(view)?;
        Ok(self.config.alpha * view.grid.h / (c + v))
    }
}

impl StepLimit for SoundSpeed {
    fn name(&self) -> &str {
        "sound_speed"
    }

    /// Multiplies `α` by `factor` (ignored unless `0 < factor ≤ 1`): when the controller's
    /// growth monitor sees an instability, a binding sound-speed limit must back off too.
    fn scale_safety(&mut self, factor: f64) {
        if factor > 0.0 && factor <= 1.0 {
            self.config.alpha *= factor;
        }
    }

    fn propose(&mut self, state: &View<'_>) -> Result<Proposal, LimitError> {
        let (c, v) = Self::speeds(state).map_err(|e| e.into_limit_error("sound_speed", state.t))?;
        let dt = self.config.alpha * state.grid.h / (c + v);
        let mut metrics = Metrics::new();
        metrics.insert("wave_speed_max".into(), c);
        metrics.insert("particle_speed_max".into(), v);
        metrics.insert("dt_eq49".into(), state.grid.h / c);
        tracing::debug!(dt, c, v, alpha = self.config.alpha, "sound_speed proposal");
        Ok(Proposal { dt, metrics })
    }
}
