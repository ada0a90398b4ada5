//! Scenario files: a serde JSON description of one run of the reference solver.
//!
//! ```json
//! {
//!   "cells": 40, "length": 1.0, "boundary": "periodic",
//!   "youngs_modulus": 1.0, "density": 1.0,
//!   "shape": "gimp", "material": "linear_elastic",
//!   "particles": {"per_cell": 2},
//!   "initial": {"standing_wave": {"amplitude": 0.01, "mode": 1}},
//!   "t_end": 1.0,
//!   "controller": null
//! }
//! ```
//!
//! Every field is optional and defaults to the value above ([`Scenario::default`]).
//! `particles` is either `{"per_cell": k}` (k evenly spaced particles per cell at cell
//! fractions `(j + ½)/k`) or `{"positions": [...]}`, with optional `"masses": [...]` (one
//! per particle) in both forms. Particle volumes are `L/n` for `n` particles, masses
//! default to `ρ L/n`, and the GIMP width equals the volume (1D), which is `h/k` for
//! `per_cell` layouts; explicit positions therefore need `n ≥ cells` so that `l_p ≤ h`.
//! `initial` is `{"standing_wave": {"amplitude": A, "mode": k}}` — `v = A c sin(2πk x/L)`,
//! `σ = 0`, `F = 1` with `c = √(E/ρ)` (see [`crate::problems`]; `k` a positive integer on a
//! periodic bar, a positive multiple of ½ on a clamped one) — or `"rest"`.
//!
//! `controller` is the [`ControllerConfig`] of the run (`null` or absent: its defaults). It
//! is stored as JSON and parsed by [`Scenario::controller_config`], which
//! [`Scenario::validate`] calls, so a bad controller setting is a [`ScenarioError::Invalid`]
//! naming `controller` and, in its reason, the nested field (e.g. `stability.safety`).
//!
//! ```
//! use mpm_dt::scenario::Scenario;
//! use mpm_dt::Stepper;
//!
//! let scenario = Scenario::from_json(r#"{"cells": 40, "particles": {"per_cell": 2}}"#)?;
//! let wave = scenario.standing_wave().unwrap(); // the exact solution
//! let mut solver = scenario.build()?;
//! let dt = 0.5 * solver.grid().h / scenario.wave_speed();
//! while solver.time() < 0.25 {
//!     solver.try_step(dt)?;
//!     solver.accept()?;
//! }
//! let view = solver.view();
//! assert!((view.v[10] - wave.velocity(view.x[10], view.t)).abs() < 1e-3);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Loading never panics: malformed JSON, unknown fields (also inside `particles` and
//! `initial`), values of the wrong type and invalid values are [`ScenarioError`]s that name
//! the field.

use crate::controller::ControllerConfig;
use crate::grid::{Boundary, Grid};
use crate::mpm::{Material, ParticleInit, ReferenceStepper};
use crate::problems::{uniform_positions, StandingWave};
use crate::shape::Shape;
use serde::{Deserialize, Serialize};
use std::path::Path;

mod error;
pub use error::ScenarioError;
use error::{invalid, take};

/// Most cells a scenario may ask for (guards against accidental huge allocations).
pub const MAX_CELLS: usize = 100_000_000;
/// Most particles a scenario may ask for.
pub const MAX_PARTICLES: usize = 1_000_000_000;

/// Which constitutive model (`youngs_modulus` gives its `E`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MaterialKind {
    /// [`Material::LinearElastic`] (eq 27).
    #[default]
    LinearElastic,
    /// [`Material::NeoHookean`].
    NeoHookean,
}

/// Particle layout.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Particles {
    /// Evenly spaced particles per cell (exclusive with `positions`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_cell: Option<usize>,
    /// Explicit particle positions (exclusive with `per_cell`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positions: Option<Vec<f64>>,
    /// Particle masses, one per particle (default `ρ L/n`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub masses: Option<Vec<f64>>,
}

