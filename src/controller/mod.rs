//! The adaptive controller: picks every `dt`, checks every trial, accepts or rejects it, and
//! says why.
//!
//! ```text
//! dt = min( each limit's proposal,                 (SoundSpeed eq 49, Stability eqs 56–58, user limits)
//!           safety · filter(dsm history),          (TemporalError eqs 20–30, Söderlind filter)
//!           dt_max,  t_end − t,
//!           max_growth · dt_prev   (1 · dt_prev right after a rejected attempt),
//!           η · dt_rejected        (on a retry) )
//! dt = dt_prev   if a limit's proposal binds and dt_prev < dt ≤ hold_growth · dt_prev
//! ```
//!
//! Per attempt: every limit proposes from the committed state, the stepper computes a trial,
//! the controller checks the trial is finite and every limit judges it; all accept ⇒
//! accept, any rejects ⇒ reject and retry with `η · dt` where `η = safety · dsm^(−1/(p+1))`
//! for an error-test failure, the limit's suggestion for other causes (or
//! `reject_shrink`), clamped to `[min_shrink, max_shrink_first]` on the first rejection and
//! `[min_shrink, max_shrink_repeated]` from the second on (SUNDIALS' rules, see
//! [`ControllerConfig`]). A limit's proposal may still bind below `min_shrink`: `dt` never
//! exceeds any limit's proposal. After `max_consecutive_rejections` rejections of one step
//! the run ends with [`ControllerError::TooManyRejections`], carrying the last
//! [`Decision`]; a growth rejection that would lower the stability safety below
//! `growth.min_safety_scale` of its start ends it with [`ControllerError::GrowthPersists`]
//! (on every process of a distributed run at the same trial).
//!
//! The controller is generic over the dimension, `Controller<D>` (`D = 1` by default):
//! it drives any `&mut dyn Stepper<D>` with `Box<dyn StepLimit<D>>` limits, and reads the
//! state only through the limits and [`crate::StateView`] (time, step, the non-finite
//! check, and the door check of every view before a limit reads it:
//! [`crate::view_check`], ending the run with [`ControllerError::InvalidView`]). A 2D or
//! 3D solver is driven exactly like a 1D one, with d-dimensional limits:
//! `Controller::<2>::standard(config)` builds the standard ones in any dimension
//! ([`StandardLimits`]), `Controller::<2>::new(config, limits)` takes any list.
//!
//! Every attempt yields a [`Decision`], emitted as an INFO `tracing` event inside one
//! `step` span per step (DEBUG events carry each limit's proposal and verdict), counted in
//! [`Stats`] and handed back to the caller. The library installs no subscriber.
//!
//! ```no_run
//! use mpm_dt::controller::{Controller, ControllerConfig};
//! # fn demo(stepper: &mut dyn mpm_dt::Stepper) -> Result<(), mpm_dt::controller::ControllerError> {
//! let mut controller = Controller::with_default_limits(ControllerConfig::default(), vec![])?;
//! controller.run_until(stepper, 1.0, &mut |d| println!("{}", d.to_json_line()))?;
//! println!("{:?}", controller.stats());
//! # Ok(()) }
//! ```

mod attempt;
mod checkpoint;
mod config;
pub mod config_dims;
mod decision;
mod door;
mod error;
mod filter;
mod on_demand;
mod scaled;
mod standard;
mod stats;
pub(crate) mod temporal_error;
mod temporal_kernels;

pub use crate::growth::{
    checkerboard_share, total_energy, GrowthConfig, GrowthIndicator, GrowthMonitor, GROWTH,
};
#[cfg(feature = "reference")]
pub(crate) use crate::growth::{particle_energy, sum_energy_lanes, ENERGY_LANES};
pub use crate::temporal::{deferral, TemporalErrorConfig};
pub use checkpoint::{Checkpoint, ControllerCheckpoint, ControllerState, LimitCheckpoint};
pub use config::{ConfigError, ControllerConfig};
pub use decision::{bound, metric, Decision, LimitRecord, Outcome};
pub use error::ControllerError;
pub use filter::{FilterPreset, SoderlindFilter, DSM_FLOOR};
pub use scaled::SafetyScaled;
pub use standard::{standard_limits, StandardLimits};
pub use stats::Stats;
pub use temporal_error::{RateKernels, TemporalError, TEMPORAL_ERROR};

