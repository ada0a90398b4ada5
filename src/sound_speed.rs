//! The speed-of-sound step limit in every dimension: eq 49 generalised to moving,
//! nonlinear material, one rule for `D = 1, 2, 3`.
//!
//! ```text
//! dt ≤ α · min_p min_a h_a / (c_p + |v_{p,a}|),     c_p = √(M_t,p / ρ_p)          (eq 49: α = 1, v = 0)
//! ```
//!
//! with `M_t,p` the particle's tangent P-wave modulus (`E_t` in 1D, `λ_t + 2μ_t` in 2D/3D)
//! and `v_{p,a}` its velocity along axis `a` — the rule Uintah applies per particle and
//! per axis. Each particle's own signal speed `c_p + |v_{p,a}|` is taken, not the largest
//! wave speed plus the largest velocity of two different particles: the smaller sum is
//! the one that bounds how far a signal crosses a cell in one step, and the rule is never
//! stricter than `α h/(c_max + ‖v‖_∞)`. In 1D, where `h` is one number, the minimum is
//! formed as `h / max_p (c_p + |v_p|)`, the same number bit for bit (division is monotone
//! and correctly rounded), from a maximum a stepper can take in its own pass
//! ([`crate::PassSummary::max_signal_speed`], [`crate::nd::SummaryNd::sound_unit_step`]).
//!
//! **α = 1 is not stable for this method.** Eq 49 reads `E dt²/h² ≤ 1` with `ρ = 1`, i.e.
//! `dt ≤ h/c`. The exact critical steps of GIMP update-stress-last measured by
//! [`crate::stability::full_map`] and the empirical blow-up runs are `0.64–0.83 h/c`
//! depending on the particle layout, and eq 56 gives `h/(√2 c)` on uniform GIMP and
//! linear layouts. Adding the particle speed keeps the rule meaningful when particles are
//! fast compared with the wave speed (they must not cross more than a fraction of a cell
//! per step).
//!
//! **Default `α = 0.5`** ([`SoundSpeedConfig`]). Measured with `examples/critical_dt`
//! (README "Stability" table, 64 cells): the frozen-particle critical steps of 1D GIMP
//! layouts are `0.69–0.80 h/c` (the smallest with a node of 1.5 % typical mass), and with
//! moving particles (`A = 10⁻²`) `0.73–0.82 h/c`; linear hats on a jittered layout drop to
//! `0.58 h/c` with moving particles. `α = 0.5` keeps a margin of at least 27 % on every GIMP
//! layout and 14 % on the jittered linear-hat one. It does **not** protect linear-hat
//! weights near small nodal masses, where the critical step collapses as
//! `√(m_min/m_typical)` with no change in `c` (0.11 h/c frozen, 0.04 h/c with moving
//! particles at 1.5 % mass): the stability limit (eq 56) covers those. The standard
//! controller uses this limit with `α = 1` as a cap beside the stability limit
//! ([`crate::controller::ControllerConfig::sound_speed`]).
//!
//! **After a growth detection** the controller lowers every limit's safety
//! ([`StepLimit::scale_safety`]); this one multiplies `α` by the factor, so that a binding
//! sound-speed cap backs off with the stability limit.
//!
//! **The per-dimension kernels** — the pass over the particles and what a stepper's summary
//! may supply instead — are the [`SignalSpeeds`] implementations: the 1D view's in
//! `stability/sound_speed.rs` (with the 1D view's vectorised validation), the 2D/3D view's in
//! `limits_nd/sound_speed.rs`.

use crate::config_error::ConfigError;
use crate::dimension::{Dim, Dimension, ViewOf};
use crate::limit::{LimitError, Metrics, Proposal, StepLimit};

/// Name in logs: `"sound_speed"`.
pub const SOUND_SPEED: &str = "sound_speed";

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

/// What a view of one dimension gives the speed-of-sound limit (module docs).
pub trait SignalSpeeds {
    /// `min_p min_a h_a / (c_p + |v_{p,a}|)`, the limit's step at `α = 1`: the stepper's own
    /// value where its summary carries one, else a pass over the particles. An error names
    /// the first particle whose fields make it meaningless (a non-finite or non-positive
    /// modulus or density, a non-finite velocity).
    fn sound_unit_step(&self) -> Result<f64, LimitError>;

