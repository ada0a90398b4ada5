//! [`SetupError`]: why a reference solver (1D, [`crate::mpm::ReferenceStepper`], or 2D/3D,
//! [`crate::nd::SolverNd`]) could not be built; one type for the test bench's solvers of
//! every dimension. Every variant names the field, and where there is one the particle, the
//! axis and the value.

use crate::fmt_num::Num;

/// Why a reference solver could not be built (module docs). Variants that only one
/// dimension's solver raises say so.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SetupError {
    /// The grid has no cells or a non-positive or non-finite spacing or origin (1D).
    #[error("invalid grid: {reason}")]
    Grid {
        /// What is wrong.
        reason: String,
    },
    /// Young's modulus is not a positive finite number (1D).
    #[error("invalid material: youngs_modulus = {value} must be positive and finite")]
    Material {
        /// The offending modulus.
        value: f64,
    },
    /// A checkpoint's time is negative or not finite (1D).
    #[error("invalid checkpoint time t = {value}")]
    Time {
        /// The offending time.
        value: f64,
    },
    /// A checkpoint's last accepted step (the staggered kick's `dt₋`) is not a positive
    /// finite number (1D).
    #[error("invalid checkpoint last step dt = {value}: must be positive and finite")]
    LastStep {
        /// The offending step.
        value: f64,
    },
    /// There are no particles.
    #[error("no particles")]
    NoParticles,
    /// A particle field has the wrong length.
    #[error("particles: {field} has {len} entries, expected {expected}")]
    Length {
        /// Field name (`"v"`, `"sigma"`, `"f"`, `"volume0"`, `"mass"`, `"width"`).
        field: &'static str,
        /// Its length.
        len: usize,
        /// Number of particles.
        expected: usize,
    },
    /// A value is NaN or infinite (1D).
    #[error("particle field {field}[{index}] = {value} is not finite")]
    NonFinite {
        /// Field name.
        field: &'static str,
        /// Particle index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A value that must be positive (`f`, `volume0`, `mass`, `width`) is not (1D).
    #[error("particle field {field}[{index}] = {value} must be positive")]
    NonPositive {
        /// Field name.
        field: &'static str,
        /// Particle index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A GIMP width exceeds the grid spacing (the weights would no longer be exact) (1D).
    #[error("particle width[{index}] = {value} exceeds the grid spacing h = {h}")]
    WidthExceedsSpacing {
        /// Particle index.
        index: usize,
        /// The width.
        value: f64,
        /// Grid spacing.
        h: f64,
    },
    /// A particle lies outside the domain (1D).
    #[error("particle x[{index}] = {value} is outside the domain [{lower}, {upper}{close}", close = if *periodic { ")" } else { "]" })]
    OutOfDomain {
        /// Particle index.
        index: usize,
        /// Its position.
        value: f64,
        /// Left end `a`.
        lower: f64,
        /// Right end `a + L`.
        upper: f64,
        /// Whether the right end is excluded (periodic domain).
        periodic: bool,
    },
    /// A value is not finite or out of its range (2D/3D).
    #[error("particles: invalid {field} {} at particle {index}", Num(*value))]
    Invalid {
        /// Which field.
        field: &'static str,
        /// Particle index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A particle lies outside a fixed box (2D/3D).
    #[error("particle {index} is outside the fixed box on axis {axis} (x = {})", Num(*x))]
    OutsideBox {
        /// Particle index.
        index: usize,
        /// The axis.
        axis: usize,
        /// Its coordinate.
        x: f64,
    },
    /// Quadratic B-splines need periodic axes (2D/3D).
    #[error("shape bspline2 needs a periodic boundary, axis {axis} is fixed")]
    BSplineOnFixedAxis {
        /// The axis.
        axis: usize,
    },
    /// The grid of an axis is invalid (no cells, non-positive or non-finite spacing, or
    /// fewer than 3 cells for B-splines) (2D/3D).
    #[error("grid: invalid cells or spacing on axis {axis}")]
    GridAxis {
        /// The axis.
        axis: usize,
    },
    /// The gravity vector is not finite (2D/3D).
    #[error("gravity is not finite")]
    Gravity,
    /// The grid's last axis has too few cells to give every process a slab (2D/3D).
    #[error(
        "{cells} cells along the last axis cannot be split into slabs of at least \
         {min_cells} cells over {processes} processes"
    )]
    Decomposition {
        /// Cells along the last axis.
        cells: usize,
        /// Number of processes.
        processes: usize,
        /// Fewest cells per slab.
        min_cells: usize,
    },
}
