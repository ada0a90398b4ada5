//! [`CertifiedConfig`]: the settings of [`super::CertifiedTracker`] (module docs of [`super`]).

use crate::stability::error::StabilityError;

/// Settings of [`super::CertifiedTracker`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CertifiedConfig {
    /// Relative margin of the served and certified value above the Rayleigh quotient,
    /// `λ̂ = (1 + margin) ρ` (default `10⁻³`, i.e. `dt` 0.05 % below the quotient's: the warm
    /// Lanczos stops when its Ritz value moves less than `10⁻⁴` relative per iteration, so the
    /// top eigenvalue is usually within this margin and the certificate passes first time).
    pub margin: f64,
    /// Certify (anchor) at least every this many proposals (default 20; 1 certifies every
    /// step).
    pub certify_every: u32,
    /// Anchor at once when the Rayleigh quotient has dropped by more than this relative amount
    /// since the last anchor (default `2·10⁻²`). On a 10⁵-particle bar the quotient of a
    /// fixed vector in the (very clustered) top of the spectrum moves by up to 1 % per step
    /// while λmax does not, so a tighter value re-anchors at almost every step; a stale mode
    /// can hide at most this much of λmax (`dt` 1 % high) for at most `certify_every`
    /// proposals, inside the `Stability` safety factor.
    pub drop_tol: f64,
    /// Taper a Lanczos mode to a window of 512 nodes around its largest component before
    /// serving it, when that keeps its Rayleigh quotient within `margin / 10` (default
    /// `true`; grids under 2048 nodes are never windowed). The served pass skips the nodes
    /// where the mode is zero, so it then costs the localised price from the first step
    /// instead of after the ~100–300 steps the power steps take to localise a Ritz vector
    /// (`stability/localise.rs`; measured: README "Stability").
    pub localise: bool,
    /// Serve proposals between anchors on the element bound when a view carries no `K_N`
    /// (default `false`; module docs, "Between anchors on the bound"): the stepper's bound
    /// ([`crate::PassSummary::element_bound`]), or the library's own from the view's GIMP
    /// weights. The tracker then asks for `K_N` only on the states it computes on it. Opt-in: faster on
    /// smooth problems, less tight on strongly nonlinear ones (measured in the module docs).
    pub on_bound: bool,
    /// Relative move of the element bound since the last proposal computed on `K_N`, either
    /// way, after which the next proposal is computed on `K_N` again (default `0.05`).
    pub bound_drift: f64,
}

impl Default for CertifiedConfig {
    fn default() -> Self {
        Self {
            margin: 1e-3,
            certify_every: 20,
            drop_tol: 2e-2,
            localise: true,
            on_bound: false,
            bound_drift: 0.05,
        }
    }
}

impl CertifiedConfig {
    /// Checks `margin > 0`, `drop_tol ≥ 0`, `bound_drift ≥ 0` (all finite) and
    /// `certify_every ≥ 1`.
    pub fn validate(&self) -> Result<(), StabilityError> {
        if !(self.margin > 0.0 && self.margin.is_finite()) {
            return Err(StabilityError::InvalidConfig {
                field: "certified.margin",
                value: self.margin,
                reason: "must be positive and finite",
            });
        }
        if !(self.drop_tol >= 0.0 && self.drop_tol.is_finite()) {
            return Err(StabilityError::InvalidConfig {
                field: "certified.drop_tol",
                value: self.drop_tol,
                reason: "must be non-negative and finite",
            });
        }
        if !(self.bound_drift >= 0.0 && self.bound_drift.is_finite()) {
            return Err(StabilityError::InvalidConfig {
                field: "certified.bound_drift",
                value: self.bound_drift,
                reason: "must be non-negative and finite",
            });
        }
        if self.certify_every == 0 {
            return Err(StabilityError::InvalidConfig {
                field: "certified.certify_every",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        Ok(())
    }
}
