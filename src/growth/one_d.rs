//! The 1D growth monitor, [`Growth<1>`](super::Growth) ([`super::GrowthMonitor`]): detects
//! the slow instability of moving particles; its rule is [`WindowMaxima`].
//!
//! Eq 56's amplification matrix `A = I − E dt²/h² D*F` assumes frozen particles. When the
//! particles move, `D*F` changes every step and high-wavenumber modes can grow slowly at
//! steps somewhat *below* the frozen-particle limit `dt_crit = h √(2/(E λmax))`. The
//! unstable mode is the checkerboard: the nodal force pattern that alternates from node to
//! node, the top eigenvector of `D*F`.
//!
//! The monitor computes one indicator per accepted state:
//!
//! * [`GrowthIndicator::Checkerboard`] (default): the checkerboard share of the nodal
//!   accelerations (eq 18), `s = |Σ_i (−1)^i m_i a_i| / Σ_i m_i |a_i|` over active nodes,
//!   in `[0, 1]`. A smooth field gives `s ≈ 0`; a growing checkerboard drives `s → 1`. Being
//!   a share it does not react to legitimate growth of the whole solution.
//! * [`GrowthIndicator::Energy`]: the total energy `Σ_p ½ m_p v_p² + Σ_p ½ σ_p² F_p V⁰_p /
//!   E_t,p` (kinetic plus linear-elastic strain energy), which an elastic problem without
//!   loads conserves up to the symplectic step's bounded oscillation.
//!
//! It keeps the maxima of the indicator over consecutive windows of `window` accepted steps.
//! Growth is detected when the last `windows` window maxima increase strictly and the last
//! exceeds the first by `factor`, above a noise `floor` — and, for the checkerboard indicator,
//! when the total energy confirms it: its maximum over the last of those windows exceeds that
//! over the first by `energy_confirm` (default 1 %).
//!
//! **Why the energy confirmation.** The share is an early detector (it sees a checkerboard long
//! before the checkerboard carries energy) but a noisy one: the smooth part of the accelerations
//! passes through zero twice per period, and on a fine grid `windows × window` steps are a fraction
//! of a period, so the share of a harmless, constant residue rises by more than `factor` on the
//! way. Measured on the resolved standing wave (`tests/controller_standing_wave.rs`, 512 cells):
//! without the confirmation the jittered runs had 21 (A = 10⁻²) and 8 (10⁻⁴) detections, each
//! cutting the step by 10 %, while their energy never grew; with it, none. The energy alone is a
//! late detector: on `tests/controller_growth.rs` (a step a few per cent above critical) it did not
//! fire before the energy passed 10× its start, whereas share + confirmation fires in time. An
//! elastic problem without loads conserves the energy up to the symplectic step's bounded
//! oscillation (well below 1 % over a few windows), so a 1 % rise is growth; with external work the
//! confirmation can be switched off (`energy_confirm = 0`). On detection the trial is rejected with
//! [`crate::limit::RejectCause::Growth`] and a suggested step `safety_factor · dt`; the controller
//! then lowers the stability safety factor of every limit by `safety_factor` for the rest of the
//! run ([`crate::limit::StepLimit::scale_safety`]) and logs it. The monitor's history is then
//! cleared, so one growth episode triggers once. A detection that would take the safety below
//! [`GrowthConfig::min_safety_scale`] of its start ends the run instead
//! ([`crate::controller::ControllerError::GrowthPersists`]).

use super::{Detection, Growth, GrowthConfig, GrowthDim, GrowthIndicator, GrowthRule};
use crate::config_error::ConfigError;
use crate::dimension::Dim;
use crate::limit::Metrics;
use crate::stepper::View;
use serde::{Deserialize, Serialize};

/// Checkerboard share of the nodal accelerations of a state (see the module docs); 0 when
/// no active node accelerates.
pub fn checkerboard_share(view: &View<'_>) -> f64 {
    let n = view
        .node_acceleration
        .len()
        .min(view.node_mass.len())
        .min(view.node_active.len());
    let (mut alt, mut total) = (0.0, 0.0);
    for i in 0..n {
        if !view.node_active[i] {
            continue;
        }
        let ma = view.node_mass[i] * view.node_acceleration[i];
        alt += if i % 2 == 0 { ma } else { -ma };
        total += ma.abs();
    }
    if total > 0.0 {
        alt.abs() / total
    } else {
        0.0
    }
}

