//! The 1D kernel of the speed-of-sound limit ([`crate::sound_speed`], where the rule, its
//! default and why it is not stable at α = 1 are documented): the 1D view's
//! [`SignalSpeeds`], with the view's vectorised validation in the same pass, and the
//! paper's eq 49 step as printed.
//!
//! In 1D the rule's minimum `min_p h/(c_p + |v_p|)` is formed as `h / max_p (c_p + |v_p|)`
//! (the same number: division is monotone and correctly rounded), `c_p = √(E_t,p/ρ_p)`.
//! A trusted [`crate::PassSummary`] carrying
//! [`max_signal_speed`](crate::PassSummary::max_signal_speed) spares the pass; one without
//! it is trusted for the checks and the maximum is taken by a plain pass.

use super::error::{check_view_speeds, StabilityError};
use crate::limit::LimitError;
use crate::sound_speed::{SignalSpeeds, SoundSpeed, SOUND_SPEED};
use crate::stepper::View;

impl SignalSpeeds for View<'_> {
    fn sound_unit_step(&self) -> Result<f64, LimitError> {
        let speeds =
            check_view_speeds(self).map_err(|e| e.into_limit_error(SOUND_SPEED, self.t))?;
        Ok(self.grid.h / speeds.signal)
    }
}

impl SoundSpeed {
    /// `(c_max, ‖v‖_∞)` of a 1D state (wave speed from the tangent modulus and density),
    /// after the view's validation, in the same pass over the particles; `c_max` is
    /// `√(max_p E_t,p/ρ_p)`, which equals `max_p` [`View::wave_speed`] bit for bit because
    /// `√` is monotone and correctly rounded.
    pub fn speeds(view: &View<'_>) -> Result<(f64, f64), StabilityError> {
        let s = check_view_speeds(view)?;
        Ok((s.c2.sqrt(), s.v))
    }

    /// The eq 49 step `h/c_max` of a 1D state (α = 1, particles at rest): the paper's rule
    /// as printed.
    pub fn dt_eq49(view: &View<'_>) -> Result<f64, StabilityError> {
        let (c, _) = Self::speeds(view)?;
        Ok(view.grid.h / c)
    }
}
