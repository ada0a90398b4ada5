//! [`SoundSpeedNd`]: the speed-of-sound step in d dimensions (eq 49 generalised),
//! `dt = α · min_p min_a h_a / (c_p + |v_{p,a}|)`, `c_p = √((λ_t + 2μ_t)/ρ)` the P-wave
//! speed of each particle's tangent moduli — the rule Uintah applies per axis.
//!
//! α = 1 is *not* stable for this method: eq 56 gives `h/(√2 c_p)` on uniform GIMP and
//! linear layouts, so a bare sound-speed rule needs α ≲ 0.7 and more on layouts with small
//! nodal masses. The controller uses it as a cap next to [`super::StabilityNd`].

use crate::dimension::{Dim, Dimension};
use crate::limit::{LimitError, Proposal, StepLimit};
use crate::nd::ViewNd;

/// Name in logs: `"sound_speed"`.
pub const SOUND_SPEED: &str = "sound_speed";

/// The speed-of-sound limit in d dimensions.
#[derive(Clone, Debug, PartialEq)]
pub struct SoundSpeedNd {
    /// The multiplier α (> 0).
    pub alpha: f64,
}

impl SoundSpeedNd {
    /// `h_min`-scaled step `min_p min_a h_a/(c_p + |v_{p,a}|)` of `view` (α = 1), or the
    /// first invalid particle value.
    pub fn unit_step<const D: usize>(view: &ViewNd<'_, D>) -> Result<f64, LimitError> {
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
}

impl<const D: usize> StepLimit<D> for SoundSpeedNd
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    fn name(&self) -> &str {
        SOUND_SPEED
    }

    fn propose(&mut self, state: &ViewNd<'_, D>) -> Result<Proposal, LimitError> {
        // The stepper's own minimum when it computed one in its pass (`SummaryNd`).
        let unit = match state.summary.and_then(|s| s.sound_unit_step) {
            Some(u) if u.is_finite() => u,
            _ => Self::unit_step(state)?,
        };
        let dt = self.alpha * unit;
        Ok(Proposal {
            dt,
            metrics: Default::default(),
        })
    }
}