impl Default for Particles {
    fn default() -> Self {
        Self {
            per_cell: Some(2),
            positions: None,
            masses: None,
        }
    }
}

/// Initial condition at `t = 0`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Initial {
    /// `v = A c sin(2πk x/L)`, `σ = 0`, `F = 1` ([`StandingWave`]).
    StandingWave {
        /// `A` (velocity amplitude `A c`).
        amplitude: f64,
        /// `k`.
        mode: f64,
    },
    /// `v = 0`, `σ = 0`, `F = 1`.
    Rest,
}

impl Default for Initial {
    fn default() -> Self {
        Initial::StandingWave {
            amplitude: 0.01,
            mode: 1.0,
        }
    }
}

/// A run of the reference solver (see the module docs for the format and defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// Number of cells `N` (default 40).
    pub cells: usize,
    /// Bar length `L` (default 1).
    pub length: f64,
    /// Boundary (default periodic).
    pub boundary: Boundary,
    /// Young's modulus `E` (default 1).
    pub youngs_modulus: f64,
    /// Initial density `ρ` (default 1).
    pub density: f64,
    /// Weights (default GIMP).
    pub shape: Shape,
    /// Constitutive model (default linear elastic).
    pub material: MaterialKind,
    /// Particle layout (default 2 per cell).
    pub particles: Particles,
    /// Initial condition (default standing wave, `A = 0.01`, `k = 1`).
    pub initial: Initial,
    /// End time (default 1: one period of the default wave).
    pub t_end: f64,
    /// Controller configuration as JSON (a [`ControllerConfig`]; default none, meaning its
    /// defaults). Read it with [`Scenario::controller_config`].
    pub controller: Option<serde_json::Value>,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            cells: 40,
            length: 1.0,
            boundary: Boundary::Periodic,
            youngs_modulus: 1.0,
            density: 1.0,
            shape: Shape::Gimp,
            material: MaterialKind::LinearElastic,
            particles: Particles::default(),
            initial: Initial::default(),
            t_end: 1.0,
            controller: None,
        }
    }
}

