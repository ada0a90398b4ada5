//! The 2D/3D growth monitor, [`Growth<D>`](super::Growth) ([`super::GrowthNd`]), and its rule
//! [`EnergyDrift`].
//!
//! Particles that move make the method unstable somewhat below the frozen-particle limit
//! (slowly growing high-wavenumber modes). This monitor watches the mechanical energy
//!
//! ```text
//! E = Σ_p ½ m_p |v_p|² + Σ_p ½ V_p σ_p : C_p⁻¹ : σ_p − Σ_p m_p g·x_p
//! ```
//!
//! (kinetic, elastic with the view's tangent moduli, gravitational), which the USL step
//! does not increase in a stable run beyond a small oscillation (the kinetic and elastic
//! parts are measured half a step apart). A trial is rejected with cause `growth`
//!
//! * when `E` rose within the step by more than half the kinetic plus elastic energy
//!   before it (a fast blow-up: a smaller step cures it), or
//! * when `E` rose, against its value `window` accepted steps earlier, by more than `tol`
//!   times the kinetic plus elastic energy then (a slow instability). The history is then
//!   cleared, so the retry is judged on the step alone: one rejection per detection.
//!
//! **The elastic part is a fixed quadratic form of the stress.** Summed here (a stepper that hands
//! over no [`crate::nd::SummaryNd`]), it is the complementary energy `½ σ:C₀⁻¹:σ` with each
//! particle's moduli `C₀` *as the first view the monitor summed reported them* (kept, 16 bytes a
//! particle) — the stored energy of a linear-elastic material, and for a hyperelastic one a measure
//! that a stable run does not increase beyond a small oscillation. Not the view's current moduli: a
//! neo-Hookean or fixed-corotated solid reports its tangent pair ([`crate::tangent`]), which moves
//! with `F`, and `½ σ:C_t⁻¹:σ` then rises through an elastic rebound that conserves the material's
//! own energy, so the monitor rejected stable steps — measured on `examples/user_flip --generic`: 7
//! detections on the falling neo-Hookean block (3 483 steps) and 2 on the disks (1 354), none with
//! the kept moduli (2 536 and 1 199 steps, as many as the solver that hands over its own energy
//! takes); one on the mpm88 jelly (`examples/mls_mpm --generic`, 1 612 steps), none with the kept
//! moduli (1 500). The moduli are taken again, and the history cleared, when the particle count
//! changes; on a grid split over processes ([`ViewNd::split`](crate::nd::ViewNd::split)), where
//! particles migrate, the view's own moduli are used. They are kept by index: a stepper that
//! reorders its particles between views (sorting them by cell, say) and whose particles differ in
//! material should hand over its own energy. A solver with a stored-energy function may hand over
//! its own elastic energy in [`crate::nd::SummaryNd::strain`] instead — any quantity that a stable
//! run does not increase beyond a small oscillation (`examples/user_flip` hands over its
//! neo-Hookean energy, `examples/mls_mpm` the complementary energy at rest moduli).
//!
//! On a growth rejection the controller lowers every limit's safety factor by
//! [`GrowthConfig::safety_factor`](super::GrowthConfig::safety_factor) for the rest of the run, and
//! ends the run when it would fall below `growth.min_safety_scale` of its start
//! ([`crate::controller::ControllerError::GrowthPersists`]).

use super::{Detection, Growth, GrowthDim, GrowthRule};
use crate::dimension::{Dim, Dimension};
use crate::limit::Metrics;
use crate::nd::{Tensor, Vector, ViewNd};
use std::collections::VecDeque;

/// The 2D/3D rule of the growth monitor: the drift of the mechanical energy `E` (module
/// docs).
#[derive(Clone, Debug)]
pub struct EnergyDrift<const D: usize> {
    gravity: Vector<D>,
    window: usize,
    tol: f64,
    /// `(E, K + U)` of the last `window + 1` accepted states.
    history: VecDeque<(f64, f64)>,
    /// Each particle's `(λ, μ)` at the first view summed here: the fixed quadratic form of
    /// the elastic energy (module docs); empty until then and where a summary is handed
    /// over.
    reference_moduli: Vec<(f64, f64)>,
}

impl<const D: usize> GrowthDim for Dim<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    type Rule = EnergyDrift<D>;
}

impl<const D: usize> Growth<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    /// A monitor for a run under `gravity`, over `window` accepted steps with relative
    /// tolerance `tol`.
    pub fn new(gravity: Vector<D>, window: usize, tol: f64) -> Self {
        Self::with_rule(EnergyDrift::new(gravity, window, tol))
    }

    /// `(E, K + U)` of a view: [`EnergyDrift::energies`].
    pub fn energies(&self, view: &ViewNd<'_, D>) -> (f64, f64) {
        self.rule().energies(view)
    }
}

impl<const D: usize> EnergyDrift<D> {
    /// The rule for a run under `gravity`, over `window` accepted steps with relative
    /// tolerance `tol`.
    pub fn new(gravity: Vector<D>, window: usize, tol: f64) -> Self {
        Self {
            gravity,
            window: window.max(1),
            tol,
            history: VecDeque::new(),
            reference_moduli: Vec::new(),
        }
    }

