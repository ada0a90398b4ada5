//! The object-safe [`StepLimit`] trait: one constraint on the time step.
//!
//! Following SUNDIALS' adaptivity controllers, *proposing* a step and *recording* an
//! accepted one are separate calls. Per attempt the controller
//!
//! 1. asks every limit to [`StepLimit::propose`] a step from the committed state and takes
//!    the smallest (and `dt_max`, and what is left to `t_end`);
//! 2. lets the stepper compute a trial with that step;
//! 3. asks every limit to [`StepLimit::judge`] the trial against the committed state;
//! 4. accepts if every verdict is [`Verdict::Accept`] — then calls
//!    [`StepLimit::accepted`] on each — or rejects, calling [`StepLimit::rejected`].
//!
//! Limits report numbers they computed (λmax, the eq 58 value, `dsm`, …) as named
//! [`Metrics`], which the controller copies into its decision log.

use crate::dimension::{Dim, Dimension, ViewOf};
use crate::fmt_num::Num;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Named diagnostic numbers a limit computed (e.g. `"lambda_max"`, `"bound58"`, `"dsm"`).
pub type Metrics = BTreeMap<String, f64>;

/// A limit's proposal for the next step. (`Proposal::default()` has `dt = 0`, a proposal
/// the controller cannot take; a limit without an opinion returns
/// [`Proposal::no_opinion`].)
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Proposal {
    /// The largest step this limit allows; `f64::INFINITY` when it has no opinion.
    pub dt: f64,
    /// Diagnostics computed on the way.
    pub metrics: Metrics,
}

impl Proposal {
    /// No opinion: `dt = ∞`, no metrics (a limit that only judges trials). Not
    /// `Proposal::default()`, whose `dt` is `0`.
    #[must_use]
    pub fn no_opinion() -> Self {
        Self {
            dt: f64::INFINITY,
            metrics: Metrics::new(),
        }
    }
}

/// Why a trial was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum RejectCause {
    /// The temporal local error estimate exceeded its tolerance (eqs 20–30).
    Error,
    /// A stability check failed (eq 58, or a stability proposal violated).
    Stability,
    /// Growth of the solution over a window of steps (slow instability).
    Growth,
    /// The trial produced NaN or infinite values, or the stepper failed.
    NonFinite,
    /// A user-supplied limit vetoed the step.
    UserVeto,
    /// Another process of a distributed run rejected the step ([`crate::reduce`]).
    OtherRank,
}

impl RejectCause {
    /// The cause's name in logs (as serialized): `"error"`, `"stability"`, `"growth"`,
    /// `"non_finite"`, `"user_veto"`, `"other_rank"`.
    pub fn as_str(self) -> &'static str {
        match self {
            RejectCause::Error => "error",
            RejectCause::Stability => "stability",
            RejectCause::Growth => "growth",
            RejectCause::NonFinite => "non_finite",
            RejectCause::UserVeto => "user_veto",
            RejectCause::OtherRank => "other_rank",
        }
    }
}

impl std::fmt::Display for RejectCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A limit's verdict on a trial step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The trial is acceptable to this limit.
    Accept,
    /// The trial must be rejected.
    Reject {
        /// Why.
        cause: RejectCause,
        /// A step this limit expects to accept, if it can tell.
        suggested_dt: Option<f64>,
    },
}

/// A verdict and the diagnostics behind it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Judgement {
    /// Accept or reject.
    pub verdict: Verdict,
    /// Diagnostics computed while judging.
    pub metrics: Metrics,
}

impl Judgement {
    /// An acceptance with no diagnostics.
    pub fn accept() -> Self {
        Self {
            verdict: Verdict::Accept,
            metrics: Metrics::new(),
        }
    }
}

