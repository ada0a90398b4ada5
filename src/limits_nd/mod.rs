//! The time-step limits in two and three dimensions, and the controller that combines them.
//!
//! * [`crate::sound_speed::SoundSpeed`] — `α · min_p min_a h_a/(c_p + |v_a|)` (eq 49
//!   generalised; one limit for every dimension, its 2D/3D kernel in [`sound_speed`]);
//! * [`StabilityNd`] — `safety · √(2/λmax(M⁻¹K))` (eq 56 generalised, [`stiffness`]; the
//!   one stability limit of every dimension, [`crate::stability::limit::Stability<D>`],
//!   with the rule [`GuardedEq56`]),
//!   `λmax` refreshed by Lanczos only when particles have moved or moduli changed enough,
//!   or stepped on the guaranteed element bound ([`element_bound`]) where that is close
//!   ([`bound_tracking`]);
//! * [`TemporalErrorNd`] — the temporal local error of eqs 20–30, judged by `dsm ≤ 1`
//!   (the controller's filter turns `dsm` into a proposal);
//! * [`GrowthNd`] — rejects a step whose mechanical energy grows and lowers the safety (the
//!   one growth monitor of every dimension, [`crate::growth::Growth<D>`]);
//! * [`critical`] — the verification table of a d-dimensional layout (sound-speed step,
//!   dense eq 56, empirical bisection on real runs).
//!
//! [`crate::controller::standard_limits`] builds the controller's list from a
//! [`crate::controller::ControllerConfig`]:
//! `sound_speed.alpha` → [`crate::sound_speed::SoundSpeed`], `stability.safety` and `stability_nd` →
//! [`StabilityNd`], `temporal` → [`TemporalErrorNd`] (when `temporal.enabled`),
//! `growth.enabled`, `window`, `windows`, `energy_tol` → [`GrowthNd`] (over
//! `windows · window` steps, default 100, tolerance 10 %). The fields that apply in 1D
//! only are refused by the controller
//! ([`crate::controller::ControllerConfig::validate_for`]).
//!
//! ```
//! use mpm_dt::controller::{Controller, ControllerConfig};
//! use mpm_dt::controller::standard_limits;
//! use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
//! use mpm_dt::{Boundary, Stepper};
//!
//! let grid = GridNd::<2>::new([Boundary::Periodic; 2], [8, 8], [1.0, 1.0]);
//! let material = MaterialNd::LinearElastic { youngs_modulus: 1.0, poisson_ratio: 0.3 };
//! let mut particles = ParticlesNd::uniform(&grid, [2, 2], 1.0, material);
//! for p in 0..particles.len() {
//!     particles.v[p][0] = 1e-3 * (2.0 * std::f64::consts::PI * particles.x[p][0]).sin();
//! }
//! let mut solver = SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<2>::zeros())?;
//! let config = ControllerConfig::default();
//! let limits = standard_limits::<2>(&config, Vector::<2>::zeros());
//! let mut controller = Controller::<2>::new(config.clone(), limits)?;
//! controller.run_until(&mut solver, 0.5, &mut |_| {})?;
//! assert!((solver.time() - 0.5).abs() < 1e-12);
//! // The same limits in one call, gravity (here none) from `config.gravity`:
//! let same = Controller::<2>::standard(config)?;
//! assert_eq!(same.limit_names(), controller.limit_names());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod bound_tracking;
pub mod element_bound;
pub mod growth;
pub mod nodal_full_map;
pub mod sound_speed;
pub mod stability;
mod stability_config;
mod start;
pub mod stiffness;
mod stress_rates;
pub mod temporal_error;
mod temporal_sweep;
pub mod transfer;

pub use crate::sound_speed::SOUND_SPEED;
pub use crate::stability::limit::StabilityNd;
pub use growth::{GrowthNd, GROWTH};
pub use stability::{GuardedEq56, STABILITY};
pub use stability_config::StabilityNdConfig;
pub use temporal_error::{RateSweeps, TemporalErrorNd};
pub use transfer::{apic_gain, TransferNd};

// The verification tools live in the test bench (`src/testbench/limits_nd/`): the critical
// steps of a layout run the 2D/3D reference solver, and the dense full map is a check on
// small layouts, not part of a limit. Their public paths stay here.
#[cfg(feature = "reference")]
pub use crate::testbench::limits_nd::{critical, full_map};
