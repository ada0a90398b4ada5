//! The temporal-error limit, one [`StepLimit`] for every dimension: [`TemporalError<D>`]
//! judges each trial by the scaled norm `dsm ≤ 1` of its forward-Euler local errors
//! `le_v,p ≈ dt²/2 · d²v_p/dt²` (eqs 20, 23) and `le_σ,p ≈ dt²/2 · d²σ_p/dt²` (eq 28).
//!
//! Both estimators scale the errors SUNDIALS-style into one number,
//!
//! ```text
//! dsm = sqrt( 1/(2N) Σ_p [ (le_v,p / w_v,p)² + (le_σ,p / w_σ,p)² ] )     (weighted RMS norm)
//! w_u,p = atol_u + atol_rel · s_u + rtol · max(|u_p^n|, |u_p^{n+1}|)
//! ```
//!
//! with the second derivatives from successive rates `r_p = (u_p^{n+1} − u_p^n)/dt` (eqs 22,
//! 27) — `d²u_p/dt² ≈ 2 (r_p − r_p^{prev}) / (dt + dt₋)` against the last checked step, on
//! the first step from the nodal rates at both ends of the trial (eqs 21, 16, 24) — and the
//! energy-equivalent field scales `s_u` of [`super::scales`].
//!
//! The limit is written once, here: the control flow of the [`StepLimit`] calls — the
//! deferral of checks while the error is small ([`super::deferral`]), the cache of the last
//! judged trial (its estimate, and the rates to keep when it is accepted), the metrics
//! `dsm`, `dsm_v`, `dsm_sigma` (and `dsm_particles` where the dimension counts them), the
//! verdict (`dsm ≤ 1` accepts, a NaN `dsm` rejects with [`RejectCause::NonFinite`], any
//! other with [`RejectCause::Error`]; no suggested step: the controller's filter turns
//! `dsm` into the next step), the reactions to acceptance and rejection, what the arrays
//! on demand need ([`StepLimit::reads_arrays`]), the checkpoint state, the memory held and
//! the controller's threads. The estimate itself — the particle passes that form the rates,
//! their second differences and the weighted sums, and the history of rates they keep —
//! is the dimension's ([`TemporalDim`], a [`TemporalEstimator`]):
//!
//! | `D` | estimator | passes | maths and file |
//! |---|---|---|---|
//! | 1 | [`RateKernels`](crate::controller::RateKernels) | two passes of SIMD kernels | `controller/temporal_error.rs` (module docs: eqs 20–30, the weights, the first step's nodal rates, eq 44's balancing, the interpretations) |
//! | 2, 3 | [`RateSweeps<D>`](crate::limits_nd::RateSweeps) | one sweep (two when a scale grew), threaded; particles matched by id on a split grid | [`crate::limits_nd::temporal_error`] |
//!
//! Aliases: [`crate::controller::TemporalError`] is `TemporalError<1>` and
//! [`crate::limits_nd::TemporalErrorNd<D>`] is `TemporalError<D>`.

use super::deferral::{self, Deferral, DeferredTrial, Scheduled};
use super::non_smooth::NonSmooth;
use super::{TemporalErrorConfig, TEMPORAL_ERROR};
use crate::dimension::{Dim, Dimension, StateView, ViewOf};
use crate::limit::{
    metric, Judgement, LimitCall, LimitError, Metrics, Proposal, RejectCause, StepLimit, Verdict,
};
use serde::de::DeserializeOwned;
use serde::Serialize;

mod checkpoint;

/// What one estimate of a trial gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// The scaled norm of the local errors (`≤ 1` accepts).
    pub dsm: f64,
    /// The velocity part `sqrt(Σ_v/N)`.
    pub dsm_v: f64,
    /// The stress part `sqrt(Σ_σ/N)`.
    pub dsm_sigma: f64,
    /// Particles in the norm (`N`), where the dimension reports it (metric
    /// `dsm_particles`; 2D/3D).
    pub count: Option<usize>,
    /// `‖v‖_∞` of the trial.
    pub v_scale: f64,
    /// `‖σ‖_∞` of the trial.
    pub sigma_scale: f64,
}

