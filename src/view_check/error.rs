//! [`ViewError`]: why a view failed the door check (module docs of [`super`]).

use crate::fmt_num::Num;

/// Why a stepper's view does not describe one consistent state. Each variant names the
/// array, the particle or node, and the offending value; [`ViewError::array`],
/// [`ViewError::index`] and [`ViewError::value`] read them uniformly. The controller
/// reports it as `ControllerError::InvalidView`, with the time and step of the view.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ViewError {
    /// An array does not have the length its count says.
    #[error("{array} has length {len}, expected {expected} (the number of {count})")]
    Length {
        /// Which array (`"x"`, `"lame_mu"`, `"node_velocity"`, `"weights"` for the weight
        /// rows, `"weights.n_nodes"` for the nodes they are over, …).
        array: &'static str,
        /// Its length.
        len: usize,
        /// The count: the length most particle arrays share, or the grid's node count.
        expected: usize,
        /// `"particles"` or `"nodes"`.
        count: &'static str,
    },
    /// The grid does not describe the nodal arrays: they agree on a node count that is not
    /// the grid's `n_nodes()` (a grid of another size than the one the solver used).
    #[error("grid has {grid_nodes} nodes (cells {cells:?}, ghosts included) but the nodal arrays have {array_nodes}")]
    Grid {
        /// `grid.n_nodes()`.
        grid_nodes: usize,
        /// The length of the nodal arrays.
        array_nodes: usize,
        /// The grid's cells per axis.
        cells: Vec<usize>,
    },
    /// A value of the committed state (or of a weight row) is NaN or infinite.
    #[error("non-finite {array} at {} {index} (value {})", if array.starts_with("node") { "node" } else { "particle" }, Num(*value))]
    NonFinite {
        /// Which array (`"x"`, `"v"`, `"sigma"`, `"F"`, …, `"node_mass"`, `"weights.s"`).
        array: &'static str,
        /// Particle or node index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A node index that does not exist: in a weight row (`"weights.nodes"`, `index` the
    /// particle) or in a split view's map to the whole grid (`"split.global_node"`,
    /// `index` the local node).
    #[error("{array}: entry {index} refers to node {node}, of {n_nodes}")]
    NodeOutOfRange {
        /// Which array.
        array: &'static str,
        /// Particle (weights) or local node (split map) index.
        index: usize,
        /// The node index.
        node: usize,
        /// Number of nodes it must be below.
        n_nodes: usize,
    },
    /// A particle's weights do not sum to one (`Σ_i S_ip = 1`).
    #[error("weights: the weights of particle {particle} sum to {} (a partition of unity sums to 1)", Num(*sum))]
    PartitionOfUnity {
        /// Particle index.
        particle: usize,
        /// `Σ_i S_ip`.
        sum: f64,
    },
    /// A particle's weight gradients do not sum to zero (`Σ_i ∇S_ip = 0`).
    #[error("weights: the gradients of particle {particle} sum to {} along axis {axis} (expected 0)", Num(*sum))]
    GradientSum {
        /// Particle index.
        particle: usize,
        /// The component.
        axis: usize,
        /// `Σ_i ∂_axis S_ip`.
        sum: f64,
    },
    /// A particle's weight gradients are not linearly complete
    /// (`Σ_i (X_i − x_p) ⊗ ∇S_ip = I`); a value `h` on the diagonal is a missing `1/h`.
    #[error("weights: Σ_i (X_i − x_p)_{row} ∂_{col} S_ip = {} for particle {particle}, expected {} (gradients missing a 1/h give h)", Num(*value), Num(*expected))]
    GradientMoment {
        /// Particle index.
        particle: usize,
        /// Row `a` of `Σ_i (X_i − x_p)_a ∂_b S_ip`.
        row: usize,
        /// Column `b`.
        col: usize,
        /// The entry.
        value: f64,
        /// `δ_ab`.
        expected: f64,
    },
}

impl ViewError {
    /// The array the error is about (`"weights"` for the weight identities, `"grid"` for a
    /// grid that does not match the nodal arrays).
    pub fn array(&self) -> &'static str {
        match self {
            ViewError::Length { array, .. }
            | ViewError::NonFinite { array, .. }
            | ViewError::NodeOutOfRange { array, .. } => array,
            ViewError::Grid { .. } => "grid",
            ViewError::PartitionOfUnity { .. }
            | ViewError::GradientSum { .. }
            | ViewError::GradientMoment { .. } => "weights",
        }
    }

    /// The particle or node index, where the error is about one.
    pub fn index(&self) -> Option<usize> {
        match self {
            ViewError::Length { .. } | ViewError::Grid { .. } => None,
            ViewError::NonFinite { index, .. } | ViewError::NodeOutOfRange { index, .. } => {
                Some(*index)
            }
            ViewError::PartitionOfUnity { particle, .. }
            | ViewError::GradientSum { particle, .. }
            | ViewError::GradientMoment { particle, .. } => Some(*particle),
        }
    }

    /// The offending value: a length, a node count or index, a non-finite value, a sum.
    pub fn value(&self) -> f64 {
        match self {
            ViewError::Length { len, .. } => *len as f64,
            ViewError::Grid { grid_nodes, .. } => *grid_nodes as f64,
            ViewError::NonFinite { value, .. } | ViewError::GradientMoment { value, .. } => *value,
            ViewError::NodeOutOfRange { node, .. } => *node as f64,
            ViewError::PartitionOfUnity { sum, .. } | ViewError::GradientSum { sum, .. } => *sum,
        }
    }
}
