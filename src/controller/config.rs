//! Controller configuration: the step-size rules, the filter, the temporal error tolerances
//! and the growth monitor, with validation.
//!
//! The numbers follow SUNDIALS' adaptive-step defaults where the controller plays the same
//! role (file `arkode_impl.h` of ARKODE and `cvode.c` of CVODE):
//!
//! | field | default | SUNDIALS |
//! |---|---|---|
//! | [`ControllerConfig::safety`] | 0.9 | ARKODE `SAFETY` = 0.9 |
//! | [`ControllerConfig::max_growth`] | 10 | CVODE `ETAMX3` = 10 (ARKODE's `GROWTH` is 20) |
//! | [`ControllerConfig::min_shrink`] | 0.1 | ARKODE/CVODE `ETAMIN` = 0.1 |
//! | [`ControllerConfig::hold_growth`] | 1.05 | ARKODE's fixed-step bounds `[1, 1.5]` (`ARKodeSetFixedStepBounds`); ours is narrower, measured |
//! | [`ControllerConfig::max_shrink_repeated`] | 0.3 | ARKODE `ETAMXF` = 0.3, applied from `SMALL_NEF` = 2 failures on |
//! | [`ControllerConfig::max_consecutive_rejections`] | 7 | CVODE/ARKODE `MXNEF` = 7 |
//!
//! The whole struct is the `controller` field of a scenario file (JSON).

use super::filter::FilterPreset;
use crate::growth::GrowthConfig;
use crate::limits_nd::StabilityNdConfig;
use crate::sound_speed::SoundSpeedConfig;
use crate::stability::{StabilityConfig, StabilityError};
use crate::temporal::TemporalErrorConfig;
use serde::{Deserialize, Serialize};

pub(crate) use crate::config_error::check;
pub use crate::config_error::ConfigError;

