//! Scenario files of any dimension (the format of `docs/design.md`, "Scenarios of any
//! dimension"), for the d-dimensional reference solver.
//!
//! ```json
//! {
//!   "dim": 2, "cells": [32, 16], "length": [2.0, 1.0], "boundary": "periodic",
//!   "youngs_modulus": 1.0, "poisson_ratio": 0.3, "density": 1.0,
//!   "shape": "gimp", "material": "linear_elastic", "gravity": [0.0, 0.0],
//!   "particles": {"per_cell": 2},
//!   "initial": {"plane_wave": {"amplitude": 0.01, "wave_vector": [1, 0], "direction": [1, 0]}},
//!   "t_end": 0.5
//! }
//! ```
//!
//! Per-axis fields (`cells`, `length`, `boundary`, `per_cell`) take one value for every axis
//! or a list of `dim`. `particles` is `{"per_cell": k}`, explicit
//! `{"positions": [[…], …], "masses", "volumes", "domain_lengths", "youngs_modulus"}`
//! (masses default to `ρ·volume`, volumes to the box volume shared equally, domain lengths
//! to `volume^(1/d)` per axis but at most a cell, moduli to the scenario's), or
//! `{"bodies": [{"box": {"min", "max"}} | {"ball": {"center", "radius"}}, "per_cell",
//! "velocity", optional "density", "youngs_modulus", "poisson_ratio"]}` — the cell-uniform
//! points inside each body; where bodies of the same `per_cell` overlap, the later body's
//! particle replaces the earlier one's (an inclusion). `initial` is `"rest"` or a `plane_wave`
//! ([`super::problems::PlaneWave`]). `controller` is a `ControllerConfig` as JSON.
//!
//! Loading never panics: unknown fields, wrong types and invalid values are
//! [`ScenarioError`]s naming the field.

use super::problems::PlaneWave;
use super::{MaterialNd, ParticlesNd, SetupError, SolverNd};
use crate::controller::ControllerConfig;
use crate::fmt_num::Num;
use crate::grid::Boundary;
use crate::nd::{GridNd, ShapeNd, Vector};
use crate::reduce::Reduce;
pub use crate::testbench::scenario::ScenarioError;
use serde::{Deserialize, Serialize};
use std::rc::Rc;

mod particles;

/// Most particles a scenario may ask for (about 22 GB for a controlled 3D run); a smaller
/// size that the machine's available memory cannot hold is refused up front too.
pub const MAX_PARTICLES: usize = 20_000_000;

/// One value for every axis, or one per axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum PerAxis<T> {
    /// The same value on every axis.
    One(T),
    /// One value per axis.
    Many(Vec<T>),
}

/// The material law: the 1D scenarios' (`linear_elastic`, the default, or `neo_hookean`),
/// read here as [`MaterialNd`]'s hypoelastic linear or compressible neo-Hookean law.
pub use crate::scenario::MaterialKind;

/// A body filled with particles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    /// An axis-aligned box `{"min": […], "max": […]}`.
    #[serde(default, rename = "box")]
    pub box_: Option<BoxShape>,
    /// A ball (disk in 2D) `{"center": […], "radius": r}`.
    #[serde(default)]
    pub ball: Option<Ball>,
    /// Particles per cell per axis (default 2).
    #[serde(default)]
    pub per_cell: Option<PerAxis<usize>>,
    /// Initial velocity (default zero).
    #[serde(default)]
    pub velocity: Option<Vec<f64>>,
    /// Density (default: the scenario's).
    #[serde(default)]
    pub density: Option<f64>,
    /// Young's modulus (default: the scenario's).
    #[serde(default)]
    pub youngs_modulus: Option<f64>,
    /// Poisson's ratio (default: the scenario's).
    #[serde(default)]
    pub poisson_ratio: Option<f64>,
}

/// An axis-aligned box.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxShape {
    /// Lower corner.
    pub min: Vec<f64>,
    /// Upper corner.
    pub max: Vec<f64>,
}

/// A ball.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ball {
    /// Centre.
    pub center: Vec<f64>,
    /// Radius.
    pub radius: f64,
}

/// How particles are placed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleSpec {
    /// Uniform layout: particles per cell per axis.
    #[serde(default)]
    pub per_cell: Option<PerAxis<usize>>,
    /// Explicit positions.
    #[serde(default)]
    pub positions: Option<Vec<Vec<f64>>>,
    /// Masses of explicit particles.
    #[serde(default)]
    pub masses: Option<Vec<f64>>,
    /// Volumes of explicit particles.
    #[serde(default)]
    pub volumes: Option<Vec<f64>>,
    /// GIMP domain lengths of explicit particles.
    #[serde(default)]
    pub domain_lengths: Option<Vec<Vec<f64>>>,
    /// Young's modulus per explicit particle.
    #[serde(default)]
    pub youngs_modulus: Option<Vec<f64>>,
    /// Bodies.
    #[serde(default)]
    pub bodies: Option<Vec<Body>>,
}

