//! Constitutive models of the d-dimensional reference solver.
//!
//! * [`MaterialNd::LinearElastic`]: hypoelastic linear elasticity,
//!   `σ ← σ + dt (λ tr(ε̇) I + 2μ ε̇)`, `ε̇ = sym(L)`, no objective rate (docs/design.md: "the USL
//!   step in d dimensions"); with `ν = 0` and `d = 1` it is the 1D rate law of eq 27.
//! * [`MaterialNd::NeoHookean`]: compressible neo-Hookean, evaluated from `F` directly:
//!   `σ = (μ/J)(F Fᵀ − I) + (λ/J) ln J · I`, stored energy per reference volume
//!   `W = μ/2 (tr(FᵀF) − d) − μ ln J + λ/2 (ln J)²`.
//!
//! Lamé parameters from Young's modulus and Poisson's ratio:
//! `λ = Eν/((1+ν)(1−2ν))`, `μ = E/(2(1+ν))`. Each material reports *tangent* Lamé moduli
//! for the stability analysis ([`crate::nd::ViewNd`]): the linear material its `λ, μ`; the
//! neo-Hookean the isotropic tangent of the Cauchy stress about a *dilated* state
//! `F = J^{1/d} I`, `λ_t = λ/J`, `μ_t = (μ − λ ln J)/J` (equal to `λ, μ` at rest). Under
//! shear the true tangent is anisotropic; this is its small-strain value.

use crate::nd::Tensor;
use serde::{Deserialize, Serialize};

/// An elastic material of the d-dimensional reference solver.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MaterialNd {
    /// Hypoelastic linear elasticity.
    LinearElastic {
        /// Young's modulus `E` (> 0).
        youngs_modulus: f64,
        /// Poisson's ratio `ν` (`0 ≤ ν < ½`).
        poisson_ratio: f64,
    },
    /// Compressible neo-Hookean.
    NeoHookean {
        /// Young's modulus `E` at zero strain (> 0).
        youngs_modulus: f64,
        /// Poisson's ratio `ν` at zero strain (`0 ≤ ν < ½`).
        poisson_ratio: f64,
    },
}

impl MaterialNd {
    /// Young's modulus.
    pub fn youngs_modulus(&self) -> f64 {
        match *self {
            MaterialNd::LinearElastic { youngs_modulus, .. }
            | MaterialNd::NeoHookean { youngs_modulus, .. } => youngs_modulus,
        }
    }

    /// Poisson's ratio.
    pub fn poisson_ratio(&self) -> f64 {
        match *self {
            MaterialNd::LinearElastic { poisson_ratio, .. }
            | MaterialNd::NeoHookean { poisson_ratio, .. } => poisson_ratio,
        }
    }