/// Everything the [`super::Controller`] can be told. `Default` gives the documented
/// defaults; [`ControllerConfig::validate`] checks every field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControllerConfig {
    /// First step to attempt \[time\]. `None` (default): the smallest of the limits'
    /// proposals on the initial state; if no limit has an opinion the controller fails with
    /// [`super::ControllerError::NoInitialStep`].
    pub dt_initial: Option<f64>,
    /// Smallest step the controller may take \[time\]; default 0 (no floor besides
    /// positivity). A step that must go below it ends the run with
    /// [`super::ControllerError::StepTooSmall`].
    pub dt_min: f64,
    /// Largest step \[time\]; `None` (default) for no cap.
    pub dt_max: Option<f64>,
    /// Safety factor applied to the filter's proposal and to the error-based shrink after a
    /// rejection (dimensionless, default 0.9 as ARKODE).
    pub safety: f64,
    /// Largest ratio between consecutive accepted steps (default 10, CVODE's `ETAMX3`).
    pub max_growth: f64,
    /// Hold band (dimensionless, default 1.05; 1 turns it off): when a limit's proposal
    /// binds (not the filter, `dt_max` or `t_end`) and would let the step grow by a factor
    /// in `(1, hold_growth]` over the previous accepted step, the previous step is kept
    /// instead. This is SUNDIALS' "fixed-step bounds" (ARKODE leaves
    /// `h` unchanged for `η ∈ [1, 1.5]`), narrowed because here the binding limit is
    /// usually the stability limit, whose proposal follows λmax up *and down* as particles
    /// move: on the standing wave λmax oscillates by about ±1.5 % with the wave, and a step
    /// that follows it varies in phase with the motion. The USL step is symplectic Euler,
    /// whose error and energy behaviour degrade under a step that varies with the solution
    /// (`∫ a d(dt)` terms, [`crate::synchronized_velocity`]); holding the step turns the
    /// sequence into a staircase that only descends with the stability limit and climbs
    /// when the head-room exceeds the band. The filter's proposals are not held: a
    /// Söderlind filter already makes the sequence smooth, and holding it turns a smooth
    /// climb into a saw-tooth (measured on the golden-log scenario). Measured on the
    /// comparison suite (README "Performance"): the error excess over α = 0.4 on uniform
    /// layouts fell from 7–14 % to under 2 %, at 1.70× instead of 1.73× fewer steps.
    /// Holding can only lower `dt`, never above any bound. It is not applied when a
    /// named bound (filter, `dt_max`, `t_end`, …) ties with the binding proposal, nor to a
    /// previous step that was shortened to land on an end time (that step may be below
    /// `dt_min`, and keeping it would be arbitrary).
    pub hold_growth: f64,
    /// Smallest factor by which a rejected step is shrunk for its retry (default 0.1,
    /// `ETAMIN`). Limits' own proposals may still bind below it: dt never exceeds any limit.
    pub min_shrink: f64,
    /// Largest factor on a retry after the first rejection of a step (default 0.9): after
    /// a rejection dt strictly shrinks.
    pub max_shrink_first: f64,
    /// Largest factor on a retry from the second consecutive rejection on (default 0.3,
    /// ARKODE's `ETAMXF` with `SMALL_NEF` = 2).
    pub max_shrink_repeated: f64,
    /// Shrink factor for a rejection whose limit suggests no step and which is not an
    /// error-test failure (non-finite state, stepper failure, growth, user veto); default 0.5.
    pub reject_shrink: f64,
    /// Consecutive rejections allowed for one step before the run ends with
    /// [`super::ControllerError::TooManyRejections`] (default 7, SUNDIALS' `MXNEF`).
    pub max_consecutive_rejections: u32,
    /// The Söderlind filter mapping the `dsm` history to the next step (default PID).
    pub filter: FilterPreset,
    /// Global order `p` of the time integrator: the filter exponents are `k/(p+1)`. The USL
    /// step (eqs 17–29) is symplectic Euler, first order (default 1, local error `O(dt²)`).
    pub order: u32,
    /// Tolerances of the [`super::TemporalError`] limit built by
    /// [`super::Controller::with_default_limits`].
    pub temporal: TemporalErrorConfig,
    /// The growth monitor of the slow instability of moving particles.
    pub growth: GrowthConfig,
    /// The [`crate::stability::Stability`] limit (eqs 56–58) of
    /// [`super::Controller::standard`]; `null` leaves it out. Default: its own defaults
    /// except `safety` 0.95 — measured on the standing wave (README "Adaptive controller"),
    /// 0.9 keeps the mean step at 0.84 of the empirical critical step, 0.95 at 0.86–0.96, and
    /// the growth monitor lowers the factor (×0.9 per detection) when moving particles make
    /// it too bold.
    pub stability: Option<StabilityConfig>,
    /// The [`crate::sound_speed::SoundSpeed`] limit of [`super::Controller::standard`]; `null`
    /// leaves it out. Default `α = 1`: eq 49 with the particle speed added, `h/(c + |v|)`.
    /// It is a *cap*, not the working limit — the true GIMP critical steps are 0.69–0.80
    /// `h/c`, which the stability limit tracks — and binds only when particles move fast
    /// compared with the wave speed (it keeps a particle from crossing a cell per step).
    pub sound_speed: Option<SoundSpeedConfig>,
    /// 2D/3D only: how the stability limit ([`crate::limits_nd::StabilityNd`]) tracks
    /// `λmax` — refresh settings, Lanczos tolerance, the scheme's velocity transfer (FLIP or
    /// APIC), the bound mode. Its safety is `stability.safety` (not read from JSON here);
    /// `stability: null` leaves the limit out in every dimension. Setting any field in a 1D
    /// run is an error ([`ControllerConfig::validate_for`]).
    pub stability_nd: StabilityNdConfig,
    /// 2D/3D only: the body force per unit mass the stepper applies (gravity), one
    /// component per axis, e.g. `[0.0, -9.8]`; `None` (default) for none. The growth monitor
    /// ([`crate::limits_nd::GrowthNd`]) counts its potential energy `−Σ m_p g·x_p`: without it
    /// a falling body's rising kinetic energy reads as growth. [`super::Controller::standard`]
    /// passes it to the monitor; [`crate::controller::standard_limits`] takes the body force as
    /// its argument instead. Its length must be the run's dimension, and it is refused in 1D
    /// runs (the 1D monitor counts no potential energy; [`ControllerConfig::validate_for`]).
    pub gravity: Option<Vec<f64>>,
}

impl Default for ControllerConfig {
    fn default() -> Self {
        Self {
            dt_initial: None,
            dt_min: 0.0,
            dt_max: None,
            safety: 0.9,
            max_growth: 10.0,
            hold_growth: 1.05,
            min_shrink: 0.1,
            max_shrink_first: 0.9,
            max_shrink_repeated: 0.3,
            reject_shrink: 0.5,
            max_consecutive_rejections: 7,
            filter: FilterPreset::Pid,
            order: 1,
            temporal: TemporalErrorConfig::default(),
            growth: GrowthConfig::default(),
            stability: Some(StabilityConfig {
                safety: 0.95,
                ..StabilityConfig::default()
            }),
            sound_speed: Some(SoundSpeedConfig { alpha: 1.0 }),
            stability_nd: StabilityNdConfig::default(),
            gravity: None,
        }
    }
}

