//! The stability limit, one [`StepLimit`] for every dimension: [`Stability<D>`] proposes a
//! fraction `safety` of the frozen-particle critical step of eq 56,
//!
//! ```text
//! dt = safety · dt_crit,    dt_crit = √(2/λmax)            (eq 56)
//! ```
//!
//! with `λmax` the largest eigenvalue of the dimension's stiffness operator (`B = D*F` on the
//! particles, or its nodal form `M^{1/2} K_N M^{1/2}`, in 1D; `M⁻¹K` on the nodal velocity
//! components in 2D/3D; the same `λmax`), tracked along the run.
//!
//! The limit is written once, here: the safety factor and its lowering after a growth
//! detection ([`StepLimit::scale_safety`], by a factor in `(0, 1]`), the proposal
//! `safety · dt_crit`, the name `"stability"`, and the checkpoint framing — the safety next
//! to the tracked state, refused on restore where it is not in `(0, ceiling]`
//! ([`StabilityRule::safety_ceiling`]) — with the hooks of the run (reductions, threads, the
//! memory held, which arrays a call reads) passed on. How `λmax` is tracked, which metrics
//! a proposal reports, and whether a trial is judged are the dimension's ([`StabilityDim`], a
//! [`StabilityRule`]):
//!
//! | `D` | rule | tracks `λmax` by | judges a trial by | file |
//! |---|---|---|---|---|
//! | 1 | [`BandedEq56`](super::one_d::BandedEq56) | the certified tracker (`LDLᵀ` inertia) or Lanczos on the `K_N` band | eq 58 on a cadence, and the proposal check `dt ≤ (1 + tol) dt_eq56` | [`super::one_d`] |
//! | 2, 3 | [`GuardedEq56<D>`](crate::limits_nd::stability::GuardedEq56) | Lanczos behind a motion guard, the element bound, the APIC and full-map gains | — (accepts) | [`crate::limits_nd::stability`] |
//!
//! Aliases: [`crate::stability::Stability`] (without a parameter) is `Stability<1>` and
//! [`crate::limits_nd::StabilityNd<D>`] is `Stability<D>`; both are built
//! by `new` from their dimension's settings ([`StabilitySettings`]: [`StabilityConfig`] in 1D,
//! [`crate::limits_nd::StabilityNdConfig`] in 2D/3D).

use crate::dimension::{Dim, Dimension};
use crate::limit::{Judgement, LimitCall, LimitError, Metrics, Proposal, StepLimit};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

// The 1D settings, also at their path in this module.
pub use super::one_d::{Refresh, StabilityConfig, Tracking};

/// The name of the limit in logs and statistics: `"stability"`.
pub const STABILITY: &str = "stability";

/// What a rule's proposal gives: the critical step `dt_crit = √(2/λmax)` (eq 56, with the
/// dimension's gains) that the limit multiplies by its safety, and the proposal's metrics.
#[derive(Clone, Debug, PartialEq)]
pub struct Critical {
    /// The critical step `dt_crit`.
    pub dt: f64,
    /// The metrics of the proposal (`λmax` and how it was obtained).
    pub metrics: Metrics,
}

/// How the stability limit of one dimension `T` (a [`Dim`]) tracks `λmax` and judges a
/// trial: the dimension-specific half of [`Stability`] (module docs). Each dimension's rule
/// is fixed by [`StabilityDim`]; the trait documents what a rule provides, and a crate
/// outside this one cannot put its own rule into a [`Stability`]. The rule keeps its own
/// tracked state between steps; [`Stability`] holds the safety and calls the rule in the
/// order of the [`StepLimit`] calls.
pub trait StabilityRule<T: Dimension>: Clone + std::fmt::Debug {
    /// The tracked state a checkpoint saves, next to the safety.
    type State: Clone + Serialize + DeserializeOwned;

