//! The growth monitor: detects the slow instability of moving particles.
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
//! **Why the energy confirmation.** The share is an early detector (it sees a checkerboard
//! long before the checkerboard carries energy) but a noisy one: the smooth part of the
//! accelerations passes through zero twice per period, and on a fine grid `windows × window`
//! steps are a fraction of a period, so the share of a harmless, constant residue rises by
//! more than `factor` on the way. Measured on the resolved standing wave
//! (`tests/controller_standing_wave.rs`, 512 cells): without the confirmation the jittered
//! runs had 21 (A = 10⁻²) and 8 (10⁻⁴) detections, each cutting the step by 10 %, while their
//! energy never grew; with it, none. The energy alone is a late detector: on
//! `tests/controller_growth.rs` (a step a few per cent above critical) it did not fire before
//! the energy passed 10× its start, whereas share + confirmation fires in time. An elastic
//! problem without loads conserves the energy up to the symplectic step's bounded oscillation
//! (well below 1 % over a few windows), so a 1 % rise is growth; with external work the
//! confirmation can be switched off (`energy_confirm = 0`). On detection the trial is rejected
//! with [`RejectCause::Growth`] and a suggested step `safety_factor · dt`; the controller then
//! lowers the stability safety factor of every limit by `safety_factor` for the rest of the
//! run ([`crate::limit::StepLimit::scale_safety`]) and logs it. The monitor's history is then
//! cleared, so one growth episode triggers once. A detection that would take the safety
//! below [`GrowthConfig::min_safety_scale`] of its start ends the run instead
//! ([`super::ControllerError::GrowthPersists`]).

use super::config::{check, ConfigError};
use crate::limit::{Judgement, LimitError, Metrics, Proposal, RejectCause, StepLimit, Verdict};
use crate::stepper::View;
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

/// Settings of the [`GrowthMonitor`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GrowthConfig {
    /// Whether [`super::Controller::with_default_limits`] installs the monitor (default true).
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
    /// [`super::ControllerError::GrowthPersists`] instead of letting it crawl on ever
    /// smaller steps. At the default `safety_factor` the 21st detection lowers the safety
    /// to 0.9²¹ ≈ 0.109 and the 22nd ends the run. Stale or frozen-particle `λmax` estimates
    /// are off by tens of per cent (a safety of 0.5 covers them); a run still growing at a
    /// tenth of its proposed steps is not one the limits control. `0` never stops.
    pub min_safety_scale: f64,
    /// With the checkerboard indicator, a detection also needs the total energy (the
    /// [`GrowthIndicator::Energy`] value) to confirm it: its maximum over the last of the
    /// compared windows must exceed that over the first by this relative amount (default
    /// 0.01; 0 switches the confirmation off). See the module docs.
    pub energy_confirm: f64,
    /// 2D/3D only ([`crate::limits_nd::GrowthNd`], an energy monitor): a rise of the
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

/// The growth monitor, a [`StepLimit`] named `"growth"` that never proposes a step.
#[derive(Clone, Debug)]
pub struct GrowthMonitor {
    config: GrowthConfig,
    state: Windows,
    /// The window state the last judged trial would leave, `(t, dt, windows)`, taken by
    /// `accepted` when it is called for that trial (same start time and step, compared bit
    /// for bit), so the indicator and the windows are computed once per accepted step.
    judged: Option<(f64, f64, Windows)>,
}

/// The name of the monitor in logs and statistics.
pub const GROWTH: &str = "growth";

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

impl GrowthMonitor {
    /// A monitor with the given settings (validated).
    pub fn new(config: GrowthConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            state: Windows::default(),
            judged: None,
        })
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

impl StepLimit for GrowthMonitor {
    fn name(&self) -> &str {
        GROWTH
    }

    fn propose(&mut self, _state: &View<'_>) -> Result<Proposal, LimitError> {
        Ok(Proposal::no_opinion())
    }

    fn judge(
        &mut self,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        let value = self.indicator(after);
        let energy = self.confirming_energy(after);
        let mut metrics = Metrics::new();
        metrics.insert("growth_indicator".to_string(), value);
        let w = self.pushed(value, energy);
        let verdict = if self.growing(&w) {
            if let (Some(a), Some(b)) = (w.maxima.first(), w.maxima.last()) {
                metrics.insert("growth_ratio".to_string(), b / a);
            }
            Verdict::Reject {
                cause: RejectCause::Growth,
                suggested_dt: Some(self.config.safety_factor * dt),
            }
        } else {
            Verdict::Accept
        };
        self.judged = Some((before.t, dt, w));
        Ok(Judgement { verdict, metrics })
    }

    fn accepted(&mut self, before: &View<'_>, after: &View<'_>, dt: f64) {
        self.state = match self.judged.take() {
            Some((t, d, w)) if t.to_bits() == before.t.to_bits() && d.to_bits() == dt.to_bits() => {
                w
            }
            _ => self.pushed(self.indicator(after), self.confirming_energy(after)),
        };
    }

    fn rejected(&mut self, _dt: f64, cause: RejectCause) {
        self.judged = None;
        if cause == RejectCause::Growth {
            self.state = Windows::default();
        }
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        serde_json::to_value(&self.state).ok()
    }

    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        self.state = serde_json::from_value(state.clone()).map_err(|e| LimitError::Restore {
            limit: GROWTH.to_string(),
            source: e.into(),
        })?;
        Ok(())
    }
}
