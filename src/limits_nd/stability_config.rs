//! [`StabilityNdConfig`]: the settings of the 2D/3D stability limit ([`super::StabilityNd`]),
//! reachable from the JSON config as `stability_nd` (its `safety` is the config's
//! `stability.safety`, shared with 1D).

use super::transfer::TransferNd;
use crate::config_error::{check, ConfigError};
use serde::{Deserialize, Serialize};

/// Settings of [`super::StabilityNd`].
///
/// In a JSON config these are the `stability_nd` object, every field but `safety`: the
/// safety is `stability.safety` ([`crate::controller::ControllerConfig::stability`]), one
/// number for every dimension, so a JSON `stability_nd.safety` is an unknown field.
/// [`crate::controller::standard_limits`] builds the limit from both. The default safety
/// is the controller config's default (0.95), so a limit built by hand with
/// `..StabilityNdConfig::default()` proposes what the standard limits propose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StabilityNdConfig {
    /// Fraction of `dt_eq56` proposed (default 0.95, the controller config's
    /// `stability.safety`). Not read from JSON (see above).
    #[serde(skip)]
    pub safety: f64,
    /// Refresh when a particle moved this many cells on some axis (default 0.5).
    pub refresh_cells: f64,
    /// Refresh when the smallest active nodal mass fell by this much, relative (default 0.1).
    pub refresh_mass: f64,
    /// Refresh when some particle's moduli grew by this much, relative (default 0.1);
    /// smaller growth scales the cached `λmax` instead (module docs). The scaling is a
    /// bound, so this threshold trades steps up to 10 % smaller against Lanczos runs:
    /// on the colliding spheres 0.05 refreshed 53 times (355 products) in 136 steps, 0.1
    /// refreshes 33 times (237 products) in the same 136 steps, a 22 % shorter run.
    pub refresh_modulus: f64,
    /// Refresh when, after a nodal mass fell, the largest diagonal entry of `A` grew by
    /// this much, relative (default 0.05); smaller growth scales the cached `λmax` by it —
    /// a heuristic (the diagonal bounds `λmax` from below only), so kept tighter than
    /// `refresh_modulus`.
    pub refresh_diagonal: f64,
    /// Refresh at least every this many proposals (default 200).
    pub max_age: u32,
    /// Lanczos tolerance (default 1e-2): residual below `tol·λ` or the value settled to
    /// `tol·λ/10` in one iteration; the Ritz value is raised by this fraction.
    pub tol: f64,
    /// Lanczos products per refresh at most (default 40).
    pub max_iter: usize,
    /// Multiplier on the refreshed `λmax` bound (default 1.0).
    pub margin: f64,
    /// The scheme's velocity transfer (default [`TransferNd::Flip`], the paper's USL):
    /// with [`TransferNd::Apic`] the limit is `√(2(1 + p)/λmax)`, `p` the transfer's
    /// Rayleigh quotient on the tracked top mode (`limits_nd/transfer.rs`).
    pub transfer: TransferNd,
    /// Step on the element bound when it is within `1 + bound_slack` of the Lanczos value
    /// (default 0.25; negative: never), [`crate::limits_nd::bound_tracking`].
    pub bound_slack: f64,
    /// In bound mode, run Lanczos again after this many proposals (default 50).
    pub bound_age: u32,
    /// The cost of one Lanczos product in bare steps, for deciding when stepping on the
    /// bound pays (default 0.5: a product gathers and scatters over the stencils once, a
    /// step about twice; [`crate::limits_nd::bound_tracking`]).
    pub product_cost: f64,
    /// Between Lanczos refreshes, track `λmax` by the element bound calibrated at the last
    /// one, `λ ≈ λ_L · B/B_L`, while `B` stays within this relative drift of `B_L`
    /// (default 0.5; negative: off, the raw-bound policy of `bound_slack` instead; under
    /// APIC on solids only), [`crate::limits_nd::bound_tracking`].
    pub bound_drift: f64,
    /// Propose from the critical step of the whole linearised FLIP step instead of its
    /// stress part (default `false`): `dt = safety · √(2/λ*)`, `λ* = λmax(A_s(I − Q_s/2))`
    /// ([`crate::stability::nodal_full_map`]), which is 1–√2 times eq 56's step (measured
    /// 1.04–1.10 on the scenarios, 1.0005–1.003 at a light node). At every Lanczos refresh
    /// a second Lanczos run in the
    /// `I − Q_s/2` inner product, warm-started from eq 56's Ritz vector, gives
    /// `gain = λmax/λ*` (at most 2), and the step is `safety·√(2·gain/λ)` until the next
    /// refresh ([`crate::limits_nd::stability`]). FLIP only (the APIC transfer has a
    /// map of its own: an error); on a run over several processes the gain stays 1 (eq 56).
    pub full_map: bool,
}

impl Default for StabilityNdConfig {
    fn default() -> Self {
        Self {
            safety: 0.95,
            refresh_cells: 0.5,
            refresh_mass: 0.1,
            refresh_modulus: 0.1,
            refresh_diagonal: 0.05,
            max_age: 200,
            tol: 1e-2,
            max_iter: 40,
            margin: 1.0,
            transfer: TransferNd::Flip,
            bound_slack: 0.25,
            bound_age: 50,
            product_cost: 0.5,
            bound_drift: 0.5,
            full_map: false,
        }
    }
}

impl StabilityNdConfig {
    /// Checks every field; the error names the first offending one by its JSON path
    /// (`stability_nd.…`, `stability.safety`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let positive = |field, v: f64| check(field, v, v.is_finite() && v > 0.0, "finite and > 0");
        check(
            "stability.safety",
            self.safety,
            self.safety > 0.0 && self.safety <= 1.0,
            "in (0, 1]",
        )?;
        positive("stability_nd.refresh_cells", self.refresh_cells)?;
        positive("stability_nd.refresh_mass", self.refresh_mass)?;
        positive("stability_nd.refresh_modulus", self.refresh_modulus)?;
        positive("stability_nd.refresh_diagonal", self.refresh_diagonal)?;
        let max_age = f64::from(self.max_age);
        check("stability_nd.max_age", max_age, self.max_age >= 1, ">= 1")?;
        check(
            "stability_nd.tol",
            self.tol,
            self.tol > 0.0 && self.tol < 1.0,
            "in (0, 1)",
        )?;
        let max_iter = self.max_iter as f64;
        check(
            "stability_nd.max_iter",
            max_iter,
            self.max_iter >= 2,
            ">= 2",
        )?;
        positive("stability_nd.margin", self.margin)?;
        if let TransferNd::Apic { inertia } = self.transfer {
            positive("stability_nd.transfer.apic.inertia", inertia)?;
        }
        check(
            "stability_nd.bound_slack",
            self.bound_slack,
            self.bound_slack.is_finite(),
            "finite (negative: never step on the bound)",
        )?;
        let bound_age = f64::from(self.bound_age);
        check(
            "stability_nd.bound_age",
            bound_age,
            self.bound_age >= 1,
            ">= 1",
        )?;
        check(
            "stability_nd.product_cost",
            self.product_cost,
            self.product_cost.is_finite() && self.product_cost >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "stability_nd.bound_drift",
            self.bound_drift,
            self.bound_drift.is_finite(),
            "finite (negative: no calibrated bound)",
        )?;
        check(
            "stability_nd.full_map",
            1.0,
            !self.full_map || self.transfer == TransferNd::Flip,
            "true only with the FLIP transfer (APIC's map is another)",
        )
    }
}