/// What the estimator reads of the limit it serves.
#[derive(Clone, Copy)]
pub struct Shared<'a, H> {
    /// The limit's settings.
    pub config: &'a TemporalErrorConfig,
    /// The rates of the last checked, accepted step.
    pub history: Option<&'a H>,
    /// The controller's threads ([`StepLimit::set_threads`]).
    pub pool: Option<&'a rayon::ThreadPool>,
}

/// The dimension-specific half of [`TemporalError`] (module docs): the history of rates it
/// keeps and the estimate of a trial from the committed state `before`, the trial `after`
/// and that history.
pub trait TemporalEstimator<T: Dimension>: Clone + std::fmt::Debug + Default {
    /// The rates of the last checked, accepted step, with its deferral schedule.
    type History: Scheduled + Clone + std::fmt::Debug + Default + Serialize + DeserializeOwned;

    /// The message of [`StepLimit::restore_state`] for a history that is not
    /// [`consistent`](Self::consistent).
    const INCONSISTENT: &'static str;

    /// Whether the limit follows the schedule in [`StepLimit::reads_arrays`] (else it always
    /// reads them, the trait's default).
    const ON_DEMAND: bool;

    /// Whether an estimate against `history` reads the particle arrays alone (else the
    /// weights and nodal fields too, as the first step's nodal rates do), `state` being
    /// the trial's view, summary-only or holding its particles
    /// ([`StepLimit::reads_nodal`]). Default `false`.
    fn particles_suffice(history: &Self::History, state: &T::View<'_>) -> bool {
        let _ = (history, state);
        false
    }

    /// Refuses settings the estimator cannot honour (default: none), before a proposal and
    /// a deferred judgement.
    fn supported(config: &TemporalErrorConfig) -> Result<(), LimitError> {
        let _ = config;
        Ok(())
    }

    /// Whether a trial whose check the schedule defers may be deferred: it keeps the
    /// particles the history describes.
    fn deferrable(history: &Self::History, before: &T::View<'_>, after: &T::View<'_>) -> bool;

    /// Whether a judgement forms the trial's rates into a history of its own (else they are
    /// formed again over the history in place when the trial is accepted,
    /// [`rates_into`](Self::rates_into)).
    fn keeps_rates(before: &T::View<'_>, after: &T::View<'_>) -> bool;

    /// The estimate of a trial of step `dt`; its rates written into `out` when given (the
    /// arrays overwritten), with the step and the trial's scales.
    fn estimate(
        &mut self,
        shared: Shared<'_, Self::History>,
        before: &T::View<'_>,
        after: &T::View<'_>,
        dt: f64,
        out: Option<&mut Self::History>,
    ) -> Result<Estimate, LimitError>;

    /// Writes the rates of an accepted trial, estimated as `e`, into `out`, with its step and
    /// scales, as [`estimate`](Self::estimate) writes them.
    fn rates_into(
        pool: Option<&rayon::ThreadPool>,
        before: &T::View<'_>,
        after: &T::View<'_>,
        dt: f64,
        e: &Estimate,
        out: &mut Self::History,
    );

    /// Whether a restored history's arrays, step and schedule belong together.
    fn consistent(history: &Self::History) -> bool;

    /// Bytes of a history counted by [`StepLimit::memory_bytes`].
    fn history_bytes(history: &Self::History) -> usize;

    /// Bytes of the estimator's own memory (default: 0).
    fn memory_bytes(&self) -> usize {
        0
    }
}

/// The dimension's [`TemporalEstimator`]: implemented for `Dim<1>`
/// ([`RateKernels`](crate::controller::RateKernels)) and for every `Dim<D>` whose view is a
/// [`crate::nd::ViewNd`], `Dim<2>` and `Dim<3>` ([`crate::limits_nd::RateSweeps`]).
pub trait TemporalDim: Dimension + Sized {
    /// The estimator of the temporal-error limit in this dimension.
    type Estimator: TemporalEstimator<Self>;
}