/// Total energy `Σ ½ m v² + Σ ½ σ² F V⁰ / E_t` of a state (particles with `E_t ≤ 0` add no
/// strain energy; fields shorter than the particle count end the sum there).
///
/// Summed in four independent lanes, combined in lane order at the end, every
/// branch a select, so the loop vectorises instead of running one chain of dependent adds
/// and divisions (deterministic: the same inputs give the same bits; it differs from a
/// sequential sum by rounding only).
pub fn total_energy(view: &View<'_>) -> f64 {
    let n = [
        view.n_particles(),
        view.mass.len(),
        view.v.len(),
        view.sigma.len(),
        view.f.len(),
        view.volume0.len(),
        view.tangent_modulus.len(),
    ]
    .into_iter()
    .min()
    .unwrap_or(0);
    let (m, v, s, f, v0, et) = (
        &view.mass[..n],
        &view.v[..n],
        &view.sigma[..n],
        &view.f[..n],
        &view.volume0[..n],
        &view.tangent_modulus[..n],
    );
    const L: usize = ENERGY_LANES;
    let mut lanes = [0.0; L];
    let chunks = m
        .chunks_exact(L)
        .zip(v.chunks_exact(L))
        .zip(s.chunks_exact(L))
        .zip(
            f.chunks_exact(L)
                .zip(v0.chunks_exact(L))
                .zip(et.chunks_exact(L)),
        );
    for (((m, v), s), ((f, v0), et)) in chunks {
        for l in 0..L {
            lanes[l] += particle_energy(m[l], v[l], s[l], f[l], v0[l], et[l]);
        }
    }
    let full = n - n % L;
    for (l, p) in (full..n).enumerate() {
        lanes[l] += particle_energy(m[p], v[p], s[p], f[p], v0[p], et[p]);
    }
    sum_energy_lanes(lanes)
}

/// [`total_energy`] of a view: the stepper's, when its pass took it
/// ([`crate::PassSummary::total_energy`], the same bits), else summed here.
fn energy_of(view: &View<'_>) -> f64 {
    view.trusted_summary()
        .map_or_else(|| total_energy(view), |s| s.total_energy)
}

/// Independent accumulators of [`total_energy`]: particle `p` goes to lane `p mod 4`.
pub(crate) const ENERGY_LANES: usize = 4;

/// One particle's term of [`total_energy`], `½ m v² + ½ σ² F V⁰ / E_t`. `E_t ≤ 0` divides by
/// +∞ instead: the select comes before the division, so a loop over it has no branch (a
/// non-finite `σ` then gives a non-finite energy, as it should).
#[inline(always)]
pub(crate) fn particle_energy(m: f64, v: f64, s: f64, f: f64, v0: f64, et: f64) -> f64 {
    let et = if et > 0.0 { et } else { f64::INFINITY };
    0.5 * m * v * v + 0.5 * s * s * f * v0 / et
}

/// The lanes of [`total_energy`] combined, in lane order.
#[inline(always)]
pub(crate) fn sum_energy_lanes(lanes: [f64; ENERGY_LANES]) -> f64 {
    lanes.iter().sum()
}

/// The monitor's memory.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
struct Windows {
    /// Maxima of completed windows, oldest first (at most `windows`).
    maxima: Vec<f64>,
    /// Maximum of the window being filled.
    current: f64,
    /// Steps in the window being filled.
    count: u32,
    /// Maxima of the total energy over the same windows (energy confirmation only).
    #[serde(default)]
    energy: Vec<f64>,
    /// Maximum of the total energy in the window being filled.
    #[serde(default)]
    energy_current: f64,
}

/// The 1D rule of the growth monitor: window maxima of the indicator, confirmed by the
/// energy (module docs).
#[derive(Clone, Debug)]
pub struct WindowMaxima {
    config: GrowthConfig,
    state: Windows,
}

impl GrowthDim for Dim<1> {
    type Rule = WindowMaxima;
}

impl Growth<1> {
    /// A monitor with the given settings (validated).
    pub fn new(config: GrowthConfig) -> Result<Self, ConfigError> {
        Ok(Self::with_rule(WindowMaxima::new(config)?))
    }

