//! Checkpoint and restart: everything the controller needs to continue a run
//! bit-identically — its config, its filter history, statistics and step history, and the
//! internal state of each limit ([`crate::limit::StepLimit::save_state`]).
//!
//! The stepper's state is the stepper's business; [`Checkpoint`] pairs a controller
//! checkpoint with any serializable stepper state. JSON keeps every `f64` bit-exact (the
//! crate enables serde_json's `float_roundtrip`).

use super::config::ControllerConfig;
use super::filter::SoderlindFilter;
use super::stats::Stats;
use serde::{Deserialize, Serialize};

/// The controller's own mutable state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControllerState {
    /// Last accepted step; `None` before the first.
    pub dt_prev: Option<f64>,
    /// The last accepted step needed retries: the next step may not grow.
    pub no_growth_next: bool,
    /// The last accepted step was shortened to land on an end time: the hold band
    /// ([`ControllerConfig::hold_growth`]) does not keep it.
    #[serde(default)]
    pub prev_landed: bool,
    /// The Söderlind filter with its history.
    pub filter: SoderlindFilter,
    /// Run statistics.
    pub stats: Stats,
    /// Product of all stability-safety reductions made after growth was detected (1 when
    /// none).
    pub safety_scale: f64,
}

/// One limit's saved state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LimitCheckpoint {
    /// The limit's name (checked on restore).
    pub name: String,
    /// What [`crate::limit::StepLimit::save_state`] returned.
    pub state: Option<serde_json::Value>,
}

/// A controller checkpoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControllerCheckpoint {
    /// The configuration.
    pub config: ControllerConfig,
    /// The controller's state.
    pub state: ControllerState,
    /// The limits' states, in the controller's order.
    pub limits: Vec<LimitCheckpoint>,
}

/// A controller checkpoint together with a stepper's state `S`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint<S> {
    /// The controller.
    pub controller: ControllerCheckpoint,
    /// The stepper.
    pub stepper: S,
}
