//! Why the controller stopped: [`ControllerError`].

use super::config::ConfigError;
use super::decision::Decision;
#[cfg(doc)]
use super::Controller;
use crate::fmt_num::Num;
use crate::limit::{LimitError, RejectCause};
use crate::stepper::StepError;
use crate::view_check::ViewError;

/// Why the controller stopped.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ControllerError {
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The pool of threads for the limits could not be started
    /// ([`Controller::with_threads`]).
    #[error("cannot start the controller's threads: {0}")]
    Threads(String),
    /// One step was rejected `count` times in a row.
    #[error("{count} consecutive rejections at t = {} (last dt = {}, cause {}{})", Num(*t), Num(last.dt), last.cause.map_or("none", RejectCause::as_str), last.message.as_deref().map(|m| format!(": {m}")).unwrap_or_default())]
    TooManyRejections {
        /// Rejections in a row.
        count: u32,
        /// Time of the committed state.
        t: f64,
        /// The last decision.
        last: Box<Decision>,
    },
    /// The growth monitor kept detecting growing energy: one more detection would lower the
    /// stability safety below `growth.min_safety_scale` ([`super::GrowthConfig`]). The
    /// limits' steps are then far below what they claim is stable and the energy still
    /// grows: the scheme is unstable for a reason they do not model, or energy is supplied
    /// to the run (a driven boundary) that the monitor does not count. The last trial was
    /// rejected; the stepper holds the last accepted state.
    #[error("the energy kept growing: growth detected {detections} times (t = {}, step {step}); the stability safety is down to {} of its start and one more reduction would go below growth.min_safety_scale = {}. The run is unstable at every step the limits propose, or energy is supplied to it that the growth monitor does not count (disable `growth`, or set `growth.min_safety_scale` to 0, if that is expected)", Num(*t), Num(*safety_scale), Num(*min_safety_scale))]
    GrowthPersists {
        /// Time of the committed state.
        t: f64,
        /// Accepted steps before it.
        step: u64,
        /// Growth detections so far (rejections with cause `growth`, this one included).
        detections: u64,
        /// The factor the safety has been lowered by so far.
        safety_scale: f64,
        /// The configured floor.
        min_safety_scale: f64,
    },
    /// The step would fall below `dt_min`, or be too small to advance `t` in floating
    /// point (below 64 ulps of `t`).
    #[error("step {} too small (dt_min = {}) at t = {} (bound by {binding})", Num(*dt), Num(*dt_min), Num(*t))]
    StepTooSmall {
        /// The step the rules gave.
        dt: f64,
        /// The configured floor.
        dt_min: f64,
        /// Time of the committed state.
        t: f64,
        /// What bound the step.
        binding: String,
        /// The last decision of this step, if any attempt was made.
        last: Option<Box<Decision>>,
    },
    /// Nothing bounds the first step: no limit proposes one and `dt_initial` is unset.
    #[error("no initial step at t = {}: no limit proposes a step and dt_initial is not set", Num(*t))]
    NoInitialStep {
        /// Time of the committed state.
        t: f64,
    },
    /// A limit proposed a step that is not a positive number.
    #[error("limit {limit} proposed dt = {} at t = {}", Num(*dt), Num(*t))]
    InvalidProposal {
        /// The limit.
        limit: String,
        /// Its proposal.
        dt: f64,
        /// Time of the committed state.
        t: f64,
    },
    /// A limit failed to evaluate.
    #[error("at t = {}: {source}", Num(*t))]
    Limit {
        /// Time of the committed state.
        t: f64,
        /// The limit's error.
        source: LimitError,
    },
    /// The stepper failed in a way a smaller step cannot fix.
    #[error("at t = {}: {source}", Num(*t))]
    Stepper {
        /// Time of the committed state.
        t: f64,
        /// The stepper's error.
        source: StepError,
    },
    /// `t_end` is not after the stepper's time, or not a number.
    #[error("t_end = {} is not after t = {}", Num(*t_end), Num(*t))]
    InvalidEnd {
        /// Time of the committed state.
        t: f64,
        /// The requested end.
        t_end: f64,
    },
    /// The stepper accepted a trial of step `dt` from `t` but reports the time `t_after`:
    /// a trial must advance the time by `dt` (a stepper that keeps or moves back its time
    /// would make [`Controller::run_until`] loop forever).
    #[error("the stepper did not advance its time: trial dt = {} from t = {}, time after accept = {}", Num(*dt), Num(*t), Num(*t_after))]
    NoProgress {
        /// Time of the committed state before the step.
        t: f64,
        /// The accepted step.
        dt: f64,
        /// The time the stepper reports after accepting it.
        t_after: f64,
    },
    /// Another process of a distributed run failed ([`crate::reduce`]); this one stops with
    /// it instead of waiting. The failing process returns its own error.
    #[error("another process failed {phase} at t = {}", Num(*t))]
    OtherRank {
        /// Time of the committed state.
        t: f64,
        /// When: `"at the door check of its view"` (its view failed
        /// [`crate::view_check`]: [`ControllerError::InvalidView`]), `"before its trial"`,
        /// `"in its trial"`, or `"with growth persisting"`
        /// (its growth monitor ended the run: [`ControllerError::GrowthPersists`]).
        phase: &'static str,
    },
    /// A view the stepper handed over does not describe one consistent state (the door
    /// check, [`crate::view_check`]): an array of the wrong length, a grid that does not
    /// match the nodal arrays, a non-finite committed value, weights that are not a
    /// partition of unity or gradients that are not complete. A smaller step cannot cure
    /// it: the run ends before any limit reads the view.
    #[error("invalid {} view at t = {} (step {step}): {source}", if *trial { "trial" } else { "committed" }, Num(*t))]
    InvalidView {
        /// Time of the view.
        t: f64,
        /// Its step index.
        step: u64,
        /// Whether it is the trial view (else the committed view).
        trial: bool,
        /// What is wrong: the array, the particle or node, the value.
        source: ViewError,
    },
    /// A checkpoint does not fit the controller's limits.
    #[error("cannot restore checkpoint: {message}")]
    Restore {
        /// What does not fit.
        message: String,
        /// The limit's error, when a limit could not read its saved state back.
        #[source]
        source: Option<LimitError>,
    },
}
