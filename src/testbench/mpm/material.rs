//! Constitutive models of the reference solver: the stress update of eq 27 and its
//! nonlinear counterpart.
//!
//! In 1D the cross-section does not change, so the Cauchy stress equals the first
//! Piola–Kirchhoff stress: `σ = P = dW/dF` for a stored energy `W(F)` per reference volume.
//! Every material reports its *tangent modulus* `E_t = F dσ/dF = dσ/d(ln F)`, the `E` that
//! the stability analysis of eqs 50–56 sees for small perturbations about the current state
//! (a velocity-gradient perturbation `δL` changes `ln F` by `dt δL` and `σ` by `dt E_t δL`),
//! and the wave speed `c = √(E_t/ρ)` with the current density `ρ = m/(F V⁰)`.

use serde::{Deserialize, Serialize};

/// An elastic material of the reference 1D solver.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Material {
    /// Linear elasticity in the paper's rate form, eq 16 / eq 27:
    /// `σⁿ⁺¹ = σⁿ + dt E ∂v/∂x`. Integrated exactly in time this is the Hencky law
    /// `σ = E ln F` (because `ḞF⁻¹ = ∂v/∂x`), so the tangent modulus is `E` at every `F`.
    LinearElastic {
        /// Young's modulus `E` (stress units, > 0).
        youngs_modulus: f64,
    },
    /// 1D neo-Hookean with Lamé `λ = 0` and shear modulus `μ = E/2`:
    /// `W(F) = (E/4)(F² − 1 − 2 ln F)`, `σ(F) = (E/2)(F − 1/F)`,
    /// tangent `E_t = F σ′(F) = (E/2)(F + 1/F)` (equal to `E` at `F = 1`, larger in both
    /// tension and compression, so the wave speed depends on `F`). The stress is evaluated
    /// from `Fⁿ⁺¹` directly (no rate form).
    NeoHookean {
        /// Young's modulus `E` at zero strain (> 0).
        youngs_modulus: f64,
    },
}

impl Default for Material {
    fn default() -> Self {
        Material::LinearElastic {
            youngs_modulus: 1.0,
        }
    }
}

impl Material {
    /// Young's modulus `E` (the small-strain modulus for neo-Hookean).
    pub fn youngs_modulus(&self) -> f64 {
        match *self {
            Material::LinearElastic { youngs_modulus }
            | Material::NeoHookean { youngs_modulus } => youngs_modulus,
        }
    }

    /// Stress `σ(F)` of a particle deformed by `F` from a stress-free state: `E ln F`
    /// (linear, the exact integral of eq 16) or `(E/2)(F − 1/F)` (neo-Hookean).
    pub fn stress(&self, f: f64) -> f64 {
        match *self {
            Material::LinearElastic { youngs_modulus } => youngs_modulus * f.ln(),
            Material::NeoHookean { youngs_modulus } => 0.5 * youngs_modulus * (f - 1.0 / f),
        }
    }

    /// Tangent modulus `E_t = F dσ/dF`: `E` (linear) or `(E/2)(F + 1/F)` (neo-Hookean).
    #[inline]
    pub fn tangent_modulus(&self, f: f64) -> f64 {
        match *self {
            Material::LinearElastic { youngs_modulus } => youngs_modulus,
            Material::NeoHookean { youngs_modulus } => 0.5 * youngs_modulus * (f + 1.0 / f),
        }
    }

    /// Longitudinal wave speed `c = √(E_t(F)/ρ)` at deformation `f` and current density
    /// `density`.
    pub fn wave_speed(&self, f: f64, density: f64) -> f64 {
        (self.tangent_modulus(f) / density).sqrt()
    }

    /// Stored energy per *reference* volume of a particle with stress `sigma` and
    /// deformation `f`. Linear: the small-strain energy `σ²/(2E)`, computed from the stress
    /// because the rate form (eq 27) carries the stress, not `F`, as its state.
    /// Neo-Hookean: `W(F) = (E/4)(F² − 1 − 2 ln F)`.
    pub fn energy_density(&self, sigma: f64, f: f64) -> f64 {
        match *self {
            Material::LinearElastic { youngs_modulus } => 0.5 * sigma * sigma / youngs_modulus,
            Material::NeoHookean { youngs_modulus } => {
                0.25 * youngs_modulus * (f * f - 1.0 - 2.0 * f.ln())
            }
        }
    }
}
