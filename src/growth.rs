//! The growth monitor, one [`StepLimit`] for every dimension: [`Growth<D>`] detects the slow
//! instability of moving particles.
//!
//! Eq 56's amplification matrix `A = I − E dt²/h² D*F` assumes frozen particles. When the
//! particles move, `D*F` changes every step and high-wavenumber modes can grow slowly at
//! steps somewhat *below* the frozen-particle limit `dt_crit = h √(2/(E λmax))`.
//!
//! The monitor is written once, here: the cache of the last judged trial (one reading of
//! each accepted state), the verdict and its cause [`RejectCause::Growth`], the reaction to
//! a growth rejection (its history cleared, so one growth episode triggers once), the
//! metrics, the checkpoint state ([`StepLimit::save_state`]) and the memory it holds. What
//! it reads from a state and the rule that judges those readings are the dimension's
//! ([`GrowthDim`], a [`GrowthRule`]):
//!
//! | `D` | rule | reads | detects | file |
//! |---|---|---|---|---|
//! | 1 | [`WindowMaxima`] | the checkerboard share of the nodal accelerations (eq 18), confirmed by the total energy; or the energy alone | window maxima increasing by `factor` | [`one_d`] |
//! | 2, 3 | [`EnergyDrift<D>`] | the mechanical energy with gravity, summed with kept moduli or taken from the stepper's [`crate::nd::SummaryNd`] | a jump within a step, or a drift by `energy_tol` over `windows × window` steps | [`nd`] |
//!
//! Aliases: [`GrowthMonitor`] is `Growth<1>` and [`GrowthNd<D>`] is
//! `Growth<D>`.
//!
//! On a growth rejection the controller lowers the stability safety factor of every limit by
//! [`GrowthConfig::safety_factor`] for the rest of the run
//! ([`StepLimit::scale_safety`]) and logs it; a detection that would take the safety below
//! [`GrowthConfig::min_safety_scale`] of its start ends the run instead
//! ([`crate::controller::ControllerError::GrowthPersists`]).

mod config;
pub mod nd;
pub mod one_d;

pub use config::{GrowthConfig, GrowthIndicator};
pub use nd::EnergyDrift;
pub use one_d::{checkerboard_share, total_energy, WindowMaxima};
#[cfg(feature = "reference")]
pub(crate) use one_d::{particle_energy, sum_energy_lanes, ENERGY_LANES};

use crate::dimension::{Dim, Dimension};
use crate::limit::{Judgement, LimitError, Metrics, Proposal, RejectCause, StepLimit, Verdict};

/// The name of the monitor in logs and statistics: `"growth"`.
pub const GROWTH: &str = "growth";

/// A rule's finding on a trial ([`GrowthRule::judge`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Detection {
    /// No growth: the trial is accepted by the monitor.
    Steady,
    /// Growth: the trial is rejected with [`RejectCause::Growth`].
    Growing {
        /// A step the rule expects to accept, if it can tell.
        suggested_dt: Option<f64>,
    },
}

/// What the growth monitor of one dimension `T` (a [`Dim`]) reads from a state and how it
/// judges those readings: the dimension-specific half of [`Growth`] (module docs). The rule
/// keeps its own memory between steps (the window maxima in 1D, the energy history in
/// 2D/3D); [`Growth`] calls it in the order of the [`StepLimit`] calls.
pub trait GrowthRule<T: Dimension>: Clone + std::fmt::Debug {
    /// What the rule reads from one state (the indicator, the energies).
    type Sample: Copy + std::fmt::Debug;

    /// The readings of a state.
    fn sample(&self, view: &T::View<'_>) -> Self::Sample;

    /// The key under which the readings of a judged trial are kept for its acceptance
    /// (compared bit for bit): the trial's start time and step in 1D, its end time and step
    /// index in 2D/3D.
    fn trial_key(before: &T::View<'_>, after: &T::View<'_>, dt: f64) -> [u64; 2];

    /// Called on every proposal with the committed state (default: nothing).
    fn start(&mut self, committed: &T::View<'_>) {
        let _ = committed;
    }

    /// Judges a trial of step `dt` from `before` whose end state reads `after`; adds the
    /// rule's metrics to `metrics`.
    fn judge(
        &mut self,
        before: &T::View<'_>,
        after: Self::Sample,
        dt: f64,
        metrics: &mut Metrics,
    ) -> Detection;

    /// Records the readings of an accepted state.
    fn record(&mut self, sample: Self::Sample);

    /// Whether the rule reads the arrays of `state` (and of the other view of the same
    /// call) rather than only its summary ([`StepLimit::reads_arrays`]). Default `true`.
    fn reads_arrays(&self, state: &T::View<'_>) -> bool {
        let _ = state;
        true
    }

    /// Called when an attempt was rejected with cause growth (by this monitor or another
    /// limit).
    fn growth_rejected(&mut self);

    /// The rule's memory for a checkpoint, or `None` when it keeps none there (the default).
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }

