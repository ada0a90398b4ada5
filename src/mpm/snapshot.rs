//! [`Snapshot`]: the committed state of a [`super::ReferenceStepper`] as serde data, for
//! checkpoint/restart.
//!
//! A snapshot holds the particle fields *and* the nodal fields (eqs 7, 17, 18) the next step
//! starts from, exactly as computed, so that a restored solver continues bit-identically
//! (recomputing the nodal sums in a different order could change their last bits). The
//! particle constants (masses, volumes, widths), grid, shape and material come from the
//! scenario the solver is rebuilt from.

use serde::{Deserialize, Serialize};

/// The committed state of the reference solver.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Time `tⁿ`.
    pub t: f64,
    /// Accepted steps so far.
    pub step: u64,
    /// Particle positions.
    pub x: Vec<f64>,
    /// Particle velocities.
    pub v: Vec<f64>,
    /// Particle stresses.
    pub sigma: Vec<f64>,
    /// Deformation gradients.
    pub f: Vec<f64>,
    /// Nodal masses (eq 7).
    pub node_mass: Vec<f64>,
    /// Nodal velocities (eq 17).
    pub node_velocity: Vec<f64>,
    /// Nodal accelerations (eq 18).
    pub node_acceleration: Vec<f64>,
}

/// A snapshot does not fit the solver it is restored into.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("snapshot field {field} has length {len}, the solver needs {expected}")]
pub struct SnapshotError {
    /// The field.
    pub field: &'static str,
    /// Its length in the snapshot.
    pub len: usize,
    /// The length the solver needs.
    pub expected: usize,
}
