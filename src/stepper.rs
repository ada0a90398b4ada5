//! The object-safe [`Stepper`] trait: what the library needs of an explicit MPM solver.
//!
//! A stepper holds a *committed* state at time `tⁿ`. [`Stepper::try_step`] computes a *trial*
//! state at `tⁿ + dt` beside it (double buffering); the caller inspects both through
//! [`Stepper::view`] and [`Stepper::trial_view`] and then either [`Stepper::accept`]s the trial
//! (it becomes the committed state) or [`Stepper::reject`]s it (the committed state is left
//! exactly as it was, bit for bit, because it was never written).
//!
//! The [`View`] is read-only and made of slices, so that any solver — the reference
//! [`crate::mpm`] solver or a user's own — can expose its fields without copying. Two parts
//! are optional work for the solver: the weights may be *deferred* (computed on first use,
//! [`ViewWeights`]), and a solver may accumulate the nodal stiffness `K_N` of eq 56 in its
//! own particle→grid pass ([`View::nodal_stiffness`], asked for through
//! [`Stepper::provide_nodal_stiffness`]) so that the stability limit needs no weights at
//! all. A view describes one state: particle fields at the particle positions, the weights `S`, `D`
//! evaluated *at those positions*, and the nodal fields obtained from them by eq 7 (mass),
//! eq 17 (velocity) and eq 18 (acceleration). These are exactly the quantities the next step
//! from that state uses, and what the estimators of Section 4 and the stability analysis of
//! Section 6 read.

use crate::dimension::{Dim, Dimension, ViewOf};
use crate::fmt_num::Num;
pub use crate::view::View;
#[cfg(doc)]
use crate::{pass_summary::PassSummary, view_weights::ViewWeights};

/// Why a trial step failed. The committed state is untouched in every case.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StepError {
    /// `dt` is not a positive finite number.
    #[error("invalid time step dt = {} at t = {}", Num(*dt), Num(*t))]
    InvalidDt {
        /// The offending step.
        dt: f64,
        /// Time of the committed state.
        t: f64,
    },
    /// A trial produced a NaN or infinite value.
    #[error("non-finite {field} at particle {index} in the trial from t = {} (step {step}) with dt = {}", Num(*t), Num(*dt))]
    NonFinite {
        /// Which field (`"x"`, `"v"`, `"sigma"`, `"F"`).
        field: &'static str,
        /// Particle index of the first offending value.
        index: usize,
        /// Time of the committed state the trial started from.
        t: f64,
        /// Number of accepted steps before the trial.
        step: u64,
        /// The trial's step.
        dt: f64,
    },
    /// A particle left a non-periodic domain.
    #[error("particle {index} left the domain along axis {axis} (coordinate {}) in the trial from t = {} (step {step}) with dt = {}", Num(*x), Num(*t), Num(*dt))]
    OutOfDomain {
        /// Particle index.
        index: usize,
        /// The axis along which it left (0 in 1D).
        axis: usize,
        /// Its trial coordinate along that axis.
        x: f64,
        /// Time of the committed state.
        t: f64,
        /// Number of accepted steps before the trial.
        step: u64,
        /// The trial's step.
        dt: f64,
    },
    /// A deformation gradient became non-positive (material inverted).
    #[error("particle {index} inverted (det F = {}) in the trial from t = {} (step {step}) with dt = {}", Num(*det_f), Num(*t), Num(*dt))]
    Inverted {
        /// Particle index.
        index: usize,
        /// `det F` of its trial deformation gradient (in 1D, `F` itself).
        det_f: f64,
        /// Time of the committed state.
        t: f64,
        /// Number of accepted steps before the trial.
        step: u64,
        /// The trial's step.
        dt: f64,
    },
    /// A solver-specific failure that a smaller step may cure (a Newton iteration that
    /// did not converge, a solver's own blow-up check): the controller rejects the trial
    /// and retries with a smaller step, as for [`StepError::NonFinite`].
    #[error("{message} (trial from t = {} (step {step}) with dt = {})", Num(*t), Num(*dt))]
    Failed {
        /// The solver's message.
        message: String,
        /// Time of the committed state the trial started from.
        t: f64,
        /// Number of accepted steps before the trial.
        step: u64,
        /// The trial's step.
        dt: f64,
    },
    /// `accept` was called with no trial pending.
    #[error("accept() called with no trial step pending")]
    NoTrial,
    /// A solver-specific failure (for users' steppers). The controller does not retry it
    /// with a smaller step: the run ends with the message.
    #[error("{0}")]
    Other(String),
}