/// The estimator of dimension `D`.
type EstimatorOf<const D: usize> = <Dim<D> as TemporalDim>::Estimator;

/// The history of dimension `D`.
type HistoryOf<const D: usize> = <EstimatorOf<D> as TemporalEstimator<Dim<D>>>::History;

/// The last judged trial: its start time and step, its estimate, and — where the estimator
/// keeps them ([`TemporalEstimator::keeps_rates`]) — its rates.
#[derive(Clone, Debug)]
struct Judged<H> {
    t: f64,
    dt: f64,
    estimate: Estimate,
    rates: Option<H>,
}

/// The temporal-error limit of dimension `D`, a [`StepLimit`] named `"temporal_error"`:
/// proposes nothing itself (the controller's filter does, from the `dsm` it reports) and
/// judges each trial by `dsm ≤ 1` (module docs). Built by `new`: validated in 1D
/// (`TemporalError::<1>::new` returns a `Result`), in 2D/3D checked before the first
/// proposal.
///
/// **Buffers.** The history a new one replaces is kept as `spare` and overwritten by the
/// next estimate, so in a run the per-particle rate arrays are allocated once, not on every
/// step.
#[derive(Clone, Debug)]
pub struct TemporalError<const D: usize>
where
    Dim<D>: TemporalDim,
{
    config: TemporalErrorConfig,
    estimator: EstimatorOf<D>,
    /// The rates of the last checked, accepted step.
    history: Option<HistoryOf<D>>,
    /// The last judged trial, reused by `accepted`.
    judged: Option<Judged<HistoryOf<D>>>,
    /// A history no longer needed, whose arrays the next estimate overwrites.
    spare: Option<HistoryOf<D>>,
    /// The last judged trial when its check was deferred.
    deferred: Option<DeferredTrial>,
    /// The controller's threads, for the estimator's passes.
    pool: Option<std::sync::Arc<rayon::ThreadPool>>,
    /// Parts of the error found not to vanish with the step ([`super::non_smooth`]).
    non_smooth: NonSmooth,
}

