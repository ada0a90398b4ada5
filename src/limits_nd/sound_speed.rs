//! The 2D/3D kernel of the speed-of-sound limit ([`crate::sound_speed`], where the rule,
//! its default and why it is not stable at α = 1 are documented): the view's
//! [`SignalSpeeds`], `min_p min_a h_a/(c_p + |v_{p,a}|)` with `c_p = √((λ_t + 2μ_t)/ρ)` the
//! P-wave speed of each particle's tangent moduli, or the stepper's own value
//! ([`crate::nd::SummaryNd::sound_unit_step`]) where it computed one in its pass.

use crate::limit::LimitError;
use crate::nd::ViewNd;
use crate::sound_speed::{SignalSpeeds, SOUND_SPEED};

/// `min_p min_a h_a/(c_p + |v_{p,a}|)` of `view` by a pass over its particles, or the first
/// particle whose wave speed is not finite.
pub fn pass_unit_step<const D: usize>(view: &ViewNd<'_, D>) -> Result<f64, LimitError> {
    let mut dt = f64::INFINITY;
    for p in 0..view.n_particles() {
        let c = view.p_wave_speed(p);
        if !c.is_finite() {
            return Err(LimitError::InvalidState {
                limit: SOUND_SPEED.into(),
                field: "wave speed",
                index: p,
                value: c,
                t: view.t,
            });
        }
        for a in 0..D {
            let s = view.grid.h[a] / (c + view.v[p][a].abs());
            dt = dt.min(s);
        }
    }
    Ok(dt)
}

impl<const D: usize> SignalSpeeds for ViewNd<'_, D> {
    fn sound_unit_step(&self) -> Result<f64, LimitError> {
        // The stepper's own minimum when it computed one in its pass (`SummaryNd`).
        match self.summary.and_then(|s| s.sound_unit_step) {
            Some(u) if u.is_finite() => Ok(u),
            _ => pass_unit_step(self),
        }
    }

    fn supplies_sound_unit_step(&self) -> bool {
        matches!(self.summary.and_then(|s| s.sound_unit_step), Some(u) if u.is_finite())
    }
}
