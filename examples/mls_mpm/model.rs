//! The MLS-MPM example's materials: mpm99's fixed-corotated jelly and mpm88's weakly
//! compressible fluid.

use nalgebra::Matrix2;

/// The particles' material.
#[derive(Clone, Copy, Debug)]
pub enum Model {
    /// Fixed-corotated elasticity (Stomakhin et al. 2012; mpm99's jelly):
    /// Kirchhoff stress `τ = P Fᵀ = 2μ(F − R)Fᵀ + λ(J − 1)J I`.
    Jelly {
        /// Young's modulus.
        youngs_modulus: f64,
        /// Poisson's ratio.
        poisson_ratio: f64,
    },
    /// mpm88's weakly compressible fluid: `τ = E (J − 1) I`, with `J` advected as
    /// `J ← (1 + dt tr C) J` and no shear stiffness.
    Fluid {
        /// mpm88's `E` (a bulk modulus).
        bulk_modulus: f64,
    },
}

impl Model {
    /// Small-strain Lamé parameters `(λ, μ)` about the rest state (`(E, 0)` for the fluid).
    pub fn lame(&self) -> (f64, f64) {
        match *self {
            Model::Jelly {
                youngs_modulus: e,
                poisson_ratio: nu,
            } => (
                e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
                e / (2.0 * (1.0 + nu)),
            ),
            Model::Fluid { bulk_modulus } => (bulk_modulus, 0.0),
        }
    }

    /// The isotropic tangent pairs `(λ_t, μ_t)` the view reports for particles at `F`,
    /// into `lambda_t` and `mu_t`
    /// (`mpm_dt::nd::ViewNd::lame_lambda`). For the jelly the bound of
    /// [`mpm_dt::tangent::fixed_corotated`] (formed by
    /// [`mpm_dt::tangent::fixed_corotated_many`], several particles at a time; its P-wave modulus `λ_t + 2μ_t` bounds the
    /// acoustic tensor in every direction, initial stress included; `(λ, μ)` at rest; at
    /// the mpm88 impact up to 1.25× the rest pair's P-wave modulus).
    ///
    /// For the fluid `(E, 0)` at every `J`: the linearisation of the force it puts on the
    /// grid, `V⁰ τ` with `τ = E (J − 1) I`, which moves by `V⁰ E J tr(δL) = V E tr(δL)` per
    /// current volume `V` — the stiffness eq 56's `K` analyses with the weights frozen.
    /// It is *not* the fluid's acoustic modulus: with `p = E (1/J − 1)`, `ρc² = −J dp/dJ =
    /// E/J`, which `(E, 0)` under-reports by `1/J` in compression (`J` ≥ 0.93 on most of
    /// mpm88's fluid, so the sound-speed cap reads a speed up to a few per cent low there)
    /// and over-reports in tension. Kept because the stability limit binds on this scene
    /// and the sound-speed cap did not (3 of 1 911 steps, when the limit still applied
    /// the APIC gain to fluids); reporting `E max(1, 1/J)` then stopped the 128-cell fluid
    /// with `GrowthPersists`, which said more about how near its failure step the gained
    /// step ran than about the moduli.
    pub fn tangents(&self, f: &[Matrix2<f64>], lambda_t: &mut [f64], mu_t: &mut [f64]) {
        let (lambda, mu) = self.lame();
        match self {
            Model::Jelly { .. } => {
                mpm_dt::tangent::fixed_corotated_many(lambda, mu, f, lambda_t, mu_t)
            }
            Model::Fluid { .. } => {
                lambda_t.fill(lambda);
                mu_t.fill(mu);
            }
        }
    }

    /// Kirchhoff stress at deformation `F` with volume ratio `J`.
    pub fn kirchhoff(&self, f: &Matrix2<f64>, j: f64) -> Matrix2<f64> {
        let (lambda, mu) = self.lame();
        match self {
            Model::Jelly { .. } => {
                let r = polar_rotation(f);
                2.0 * mu * (f - r) * f.transpose() + Matrix2::identity() * (lambda * (j - 1.0) * j)
            }
            Model::Fluid { .. } => Matrix2::identity() * (lambda * (j - 1.0)),
        }
    }

    /// Stored energy per reference volume, the potential of the stress above
    /// (`τ = J ψ'(J) I` for the volumetric part): the jelly's `μ|F − R|² + λ/2 (J − 1)²`
    /// (Stomakhin et al.), the fluid's `E (J − 1 − ln J)` (whose Kirchhoff stress is
    /// mpm88's `E (J − 1) I`).
    pub fn energy_density(&self, f: &Matrix2<f64>, j: f64) -> f64 {
        let (lambda, mu) = self.lame();
        match self {
            Model::Jelly { .. } => {
                mu * (f - polar_rotation(f)).norm_squared() + 0.5 * lambda * (j - 1.0).powi(2)
            }
            Model::Fluid { bulk_modulus } => bulk_modulus * (j - 1.0 - j.ln()),
        }
    }
}

/// The rotation of the polar decomposition `F = R S` in 2D (closed form).
pub fn polar_rotation(f: &Matrix2<f64>) -> Matrix2<f64> {
    let (a, b) = (f[(0, 0)] + f[(1, 1)], f[(1, 0)] - f[(0, 1)]);
    let n = (a * a + b * b).sqrt();
    if n == 0.0 {
        return Matrix2::identity();
    }
    let (c, s) = (a / n, b / n);
    Matrix2::new(c, -s, s, c)
}