    /// The critical step of eq 56 for the committed `state` (and the metrics of how `λmax`
    /// was obtained); `safety` is the limit's current one, for the metrics and logs.
    fn critical(&mut self, state: &T::View<'_>, safety: f64) -> Result<Critical, LimitError>;

    /// Judges a trial of step `dt` from `before` to `after`; a rejection suggests
    /// `safety · dt_crit`. Default: accepts.
    fn judge(
        &mut self,
        before: &T::View<'_>,
        after: &T::View<'_>,
        dt: f64,
        safety: f64,
    ) -> Result<Judgement, LimitError> {
        let _ = (before, after, dt, safety);
        Ok(Judgement::accept())
    }

    /// The largest safety a restored state may carry.
    fn safety_ceiling(&self) -> f64;

    /// The tracked state for a checkpoint.
    fn state(&self) -> Cow<'_, Self::State>;

    /// Restores a state of [`StabilityRule::state`]; a state that does not belong together
    /// is refused with what is wrong, and the rule is left as it was.
    fn restore(&mut self, state: Self::State) -> Result<(), &'static str>;

    /// [`StepLimit::reads_nodal_stiffness`] (default `false`).
    fn reads_nodal_stiffness(&self) -> bool {
        false
    }

    /// [`StepLimit::reads_element_bound`] (default `false`).
    fn reads_element_bound(&self) -> bool {
        false
    }

    /// [`StepLimit::reads_arrays`] (default `true`).
    fn reads_arrays(&self, call: LimitCall, state: &T::View<'_>) -> bool {
        let _ = (call, state);
        true
    }

    /// [`StepLimit::set_reduce`] (default: nothing).
    fn set_reduce(&mut self, reduce: std::rc::Rc<dyn crate::reduce::Reduce>) {
        let _ = reduce;
    }

    /// [`StepLimit::set_threads`] (default: nothing).
    fn set_threads(&mut self, pool: Option<std::sync::Arc<rayon::ThreadPool>>) {
        let _ = pool;
    }

    /// Bytes of heap memory the rule holds between calls (default: 0).
    fn memory_bytes(&self) -> usize {
        0
    }
}

/// The dimension's [`StabilityRule`]: implemented for `Dim<1>` ([`BandedEq56`](super::one_d::BandedEq56)) and for every
/// `Dim<D>` whose view is a [`crate::nd::ViewNd`], `Dim<2>` and `Dim<3>`
/// ([`crate::limits_nd::stability::GuardedEq56`]).
pub trait StabilityDim: Dimension + Sized {
    /// The rule of the stability limit in this dimension.
    type Rule: StabilityRule<Self>;
}

/// The rule of dimension `D`.
pub(crate) type RuleOf<const D: usize> = <Dim<D> as StabilityDim>::Rule;

/// The settings a stability limit of dimension `D` is built from: [`super::StabilityConfig`] for
/// `D = 1`, [`crate::limits_nd::StabilityNdConfig`] for `D = 2, 3` (so `Stability::new` of a
/// 1D config needs no dimension written).
pub trait StabilitySettings<const D: usize>
where
    Dim<D>: StabilityDim,
{
    /// Why settings are refused.
    type Error;

    /// The limit with these settings, validated.
    fn build(self) -> Result<Stability<D>, Self::Error>;
}

/// The stability limit of dimension `D` (eq 56; in 1D also eq 58), a [`StepLimit`] named
/// `"stability"`: proposes `safety · dt_crit` with `dt_crit` from the dimension's
/// [`StabilityRule`] (module docs). `Stability` without a parameter is the 1D limit.
#[derive(Clone, Debug)]
pub struct Stability<const D: usize = 1>
where
    Dim<D>: StabilityDim,
{
    /// The current safety factor: the configured one, lowered after growth.
    safety: f64,
    rule: RuleOf<D>,
}

/// The 2D/3D stability limit: an alias of `Stability<D>`.
pub type StabilityNd<const D: usize> = Stability<D>;

/// What a checkpoint stores: the safety, and the rule's tracked state beside it (one JSON
/// object).
#[derive(Serialize, Deserialize)]
struct Checkpoint<'a, S: Clone> {
    safety: f64,
    #[serde(flatten)]
    tracked: Cow<'a, S>,
}