    /// Restores a state produced by [`GrowthRule::save_state`] (default: accepts anything
    /// and does nothing).
    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), serde_json::Error> {
        let _ = state;
        Ok(())
    }

    /// Bytes of heap memory the rule holds between calls (default: 0).
    fn memory_bytes(&self) -> usize {
        0
    }
}

/// The dimension's [`GrowthRule`]: implemented for `Dim<1>` ([`WindowMaxima`]) and for every
/// `Dim<D>` whose view is a [`crate::nd::ViewNd`], `Dim<2>` and `Dim<3>` ([`EnergyDrift`]).
pub trait GrowthDim: Dimension + Sized {
    /// The rule of the growth monitor in this dimension.
    type Rule: GrowthRule<Self>;
}

/// The rule of dimension `D`.
type RuleOf<const D: usize> = <Dim<D> as GrowthDim>::Rule;

/// The readings of the rule of dimension `D`.
type SampleOf<const D: usize> = <RuleOf<D> as GrowthRule<Dim<D>>>::Sample;

/// The growth monitor of dimension `D`, a [`StepLimit`] named `"growth"` that never
/// proposes a step and rejects trials that show growth (module docs). Built by `new`: from
/// a [`GrowthConfig`] in 1D ([`WindowMaxima::new`]), from the gravity, the window and the
/// tolerance in 2D/3D ([`EnergyDrift::new`]).
#[derive(Clone, Debug)]
pub struct Growth<const D: usize>
where
    Dim<D>: GrowthDim,
{
    rule: RuleOf<D>,
    /// The readings of the last judged trial, under its [`GrowthRule::trial_key`], taken by
    /// `accepted` when it is called for that trial, so the indicator is computed once per
    /// accepted step.
    judged: Option<([u64; 2], SampleOf<D>)>,
}

/// The 1D growth monitor, `Growth<1>`: an alias.
pub type GrowthMonitor = Growth<1>;

/// The 2D/3D growth monitor, `Growth<D>`: an alias.
pub type GrowthNd<const D: usize> = Growth<D>;

impl<const D: usize> Growth<D>
where
    Dim<D>: GrowthDim,
{
    /// A monitor around a rule.
    pub fn with_rule(rule: RuleOf<D>) -> Self {
        Self { rule, judged: None }
    }

    /// The monitor's rule.
    pub fn rule(&self) -> &RuleOf<D> {
        &self.rule
    }
}

impl<const D: usize> StepLimit<D> for Growth<D>
where
    Dim<D>: GrowthDim,
{
    fn name(&self) -> &str {
        GROWTH
    }

    fn propose(&mut self, state: &<Dim<D> as Dimension>::View<'_>) -> Result<Proposal, LimitError> {
        self.rule.start(state);
        Ok(Proposal::no_opinion())
    }

    fn judge(
        &mut self,
        before: &<Dim<D> as Dimension>::View<'_>,
        after: &<Dim<D> as Dimension>::View<'_>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        let sample = self.rule.sample(after);
        self.judged = Some((RuleOf::<D>::trial_key(before, after, dt), sample));
        let mut metrics = Metrics::new();
        let verdict = match self.rule.judge(before, sample, dt, &mut metrics) {
            Detection::Growing { suggested_dt } => Verdict::Reject {
                cause: RejectCause::Growth,
                suggested_dt,
            },
            Detection::Steady => Verdict::Accept,
        };
        Ok(Judgement { verdict, metrics })
    }

    fn accepted(
        &mut self,
        before: &<Dim<D> as Dimension>::View<'_>,
        after: &<Dim<D> as Dimension>::View<'_>,
        dt: f64,
    ) {
        let sample = match self.judged.take() {
            Some((key, s)) if key == RuleOf::<D>::trial_key(before, after, dt) => s,
            _ => self.rule.sample(after),
        };
        self.rule.record(sample);
    }

    fn reads_arrays(
        &self,
        _call: crate::limit::LimitCall,
        state: &<Dim<D> as Dimension>::View<'_>,
    ) -> bool {
        self.rule.reads_arrays(state)
    }

    fn rejected(&mut self, _dt: f64, cause: RejectCause) {
        self.judged = None;
        if cause == RejectCause::Growth {
            self.rule.growth_rejected();
        }
    }

    fn memory_bytes(&self) -> usize {
        self.rule.memory_bytes()
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        self.rule.save_state()
    }

    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        self.rule
            .restore_state(state)
            .map_err(|e| LimitError::Restore {
                limit: GROWTH.to_string(),
                source: e.into(),
            })
    }
}
