//! Which fields of a [`ControllerConfig`] apply in which dimension.
//!
//! One config serves every dimension, and every field means the same wherever it applies:
//!
//! | fields | 1D | 2D/3D |
//! |---|---|---|
//! | the controller's own (`dt_*`, `safety`, growth and shrink factors, `filter`, `order`, rejections) | ✓ | ✓ |
//! | `sound_speed.alpha` | ✓ | ✓ |
//! | `stability` (`null` leaves the limit out), `stability.safety` | ✓ | ✓ |
//! | `stability.tol`, `reading`, `lanczos`, `tracking`, `bound58_every` (eq 58, the certified tracker) | ✓ | refused |
//! | `stability_nd.*` (λmax tracking by Lanczos, motion guard, element bound, APIC transfer) | refused | ✓ |
//! | `temporal.*` but `balance` | ✓ | ✓ |
//! | `temporal.balance` (eq 44's spatial error: the 1D estimators) | ✓ | refused |
//! | `growth.enabled`, `window`, `windows`, `safety_factor`, `min_safety_scale` | ✓ | ✓ |
//! | `growth.indicator`, `factor`, `floor`, `energy_confirm` (the checkerboard share) | ✓ | refused |
//! | `growth.energy_tol` (the 2D/3D energy monitor's tolerance) | refused | ✓ |
//! | `gravity` (the 2D/3D energy monitor's potential energy; one component per axis) | refused | ✓ |
//!
//! "Refused": a value other than the default is a [`ConfigError::NotInDimension`] naming
//! the field, so that no setting is ignored without a word. The growth monitors differ by
//! dimension: the 1D monitor watches the checkerboard share of the nodal accelerations
//! confirmed by the energy, the 2D/3D monitor the mechanical energy over
//! `windows × window` steps ([`crate::limits_nd::GrowthNd`]); what they share means the
//! same in both.

// "Set" means "differs from the default", bit for bit: exact float comparison is the point.
#![allow(clippy::float_cmp)]

use super::config::{ConfigError, ControllerConfig};
use crate::growth::GrowthConfig;
use crate::limits_nd::StabilityNdConfig;
use crate::stability::StabilityConfig;

const ONE_D_STABILITY: &str = "the 1D stability limit (eq 58, the certified tracker)";
const ONE_D_GROWTH: &str = "the 1D growth monitor (checkerboard share)";
const ND_STABILITY: &str = "the 2D/3D stability limit's λmax tracking";
const ND_GROWTH: &str = "the 2D/3D growth monitor (energy)";
const ONE_D_TEMPORAL: &str = "the 1D temporal error's balance with eq 44's spatial error";

impl ControllerConfig {
    /// [`Self::validate`], and every field that does not apply in `dim` dimensions left at
    /// its default (module docs); the controller calls it with its dimension.
    pub fn validate_for(&self, dim: usize) -> Result<(), ConfigError> {
        self.validate()?;
        let refuse = |field, applies| {
            Err(ConfigError::NotInDimension {
                field,
                dim,
                applies,
            })
        };
        if dim == 1 {
            if let Some(field) = changed_nd_stability(&self.stability_nd) {
                return refuse(field, ND_STABILITY);
            }
            if self.growth.energy_tol != GrowthConfig::default().energy_tol {
                return refuse("growth.energy_tol", ND_GROWTH);
            }
            if self.gravity.is_some() {
                return refuse("gravity", ND_GROWTH);
            }
        } else {
            if let Some(g) = &self.gravity {
                if g.len() != dim {
                    return Err(ConfigError::WrongLength {
                        field: "gravity",
                        len: g.len(),
                        dim,
                    });
                }
            }
            if let Some(field) = self.stability.as_ref().and_then(changed_1d_stability) {
                return refuse(field, ONE_D_STABILITY);
            }
            if let Some(field) = changed_1d_growth(&self.growth) {
                return refuse(field, ONE_D_GROWTH);
            }
            if self.temporal.balance.is_some() {
                return refuse("temporal.balance", ONE_D_TEMPORAL);
            }
            // A Rust caller may set `stability_nd.safety`; the limit uses `stability.safety`.
            // (Without the limit, `stability: null`, neither is used.)
            let nd = self.stability_nd.safety;
            if let Some(shared) = self.stability.as_ref().map(|s| s.safety) {
                if nd != StabilityNdConfig::default().safety && nd != shared {
                    return Err(ConfigError::Inconsistent {
                        field: "stability_nd.safety",
                        value: nd,
                        other: "stability.safety",
                        other_value: shared,
                    });
                }
            }
        }
        Ok(())
    }
}

/// The first 1D-only stability field that differs from its default.
fn changed_1d_stability(c: &StabilityConfig) -> Option<&'static str> {
    let d = StabilityConfig::default();
    [
        ("stability.tol", c.tol != d.tol),
        ("stability.reading", c.reading != d.reading),
        ("stability.lanczos", c.lanczos != d.lanczos),
        ("stability.tracking", c.tracking != d.tracking),
        (
            "stability.bound58_every",
            c.bound58_every != d.bound58_every,
        ),
    ]
    .into_iter()
    .find_map(|(field, changed)| changed.then_some(field))
}

/// The first 1D-only growth field that differs from its default.
fn changed_1d_growth(c: &GrowthConfig) -> Option<&'static str> {
    let d = GrowthConfig::default();
    [
        ("growth.indicator", c.indicator != d.indicator),
        ("growth.factor", c.factor != d.factor),
        ("growth.floor", c.floor != d.floor),
        (
            "growth.energy_confirm",
            c.energy_confirm != d.energy_confirm,
        ),
    ]
    .into_iter()
    .find_map(|(field, changed)| changed.then_some(field))
}

/// The first `stability_nd` field that differs from its default (its safety is
/// `stability.safety` and is not compared).
fn changed_nd_stability(c: &StabilityNdConfig) -> Option<&'static str> {
    let d = StabilityNdConfig::default();
    [
        (
            "stability_nd.refresh_cells",
            c.refresh_cells != d.refresh_cells,
        ),
        (
            "stability_nd.refresh_mass",
            c.refresh_mass != d.refresh_mass,
        ),
        (
            "stability_nd.refresh_modulus",
            c.refresh_modulus != d.refresh_modulus,
        ),
        (
            "stability_nd.refresh_diagonal",
            c.refresh_diagonal != d.refresh_diagonal,
        ),
        ("stability_nd.max_age", c.max_age != d.max_age),
        ("stability_nd.tol", c.tol != d.tol),
        ("stability_nd.max_iter", c.max_iter != d.max_iter),
        ("stability_nd.margin", c.margin != d.margin),
        ("stability_nd.transfer", c.transfer != d.transfer),
        ("stability_nd.bound_slack", c.bound_slack != d.bound_slack),
        ("stability_nd.bound_age", c.bound_age != d.bound_age),
        (
            "stability_nd.product_cost",
            c.product_cost != d.product_cost,
        ),
        ("stability_nd.bound_drift", c.bound_drift != d.bound_drift),
        ("stability_nd.full_map", c.full_map != d.full_map),
    ]
    .into_iter()
    .find_map(|(field, changed)| changed.then_some(field))
}
