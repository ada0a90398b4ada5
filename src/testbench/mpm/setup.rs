//! Initial particle data of the reference solver and its validation.
//!
//! A [`ParticleInit`] lists the particle fields at `t = 0`: position `x_p`, velocity
//! `v_p`, stress `σ_p`, deformation gradient `F_p`, initial volume `V_p⁰` (eq 8), mass
//! `m_p` and GIMP width `l_p`. Everything is checked before the solver is built: GIMP's
//! closed-form weights are exact only for `0 < l_p ≤ h` (a particle domain then touches at
//! most three nodes), so wider particles are an error rather than silently wrong weights.

use crate::grid::{Boundary, Grid};
pub use crate::testbench::setup_error::SetupError;
use serde::{Deserialize, Serialize};

/// Particle fields at `t = 0` (or at a checkpoint). All vectors have one entry per particle.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ParticleInit {
    /// Positions `x_p` (inside `[a, a + L)` periodic, `[a, a + L]` fixed).
    pub x: Vec<f64>,
    /// Velocities `v_p`.
    pub v: Vec<f64>,
    /// Cauchy stresses `σ_p`.
    pub sigma: Vec<f64>,
    /// Deformation gradients `F_p > 0` (eq 8; usually 1).
    pub f: Vec<f64>,
    /// Initial volumes `V_p⁰ > 0` (eq 8).
    pub volume0: Vec<f64>,
    /// Masses `m_p > 0`.
    pub mass: Vec<f64>,
    /// GIMP particle widths `l_p` with `0 < l_p ≤ h` (ignored by linear-hat weights but
    /// still validated). In 1D the natural choice is `l_p = V_p⁰`.
    pub width: Vec<f64>,
}

/// Checks the grid.
pub(crate) fn validate_grid(grid: &Grid) -> Result<(), SetupError> {
    if grid.cells == 0 {
        return Err(SetupError::Grid {
            reason: "cells must be at least 1".into(),
        });
    }
    if grid.boundary == Boundary::Periodic && grid.cells < 3 {
        return Err(SetupError::Grid {
            reason: format!(
                "a periodic grid needs at least 3 cells (has {}): on fewer a particle touches one node twice",
                grid.cells
            ),
        });
    }
    if grid.cells > (u32::MAX as usize) - 8 {
        return Err(SetupError::Grid {
            reason: format!("cells = {} is too large", grid.cells),
        });
    }
    if !(grid.h.is_finite() && grid.h > 0.0) {
        return Err(SetupError::Grid {
            reason: format!("spacing h = {} must be positive and finite", grid.h),
        });
    }
    if !grid.origin.is_finite() || !grid.length().is_finite() {
        return Err(SetupError::Grid {
            reason: format!("origin = {} and length must be finite", grid.origin),
        });
    }
    Ok(())
}

impl ParticleInit {
    /// Number of particles (length of `x`).
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Checks lengths, finiteness, positivity, `l_p ≤ h` and that every particle lies in
    /// the domain of `grid`.
    pub fn validate(&self, grid: &Grid) -> Result<(), SetupError> {
        validate_grid(grid)?;
        let n = self.x.len();
        if n == 0 {
            return Err(SetupError::NoParticles);
        }
        let fields: [(&'static str, &[f64]); 7] = [
            ("x", &self.x),
            ("v", &self.v),
            ("sigma", &self.sigma),
            ("f", &self.f),
            ("volume0", &self.volume0),
            ("mass", &self.mass),
            ("width", &self.width),
        ];
        for (field, values) in fields {
            if values.len() != n {
                return Err(SetupError::Length {
                    field,
                    len: values.len(),
                    expected: n,
                });
            }
            if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(SetupError::NonFinite {
                    field,
                    index,
                    value,
                });
            }
        }
        for (field, values) in [
            ("f", &self.f),
            ("volume0", &self.volume0),
            ("mass", &self.mass),
            ("width", &self.width),
        ] {
            if let Some((index, &value)) = values.iter().enumerate().find(|(_, &v)| v <= 0.0) {
                return Err(SetupError::NonPositive {
                    field,
                    index,
                    value,
                });
            }
        }
        if let Some((index, &value)) = self.width.iter().enumerate().find(|(_, &w)| w > grid.h) {
            return Err(SetupError::WidthExceedsSpacing {
                index,
                value,
                h: grid.h,
            });
        }
        let (lower, upper) = (grid.origin, grid.origin + grid.length());
        let periodic = grid.boundary == Boundary::Periodic;
        let inside = |x: f64| x >= lower && if periodic { x < upper } else { x <= upper };
        if let Some((index, &value)) = self.x.iter().enumerate().find(|(_, &x)| !inside(x)) {
            return Err(SetupError::OutOfDomain {
                index,
                value,
                lower,
                upper,
                periodic,
            });
        }
        Ok(())
    }
}
