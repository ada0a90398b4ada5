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
//! exceeds the first by `factor`, above a noise `floor`. On detection the trial is rejected
//! with [`RejectCause::Growth`] and a suggested step `safety_factor · dt`; the controller then
//! lowers the stability safety factor of every limit by `safety_factor` for the rest of the
//! run ([`crate::limit::StepLimit::scale_safety`]) and logs it. The monitor's history is then
//! cleared, so one growth episode triggers once.

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
}

/// The growth monitor, a [`StepLimit`] named `"growth"` that never proposes a step.
#[derive(Clone, Debug)]
pub struct GrowthMonitor {
    config: GrowthConfig,
    state: Windows,
    /// The indicator of the last judged trial `(t, dt, value)`, reused by `accepted` when
    /// it is called for that trial (same start time and step, compared bit for bit), so the
    /// indicator is computed once per accepted step, not twice.
    judged: Option<(f64, f64, f64)>,
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
/// strain energy).
pub fn total_energy(view: &View<'_>) -> f64 {
    let n = view.n_particles();
    let mut e = 0.0;
    for p in 0..n {
        let (m, v) = (view.mass.get(p), view.v.get(p));
        if let (Some(m), Some(v)) = (m, v) {
            e += 0.5 * m * v * v;
        }
        if let (Some(s), Some(f), Some(v0), Some(et)) = (
            view.sigma.get(p),
            view.f.get(p),
            view.volume0.get(p),
            view.tangent_modulus.get(p),
        ) {
            if *et > 0.0 {
                e += 0.5 * s * s * f * v0 / et;
            }
        }
    }
    e
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
            GrowthIndicator::Energy => total_energy(view),
        }
    }

    /// The window state after adding `value`.
    fn pushed(&self, value: f64) -> Windows {
        let mut w = self.state.clone();
        w.current = if w.count == 0 {
            value
        } else {
            w.current.max(value)
        };
        w.count += 1;
        if w.count >= self.config.window {
            w.maxima.push(w.current);
            let keep = self.config.windows as usize;
            if w.maxima.len() > keep {
                w.maxima.remove(0);
            }
            w.count = 0;
            w.current = 0.0;
        }
        w
    }

    /// Whether the window maxima show growth.
    fn growing(&self, w: &Windows) -> bool {
        let m = &w.maxima;
        if m.len() < self.config.windows as usize {
            return false;
        }
        let (first, last) = (m[0], m[m.len() - 1]);
        let increasing = m.windows(2).all(|p| p[1] > p[0]);
        increasing && last > self.config.floor && last >= self.config.factor * first
    }
}

impl StepLimit for GrowthMonitor {
    fn name(&self) -> &str {
        GROWTH
    }

    fn propose(&mut self, _state: &View<'_>) -> Result<Proposal, LimitError> {
        Ok(Proposal {
            dt: f64::INFINITY,
            metrics: Metrics::new(),
        })
    }

    fn judge(
        &mut self,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        let value = self.indicator(after);
        self.judged = Some((before.t, dt, value));
        let mut metrics = Metrics::new();
        metrics.insert("growth_indicator".to_string(), value);
        let w = self.pushed(value);
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
        Ok(Judgement { verdict, metrics })
    }

    fn accepted(&mut self, before: &View<'_>, after: &View<'_>, dt: f64) {
        let value = match self.judged.take() {
            Some((t, d, value))
                if t.to_bits() == before.t.to_bits() && d.to_bits() == dt.to_bits() =>
            {
                value
            }
            _ => self.indicator(after),
        };
        self.state = self.pushed(value);
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
        self.state = serde_json::from_value(state.clone()).map_err(|e| LimitError::Other {
            limit: GROWTH.to_string(),
            message: format!("cannot restore state: {e}"),
        })?;
        Ok(())
    }
}