impl<const D: usize> TemporalError<D>
where
    Dim<D>: TemporalDim,
{
    /// A limit with the given settings, not validated (the dimensions' `new` do).
    pub(crate) fn with_config(config: TemporalErrorConfig) -> Self {
        Self {
            config,
            estimator: EstimatorOf::<D>::default(),
            history: None,
            judged: None,
            spare: None,
            deferred: None,
            pool: None,
            non_smooth: NonSmooth::default(),
        }
    }

    /// The limit's settings.
    pub fn config(&self) -> &TemporalErrorConfig {
        &self.config
    }

    /// Bytes of the per-particle arrays held (their capacities): the history, a judged
    /// trial's rates, a spare history and the estimator's own (the id table of a
    /// grid-decomposed run). The 1D limit counts none.
    pub fn memory_bytes(&self) -> usize {
        let judged = self.judged.as_ref().and_then(|j| j.rates.as_ref());
        [self.history.as_ref(), judged, self.spare.as_ref()]
            .into_iter()
            .flatten()
            .map(EstimatorOf::<D>::history_bytes)
            .sum::<usize>()
            + self.estimator.memory_bytes()
    }

    fn other(message: String) -> LimitError {
        LimitError::Other {
            limit: TEMPORAL_ERROR.to_string(),
            message,
        }
    }

    /// `dsm` of a trial predicted from the history's checked one, when this trial's check
    /// is deferred ([`Deferral::predict`]) and the trial keeps the history's particles
    /// ([`TemporalEstimator::deferrable`], compared only for a trial the schedule defers).
    fn deferrable(&self, before: &ViewOf<'_, D>, after: &ViewOf<'_, D>, dt: f64) -> Option<f64> {
        let h = self.history.as_ref()?;
        h.deferral()
            .predict(h.step(), dt, &self.config)
            .filter(|_| EstimatorOf::<D>::deferrable(h, before, after))
    }

    /// A history whose arrays the next estimate overwrites.
    fn take_buffer(&mut self) -> HistoryOf<D> {
        self.spare.take().unwrap_or_default()
    }

    /// The estimate of a trial; with its rates formed into a history of their own where the
    /// estimator keeps them ([`TemporalEstimator::keeps_rates`]).
    fn judge_trial(
        &mut self,
        before: &ViewOf<'_, D>,
        after: &ViewOf<'_, D>,
        dt: f64,
    ) -> Result<Judged<HistoryOf<D>>, LimitError> {
        let mut rates = EstimatorOf::<D>::keeps_rates(before, after).then(|| self.take_buffer());
        let shared = Shared {
            config: &self.config,
            history: self.history.as_ref(),
            pool: self.pool.as_deref(),
        };
        match self
            .estimator
            .estimate(shared, before, after, dt, rates.as_mut())
        {
            Ok(estimate) => Ok(Judged {
                t: before.time(),
                dt,
                estimate,
                rates,
            }),
            Err(err) => {
                if rates.is_some() {
                    self.spare = rates;
                }
                Err(err)
            }
        }
    }

    /// The accepted trial's rates written over the history in place, with the schedule
    /// that follows its check (what [`deferral::install`] gives a new history).
    fn install_in_place(
        &mut self,
        before: &ViewOf<'_, D>,
        after: &ViewOf<'_, D>,
        dt: f64,
        e: &Estimate,
    ) {
        let previous = self.history.as_ref().map(|h| h.deferral());
        let mut h = self
            .history
            .take()
            .or_else(|| self.spare.take())
            .unwrap_or_default();
        EstimatorOf::<D>::rates_into(self.pool.as_deref(), before, after, dt, e, &mut h);
        *h.schedule() = Deferral::after_check(previous, e.dsm, &self.config);
        self.history = Some(h);
    }
}

/// The metrics and verdict of a checked trial (module docs).
fn judgement(e: &Estimate) -> Judgement {
    let mut metrics = Metrics::new();
    metrics.insert(metric::DSM.to_string(), e.dsm);
    metrics.insert("dsm_v".to_string(), e.dsm_v);
    metrics.insert("dsm_sigma".to_string(), e.dsm_sigma);
    if let Some(count) = e.count {
        metrics.insert("dsm_particles".to_string(), count as f64);
    }
    let verdict = if e.dsm <= 1.0 {
        Verdict::Accept
    } else {
        Verdict::Reject {
            cause: if e.dsm.is_nan() {
                RejectCause::NonFinite
            } else {
                RejectCause::Error
            },
            suggested_dt: None,
        }
    };
    Judgement { verdict, metrics }
}