/// Names of the metrics the controller reads from the limits, and the diagnostics the
/// standard limits add to a decision's records ([`crate::controller::LimitRecord::metrics`],
/// in the JSON log and `on_decision`). The controller reads only the constants below; the
/// others are for users and tools, per limit:
///
/// | limit | metric | meaning |
/// |---|---|---|
/// | `sound_speed` | `dt_sound_unit` | the speed-of-sound step at α = 1, `min_p min_a h_a/(c_p + \|v_pa\|)` (eq 49) |
/// | `stability` (both) | `lambda_max` | `λmax` the proposal used (eq 56) |
/// | `stability` (1D) | `dt_eq56`, `safety` | the eq 56 step before the safety factor, and that factor |
/// | `stability` (1D) | `lanczos_applications`, `lanczos_residual` | operator products of this proposal's estimate (0 when a cached value served), its residual |
/// | `stability` (1D, certified) | `lambda_rayleigh`, `lambda_certified`, `lambda_factorisations` | the Rayleigh quotient, whether the `LDLᵀ` inertia test certified it (1/0), factorisations spent |
/// | `stability` (1D, judge) | `bound58`, `bound58_euclidean` | eq 58's lower bound on the amplification matrix's norm, in the energy and the Euclidean norm |
/// | `stability` (2D/3D) | `refreshes`, `lanczos_applications` | Lanczos runs and operator products since the start, on a proposal that refreshed |
/// | `stability` (2D/3D) | `bound_ratio` | `B/λ`, the element bound over the Lanczos value at the last refresh ([`crate::limits_nd::bound_tracking`]) |
/// | `stability` (2D/3D) | `bound_proposals`, `calibrated_proposals` | proposals made on the element bound, and on the calibrated bound, since the start |
/// | `stability` (2D/3D, APIC) | `transfer_gain` | `1 + p` of [`crate::limits_nd::transfer`] |
/// | `temporal_error` | `dsm_v`, `dsm_sigma`, `dsm_particles` | the velocity and stress parts of `dsm` (eqs 20–30) and the particles in the norm |
/// | `temporal_error` | `dsm_excluded` | the parts left out of `dsm` because they did not fall with the step (1 velocity, 2 stress, 3 both; [`crate::temporal::non_smooth`]) |
/// | `growth` (1D) | `growth_indicator`, `growth_ratio` | the monitor's indicator of the trial and, on a detection, the last window maximum over the first |
/// | `growth` (2D/3D) | `energy` | the watched energy `E` of the trial ([`crate::growth::nd`]) |
/// | any, after a growth detection | `safety_scale` | the factor every limit's proposal is multiplied by for the rest of the run |
pub mod metric {
    /// Scaled temporal error (eqs 20–30), `dsm ≤ 1` accepts; fed to the filter.
    pub const DSM: &str = "dsm";
    /// A deferred temporal-error check's predicted `dsm` (not measured; not fed to the
    /// filter; [`crate::temporal::deferral`]).
    pub const DSM_PREDICTED: &str = "dsm_predicted";
    /// Largest eigenvalue of `D*F` (eq 56) tracked by the stability limit.
    pub const LAMBDA_MAX: &str = "lambda_max";
    /// The eq 58 lower bound on the amplification-matrix norm.
    pub const BOUND58: &str = "bound58";
}

/// A limit failed to evaluate (bad state, not a rejected step).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LimitError {
    /// The state holds a value the limit cannot work with.
    #[error("limit {limit}: invalid {field} at index {index} (value {}) at t = {}", Num(*value), Num(*t))]
    InvalidState {
        /// The limit's name.
        limit: String,
        /// Which field.
        field: &'static str,
        /// Particle or node index.
        index: usize,
        /// The offending value.
        value: f64,
        /// Time of the state.
        t: f64,
    },
    /// The limit refuses one of its settings.
    #[error("limit {limit}: {source}")]
    Config {
        /// The limit's name.
        limit: String,
        /// The setting and why.
        source: crate::config_error::ConfigError,
    },
    /// A checkpoint's state for the limit could not be read back
    /// ([`StepLimit::restore_state`]).
    #[error("limit {limit}: cannot restore state: {source}")]
    Restore {
        /// The limit's name.
        limit: String,
        /// The JSON reader's error.
        source: crate::config_error::JsonError,
    },
    /// Anything else, described.
    #[error("limit {limit}: {message}")]
    Other {
        /// The limit's name.
        limit: String,
        /// What went wrong.
        message: String,
    },
}

/// A call of a limit that [`StepLimit::reads_arrays`] asks about.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LimitCall {
    /// [`StepLimit::propose`] on the committed state.
    Propose,
    /// [`StepLimit::judge`] of a trial of step `dt`.
    Judge {
        /// The trial's step.
        dt: f64,
    },
    /// [`StepLimit::accepted`] of a trial of step `dt`.
    Accepted {
        /// The trial's step.
        dt: f64,
    },
}