impl Scenario {
    /// Parses and validates a scenario.
    pub fn from_json(text: &str) -> Result<Self, ScenarioError> {
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| ScenarioError::Syntax {
                line: e.line(),
                column: e.column(),
                message: e.to_string(),
            })?;
        let serde_json::Value::Object(mut obj) = value else {
            return Err(ScenarioError::Syntax {
                line: 0,
                column: 0,
                message: "the top level must be an object".into(),
            });
        };
        let mut s = Scenario::default();
        take(&mut obj, "cells", &mut s.cells)?;
        take(&mut obj, "length", &mut s.length)?;
        take(&mut obj, "boundary", &mut s.boundary)?;
        take(&mut obj, "youngs_modulus", &mut s.youngs_modulus)?;
        take(&mut obj, "density", &mut s.density)?;
        take(&mut obj, "shape", &mut s.shape)?;
        take(&mut obj, "material", &mut s.material)?;
        take(&mut obj, "particles", &mut s.particles)?;
        take(&mut obj, "initial", &mut s.initial)?;
        take(&mut obj, "t_end", &mut s.t_end)?;
        take(&mut obj, "controller", &mut s.controller)?;
        if let Some(field) = obj.keys().next() {
            return Err(ScenarioError::UnknownField {
                field: field.clone(),
            });
        }
        s.validate()?;
        Ok(s)
    }

    /// Reads, parses and validates a scenario file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, ScenarioError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Self::from_json(&text)
    }

    /// The controller configuration of the run: the `controller` field parsed and validated,
    /// or [`ControllerConfig::default`] when it is absent or `null`.
    pub fn controller_config(&self) -> Result<ControllerConfig, ScenarioError> {
        match &self.controller {
            None | Some(serde_json::Value::Null) => Ok(ControllerConfig::default()),
            Some(v) => ControllerConfig::from_value(v.clone())
                .map_err(|e| invalid("controller", e.to_string())),
        }
    }

    /// Checks every value (also called by [`Scenario::from_json`]; call it yourself after
    /// building a scenario in code).
    pub fn validate(&self) -> Result<(), ScenarioError> {
        self.controller_config()?;
        self.validate_cells()?;
        positive("length", self.length)?;
        positive("youngs_modulus", self.youngs_modulus)?;
        positive("density", self.density)?;
        positive("t_end", self.t_end)?;
        let n = self.validated_particle_count()?;
        // Solver, controller and tracker memory, estimated generously: two particle states
        // and the weights (~200 B a particle), nodal fields and the tracker's vectors
        // (~1 kB a node).
        let bytes = 400.0 * n as f64 + 1000.0 * self.cells as f64;
        crate::memory::check(bytes).map_err(|reason| invalid("particles", reason))?;
        self.validate_masses(n)?;
        self.validate_initial()
    }

    /// Checks that `cells` is in range and large enough for the boundary.
    fn validate_cells(&self) -> Result<(), ScenarioError> {
        if self.cells == 0 || self.cells > MAX_CELLS {
            return Err(invalid(
                "cells",
                format!("{} must be in 1..={MAX_CELLS}", self.cells),
            ));
        }
        if self.boundary == Boundary::Periodic && self.cells < 3 {
            return Err(invalid(
                "cells",
                format!("{} cells: a periodic bar needs at least 3", self.cells),
            ));
        }
        Ok(())
    }

    /// Checks the particle layout (`per_cell` or `positions`); returns the particle count.
    fn validated_particle_count(&self) -> Result<usize, ScenarioError> {
        match (&self.particles.per_cell, &self.particles.positions) {
            (Some(_), Some(_)) | (None, None) => Err(invalid(
                "particles",
                "give exactly one of `per_cell` and `positions`",
            )),
            (Some(k), None) => {
                if *k == 0 || k.saturating_mul(self.cells) > MAX_PARTICLES {
                    return Err(invalid(
                        "particles.per_cell",
                        format!("{k} must be at least 1 (and cells × per_cell ≤ {MAX_PARTICLES})"),
                    ));
                }
                Ok(k * self.cells)
            }
            (None, Some(xs)) => self.validate_positions(xs),
        }
    }

    /// Checks explicit positions lie on the bar and number at least `cells`; returns the count.
    fn validate_positions(&self, xs: &[f64]) -> Result<usize, ScenarioError> {
        let periodic = self.boundary == Boundary::Periodic;
        for (i, &x) in xs.iter().enumerate() {
            let inside = x >= 0.0
                && if periodic {
                    x < self.length
                } else {
                    x <= self.length
                };
            if !inside {
                return Err(invalid(
                    "particles.positions",
                    format!(
                        "positions[{i}] = {x} is not in [0, {}{}",
                        self.length,
                        if periodic { ")" } else { "]" }
                    ),
                ));
            }
        }
        if xs.len() < self.cells {
            return Err(invalid(
                "particles.positions",
                format!(
                    "{} particles on {} cells: the GIMP width L/n would exceed h (need n ≥ cells)",
                    xs.len(),
                    self.cells
                ),
            ));
        }
        Ok(xs.len())
    }

    /// Checks the optional masses: one for each of the `n` particles, each positive and finite.
    fn validate_masses(&self, n: usize) -> Result<(), ScenarioError> {
        if let Some(ms) = &self.particles.masses {
            if ms.len() != n {
                return Err(invalid(
                    "particles.masses",
                    format!("{} masses for {n} particles", ms.len()),
                ));
            }
            if let Some((i, m)) = ms
                .iter()
                .enumerate()
                .find(|(_, m)| !(m.is_finite() && **m > 0.0))
            {
                return Err(invalid(
                    "particles.masses",
                    format!("masses[{i}] = {m} must be positive and finite"),
                ));
            }
        }
        Ok(())
    }

    /// Checks the standing wave's amplitude is finite and its mode fits the boundary.
    fn validate_initial(&self) -> Result<(), ScenarioError> {
        if let Initial::StandingWave { amplitude, mode } = self.initial {
            if !amplitude.is_finite() {
                return Err(invalid(
                    "initial.standing_wave.amplitude",
                    format!("{amplitude} must be finite"),
                ));
            }
            let wave = StandingWave::new(
                amplitude,
                mode,
                self.youngs_modulus,
                self.density,
                self.length,
            );
            if !wave.mode_fits(self.boundary) {
                return Err(invalid(
                    "initial.standing_wave.mode",
                    match self.boundary {
                        Boundary::Periodic => {
                            format!("{mode} must be a positive integer on a periodic bar")
                        }
                        Boundary::Fixed => {
                            format!("{mode} must be a positive multiple of 1/2 on a clamped bar")
                        }
                    },
                ));
            }
        }
        Ok(())
    }

    /// The background grid on `[0, length]`.
    pub fn grid(&self) -> Result<Grid, ScenarioError> {
        self.validate()?;
        Ok(Grid::new(self.boundary, self.cells, self.length))
    }

    /// The material with this scenario's Young's modulus.
    pub fn material(&self) -> Material {
        let youngs_modulus = self.youngs_modulus;
        match self.material {
            MaterialKind::LinearElastic => Material::LinearElastic { youngs_modulus },
            MaterialKind::NeoHookean => Material::NeoHookean { youngs_modulus },
        }
    }

    /// Initial wave speed `c = √(E/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// The exact solution, when the initial condition is a standing wave (exact for the
    /// linear elastic material at small amplitude; see [`crate::problems`]).
    pub fn standing_wave(&self) -> Option<StandingWave> {
        match self.initial {
            Initial::StandingWave { amplitude, mode } => Some(StandingWave::new(
                amplitude,
                mode,
                self.youngs_modulus,
                self.density,
                self.length,
            )),
            Initial::Rest => None,
        }
    }

    /// The exact solution to measure errors against: the standing wave of
    /// [`Self::standing_wave`] for the linear elastic material, `None` for the neo-Hookean
    /// one (which has no exact solution here).
    pub fn exact_solution(&self) -> Option<StandingWave> {
        match self.material {
            MaterialKind::LinearElastic => self.standing_wave(),
            MaterialKind::NeoHookean => None,
        }
    }

    /// The particles at `t = 0`.
    pub fn particle_init(&self) -> Result<ParticleInit, ScenarioError> {
        let grid = self.grid()?;
        let positions = match (&self.particles.per_cell, &self.particles.positions) {
            (Some(k), _) => uniform_positions(&grid, *k),
            (None, Some(xs)) => xs.clone(),
            (None, None) => unreachable_layout()?,
        };
        let wave = self.standing_wave().unwrap_or_else(|| {
            StandingWave::new(0.0, 1.0, self.youngs_modulus, self.density, self.length)
        });
        let mut init = wave.particle_init(positions);
        if let Some(ms) = &self.particles.masses {
            init.mass.clone_from(ms);
        }
        Ok(init)
    }

    /// The reference solver at `t = 0`.
    pub fn build(&self) -> Result<ReferenceStepper, ScenarioError> {
        let grid = self.grid()?;
        let init = self.particle_init()?;
        Ok(ReferenceStepper::new(
            grid,
            self.shape,
            self.material(),
            init,
        )?)
    }
}

/// `Ok` when `v` is positive and finite, else an [`ScenarioError::Invalid`] naming `field`.
fn positive(field: &'static str, v: f64) -> Result<(), ScenarioError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("{v} must be positive and finite")))
    }
}

/// `validate` rules out a layout with neither form; report it as invalid anyway.
fn unreachable_layout() -> Result<Vec<f64>, ScenarioError> {
    Err(invalid(
        "particles",
        "give exactly one of `per_cell` and `positions`",
    ))
}