/// An explicit MPM solver as the controller drives it. Object safe: the controller takes
/// `&mut dyn Stepper<D>` (`D = 1` by default; [`crate::dimension`]).
pub trait Stepper<const D: usize = 1>
where
    Dim<D>: Dimension,
{
    /// Time of the committed state.
    fn time(&self) -> f64;

    /// Number of accepted steps so far.
    fn step_count(&self) -> u64;

    /// Computes a trial state at `time() + dt` from the committed state, replacing any
    /// previous trial. On error no trial is pending and the committed state is unchanged.
    ///
    /// The step order the limits assume (update stress last, USL): the committed state's
    /// nodal fields give the grid update and the grid → particle update of positions,
    /// velocities, `F` and stress; then a particle → grid pass **at the new positions**
    /// forms the trial's nodal mass, velocity and acceleration. The trial's view must carry
    /// those nodal fields (the next step starts from them, and the stability and temporal
    /// limits judge the trial on them), with weights formed at the new positions.
    fn try_step(&mut self, dt: f64) -> Result<(), StepError>;

    /// Makes the pending trial the committed state.
    fn accept(&mut self) -> Result<(), StepError>;

    /// Discards the pending trial (no-op if none): the committed state is bit-identical to
    /// what it was before `try_step`.
    fn reject(&mut self);

    /// The committed state.
    fn view(&self) -> ViewOf<'_, D>;

    /// The pending trial state, if any.
    fn trial_view(&self) -> Option<ViewOf<'_, D>>;

    /// Asks the stepper to accumulate the nodal stiffness ([`View::nodal_stiffness`]) in
    /// the states it computes from now on (`true`) or to stop (`false`); returns whether it
    /// does. The controller asks when one of its limits reads it
    /// ([`crate::StepLimit::reads_nodal_stiffness`]), before every step, so a repeated call
    /// with the same value should cost nothing. The default does not provide it.
    fn provide_nodal_stiffness(&mut self, on: bool) -> bool {
        let _ = on;
        false
    }

    /// Like [`Self::provide_nodal_stiffness`], for the states the coming trials write only:
    /// the committed state is left as it is (a stepper that computes `K_N` for the
    /// committed state when switched on should skip that here). The controller calls it
    /// before every trial with whether its limits' next proposal reads `K_N`, which
    /// changes from step to step when the stability limit serves on the element bound
    /// ([`crate::stability::CertifiedTracker::wants_nodal_stiffness`]); it calls it only
    /// when some limit reads the element bound. The default forwards to
    /// [`Self::provide_nodal_stiffness`], which for a stepper that computes `K_N` for the
    /// committed state when switched on repeats that work: override it to save it.
    fn provide_nodal_stiffness_on_trials(&mut self, on: bool) -> bool {
        self.provide_nodal_stiffness(on)
    }

    /// Asks the stepper to add the element bound ([`PassSummary::element_bound`], 1D) to the
    /// summaries of the states it computes from now on (`true`) or to stop (`false`);
    /// returns whether it does. The controller asks when one of its limits reads it
    /// ([`crate::StepLimit::reads_element_bound`]: the 1D certified tracker serving on the
    /// bound). The default does not provide it; the library then takes it from the view's
    /// weights when they are its own GIMP weights.
    fn provide_element_bound(&mut self, on: bool) -> bool {
        let _ = on;
        false
    }

    /// Asks the stepper to hand over its particle and nodal arrays on demand (`true`) from
    /// now on: its [`Self::view`] and [`Self::trial_view`] may then be summary-only
    /// ([`crate::nd::ViewNd::summary_only`]: the state's time, step, grid and pass summary,
    /// no arrays) until the controller calls [`Self::load_arrays`] for that state. Returns
    /// whether it does. For a solver whose particles live elsewhere — on a GPU, in another
    /// process, in Python — so that a step hands over a few numbers, not its arrays.
    ///
    /// The controller asks only in a single-process run, and loads a state's arrays
    /// exactly when one of its limits declares that its next call reads them
    /// ([`crate::StepLimit::reads_arrays`]; a limit that does not say reads them always),
    /// when the door check of the committed view is due (the first view, then every
    /// [`crate::view_check::VIEW_CHECK_CADENCE`]th step) and when a trial's summary is not
    /// finite (to name the particle). With the standard limits that is a λmax refresh, a
    /// temporal-error check and those door checks; a stepper whose summary lacks the
    /// element bound or the speed-of-sound step has its arrays loaded at every step.
    ///
    /// What the stepper gives up: a state whose arrays are never loaded is not checked by
    /// the library (a particle outside the grid or inverted is the stepper's to report, as
    /// a [`StepError`] from [`Self::try_step`]); its summary must be marked finite only
    /// when every value the summary covers is. The default does not hand over on demand.
    fn provide_arrays_on_demand(&mut self, on: bool) -> bool {
        let _ = on;
        false
    }

    /// Makes the arrays of the committed state (`trial == false`) or of the pending trial
    /// (`true`) part of the next [`Self::view`] / [`Self::trial_view`]; a no-op for a state
    /// already loaded and for a stepper that does not hand over on demand. A retryable
    /// error for a trial (non-finite, inverted, out of the domain, `Failed`) rejects it as
    /// if [`Self::try_step`] had returned it; any other error ends the run.
    fn load_arrays(&mut self, trial: bool) -> Result<(), StepError> {
        let _ = trial;
        Ok(())
    }

    /// [`Self::load_arrays`] for a call that reads the particle arrays alone
    /// ([`crate::StepLimit::reads_nodal`]): a stepper may then skip forming the state's
    /// weights and nodal fields, its view being [`crate::nd::ViewNd::without_nodal`] until
    /// [`Self::load_arrays`]. The default loads everything.
    fn load_particles(&mut self, trial: bool) -> Result<(), StepError> {
        self.load_arrays(trial)
    }

    /// Asks the stepper to attach a [`PassSummary`] ([`View::summary`]; in 2D/3D a
    /// [`crate::nd::SummaryNd`], [`crate::nd::ViewNd::summary`]) to the states its passes
    /// compute from now on (`true`) or to stop (`false`); returns whether it does. The
    /// controller asks (`true`) before every step, so a repeated call should cost nothing
    /// once the summary is on. The default does not provide it.
    fn provide_summary(&mut self, on: bool) -> bool {
        let _ = on;
        false
    }
}