    /// Keeps the moduli of `view` as the energy's fixed quadratic form, where the energy is
    /// summed here (no summary, an undivided grid) and none are kept for its particle
    /// count; a change of count clears the history (module docs).
    fn keep_reference_moduli(&mut self, view: &ViewNd<'_, D>) {
        let n = view.n_particles();
        if view.summary.is_some() || view.split.is_some() || self.reference_moduli.len() == n {
            return;
        }
        if !self.reference_moduli.is_empty() {
            self.history.clear();
        }
        self.reference_moduli.clear();
        self.reference_moduli.extend(
            view.lame_lambda
                .iter()
                .copied()
                .zip(view.lame_mu.iter().copied()),
        );
    }

    /// `(E, K + U)` of a view (module docs), from the view's [`SummaryNd`] when the
    /// stepper offers one (no pass over the particles), else summed here with the kept
    /// moduli (the view's own before any are kept, or where their count differs).
    ///
    /// [`SummaryNd`]: crate::nd::SummaryNd
    pub fn energies(&self, view: &ViewNd<'_, D>) -> (f64, f64) {
        // The stepper's totals, when it offers them: no pass of our own.
        if let Some(s) = &view.summary {
            let ku = s.kinetic + s.strain;
            return (ku - self.gravity.dot(&s.first_moment), ku);
        }
        let mut ku = 0.0;
        let mut pot = 0.0;
        let kept = (self.reference_moduli.len() == view.n_particles() && view.split.is_none())
            .then_some(&self.reference_moduli);
        for p in 0..view.n_particles() {
            ku += 0.5 * view.mass[p] * view.v[p].norm_squared();
            let (l, m) = match kept {
                Some(moduli) => moduli[p],
                None => (view.lame_lambda[p], view.lame_mu[p]),
            };
            let s: &Tensor<D> = &view.sigma[p];
            if m > 0.0 {
                // ½ σ:C⁻¹σ with C⁻¹σ = (σ − λ tr σ/(2μ + dλ) I)/(2μ), contracted directly.
                let tr = s.trace();
                let s_c = (s.norm_squared() - l * tr * tr / (2.0 * m + D as f64 * l)) / (2.0 * m);
                ku += 0.5 * crate::nd::det(&view.f[p]) * view.volume0[p] * s_c;
            } else if l > 0.0 {
                let pr = s.trace() / D as f64;
                ku += 0.5 * crate::nd::det(&view.f[p]) * view.volume0[p] * D as f64 * pr * pr
                    / (D as f64 * l);
            }
            pot -= view.mass[p] * self.gravity.dot(&view.x[p]);
        }
        (ku + pot, ku)
    }
}

impl<const D: usize> GrowthRule<Dim<D>> for EnergyDrift<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    /// `(E, K + U)`.
    type Sample = (f64, f64);

    fn sample(&self, view: &ViewNd<'_, D>) -> (f64, f64) {
        self.energies(view)
    }

    /// Only where the state carries no summary: with one, the energies are the summary's
    /// and no moduli are kept.
    fn reads_arrays(&self, state: &ViewNd<'_, D>) -> bool {
        state.summary.is_none()
    }

    fn trial_key(_before: &ViewNd<'_, D>, after: &ViewNd<'_, D>, _dt: f64) -> [u64; 2] {
        [after.t.to_bits(), after.step]
    }

    fn start(&mut self, state: &ViewNd<'_, D>) {
        self.keep_reference_moduli(state);
        if self.history.is_empty() {
            let e = self.energies(state);
            self.history.push_back(e);
        }
    }

    fn judge(
        &mut self,
        before: &ViewNd<'_, D>,
        energies: (f64, f64),
        _dt: f64,
        metrics: &mut Metrics,
    ) -> Detection {
        let (e_after, _) = energies;
        let (e_before, ku_before) = match self.history.back() {
            Some(&b) => b,
            None => self.energies(before),
        };
        let (e_old, ku_old) = self
            .history
            .front()
            .copied()
            .unwrap_or((e_before, ku_before));
        metrics.insert("energy".into(), e_after);
        let jump = e_after - e_before > 0.5 * ku_before.max(f64::MIN_POSITIVE);
        let slow = self.history.len() > self.window
            && e_after - e_old > self.tol * ku_old.max(f64::MIN_POSITIVE);
        if !e_after.is_finite() || jump || slow {
            if slow {
                self.history.clear();
                self.history.push_back((e_before, ku_before));
            }
            Detection::Growing { suggested_dt: None }
        } else {
            Detection::Steady
        }
    }

    fn record(&mut self, e: (f64, f64)) {
        self.history.push_back(e);
        while self.history.len() > self.window + 1 {
            self.history.pop_front();
        }
    }

    fn growth_rejected(&mut self) {}

    /// The energy history and the kept moduli, for a checkpoint: restored, the monitor
    /// judges the next trials bit for bit as the run that went on.
    fn save_state(&self) -> Option<serde_json::Value> {
        serde_json::to_value((&self.history, &self.reference_moduli)).ok()
    }

    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), serde_json::Error> {
        (self.history, self.reference_moduli) = serde_json::from_value(state.clone())?;
        Ok(())
    }

    fn memory_bytes(&self) -> usize {
        self.reference_moduli.capacity() * std::mem::size_of::<(f64, f64)>()
    }
}