/// One constraint on the time step. Object safe: the controller holds
/// `Box<dyn StepLimit<D>>` (`D = 1` by default; [`crate::dimension`]).
pub trait StepLimit<const D: usize = 1>
where
    Dim<D>: Dimension,
{
    /// Short stable name used in logs and statistics (e.g. `"sound_speed"`).
    fn name(&self) -> &str;

    /// The largest step this limit allows from the committed state `state`.
    fn propose(&mut self, state: &ViewOf<'_, D>) -> Result<Proposal, LimitError>;

    /// Judges a trial of step `dt` from `before` (committed) to `after` (trial).
    fn judge(
        &mut self,
        before: &ViewOf<'_, D>,
        after: &ViewOf<'_, D>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        let _ = (before, after, dt);
        Ok(Judgement::accept())
    }

    /// Records an accepted step (update histories, warm starts).
    fn accepted(&mut self, before: &ViewOf<'_, D>, after: &ViewOf<'_, D>, dt: f64) {
        let _ = (before, after, dt);
    }

    /// Whether this limit's next proposal reads [`crate::View::nodal_stiffness`] (default
    /// `false`); the controller then asks its stepper to provide it
    /// ([`crate::Stepper::provide_nodal_stiffness`] for the committed state before a
    /// proposal, [`crate::Stepper::provide_nodal_stiffness_on_trials`] before a trial, with
    /// the answer after the proposal).
    fn reads_nodal_stiffness(&self) -> bool {
        false
    }

    /// Whether this limit's `call` reads the particle or nodal arrays of the views it is
    /// given (for [`LimitCall::Propose`], `state` is the committed view; for a judgement or
    /// an acceptance, the trial's; either may be summary-only). The controller of a stepper
    /// that hands over its arrays on demand ([`crate::Stepper::provide_arrays_on_demand`])
    /// loads them exactly when some limit answers `true`. Default `true`: a limit that does
    /// not say is always given full views. An answer must not depend on the arrays (they
    /// may be absent) and a `false` must be kept: the call then reads only the views'
    /// times, steps, grids and summaries.
    fn reads_arrays(&self, call: LimitCall, state: &ViewOf<'_, D>) -> bool {
        let _ = (call, state);
        true
    }

    /// Where `call` reads arrays ([`Self::reads_arrays`]), whether it reads the views'
    /// weights and nodal fields too (`false`: the particle arrays alone, so that a stepper
    /// handing over on demand may skip forming them, [`crate::Stepper::load_particles`]).
    /// `state` is as for [`Self::reads_arrays`], or the trial's view holding its particle
    /// arrays: the controller asks again once they are loaded, and loads the rest where
    /// the answer turns `true`. Default `true`; a `false` must be kept as for
    /// [`Self::reads_arrays`].
    fn reads_nodal(&self, call: LimitCall, state: &ViewOf<'_, D>) -> bool {
        let _ = (call, state);
        true
    }

    /// Whether this limit reads [`crate::PassSummary::element_bound`] (default `false`); the
    /// controller then asks its stepper to provide it
    /// ([`crate::Stepper::provide_element_bound`]).
    fn reads_element_bound(&self) -> bool {
        false
    }

    /// Records a rejected attempt of step `dt` and its cause.
    fn rejected(&mut self, dt: f64, cause: RejectCause) {
        let _ = (dt, cause);
    }

    /// Multiplies this limit's stability safety factor by `factor` (in `(0, 1]`) for the
    /// rest of the run. The controller calls it on every limit when its growth monitor
    /// detects a slowly growing instability. Limits without a safety factor ignore it
    /// (the default); a stability limit lowers the factor it applies to its critical step.
    fn scale_safety(&mut self, factor: f64) {
        let _ = factor;
    }

    /// Bytes of heap memory the limit holds between calls (its arrays' capacities):
    /// per-particle histories and references, nodal vectors. What a user's solver pays
    /// for the limit on top of its own state ([`crate::controller::Controller::memory_bytes`]).
    /// Default: 0 (a limit that keeps no arrays).
    fn memory_bytes(&self) -> usize {
        0
    }

    /// Hands the limit the run's global reductions ([`crate::reduce`]); called by
    /// [`Controller::with_reduce`](crate::controller::Controller::with_reduce). A limit
    /// whose proposal needs sums over the whole state (the d-dimensional stability
    /// tracker's Lanczos products) reduces with it, and must then take part in the same
    /// reductions on every process. Default: ignored (a proposal from local data only,
    /// which the controller's global minimum covers).
    fn set_reduce(&mut self, reduce: std::rc::Rc<dyn crate::reduce::Reduce>) {
        let _ = reduce;
    }

    /// Hands the limit a pool of threads for its passes over the particles (`None`: the
    /// calling thread); called by
    /// [`Controller::with_threads`](crate::controller::Controller::with_threads). A limit
    /// that uses it gives the same proposals and verdicts, bit for bit, on any number of
    /// the pool's threads (sums may be taken in another order than without a pool: say so
    /// where they are). Default: ignored (the limit's passes run on the calling thread).
    fn set_threads(&mut self, pool: Option<std::sync::Arc<rayon::ThreadPool>>) {
        let _ = pool;
    }

    /// The limit's internal state (histories, warm starts) for a checkpoint, or `None`
    /// when the limit is stateless (the default). Restoring it with
    /// [`StepLimit::restore_state`] must make the limit behave bit-identically.
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }

    /// Restores a state produced by [`StepLimit::save_state`]. The default accepts
    /// anything and does nothing (stateless limits).
    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        let _ = state;
        Ok(())
    }
}