    /// Whether [`Self::sound_unit_step`] takes the stepper's own value (no pass over the
    /// particles). Default `false`.
    fn supplies_sound_unit_step(&self) -> bool {
        false
    }
}

/// The speed-of-sound limit `dt ≤ α min_p min_a h_a/(c_p + |v_{p,a}|)` (module docs), for
/// a run of any dimension: it implements [`StepLimit<D>`] for every `D` whose view
/// implements [`SignalSpeeds`].
#[derive(Clone, Debug, PartialEq)]
pub struct SoundSpeed {
    config: SoundSpeedConfig,
    /// `α` as configured, before any [`StepLimit::scale_safety`].
    configured_alpha: f64,
}

impl Default for SoundSpeed {
    /// The limit with the default settings.
    fn default() -> Self {
        Self::unchecked(SoundSpeedConfig::default())
    }
}

impl SoundSpeed {
    /// The limit with factor `config.alpha`, which must be positive and finite.
    pub fn new(config: SoundSpeedConfig) -> Result<Self, ConfigError> {
        crate::config_error::check(
            "sound_speed.alpha",
            config.alpha,
            config.alpha.is_finite() && config.alpha > 0.0,
            "positive and finite",
        )?;
        Ok(Self::unchecked(config))
    }

    /// The limit without checking `config` (for builders whose caller validates it).
    pub(crate) fn unchecked(config: SoundSpeedConfig) -> Self {
        Self {
            config,
            configured_alpha: config.alpha,
        }
    }

    /// The settings (with `α` as lowered by [`StepLimit::scale_safety`], if it was).
    pub fn config(&self) -> SoundSpeedConfig {
        self.config
    }

    /// The step at `α = 1` of a state of any dimension ([`SignalSpeeds::sound_unit_step`]):
    /// what a fixed rule `dt = α·unit` multiplies.
    pub fn unit_step<V: SignalSpeeds>(view: &V) -> Result<f64, LimitError> {
        view.sound_unit_step()
    }

    /// This limit's step for a state.
    pub fn dt<V: SignalSpeeds>(&self, view: &V) -> Result<f64, LimitError> {
        Ok(self.config.alpha * view.sound_unit_step()?)
    }
}

impl<const D: usize> StepLimit<D> for SoundSpeed
where
    Dim<D>: Dimension,
    for<'a> ViewOf<'a, D>: SignalSpeeds,
{
    fn name(&self) -> &str {
        SOUND_SPEED
    }

    /// Multiplies `α` by `factor` (ignored unless `0 < factor ≤ 1`): when the controller's
    /// growth monitor sees an instability, a binding sound-speed limit must back off too.
    fn scale_safety(&mut self, factor: f64) {
        if factor > 0.0 && factor <= 1.0 {
            self.config.alpha *= factor;
        }
    }

    /// `α` as lowered after growth, for a checkpoint (the rest of the limit is its config).
    fn save_state(&self) -> Option<serde_json::Value> {
        Some(serde_json::json!({ "alpha": self.config.alpha }))
    }

    /// Restores `α`; one that is not in `(0, the configured α]` is a
    /// [`LimitError::Restore`].
    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        let alpha = state["alpha"]
            .as_f64()
            .filter(|&a| a > 0.0 && a <= self.configured_alpha);
        match alpha {
            Some(a) => {
                self.config.alpha = a;
                Ok(())
            }
            None => Err(LimitError::Restore {
                limit: SOUND_SPEED.to_string(),
                source: <serde_json::Error as serde::de::Error>::custom(format!(
                    "alpha: {state} holds no number in (0, {}]",
                    self.configured_alpha
                ))
                .into(),
            }),
        }
    }

    /// Only a proposal reads the arrays, and only where the view's summary carries no
    /// finite speed-of-sound step.
    fn reads_arrays(&self, call: crate::limit::LimitCall, state: &ViewOf<'_, D>) -> bool {
        call == crate::limit::LimitCall::Propose && !state.supplies_sound_unit_step()
    }

    fn propose(&mut self, state: &ViewOf<'_, D>) -> Result<Proposal, LimitError> {
        let unit = state.sound_unit_step()?;
        let dt = self.config.alpha * unit;
        let mut metrics = Metrics::new();
        metrics.insert("dt_sound_unit".into(), unit);
        tracing::debug!(dt, unit, alpha = self.config.alpha, "sound_speed proposal");
        Ok(Proposal { dt, metrics })
    }
}
