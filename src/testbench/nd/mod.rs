//! The 2D/3D reference solver ([`SolverNd`]) with its particles, material, threaded and
//! grid-decomposed steps, its scenarios ([`scenario`]) and exact problems ([`problems`]),
//! built on the library's [`crate::nd`] (grid, shapes, weights, views, kernels). Their public
//! paths are [`crate::nd`]'s: `mpm_dt::nd::SolverNd`, `mpm_dt::nd::scenario`, ….

mod fused;
mod material;
mod migration;
mod particles;
mod prefetch;
pub mod problems;
mod row_sums;
pub mod scenario;
mod slab;
mod solver;
mod threaded;
mod update;

pub use material::MaterialNd;
pub use particles::{ParticlesNd, SetupError};
pub use slab::MIN_CELLS as MIN_SLAB_CELLS;
pub use solver::{SolverNd, ThreadsError};
