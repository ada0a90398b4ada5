//! The field scales of the temporal error's weights: one rule for every dimension.
//!
//! The weight of a particle's local error is `w_u,p = atol_u + atol_rel · s_u + rtol · û_p`
//! (eqs 20–30 scaled SUNDIALS-style; module docs of the limits). `s_u` is the field's scale
//! `‖u‖_∞` in energy-equivalent units (a vibrating body swaps its energy between `v` and
//! `σ`, so `‖v‖_∞ = max(max_p v̂_p, max_p σ̂_p/z_p)` and `‖σ‖_∞ = max(max_p σ̂_p,
//! max_p v̂_p z_p)` with the P-wave impedance `z_p`), taken over the committed and the trial
//! state: *this check's* scales. The weights also remember the last checked step's scales,
//! so that a field passing through zero everywhere at once (the stress of a released
//! standing wave) is not judged against its own `O(dt)` size:
//!
//! ```text
//! s = s_prev                    while neither scale grew by more than 10 % (SCALE_SLACK)
//! s = max(s_new, s_prev)        (both fields) once one did;   s = s_new on the first check
//! ```
//!
//! **Why this rule.** The 1D limit used to take `max(s_new, s_prev)` always, the 2D/3D
//! limit this one; one rule serves both now. It lets a check form its weights *before* its
//! pass over the particles (the new scales are known only after it) and take the sums in
//! that one pass, redoing them only when a scale grew by more than the slack (a run
//! gaining energy). Within the slack the weights are at most 10 % smaller in their
//! `atol_rel` part than `max(s_new, s_prev)` would make them: a slightly stricter test,
//! never a looser one. The scales kept for the next check are this check's own `s_new`.

/// How much a field scale may grow before a check's weights take the new one (module docs).
pub const SCALE_SLACK: f64 = 0.1;

/// The field scales `(‖v‖_∞, ‖σ‖_∞)` a check's weights use (module docs), from this check's
/// scales `new` and the last checked step's `prev` (`None` on the first check, or after the
/// history was lost).
pub fn weight_scales(new: (f64, f64), prev: Option<(f64, f64)>) -> (f64, f64) {
    let Some(prev) = prev else {
        return new;
    };
    if grew(new.0, prev.0) || grew(new.1, prev.1) {
        (new.0.max(prev.0), new.1.max(prev.1))
    } else {
        prev
    }
}

/// Whether a scale grew by more than [`SCALE_SLACK`].
fn grew(new: f64, prev: f64) -> bool {
    new > (1.0 + SCALE_SLACK) * prev
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_previous_scales_hold_within_the_slack_and_the_larger_beyond_it() {
        assert_eq!(weight_scales((2.0, 3.0), None), (2.0, 3.0));
        // Within 10 %, or smaller: the previous scales, both.
        assert_eq!(weight_scales((1.05, 0.5), Some((1.0, 1.0))), (1.0, 1.0));
        // One grew by more: the larger of each pair.
        assert_eq!(weight_scales((1.2, 0.5), Some((1.0, 1.0))), (1.2, 1.0));
        assert_eq!(weight_scales((0.5, 2.0), Some((1.0, 1.0))), (1.0, 2.0));
        // A zero previous scale: any positive new one grew.
        assert_eq!(
            weight_scales((1e-300, 0.0), Some((0.0, 0.0))),
            (1e-300, 0.0)
        );
    }
}