    /// Lamé parameters `(λ, μ)` at zero strain.
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus(), self.poisson_ratio());
        (
            e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            e / (2.0 * (1.0 + nu)),
        )
    }

    /// P-wave modulus `λ + 2μ` at zero strain.
    pub fn p_modulus(&self) -> f64 {
        let (l, m) = self.lame();
        l + 2.0 * m
    }

    /// Tangent Lamé moduli `(λ_t, μ_t)` at a state with `det F = j` (module docs).
    #[inline]
    pub fn tangent(&self, j: f64) -> (f64, f64) {
        self.tangent_with(self.lame(), j)
    }

    /// [`Self::tangent`] with the material's [`Self::lame`] pair `(l, m)` given (formed
    /// once for a run of particles of one material: [`LameCache`]).
    #[inline]
    pub(super) fn tangent_with(&self, (l, m): (f64, f64), j: f64) -> (f64, f64) {
        match self {
            MaterialNd::LinearElastic { .. } => (l, m),
            MaterialNd::NeoHookean { .. } => (l / j, (m - l * j.ln()) / j),
        }
    }

    /// The stress after a step: `σ_old + dt(λ tr(ε̇) I + 2μ ε̇)` (linear) or `σ(F_new)`
    /// (neo-Hookean); `l` the velocity gradient of the step.
    #[inline]
    pub fn update<const D: usize>(
        &self,
        sigma_old: &Tensor<D>,
        l: &Tensor<D>,
        f_new: &Tensor<D>,
        dt: f64,
    ) -> Tensor<D> {
        self.update_with(self.lame(), sigma_old, l, f_new, dt)
    }

    /// [`Self::update`] with the material's [`Self::lame`] pair given ([`LameCache`]).
    #[inline]
    pub(super) fn update_with<const D: usize>(
        &self,
        (lambda, mu): (f64, f64),
        sigma_old: &Tensor<D>,
        l: &Tensor<D>,
        f_new: &Tensor<D>,
        dt: f64,
    ) -> Tensor<D> {
        match self {
            MaterialNd::LinearElastic { .. } => {
                let eps = (l + l.transpose()) * 0.5;
                sigma_old
                    + (Tensor::<D>::identity() * (lambda * eps.trace()) + eps * (2.0 * mu)) * dt
            }
            MaterialNd::NeoHookean { .. } => {
                let j = crate::nd::det(f_new);
                (f_new * f_new.transpose() - Tensor::<D>::identity()) * (mu / j)
                    + Tensor::<D>::identity() * (lambda * j.ln() / j)
            }
        }
    }

    /// Stored energy of a particle of reference volume `v0`, deformation `f` and stress
    /// `sigma`: `det(F) V⁰ · ½ σ:C⁻¹:σ` (linear; `C⁻¹σ = (σ − λ tr σ/(2μ + dλ) I)/(2μ)`)
    /// or `V⁰ W(F)` (neo-Hookean).
    pub fn energy<const D: usize>(&self, sigma: &Tensor<D>, f: &Tensor<D>, v0: f64) -> f64 {
        let j = crate::nd::det(f);
        match *self {
            MaterialNd::LinearElastic {
                youngs_modulus: e,
                poisson_ratio: nu,
            } => {
                // ½ σ:C⁻¹σ = (σ:σ − λ tr²σ/(2μ + dλ))/(4μ) with λ/(2μ + dλ) = ν/(1 + (d−2)ν)
                // and 1/(4μ) = (1+ν)/(2E): one division (this runs once per particle in
                // every controlled step's summary).
                let tr = sigma.trace();
                let q = 1.0 + (D as f64 - 2.0) * nu;
                j * v0 * (1.0 + nu) * (sigma.norm_squared() * q - nu * tr * tr) / (2.0 * e * q)
            }
            MaterialNd::NeoHookean { .. } => {
                let (lambda, mu) = self.lame();
                let lnj = j.ln();
                v0 * (0.5 * mu * ((f.transpose() * f).trace() - D as f64) - mu * lnj
                    + 0.5 * lambda * lnj * lnj)
            }
        }
    }

    /// Body-force free check of a material's numbers: `E > 0` finite, `0 ≤ ν < ½`.
    pub fn is_valid(&self) -> bool {
        let (e, nu) = (self.youngs_modulus(), self.poisson_ratio());
        e.is_finite() && e > 0.0 && nu.is_finite() && (0.0..0.5).contains(&nu)
    }
}

/// The Lamé pair of the last material asked for: a pass over particles of few materials
/// forms `λ = Eν/((1+ν)(1−2ν))`, `μ = E/(2(1+ν))` (two divisions) once per run of
/// particles of one material instead of once per particle, the same numbers bit for bit.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct LameCache {
    last: Option<(MaterialNd, (f64, f64))>,
}

impl LameCache {
    /// `material.lame()`, formed anew only when `material` differs from the last one.
    #[inline(always)]
    pub fn get(&mut self, material: &MaterialNd) -> (f64, f64) {
        match self.last {
            Some((m, lame)) if same(&m, material) => lame,
            _ => {
                let lame = material.lame();
                self.last = Some((*material, lame));
                lame
            }
        }
    }
}

/// The same material bit for bit (not `==`: `ν = −0` and `ν = 0` give `λ` of two signs).
#[inline(always)]
fn same(a: &MaterialNd, b: &MaterialNd) -> bool {
    std::mem::discriminant(a) == std::mem::discriminant(b)
        && a.youngs_modulus().to_bits() == b.youngs_modulus().to_bits()
        && a.poisson_ratio().to_bits() == b.poisson_ratio().to_bits()
}