impl<const D: usize> StepLimit<D> for TemporalError<D>
where
    Dim<D>: TemporalDim,
{
    fn name(&self) -> &str {
        TEMPORAL_ERROR
    }

    /// No opinion (`∞`): the controller's filter proposes the accuracy-limited step. A
    /// setting the estimator cannot honour ends the run here, before a trial.
    fn propose(&mut self, _state: &ViewOf<'_, D>) -> Result<Proposal, LimitError> {
        EstimatorOf::<D>::supported(&self.config)?;
        Ok(Proposal::no_opinion())
    }

    fn judge(
        &mut self,
        before: &ViewOf<'_, D>,
        after: &ViewOf<'_, D>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        self.deferred = None;
        if let Some(predicted) = self.deferrable(before, after, dt) {
            EstimatorOf::<D>::supported(&self.config)?;
            self.deferred = Some(DeferredTrial {
                t: before.time(),
                dt,
            });
            return Ok(DeferredTrial::judgement(predicted));
        }
        let judged = self.judge_trial(before, after, dt)?;
        // Judged without the parts that do not fall with the step; the deferral of the
        // next checks follows the estimate as it is (no deferral while a part is out).
        let lagged = self.config.lag.is_some();
        let e = self
            .non_smooth
            .judge_lagged(before.time(), dt, &judged.estimate, lagged);
        if let Some(old) = self.judged.replace(judged).and_then(|j| j.rates) {
            self.spare = Some(old);
        }
        let mut judgement = judgement(&e);
        if let Some(parts) = self.non_smooth.metric() {
            judgement.metrics.insert("dsm_excluded".to_string(), parts);
        }
        Ok(judgement)
    }

    /// Where the estimator follows the schedule ([`TemporalEstimator::ON_DEMAND`], 2D/3D): a
    /// proposal reads nothing; a judgement reads both states unless the schedule defers
    /// the check ([`super::deferral`]; the particles are not compared here: a stepper hands
    /// over on demand in single-process runs only); an acceptance unless its trial's check
    /// was deferred. Elsewhere always.
    fn reads_arrays(&self, call: LimitCall, _state: &ViewOf<'_, D>) -> bool {
        if !EstimatorOf::<D>::ON_DEMAND {
            return true;
        }
        match call {
            LimitCall::Propose => false,
            LimitCall::Judge { dt } => self
                .history
                .as_ref()
                .and_then(|h| h.deferral().predict(h.step(), dt, &self.config))
                .is_none(),
            LimitCall::Accepted { .. } => self.deferred.is_none(),
        }
    }

    /// Against a history that describes the particles, an estimate reads their arrays
    /// alone ([`TemporalEstimator::particles_suffice`]: the rates of the last checked
    /// step stand for the nodal ones); the first check reads the nodal fields too.
    fn reads_nodal(&self, _call: LimitCall, state: &ViewOf<'_, D>) -> bool {
        !EstimatorOf::<D>::ON_DEMAND
            || !self
                .history
                .as_ref()
                .is_some_and(|h| EstimatorOf::<D>::particles_suffice(h, state))
    }

    fn accepted(&mut self, before: &ViewOf<'_, D>, after: &ViewOf<'_, D>, dt: f64) {
        if deferral::spend_deferred(&mut self.history, self.deferred.take(), before.time(), dt) {
            return;
        }
        // The judged trial's estimate when it is this one (same start time and step), else
        // estimated again.
        let judged = match self.judged.take() {
            Some(j)
                if j.t.to_bits() == before.time().to_bits() && j.dt.to_bits() == dt.to_bits() =>
            {
                Ok(j)
            }
            stale => {
                if let Some(h) = stale.and_then(|j| j.rates) {
                    self.spare = Some(h);
                }
                self.judge_trial(before, after, dt)
            }
        };
        let old = match judged {
            Ok(Judged {
                estimate,
                rates: None,
                ..
            }) => {
                self.install_in_place(before, after, dt, &estimate);
                None
            }
            Ok(Judged {
                estimate,
                rates: Some(mut h),
                ..
            }) => {
                h.schedule().dsm = estimate.dsm;
                deferral::install(&mut self.history, Some(h), &self.config)
            }
            Err(_) => deferral::install(&mut self.history, None, &self.config),
        };
        if old.is_some() {
            self.spare = old;
        }
    }

    /// Any rejection ends a deferral ([`super::deferral`]): the next trial is checked.
    fn rejected(&mut self, _dt: f64, _cause: RejectCause) {
        if let Some(h) = self.judged.take().and_then(|j| j.rates) {
            self.spare = Some(h);
        }
        self.deferred = None;
        if let Some(h) = self.history.as_mut() {
            h.schedule().reset();
        }
    }

    fn memory_bytes(&self) -> usize {
        TemporalError::memory_bytes(self)
    }

    fn set_threads(&mut self, pool: Option<std::sync::Arc<rayon::ThreadPool>>) {
        self.pool = pool;
    }

    /// The history of rates and the parts left out of the norm (`checkpoint` module).
    fn save_state(&self) -> Option<serde_json::Value> {
        self.saved()
    }

    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        self.restore(state)
    }
}
