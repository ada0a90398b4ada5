//! What the temporal-error limits of every dimension share (eqs 20–30): their settings
//! ([`TemporalErrorConfig`]), their name in logs, the field scales of their weights
//! ([`scales`]) and the deferral of checks while the error is small ([`deferral`]). The limits themselves: the 1D
//! [`crate::controller::TemporalError`] and the 2D/3D [`crate::limits_nd::TemporalErrorNd`].

mod config;
pub mod deferral;
pub mod scales;

pub use config::TemporalErrorConfig;

/// The name of the temporal-error limit in logs and statistics (every dimension).
pub const TEMPORAL_ERROR: &str = "temporal_error";
