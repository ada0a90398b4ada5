//! The temporal-error limit of every dimension (eqs 20–30): the limit itself,
//! [`TemporalError<D>`] ([`limit`], the shared control flow, with the dimension's estimator
//! behind [`TemporalEstimator`]), its settings ([`TemporalErrorConfig`]), its name in logs,
//! the field scales of its weights ([`scales`]), the deferral of checks while the error is
//! small ([`deferral`]) and the parts of the error that do not vanish with the step
//! ([`non_smooth`]). The estimators: the 1D [`crate::controller::RateKernels`]
//! ([`crate::controller::TemporalError`] is `TemporalError<1>`) and the 2D/3D
//! [`crate::limits_nd::RateSweeps<D>`] ([`crate::limits_nd::TemporalErrorNd<D>`] is `TemporalError<D>`).

mod config;
pub mod deferral;
pub mod limit;
pub mod non_smooth;
pub mod scales;

pub use config::TemporalErrorConfig;
pub use limit::{Estimate, TemporalDim, TemporalError, TemporalEstimator};

/// The name of the temporal-error limit in logs and statistics (every dimension).
pub const TEMPORAL_ERROR: &str = "temporal_error";