use crate::dimension::{Dim, Dimension};
use crate::limit::StepLimit;
use crate::stepper::Stepper;
/// The adaptive controller. Owns its config, limits, filter and statistics; drives any
/// `&mut dyn Stepper<D>` (`D = 1` by default).
pub struct Controller<const D: usize = 1>
where
    Dim<D>: Dimension,
{
    config: ControllerConfig,
    limits: Vec<Box<dyn StepLimit<D>>>,
    state: ControllerState,
    /// Global reductions over the run's processes ([`crate::reduce`]).
    reduce: std::rc::Rc<dyn crate::reduce::Reduce>,
    /// Whether a committed view has passed the door check's contents part
    /// ([`crate::view_check`]); not part of a checkpoint (a restored controller checks its
    /// first view).
    first_view_checked: bool,
    /// Whether the stepper of the current step hands over its arrays on demand
    /// ([`on_demand`]); asked at every step.
    arrays_on_demand: bool,
}

impl<const D: usize> std::fmt::Debug for Controller<D>
where
    Dim<D>: Dimension,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Controller")
            .field("config", &self.config)
            .field(
                "limits",
                &self.limits.iter().map(|l| l.name()).collect::<Vec<_>>(),
            )
            .field("state", &self.state)
            .field("reduce", &self.reduce)
            .finish()
    }
}
impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// A controller with exactly these limits.
    pub fn new(
        config: ControllerConfig,
        limits: Vec<Box<dyn StepLimit<D>>>,
    ) -> Result<Self, ControllerError> {
        config.validate_for(D)?;
        let state = ControllerState {
            dt_prev: None,
            no_growth_next: false,
            prev_landed: false,
            filter: SoderlindFilter::new(config.filter, config.order),
            stats: Stats::default(),
            safety_scale: 1.0,
        };
        Ok(Self {
            config,
            limits,
            state,
            reduce: std::rc::Rc::new(crate::reduce::SingleProcess),
            first_view_checked: false,
            arrays_on_demand: false,
        })
    }

    /// The same controller deciding together with the other processes of a distributed
    /// run: every step is the global minimum and any process's rejection rejects
    /// everywhere ([`crate::reduce`]). Every process must drive its controller with the
    /// same calls.
    /// The limits receive it too ([`StepLimit::set_reduce`]).
    pub fn with_reduce(mut self, reduce: std::rc::Rc<dyn crate::reduce::Reduce>) -> Self {
        for limit in self.limits.iter_mut() {
            limit.set_reduce(std::rc::Rc::clone(&reduce));
        }
        self.reduce = reduce;
        self
    }

    /// Runs the limits' passes over the particles on `threads` threads of a pool of their
    /// own (`None` or `Some(0)`: on the calling thread, the default), for a stepper whose
    /// own step is threaded (for instance [`crate::nd::SolverNd::set_threads`]), so that
    /// the controller's share of a step does not grow as the stepper's shrinks. Every
    /// decision is the same, bit for bit, on any number of threads (`Some(1)` included). The
    /// limits that use it: the d-dimensional stability limit's layout guard
    /// ([`crate::limits_nd::StabilityNd`]), whose maxima do not depend on the order either,
    /// so it is also bit for bit the unthreaded run; the stability limit's Lanczos products
    /// on layouts of 16 384 particles or more
    /// ([`crate::limits_nd::stiffness::apply_scaled_on`]) and the temporal error's sweeps
    /// ([`crate::limits_nd::TemporalErrorNd`]), whose sums are taken over a fixed split of
    /// the particles on a pool, so that `λmax` and `dsm` differ from an unthreaded run's by
    /// round-off.
    pub fn with_threads(mut self, threads: Option<usize>) -> Result<Self, ControllerError> {
        let pool = match threads {
            None | Some(0) => None,
            Some(n) => Some(std::sync::Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| ControllerError::Threads(e.to_string()))?,
            )),
        };
        for limit in self.limits.iter_mut() {
            limit.set_threads(pool.clone());
        }
        Ok(self)
    }

    /// The configuration.
    pub fn config(&self) -> &ControllerConfig {
        &self.config
    }

    /// Run statistics so far.
    pub fn stats(&self) -> &Stats {
        &self.state.stats
    }

    /// The controller's state (filter, last step, statistics).
    pub fn state(&self) -> &ControllerState {
        &self.state
    }

    /// Names of the limits in order.
    pub fn limit_names(&self) -> Vec<String> {
        self.limits.iter().map(|l| l.name().to_string()).collect()
    }

    /// Bytes of heap memory the controller holds between steps: its limits' arrays
    /// ([`StepLimit::memory_bytes`]) and the filter's history. What an embedding solver pays
    /// for the controller on top of its own state. With the standard 2D/3D limits
    /// ([`crate::controller::standard_limits`]) it is O(particles) for the temporal-error
    /// history (`(D + D(D+1)/2)·8` bytes a particle while the stresses are symmetric,
    /// `(D + D²)·8` otherwise) and the stability tracker's motion guard (`4D + 16`):
    /// 100 bytes a particle in 3D and 64 in 2D for the reference solver; plus O(nodes) for
    /// the tracker's Ritz vector (`D·8` a node). The growth monitor and the sound-speed
    /// limit hold O(1). Passes over the particles allocate nothing per particle; a `λmax`
    /// refresh holds its Lanczos basis (O(nodes)) while it runs, and on layouts of at most
    /// 2²⁰ weight-row entries the formed rows its products read (O(particles)).
    pub fn memory_bytes(&self) -> usize {
        self.limits.iter().map(|l| l.memory_bytes()).sum::<usize>()
            + self.state.filter.history.capacity() * std::mem::size_of::<(f64, f64)>()
    }

    /// Saves the controller's state and its limits' states.
    pub fn checkpoint(&self) -> ControllerCheckpoint {
        ControllerCheckpoint {
            config: self.config.clone(),
            state: self.state.clone(),
            limits: self
                .limits
                .iter()
                .map(|l| LimitCheckpoint {
                    name: l.name().to_string(),
                    state: l.save_state(),
                })
                .collect(),
        }
    }

    /// Rebuilds a controller of any dimension from a checkpoint and freshly constructed limits (same names,
    /// same order as when it was saved); each limit's state is restored.
    pub fn from_checkpoint(
        checkpoint: ControllerCheckpoint,
        mut limits: Vec<Box<dyn StepLimit<D>>>,
    ) -> Result<Self, ControllerError> {
        checkpoint.config.validate_for(D)?;
        if limits.len() != checkpoint.limits.len() {
            return Err(ControllerError::Restore {
                message: format!(
                    "checkpoint has {} limits, {} given",
                    checkpoint.limits.len(),
                    limits.len()
                ),
                source: None,
            });
        }
        for (limit, saved) in limits.iter_mut().zip(&checkpoint.limits) {
            if limit.name() != saved.name {
                return Err(ControllerError::Restore {
                    message: format!("expected limit {}, got {}", saved.name, limit.name()),
                    source: None,
                });
            }
            if let Some(s) = &saved.state {
                limit
                    .restore_state(s)
                    .map_err(|e| ControllerError::Restore {
                        message: e.to_string(),
                        source: Some(e),
                    })?;
            }
        }
        Ok(Self {
            config: checkpoint.config,
            limits,
            state: checkpoint.state,
            reduce: std::rc::Rc::new(crate::reduce::SingleProcess),
            first_view_checked: false,
            arrays_on_demand: false,
        })
    }

    /// Advances until the stepper reaches `t_end`, calling `on_decision` for every attempt
    /// (accepted or rejected, also those of a step that ends in an error).
    ///
    /// `t_end` must be after the stepper's time ([`ControllerError::InvalidEnd`]
    /// otherwise); a stepper whose accepted trial does not advance its time ends the run
    /// with [`ControllerError::NoProgress`].
    pub fn run_until(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        t_end: f64,
        on_decision: &mut dyn FnMut(&Decision),
    ) -> Result<&Stats, ControllerError> {
        let t = stepper.time();
        if t_end.is_nan() || attempt::reached(t, t_end) {
            return Err(ControllerError::InvalidEnd { t, t_end });
        }
        while !attempt::reached(stepper.time(), t_end) {
            self.advance(stepper, t_end, on_decision)?;
        }
        Ok(&self.state.stats)
    }

    /// Advances one accepted step towards `t_end` (never past it), retrying rejected
    /// attempts. Returns every attempt's decision; the last one is the accepted step.
    /// (On an error the attempts made are lost here; [`Controller::run_until`] hands every
    /// one to its callback.)
    pub fn step(
        &mut self,
        stepper: &mut dyn Stepper<D>,
        t_end: f64,
    ) -> Result<Vec<Decision>, ControllerError> {
        let mut decisions = Vec::new();
        self.advance(stepper, t_end, &mut |d| decisions.push(d.clone()))?;
        Ok(decisions)
    }
}

/// The 1D constructors: the library's 1D limits.
impl Controller {
    /// Rebuilds a 1D controller from a checkpoint and freshly constructed limits (same
    /// names, same order as when it was saved); each limit's state is restored.
    /// [`Controller::from_checkpoint`] does the same in any dimension.
    pub fn restore(
        checkpoint: ControllerCheckpoint,
        limits: Vec<Box<dyn StepLimit>>,
    ) -> Result<Self, ControllerError> {
        Self::from_checkpoint(checkpoint, limits)
    }
}