/// The plane-wave initial condition.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneWaveSpec {
    /// Amplitude `A` (velocity `A c`).
    pub amplitude: f64,
    /// Integer wave numbers per axis.
    pub wave_vector: Vec<f64>,
    /// Polarisation.
    pub direction: Vec<f64>,
}

/// The initial condition.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum InitialNd {
    /// At rest (bodies keep their own velocities).
    #[default]
    Rest,
    /// A plane standing wave.
    PlaneWave(PlaneWaveSpec),
}

/// A scenario of any dimension (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScenarioNd {
    /// Dimension, 1–3 (1: the 1D format of [`crate::scenario`]).
    pub dim: usize,
    /// Cells per axis.
    pub cells: PerAxis<usize>,
    /// Domain length per axis.
    pub length: PerAxis<f64>,
    /// Boundary per axis.
    pub boundary: PerAxis<Boundary>,
    /// Young's modulus.
    pub youngs_modulus: f64,
    /// Poisson's ratio, `0 ≤ ν < ½`.
    pub poisson_ratio: f64,
    /// Density.
    pub density: f64,
    /// Weight functions.
    pub shape: ShapeNd,
    /// Material law.
    pub material: MaterialKind,
    /// Body force per unit mass, one number per axis.
    pub gravity: Option<Vec<f64>>,
    /// Particles.
    pub particles: ParticleSpec,
    /// Initial condition.
    pub initial: InitialNd,
    /// End time.
    pub t_end: f64,
    /// Controller settings (JSON of `ControllerConfig`).
    pub controller: Option<serde_json::Value>,
}

impl Default for ScenarioNd {
    fn default() -> Self {
        Self {
            dim: 2,
            cells: PerAxis::One(16),
            length: PerAxis::One(1.0),
            boundary: PerAxis::One(Boundary::Periodic),
            youngs_modulus: 1.0,
            poisson_ratio: 0.0,
            density: 1.0,
            shape: ShapeNd::Gimp,
            material: MaterialKind::LinearElastic,
            gravity: None,
            particles: ParticleSpec {
                per_cell: Some(PerAxis::One(2)),
                positions: None,
                masses: None,
                volumes: None,
                domain_lengths: None,
                youngs_modulus: None,
                bodies: None,
            },
            initial: InitialNd::Rest,
            t_end: 1.0,
            controller: None,
        }
    }
}

fn invalid(field: &str, reason: impl Into<String>) -> ScenarioError {
    ScenarioError::Invalid {
        field: field.to_string(),
        reason: reason.into(),
    }
}

fn per_axis<T: Copy, const D: usize>(v: &PerAxis<T>, field: &str) -> Result<[T; D], ScenarioError> {
    match v {
        PerAxis::One(x) => Ok([*x; D]),
        PerAxis::Many(xs) => <[T; D]>::try_from(xs.as_slice()).map_err(|_| {
            invalid(
                field,
                format!("expected one value or {D}, got {}", xs.len()),
            )
        }),
    }
}

fn vector<const D: usize>(v: &[f64], field: &str) -> Result<Vector<D>, ScenarioError> {
    if v.len() != D {
        return Err(invalid(
            field,
            format!("expected {D} values, got {}", v.len()),
        ));
    }
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(invalid(field, format!("{} is not finite", Num(*x))));
    }
    Ok(Vector::<D>::from_column_slice(v))
}

impl ScenarioNd {
    /// Parses a scenario from JSON text (no value checks beyond types; [`Self::build`]
    /// checks the rest).
    pub fn from_json(text: &str) -> Result<Self, ScenarioError> {
        serde_json::from_str(text).map_err(|e| ScenarioError::Parse(e.to_string()))
    }

