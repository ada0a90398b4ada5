//! Problems with exact solutions in d dimensions: plane standing waves on periodic boxes.
//!
//! For hypoelastic linear elasticity (Lamé `λ, μ`, density `ρ`) on a periodic box of
//! lengths `L_a`, with integer wave numbers `k_a`, wave vector `K_a = 2π k_a / L_a` and unit
//! polarisation `d̂`,
//!
//! ```text
//! v(x, t) = A c sin(K·x) cos(ω t) d̂,
//! σ(x, t) = (A c/ω) cos(K·x) sin(ω t) [λ (d̂·K) I + μ (d̂ ⊗ K + K ⊗ d̂)],   ω = c |K|,
//! ```
//!
//! solves `ρ ∂v/∂t = ∇·σ`, `∂σ/∂t = λ tr(ε̇) I + 2μ ε̇` exactly when `d̂ ∥ K` (a P wave,
//! `c = c_p = √((λ + 2μ)/ρ)`) or `d̂ ⊥ K` (an S wave, `c = c_s = √(μ/ρ)`): substituting,
//! `∇·σ = −(A c/ω) sin(K·x) sin(ωt) [(λ + μ)(d̂·K) K + μ |K|² d̂]`, which is
//! `−ρ A c ω sin(K·x) sin(ωt) d̂` in both cases. At `t = 0`: `v = A c sin(K·x) d̂`, `σ = 0`,
//! `F = I` (docs/design.md's `plane_wave` initial condition).

use super::MaterialNd;
use crate::grid::Boundary;
use crate::nd::{GridNd, Tensor, Vector};

/// Which kind of plane wave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaveKind {
    /// Polarisation along the wave vector (speed `c_p`).
    P,
    /// Polarisation across the wave vector (speed `c_s`).
    S,
}

/// Why a plane wave cannot be set up.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlaneWaveError {
    /// The polarisation is neither along nor across the wave vector.
    #[error("plane_wave.direction must be parallel or perpendicular to the wave vector")]
    Oblique,
    /// The wave vector or the direction is zero or not finite.
    #[error("plane_wave.{field} must be a non-zero finite vector")]
    Degenerate {
        /// `wave_vector` or `direction`.
        field: &'static str,
    },
    /// The box is not periodic on every axis the wave varies along.
    #[error("plane_wave needs periodic boundaries (axis {axis} is fixed)")]
    NotPeriodic {
        /// The axis.
        axis: usize,
    },
    /// The material is not linear elastic (the solution is for the linear law), or its
    /// shear modulus is zero for an S wave.
    #[error("plane_wave needs a linear elastic material")]
    Material,
}

/// A plane standing wave (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneWave<const D: usize> {
    /// Amplitude `A` (relative to the wave speed).
    pub amplitude: f64,
    /// Wave vector `K` (1/length).
    pub wave_vector: Vector<D>,
    /// Unit polarisation `d̂`.
    pub direction: Vector<D>,
    /// P or S.
    pub kind: WaveKind,
    /// Wave speed `c`.
    pub speed: f64,
    /// Lamé `λ`.
    pub lambda: f64,
    /// Lamé `μ`.
    pub mu: f64,
}

impl<const D: usize> PlaneWave<D> {
    /// The wave with integer wave numbers `k` on `grid`, polarisation `direction`, in a
    /// linear elastic `material` of density `density`.
    pub fn new(
        grid: &GridNd<D>,
        material: MaterialNd,
        density: f64,
        amplitude: f64,
        k: [f64; D],
        direction: Vector<D>,
    ) -> Result<Self, PlaneWaveError> {
        let MaterialNd::LinearElastic { .. } = material else {
            return Err(PlaneWaveError::Material);
        };
        let wave_vector =
            Vector::<D>::from_fn(|a, _| 2.0 * std::f64::consts::PI * k[a] / grid.length(a));
        for (a, &ka) in k.iter().enumerate() {
            if ka != 0.0 && grid.boundary[a] == Boundary::Fixed {
                return Err(PlaneWaveError::NotPeriodic { axis: a });
            }
        }
        let (kn, dn) = (wave_vector.norm(), direction.norm());
        if !(kn.is_finite() && kn > 0.0) {
            return Err(PlaneWaveError::Degenerate {
                field: "wave_vector",
            });
        }
        if !(dn.is_finite() && dn > 0.0) {
            return Err(PlaneWaveError::Degenerate { field: "direction" });
        }
        let d = direction / dn;
        let cos = (d.dot(&wave_vector) / kn).abs();
        let (lambda, mu) = material.lame();
        let kind = if (cos - 1.0).abs() < 1e-12 {
            WaveKind::P
        } else if cos < 1e-12 {
            WaveKind::S
        } else {
            return Err(PlaneWaveError::Oblique);
        };
        let speed = match kind {
            WaveKind::P => ((lambda + 2.0 * mu) / density).sqrt(),
            WaveKind::S => (mu / density).sqrt(),
        };
        if !(speed.is_finite() && speed > 0.0) {
            return Err(PlaneWaveError::Material);
        }
        Ok(Self {
            amplitude,
            wave_vector,
            direction: d,
            kind,
            speed,
            lambda,
            mu,
        })
    }

    /// Angular frequency `ω = c |K|`.
    pub fn omega(&self) -> f64 {
        self.speed * self.wave_vector.norm()
    }

    /// Exact velocity at `x`, `t`.
    pub fn velocity(&self, x: &Vector<D>, t: f64) -> Vector<D> {
        self.direction
            * (self.amplitude
                * self.speed
                * self.wave_vector.dot(x).sin()
                * (self.omega() * t).cos())
    }

    /// The velocity error of a state against this wave, relative to its velocity
    /// amplitude: `max_p |v_p − v(x_p, t)|∞ / (|A| c)`.
    pub fn velocity_error(&self, view: &crate::nd::ViewNd<'_, D>) -> f64 {
        let scale = self.amplitude.abs() * self.speed;
        (0..view.n_particles())
            .map(|p| (view.v[p] - self.velocity(&view.x[p], view.t)).amax() / scale)
            .fold(0.0, f64::max)
    }

    /// Exact stress at `x`, `t`.
    pub fn stress(&self, x: &Vector<D>, t: f64) -> Tensor<D> {
        let k = &self.wave_vector;
        let d = &self.direction;
        let pattern = Tensor::<D>::identity() * (self.lambda * d.dot(k))
            + (d * k.transpose() + k * d.transpose()) * self.mu;
        pattern
            * (self.amplitude * self.speed / self.omega()
                * k.dot(x).cos()
                * (self.omega() * t).sin())
    }
}