    /// The indicator of a state.
    pub fn indicator(&self, view: &View<'_>) -> f64 {
        self.rule().indicator(view)
    }
}

impl WindowMaxima {
    /// The rule with the given settings (validated), its windows empty.
    pub fn new(config: GrowthConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            state: Windows::default(),
        })
    }

    /// The rule's settings.
    pub fn config(&self) -> &GrowthConfig {
        &self.config
    }

    /// The indicator of a state.
    pub fn indicator(&self, view: &View<'_>) -> f64 {
        match self.config.indicator {
            GrowthIndicator::Checkerboard => checkerboard_share(view),
            GrowthIndicator::Energy => energy_of(view),
        }
    }

    /// The window state after adding `value` (and the state's energy, when confirming).
    fn pushed(&self, value: f64, energy: Option<f64>) -> Windows {
        let mut w = self.state.clone();
        let first = w.count == 0;
        w.current = if first { value } else { w.current.max(value) };
        if let Some(e) = energy {
            w.energy_current = if first { e } else { w.energy_current.max(e) };
        }
        w.count += 1;
        if w.count >= self.config.window {
            let keep = self.config.windows as usize;
            w.maxima.push(w.current);
            if w.maxima.len() > keep {
                w.maxima.remove(0);
            }
            if energy.is_some() {
                w.energy.push(w.energy_current);
                if w.energy.len() > keep {
                    w.energy.remove(0);
                }
            }
            w.count = 0;
            w.current = 0.0;
            w.energy_current = 0.0;
        }
        w
    }

    /// The state's total energy when the checkerboard indicator is confirmed by it.
    fn confirming_energy(&self, view: &View<'_>) -> Option<f64> {
        (self.config.indicator == GrowthIndicator::Checkerboard && self.config.energy_confirm > 0.0)
            .then(|| energy_of(view))
    }

    /// Whether the window maxima show growth.
    fn growing(&self, w: &Windows) -> bool {
        let m = &w.maxima;
        if m.len() < self.config.windows as usize {
            return false;
        }
        let (first, last) = (m[0], m[m.len() - 1]);
        let increasing = m.windows(2).all(|p| p[1] > p[0]);
        let confirmed = match (w.energy.first(), w.energy.last()) {
            _ if self.config.indicator != GrowthIndicator::Checkerboard
                || self.config.energy_confirm == 0.0 =>
            {
                true
            }
            (Some(&e0), Some(&e1)) if w.energy.len() == m.len() => {
                e1 >= (1.0 + self.config.energy_confirm) * e0
            }
            _ => false,
        };
        increasing && confirmed && last > self.config.floor && last >= self.config.factor * first
    }
}

impl GrowthRule<Dim<1>> for WindowMaxima {
    /// The indicator and, when confirming, the total energy.
    type Sample = (f64, Option<f64>);

    fn sample(&self, view: &View<'_>) -> (f64, Option<f64>) {
        (self.indicator(view), self.confirming_energy(view))
    }

    fn trial_key(before: &View<'_>, _after: &View<'_>, dt: f64) -> [u64; 2] {
        [before.t.to_bits(), dt.to_bits()]
    }

    fn judge(
        &mut self,
        _before: &View<'_>,
        (value, energy): (f64, Option<f64>),
        dt: f64,
        metrics: &mut Metrics,
    ) -> Detection {
        metrics.insert("growth_indicator".to_string(), value);
        let w = self.pushed(value, energy);
        if !self.growing(&w) {
            return Detection::Steady;
        }
        if let (Some(a), Some(b)) = (w.maxima.first(), w.maxima.last()) {
            metrics.insert("growth_ratio".to_string(), b / a);
        }
        Detection::Growing {
            suggested_dt: Some(self.config.safety_factor * dt),
        }
    }

    fn record(&mut self, (value, energy): (f64, Option<f64>)) {
        self.state = self.pushed(value, energy);
    }

    fn growth_rejected(&mut self) {
        self.state = Windows::default();
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        serde_json::to_value(&self.state).ok()
    }

    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), serde_json::Error> {
        self.state = serde_json::from_value(state.clone())?;
        Ok(())
    }
}