impl ControllerConfig {
    /// Parses a config from JSON (unknown fields are errors) and validates it.
    pub fn from_json(json: &str) -> Result<Self, ConfigError> {
        let config: Self = serde_json::from_str(json).map_err(ConfigError::json)?;
        config.validate()?;
        Ok(config)
    }

    /// Parses a config from a JSON value (the `controller` field of a scenario).
    pub fn from_value(value: serde_json::Value) -> Result<Self, ConfigError> {
        let config: Self = serde_json::from_value(value).map_err(ConfigError::json)?;
        config.validate()?;
        Ok(config)
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_steps()?;
        self.filter.validate()?;
        self.temporal.validate()?;
        self.growth.validate()?;
        self.validate_limits()
    }

    /// Checks the controller's own step settings (`dt_*`, safety, growth and shrink
    /// factors, rejections, order).
    fn validate_steps(&self) -> Result<(), ConfigError> {
        if let Some(dt) = self.dt_initial {
            check(
                "dt_initial",
                dt,
                dt.is_finite() && dt > 0.0,
                "finite and > 0",
            )?;
        }
        check(
            "dt_min",
            self.dt_min,
            self.dt_min.is_finite() && self.dt_min >= 0.0,
            "finite and >= 0",
        )?;
        if let Some(dt) = self.dt_max {
            check("dt_max", dt, dt > 0.0, "> 0")?;
            if dt < self.dt_min {
                return Err(ConfigError::Inconsistent {
                    field: "dt_max",
                    value: dt,
                    other: "dt_min",
                    other_value: self.dt_min,
                });
            }
        }
        check(
            "safety",
            self.safety,
            self.safety > 0.0 && self.safety <= 1.0,
            "in (0, 1]",
        )?;
        check(
            "max_growth",
            self.max_growth,
            self.max_growth.is_finite() && self.max_growth >= 1.0,
            "finite and >= 1",
        )?;
        check(
            "hold_growth",
            self.hold_growth,
            self.hold_growth.is_finite() && self.hold_growth >= 1.0,
            "finite and >= 1",
        )?;
        check(
            "min_shrink",
            self.min_shrink,
            self.min_shrink > 0.0 && self.min_shrink < 1.0,
            "in (0, 1)",
        )?;
        check(
            "max_shrink_first",
            self.max_shrink_first,
            self.max_shrink_first >= self.min_shrink && self.max_shrink_first < 1.0,
            "in [min_shrink, 1)",
        )?;
        check(
            "max_shrink_repeated",
            self.max_shrink_repeated,
            self.max_shrink_repeated >= self.min_shrink && self.max_shrink_repeated < 1.0,
            "in [min_shrink, 1)",
        )?;
        check(
            "reject_shrink",
            self.reject_shrink,
            self.reject_shrink > 0.0 && self.reject_shrink < 1.0,
            "in (0, 1)",
        )?;
        check(
            "max_consecutive_rejections",
            f64::from(self.max_consecutive_rejections),
            self.max_consecutive_rejections >= 1,
            ">= 1",
        )?;
        check("order", f64::from(self.order), self.order >= 1, ">= 1")
    }

    /// Checks the stability and sound-speed limits' settings (1D and 2D/3D), naming a
    /// field by its JSON path.
    fn validate_limits(&self) -> Result<(), ConfigError> {
        let stability_field = |e: StabilityError, prefix: &'static str| match e {
            StabilityError::InvalidConfig {
                field,
                value,
                reason,
            } => ConfigError::OutOfRange {
                field: match (prefix, field) {
                    ("stability", "safety") => "stability.safety",
                    ("stability", "tol") => "stability.tol",
                    (p, _) => p,
                },
                value,
                expected: reason,
            },
            other => ConfigError::Parse {
                message: format!("{prefix}: {other}"),
                source: None,
            },
        };
        let mut nd = self.stability_nd.clone();
        if let Some(c) = &self.stability {
            nd.safety = c.safety;
        }
        nd.validate()?;
        for &g in self.gravity.iter().flatten() {
            check("gravity", g, g.is_finite(), "finite in every component")?;
        }
        if let Some(c) = self.stability {
            crate::stability::Stability::new(c).map_err(|e| stability_field(e, "stability"))?;
        }
        if let Some(c) = self.sound_speed {
            crate::sound_speed::SoundSpeed::new(c)?;
        }
        Ok(())
    }
}
