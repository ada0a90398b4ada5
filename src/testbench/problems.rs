//! Problems with exact solutions, shared by tests, examples and benches.
//!
//! # The standing wave (vibrating bar)
//!
//! For the model problem of eqs 1–2 with linear elasticity, `ρ v_t = σ_x`, `σ_t = E v_x`
//! (`b = 0`), wave speed `c = √(E/ρ)`, wavenumber `κ = 2πk/L`, the standing wave
//!
//! ```text
//! v(x, t) = A c sin(κ (x − a)) cos(ω t),
//! σ(x, t) = E A cos(κ (x − a)) sin(ω t),        ω = c κ = 2π k c / L,
//! u(x, t) = (A/κ) sin(κ (x − a)) sin(ω t)        (displacement, u = 0 at t = 0)
//! ```
//!
//! is an exact solution: `σ_t = E A ω cos·cos = E v_x` because `ω = cκ`, and
//! `ρ v_t = −ρ A c ω sin·sin = −E A κ sin·sin = σ_x` because `ρ c² = E`.
//! With `L = 1`, `ρ = 1`, `C = √E`, `A = 1` this is `v = C sin(2πx) cos(2πCt)`: the
//! frequency is `2πC`. **Eq 45 prints `cos(Cπ t)`, which does not solve eqs 1–2** (it would
//! need `ω = cκ/2`). Its period is `L/(k c)`.
//!
//! The mode `k` may be any positive integer on a periodic bar. On a clamped bar (fixed
//! ends, `v(a) = v(a + L) = 0`) `sin(κ(x − a))` vanishes at both ends whenever `2k` is an
//! integer, so `k = 1/2` is the fundamental (one half wave), `k = 1` the first overtone, and
//! so on: the same formula covers both boundaries.
//!
//! The solution is that of the *linear* problem, written in the reference coordinate; the
//! MPM solver moves particles (geometric nonlinearity), so comparisons should use an
//! amplitude small enough that `u ≪ h` (e.g. `A ≤ 10⁻³`), at the particles' initial
//! positions.

use crate::grid::{Boundary, Grid};
use crate::mpm::ParticleInit;
use crate::stepper::View;
use crate::synchronized_velocity::SyncVelocityError;
use std::f64::consts::PI;

/// The standing wave of the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StandingWave {
    /// Velocity amplitude factor `A` (velocity amplitude is `A c`).
    pub amplitude: f64,
    /// Mode `k`: `k` full waves over `L` (periodic), or `2k` half waves (clamped).
    pub mode: f64,
    /// Young's modulus `E`.
    pub youngs_modulus: f64,
    /// Density `ρ`.
    pub density: f64,
    /// Bar length `L`.
    pub length: f64,
    /// Left end `a` of the bar.
    pub origin: f64,
}

impl StandingWave {
    /// A standing wave on `[0, length]`.
    pub fn new(amplitude: f64, mode: f64, youngs_modulus: f64, density: f64, length: f64) -> Self {
        Self {
            amplitude,
            mode,
            youngs_modulus,
            density,
            length,
            origin: 0.0,
        }
    }

    /// Wave speed `c = √(E/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// Wavenumber `κ = 2πk/L`.
    pub fn wavenumber(&self) -> f64 {
        2.0 * PI * self.mode / self.length
    }

    /// Angular frequency `ω = cκ = 2πkc/L` (not eq 45's `Cπ`).
    pub fn angular_frequency(&self) -> f64 {
        self.wave_speed() * self.wavenumber()
    }

    /// Period `2π/ω = L/(kc)`.
    pub fn period(&self) -> f64 {
        2.0 * PI / self.angular_frequency()
    }

    /// Exact velocity `v(x, t) = A c sin(κ(x − a)) cos(ωt)`.
    pub fn velocity(&self, x: f64, t: f64) -> f64 {
        self.amplitude
            * self.wave_speed()
            * (self.wavenumber() * (x - self.origin)).sin()
            * (self.angular_frequency() * t).cos()
    }