    /// Reads and parses a scenario file.
    pub fn from_file(path: impl AsRef<std::path::Path>) -> Result<Self, ScenarioError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Self::from_json(&text)
    }

    /// The dimension a JSON text declares (`dim`, 1 when absent), for dispatching to the 1D
    /// [`crate::scenario::Scenario`] or to this format.
    pub fn dim_of(text: &str) -> Result<usize, ScenarioError> {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| ScenarioError::Parse(e.to_string()))?;
        match v.get("dim") {
            None => Ok(1),
            Some(d) => d
                .as_u64()
                .filter(|d| (1..=3).contains(d))
                .map(|d| d as usize)
                .ok_or_else(|| invalid("dim", "must be 1, 2 or 3")),
        }
    }

    /// The controller configuration (`controller`, or the defaults), checked for the
    /// scenario's dimension ([`ControllerConfig::validate_for`]: a 1D-only setting is an
    /// error naming it).
    pub fn controller_config(&self) -> Result<ControllerConfig, ScenarioError> {
        match &self.controller {
            None | Some(serde_json::Value::Null) => Ok(ControllerConfig::default()),
            Some(v) => ControllerConfig::from_value(v.clone())
                .and_then(|c| c.validate_for(self.dim).map(|()| c))
                .map_err(|e| invalid("controller", e.to_string())),
        }
    }

    /// The scenario's material for moduli `e`, `nu`.
    fn material(&self, e: f64, nu: f64) -> MaterialNd {
        match self.material {
            MaterialKind::LinearElastic => MaterialNd::LinearElastic {
                youngs_modulus: e,
                poisson_ratio: nu,
            },
            MaterialKind::NeoHookean => MaterialNd::NeoHookean {
                youngs_modulus: e,
                poisson_ratio: nu,
            },
        }
    }

    fn check_scalars(&self) -> Result<(), ScenarioError> {
        for (field, v) in [
            ("youngs_modulus", self.youngs_modulus),
            ("density", self.density),
            ("t_end", self.t_end),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(
                    field,
                    format!("{} must be a positive number", Num(v)),
                ));
            }
        }
        if !(self.poisson_ratio.is_finite() && (0.0..0.5).contains(&self.poisson_ratio)) {
            return Err(invalid(
                "poisson_ratio",
                format!("{} must be in [0, 0.5)", Num(self.poisson_ratio)),
            ));
        }
        self.controller_config()?;
        Ok(())
    }

    /// Builds the solver of dimension `D` (which must equal `dim`) and the exact solution,
    /// if the initial condition has one.
    pub fn build<const D: usize>(
        &self,
    ) -> Result<(SolverNd<D>, Option<PlaneWave<D>>), ScenarioError> {
        self.build_with(SolverNd::new)
    }

    /// [`Self::build`] for this process's part of a run split over the processes of
    /// `reduce` by particle ([`SolverNd::new_distributed`]).
    pub fn build_distributed<const D: usize>(
        &self,
        reduce: Rc<dyn Reduce>,
    ) -> Result<(SolverNd<D>, Option<PlaneWave<D>>), ScenarioError> {
        self.build_with(|g, s, p, a| SolverNd::new_distributed(g, s, p, a, reduce))
    }

    /// [`Self::build`] for this process's slab of a run whose grid is decomposed along its
    /// last axis over the processes of `reduce` ([`SolverNd::new_slab`]).
    pub fn build_slab<const D: usize>(
        &self,
        reduce: Rc<dyn Reduce>,
    ) -> Result<(SolverNd<D>, Option<PlaneWave<D>>), ScenarioError> {
        self.build_with(|g, s, p, a| SolverNd::new_slab(g, s, p, a, reduce))
    }

    /// The scenario's parts handed to one of the solver's constructors.
    fn build_with<const D: usize>(
        &self,
        make: impl FnOnce(
            GridNd<D>,
            ShapeNd,
            ParticlesNd<D>,
            Vector<D>,
        ) -> Result<SolverNd<D>, SetupError>,
    ) -> Result<(SolverNd<D>, Option<PlaneWave<D>>), ScenarioError> {
        let (grid, particles, gravity, wave) = self.parts::<D>()?;
        Ok((make(grid, self.shape, particles, gravity)?, wave))
    }

    /// The grid, particles (with the initial velocity), gravity and exact solution.
    #[allow(clippy::type_complexity)]
    fn parts<const D: usize>(
        &self,
    ) -> Result<(GridNd<D>, ParticlesNd<D>, Vector<D>, Option<PlaneWave<D>>), ScenarioError> {
        if self.dim != D {
            return Err(invalid(
                "dim",
                format!("scenario is {}D, built as {D}D", self.dim),
            ));
        }
        self.check_scalars()?;
        let cells: [usize; D] = per_axis(&self.cells, "cells")?;
        let length: [f64; D] = per_axis(&self.length, "length")?;
        let boundary: [Boundary; D] = per_axis(&self.boundary, "boundary")?;
        for a in 0..D {
            if cells[a] == 0 || cells[a] > 1 << 20 {
                return Err(invalid("cells", "each must be in 1..=1048576"));
            }
            if !(length[a].is_finite() && length[a] > 0.0) {
                return Err(invalid(
                    "length",
                    format!("{} must be positive", Num(length[a])),
                ));
            }
        }
        let grid = GridNd::<D>::new(boundary, cells, length);
        let gravity = match &self.gravity {
            None => Vector::<D>::zeros(),
            Some(g) => vector::<D>(g, "gravity")?,
        };
        let base = self.material(self.youngs_modulus, self.poisson_ratio);
        let mut particles = self.particles::<D>(&grid, base)?;
        let wave = match &self.initial {
            InitialNd::Rest => None,
            InitialNd::PlaneWave(w) => {
                let k = vector::<D>(&w.wave_vector, "initial.plane_wave.wave_vector")?;
                let d = vector::<D>(&w.direction, "initial.plane_wave.direction")?;
                if !w.amplitude.is_finite() {
                    return Err(invalid("initial.plane_wave.amplitude", "must be finite"));
                }
                let wave = PlaneWave::new(
                    &grid,
                    base,
                    self.density,
                    w.amplitude,
                    std::array::from_fn(|a| k[a]),
                    d,
                )?;
                for p in 0..particles.len() {
                    particles.v[p] += wave.velocity(&particles.x[p], 0.0);
                }
                Some(wave)
            }
        };
        Ok((grid, particles, gravity, wave))
    }
}