impl<const D: usize> Stability<D>
where
    Dim<D>: StabilityDim,
{
    /// The limit with `settings`, validated ([`StabilitySettings`]).
    pub fn new<S: StabilitySettings<D>>(settings: S) -> Result<Self, S::Error> {
        settings.build()
    }

    /// A limit around a rule, starting from `safety`.
    pub(crate) fn with_rule(safety: f64, rule: RuleOf<D>) -> Self {
        Self { safety, rule }
    }

    /// The current safety factor.
    pub fn safety(&self) -> f64 {
        self.safety
    }

    /// Sets the current safety factor (callers check it).
    pub(crate) fn put_safety(&mut self, safety: f64) {
        self.safety = safety;
    }

    /// The limit's rule.
    pub fn rule(&self) -> &<Dim<D> as StabilityDim>::Rule {
        &self.rule
    }

    /// The limit's rule, to change.
    pub(crate) fn rule_mut(&mut self) -> &mut RuleOf<D> {
        &mut self.rule
    }
}

/// A [`LimitError::Restore`] of this limit.
fn restore_error(source: serde_json::Error) -> LimitError {
    LimitError::Restore {
        limit: STABILITY.to_string(),
        source: source.into(),
    }
}

impl<const D: usize> StepLimit<D> for Stability<D>
where
    Dim<D>: StabilityDim,
{
    fn name(&self) -> &str {
        STABILITY
    }

    fn propose(&mut self, state: &<Dim<D> as Dimension>::View<'_>) -> Result<Proposal, LimitError> {
        let critical = self.rule.critical(state, self.safety)?;
        Ok(Proposal {
            dt: self.safety * critical.dt,
            metrics: critical.metrics,
        })
    }

    fn judge(
        &mut self,
        before: &<Dim<D> as Dimension>::View<'_>,
        after: &<Dim<D> as Dimension>::View<'_>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        self.rule.judge(before, after, dt, self.safety)
    }

    fn reads_nodal_stiffness(&self) -> bool {
        self.rule.reads_nodal_stiffness()
    }

    fn reads_element_bound(&self) -> bool {
        self.rule.reads_element_bound()
    }

    fn reads_arrays(&self, call: LimitCall, state: &<Dim<D> as Dimension>::View<'_>) -> bool {
        self.rule.reads_arrays(call, state)
    }

    /// Multiplies the safety factor by `factor` (ignored unless `0 < factor ≤ 1`).
    fn scale_safety(&mut self, factor: f64) {
        if factor > 0.0 && factor <= 1.0 {
            let new = self.safety * factor;
            tracing::debug!(old = self.safety, new, "stability safety scaled");
            self.safety = new;
        }
    }

    fn set_reduce(&mut self, reduce: std::rc::Rc<dyn crate::reduce::Reduce>) {
        self.rule.set_reduce(reduce);
    }

    fn set_threads(&mut self, pool: Option<std::sync::Arc<rayon::ThreadPool>>) {
        self.rule.set_threads(pool);
    }

    fn memory_bytes(&self) -> usize {
        self.rule.memory_bytes()
    }

    /// The safety and the rule's tracked state, in one object (JSON keeps every `f64`
    /// bit-exact: serde_json's `float_roundtrip`). Restored, the limit proposes bit for bit
    /// what it would have proposed had the run gone on.
    fn save_state(&self) -> Option<serde_json::Value> {
        serde_json::to_value(Checkpoint {
            safety: self.safety,
            tracked: self.rule.state(),
        })
        .ok()
    }

    /// Refuses, with a [`LimitError::Restore`] naming the limit and leaving it as it was, a
    /// state that does not read, whose safety is not in `(0, ceiling]`
    /// ([`StabilityRule::safety_ceiling`]) or whose tracked state the rule refuses
    /// ([`StabilityRule::restore`]).
    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        let saved: Checkpoint<'static, <RuleOf<D> as StabilityRule<Dim<D>>>::State> =
            serde_json::from_value(state.clone()).map_err(restore_error)?;
        let invalid = |what: &str| restore_error(serde::de::Error::custom(what));
        if !(saved.safety > 0.0 && saved.safety <= self.rule.safety_ceiling()) {
            return Err(invalid(&format!(
                "safety = {} not in (0, {}]",
                saved.safety,
                self.rule.safety_ceiling()
            )));
        }
        self.rule
            .restore(saved.tracked.into_owned())
            .map_err(invalid)?;
        self.safety = saved.safety;
        Ok(())
    }
}
