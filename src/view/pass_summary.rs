//! [`PassSummary`]: what a stepper checked and measured while its own pass wrote a state.
//!
//! Every limit reads every view, and three of them would otherwise each make a pass over
//! the particles for a handful of reductions: the stability module validates the fields
//! and takes `max_p E_t,p/ρ_p`, `max_p |v_p|` and `max_p (c_p + |v_p|)` (the sound-speed
//! limit, eq 49), the growth
//! monitor sums the total energy, and the controller looks for a non-finite value in the
//! trial. A solver's step already touches every particle once; it can take the same
//! reductions there, in registers, for a few operations per particle (measured: README
//! "Controller overhead"). A stepper that does so attaches a `PassSummary` to the views of
//! the states its passes wrote ([`crate::View::summary`]), when the controller asks
//! ([`crate::Stepper::provide_summary`]); the limits then skip their scans.
//!
//! **The contract.** `Some(summary)` on a view is the stepper's guarantee that the view
//! passes the checks of the stability module — finite `x`, `v`, `σ`; positive finite `F`,
//! `V⁰`, `m_p`, `E_t`, `ρ`; positive finite mass at every active node; at least one active
//! node — and that the three numbers are what the library would compute from the view:
//!
//! ```text
//! max_wave_speed_sq = max_p E_t,p / ρ_p      (E_t and ρ the view's own fields, one division)
//! max_speed         = max_p |v_p|
//! total_energy      = controller::total_energy(view)   (the same lanes, the same bits)
//! ```
//!
//! A stepper may add the element bound ([`PassSummary::element_bound`], from the weights
//! its pass evaluates anyway); it vouches that the value is the formula's over the view's
//! own weights, moduli and masses. It may add the largest signal speed
//! ([`PassSummary::max_signal_speed`], `max_p (√(E_t,p/ρ_p) + |v_p|)`, the speed-of-sound
//! limit's maximum); without it that limit takes it by a pass of its own.
//!
//! The maxima do not depend on the order of the particles, so a stepper computes them in
//! any order; the energy must follow [`crate::controller::total_energy`]'s grouping (particle
//! `p` in lane `p mod 4`, lanes added in order) to give the same bits. A stepper that cannot
//! guarantee all of it leaves the summary out; the limits then check the view themselves.
//!
//! **Stamped to its view.** A stepper builds the summary with [`PassSummary::new`] and
//! attaches it to a view with [`PassSummary::stamp`], which records where the view's
//! arrays live. The library reads it through [`crate::View::trusted_summary`], which ignores
//! a summary whose view's arrays are not the stamped ones: a view rebuilt from another with
//! a field replaced (`View { sigma, ..*view }`) falls back to the checks instead of
//! inheriting a guarantee about other data. The stamp is not serialized (a deserialized
//! summary is never trusted).

use super::View;
use serde::{Deserialize, Serialize};

/// Reductions over one state's particles taken by the stepper's pass (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassSummary {
    /// `max_p E_t,p/ρ_p`, the squared largest wave speed \[length²/time²\].
    pub max_wave_speed_sq: f64,
    /// `max_p |v_p|` \[length/time\].
    pub max_speed: f64,
    /// Kinetic plus stored energy, `Σ_p ½ m_p v_p² + ½ σ_p² F_p V_p⁰ / E_t,p`, summed as
    /// [`crate::controller::total_energy`] sums it.
    pub total_energy: f64,
    /// An upper bound on `λmax` of the state's eq 56 operator, `B = max_p (E_t,p V_p/m_p)
    /// Σ_i D_ip²/S_ip` (the element eigenvalue inequality with particles as elements,
    /// `λmax(M⁻¹K) ≤ max_p λmax(M_p⁻¹K_p)`, `M_p = diag(m_p S_ip)`, `K_p = E_t,p V_p d_p d_pᵀ`),
    /// or `None` when the stepper does not take it. `+∞` where some `S_ip = 0` has
    /// `D_ip ≠ 0` (linear hats at a node). The certified tracker serves proposals between
    /// its anchors from it ([`crate::stability::certified`], "Between anchors on the bound").
    #[serde(default)]
    pub element_bound: Option<f64>,
    /// `max_p (√(E_t,p/ρ_p) + |v_p|)`, the largest signal speed, from which the
    /// speed-of-sound limit forms its step `α h / max_p(c_p + |v_p|)`
    /// ([`crate::sound_speed`]); `None` when the stepper does not take it (the limit then
    /// takes it by a pass of its own). Each particle's `√` is `f64::sqrt` of the same
    /// quotient `E_t/ρ` the view's fields give ([`crate::View::wave_speed`]).
    #[serde(default)]
    pub max_signal_speed: Option<f64>,
    /// The view it was stamped for ([`PassSummary::stamp`]); `None` until stamped.
    #[serde(skip)]
    stamp: Option<Stamp>,
}

/// Addresses and lengths of the arrays of a view that a summary vouches for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Stamp([(usize, usize); 10]);

impl Stamp {
    fn of(view: &View<'_>) -> Self {
        let a = |s: &[f64]| (s.as_ptr() as usize, s.len());
        Stamp([
            a(view.x),
            a(view.v),
            a(view.sigma),
            a(view.f),
            a(view.volume0),
            a(view.mass),
            a(view.tangent_modulus),
            a(view.density),
            a(view.node_mass),
            (view.node_active.as_ptr() as usize, view.node_active.len()),
        ])
    }
}

impl PassSummary {
    /// A summary with these reductions, not yet stamped to a view.
    pub fn new(max_wave_speed_sq: f64, max_speed: f64, total_energy: f64) -> Self {
        Self {
            max_wave_speed_sq,
            max_speed,
            total_energy,
            element_bound: None,
            max_signal_speed: None,
            stamp: None,
        }
    }

    /// The summary with its [`Self::element_bound`] set.
    pub fn with_element_bound(self, bound: f64) -> Self {
        Self {
            element_bound: Some(bound),
            ..self
        }
    }

    /// The summary with its [`Self::max_signal_speed`] set.
    pub fn with_signal_speed(self, speed: f64) -> Self {
        Self {
            max_signal_speed: Some(speed),
            ..self
        }
    }

    /// The summary stamped for `view`, the stepper's view of the state it describes.
    pub fn stamp(self, view: &View<'_>) -> Self {
        Self {
            stamp: Some(Stamp::of(view)),
            ..self
        }
    }

    /// Whether the summary was stamped for a view with exactly these arrays.
    pub fn describes(&self, view: &View<'_>) -> bool {
        self.stamp == Some(Stamp::of(view))
    }
}