    /// `max_p |v_p − v(X_p, t)|`: the L∞ error ([`crate::estimators::linf`], NaN propagates)
    /// of particle velocities `v` whose reference positions are `x0`.
    pub fn velocity_error_linf(&self, x0: &[f64], v: &[f64], t: f64) -> f64 {
        let e: Vec<f64> = x0
            .iter()
            .zip(v)
            .map(|(&x, &v)| v - self.velocity(x, t))
            .collect();
        crate::estimators::linf(&e)
    }

    /// The errors of a state against this wave at the state's time: `(synchronised, raw)`,
    /// [`Self::velocity_error_linf`] of [`View::synchronized_velocity`]`(half_step)` (an
    /// error if `half_step` or the view is invalid) and of the raw particle velocities.
    /// `x0` are the particles' reference positions.
    pub fn velocity_errors(
        &self,
        x0: &[f64],
        view: &View<'_>,
        half_step: f64,
    ) -> (Result<f64, SyncVelocityError>, f64) {
        let synchronised = view
            .synchronized_velocity(half_step)
            .map(|v| self.velocity_error_linf(x0, &v, view.t));
        (synchronised, self.velocity_error_linf(x0, view.v, view.t))
    }

    /// Exact stress `σ(x, t) = E A cos(κ(x − a)) sin(ωt)`.
    pub fn stress(&self, x: f64, t: f64) -> f64 {
        self.youngs_modulus
            * self.amplitude
            * (self.wavenumber() * (x - self.origin)).cos()
            * (self.angular_frequency() * t).sin()
    }

    /// Exact displacement `u(x, t) = (A/κ) sin(κ(x − a)) sin(ωt)`.
    pub fn displacement(&self, x: f64, t: f64) -> f64 {
        self.amplitude / self.wavenumber()
            * (self.wavenumber() * (x - self.origin)).sin()
            * (self.angular_frequency() * t).sin()
    }

    /// Total (kinetic + strain) energy of the exact solution, constant in time:
    /// `ρ A² c² L / 4` (for integer `2k`, i.e. whole half waves over `L`).
    pub fn energy(&self) -> f64 {
        0.25 * self.density * self.amplitude.powi(2) * self.wave_speed().powi(2) * self.length
    }

    /// Whether the mode fits `boundary`: a positive integer (periodic) or a positive
    /// multiple of ½ (fixed).
    pub fn mode_fits(&self, boundary: Boundary) -> bool {
        let m = match boundary {
            Boundary::Periodic => self.mode,
            Boundary::Fixed => 2.0 * self.mode,
        };
        m.is_finite() && m >= 1.0 && m.fract() == 0.0
    }

    /// Particles at `positions` carrying the wave at `t = 0`: `v = v(x, 0)`, `σ = 0`,
    /// `F = 1`, volume and GIMP width `L/n` each, mass `ρ L/n`.
    pub fn particle_init(&self, positions: Vec<f64>) -> ParticleInit {
        let n = positions.len();
        let vol = self.length / n.max(1) as f64;
        ParticleInit {
            v: positions.iter().map(|&x| self.velocity(x, 0.0)).collect(),
            sigma: vec![0.0; n],
            f: vec![1.0; n],
            volume0: vec![vol; n],
            mass: vec![self.density * vol; n],
            width: vec![vol; n],
            x: positions,
        }
    }

    /// The wave on `ppc` evenly spaced particles per cell of `grid` (at cell fractions
    /// `(j + ½)/ppc`), GIMP width `h/ppc`.
    pub fn uniform_particles(&self, grid: &Grid, ppc: usize) -> ParticleInit {
        self.particle_init(uniform_positions(grid, ppc))
    }
}

/// `ppc` evenly spaced positions per cell, `x = a + (c + (j + ½)/ppc) h`.
pub fn uniform_positions(grid: &Grid, ppc: usize) -> Vec<f64> {
    let ppc_f = ppc as f64;
    (0..grid.cells)
        .flat_map(|c| {
            (0..ppc).map(move |j| grid.origin + (c as f64 + (j as f64 + 0.5) / ppc_f) * grid.h)
        })
        .collect()
}
