//! The test bench: the reference solvers, their scenarios and exact problems, and the
//! verification tools that run them (the `reference` feature, on by default).
//!
//! It builds on the library and the library never names it: without the feature the crate
//! compiles nothing below `src/testbench/`. Each file keeps, below `src/testbench/`, the path
//! it would have in the library's tree, and each module keeps its public path through a
//! re-export at its old place:
//!
//! | source | what | public path |
//! |---|---|---|
//! | `mpm/` | the 1D update-stress-last reference solver (eqs 17–29) | [`crate::mpm`] |
//! | `scenario.rs`, `scenario/` | 1D scenario files with validation | [`crate::scenario`] |
//! | `problems.rs` | 1D problems with exact solutions (the vibrating bar) | [`crate::problems`] |
//! | `memory.rs` | the memory check before allocating a run | [`crate::memory`] |
//! | `nd/` | the 2D/3D reference solver ([`crate::nd::SolverNd`]: particles, material, fused and threaded steps, slabs and migration) | [`crate::nd`] |
//! | `nd/scenario/`, `nd/problems.rs` | 2D/3D scenarios and exact problems | [`crate::nd::scenario`], [`crate::nd::problems`] |
//! | `stability/empirical.rs` | the 1D empirical critical step | [`crate::stability::empirical`] |
//! | `stability/full_map.rs` | the 1D dense frozen-particle full map (small layouts) | [`crate::stability::full_map`] |
//! | `limits_nd/critical.rs` | the 2D/3D critical steps of a layout | [`crate::limits_nd::critical`] |
//! | `limits_nd/full_map.rs` | the 2D/3D dense frozen-particle full map (small layouts) | [`crate::limits_nd::full_map`] |

pub mod limits_nd;
pub mod memory;
pub mod mpm;
pub mod nd;
pub mod problems;
pub mod scenario;
pub mod setup_error;
pub mod stability;
