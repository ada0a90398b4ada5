//! The 1D stability limit, [`Stability<1>`](super::limit::Stability) ([`super::Stability`]):
//! its rule [`BandedEq56`], the tracked eq 56 critical step, checked by eq 58.
//!
//! ```text
//! propose:  dt = safety · dt_eq56,   dt_eq56 = √(2/λmax(B)) = h √(2/(c²_ref λ̂))    (eq 56)
//! judge:    reject if  bound58_W(trial, dt) > 1 + tol                               (eq 58)
//!           or if      dt > (1 + tol) dt_eq56            (a violated stability proposal)
//! ```
//!
//! `λmax(B)` is tracked on the *nodal* form of the operator, `C = M^{1/2} K_N M^{1/2}`
//! ([`NodalOperator`], same λmax, `n_nodes` unknowns, banded), with `K_N` from the stepper (or
//! assembled from the `D` weights when the stepper does not provide it). The default
//! [`Tracking::Certified`] ([`CertifiedTracker`]) serves each proposal from one fused pass over
//! the nodes (a generalised Rayleigh quotient and a power step) and certifies the value by an
//! `LDLᵀ` inertia test every 20 proposals or when the pass looks suspicious; Lanczos runs only
//! when a certificate fails. [`Tracking::Lanczos`] is the previous default: a warm-started
//! Lanczos update ([`LambdaMaxTracker`]) at every proposal or on [`Refresh`] thresholds.
//! The eq 58 value is the
//! [`Bound58Reading::Consistent`](super::Bound58Reading::Consistent) reading in the strain-energy norm (default): it is a true
//! lower bound on `ρ(A)`, so a value above 1 *proves* the step's stress amplification
//! unstable — but it stays near 1 while `ρ(A)` grows (see [`mod@super::bound58`]), which is why
//! the proposal, not the bound, does the real work.
//!
//! The eq 58 value is computed on the *trial* state (its stress field, layout and moduli) at
//! the trial's `dt`: the amplification the trial's stress error would see over one more step
//! of the same size. A trial whose stress has no curvature (`Δσ = 0`) carries no information
//! and is not rejected by eq 58.
//!
//! # When λmax is recomputed in [`Tracking::Lanczos`] mode ([`Refresh`])
//!
//! [`Refresh::every_step`] updates λmax at every proposal. [`Refresh::cached`] is an *opt-in*
//! cheaper mode: it re-runs Lanczos only when the
//! state has drifted from the one of the last update — some particle moved more than
//! `max_displacement · h`, some active nodal mass changed by more than the relative
//! `max_mass_change` (or a node switched between active and inactive), some `E_t,p V_p`
//! changed by more than `max_modulus_change`, or `max_steps` proposals have passed.
//!
//! **Known failure of the cached mode** (why it is not the default): on the linear-hat
//! small-mass scenario of the comparison suite (`scenarios/suite/linear_small_mass.json`) it
//! blew up at t = 0.58 while every-step tracking finished: as a nodal mass collapses, λ̂ jumps
//! from about 22 to about 5000 within one step, and a warm-started update from the old
//! eigenvector can converge to the old, still-valid eigenpair instead of the new top one; the
//! cold restarts every 10 updates that rescue every-step tracking then come 10 *updates*, not
//! 10 steps, apart. Use it on GIMP layouts, where λmax barely moves. (Measured before the
//! tracker gained its diagonal lower-bound guard, see [`super::lambda_max::WARM_BLEND`]; with
//! it the same cached run finishes, 474 steps and 3 rejections — one scenario, no proof.)
//!
//! # Cost, and why eq 58 is checked on a cadence
//!
//! At 10⁵ particles (GIMP, 2 per cell; `cargo bench --bench stability`, README "Stability")
//! assembling `K_N` from a view's weights costs about one reference solver step, which is why
//! the reference solver accumulates it in its own pass instead (the limit then only reads it).
//! The certified tracking's served proposal is one pass over the nodes; its `LDLᵀ`
//! certificate costs about a fifth of a solver step, every 20 proposals; a Lanczos update per
//! proposal (the previous default) cost most of a solver step. Eq 58 needs the Section 4
//! estimates (nodal second and third derivatives of the stress, the weights' moments), about
//! three solver steps per evaluation, while it can only certify instability (it stays near 1
//! while `ρ(A)` grows). It is therefore evaluated on the trial of every
//! [`StabilityConfig::bound58_every`]-th proposal (default 50: the first trial of a run, then
//! every 50th), which keeps its share near 6 % of a step; set it to 1 to check every trial,
//! as the paper's "track stability automatically" suggests, at that price.
//!
//! The safety factor is the limit's ([`super::limit`]); in 1D it can also be set at run time
//! ([`Stability::set_safety`]). The controller's growth monitor lowers it when it sees the
//! slow instability of moving particles.

use super::bound58::bound58;
use super::certified::{CertifiedConfig, CertifiedEstimate, CertifiedState, CertifiedTracker};
use super::error::StabilityError;
use super::lambda_max::{LambdaEstimate, LambdaMaxTracker, TrackerState};
use super::limit::{
    Critical, Stability, StabilityDim, StabilityRule, StabilitySettings, STABILITY,
};
use super::nodal::NodalOperator;
use crate::dimension::Dim;
use crate::limit::{Judgement, LimitError, Metrics, RejectCause, Verdict};
use crate::stepper::View;
use config::check_safety;
pub use config::{StabilityConfig, Tracking};
pub use refresh::Refresh;
use refresh::RefreshReference;
use std::borrow::Cow;

mod config;
mod refresh;

/// The rule of the 1D stability limit (module docs): `λmax` of the nodal eq 56 operator
/// tracked by the certified tracker or Lanczos, trials judged by eq 58 and the proposal
/// check. `Stability::default()` is `Stability::new` with [`StabilityConfig::default`].
#[derive(Clone, Debug, Default)]
pub struct BandedEq56 {
    /// The settings (their safety is the configured one; the limit holds the current).
    config: StabilityConfig,
    /// The Lanczos tracker of [`Tracking::Lanczos`].
    tracker: LambdaMaxTracker,
    /// The tracker of [`Tracking::Certified`].
    certified: CertifiedTracker,
    /// The nodal form of the eq 56 operator, rebuilt in place at each update.
    nodal: NodalOperator,
    reference: Option<RefreshReference>,
    /// The estimate the last proposal used (in the default mode the served or certified value).
    current: Option<LambdaEstimate>,
    /// Whether eq 58 is due on the trial of the last proposal.
    fresh: bool,
    /// Proposals so far (for [`StabilityConfig::bound58_every`]).
    proposals: u64,
}

impl StabilityDim for Dim<1> {
    type Rule = BandedEq56;
}

impl StabilitySettings<1> for StabilityConfig {
    type Error = StabilityError;

    fn build(self) -> Result<Stability, StabilityError> {
        BandedEq56::new(self).map(|rule| Stability::with_rule(self.safety, rule))
    }
}

impl Default for Stability {
    fn default() -> Self {
        Stability::with_rule(StabilityConfig::default().safety, BandedEq56::default())
    }
}

impl Stability {
    /// The settings (with the current safety factor).
    pub fn config(&self) -> StabilityConfig {
        StabilityConfig {
            safety: self.safety(),
            ..self.rule().config
        }
    }

    /// Changes the safety factor (must be in `(0, 1]`); the controller's growth monitor
    /// lowers it after detecting growth.
    pub fn set_safety(&mut self, safety: f64) -> Result<(), StabilityError> {
        check_safety(safety)?;
        tracing::debug!(
            old = self.safety(),
            new = safety,
            "stability safety changed"
        );
        self.put_safety(safety);
        Ok(())
    }

    /// The λmax estimate the last proposal used (the certified upper bound by default).
    pub fn last_estimate(&self) -> Option<LambdaEstimate> {
        self.rule().current
    }

    /// The Lanczos tracker of [`Tracking::Lanczos`] (e.g. to read the eigenvector).
    pub fn tracker(&self) -> &LambdaMaxTracker {
        &self.rule().tracker
    }

    /// The certified tracker of [`Tracking::Certified`].
    pub fn certified_tracker(&self) -> &CertifiedTracker {
        &self.rule().certified
    }

    /// The Lanczos estimate of λmax for `state` (a lower bound), updating the Lanczos tracker.
    /// The iteration runs on the nodal form `C = M^{1/2} K_N M^{1/2}` of the eq 56 operator
    /// ([`NodalOperator`]), which has the same `λmax` as the particle form `B` on `n_nodes`
    /// instead of `n_particles` unknowns (the tracker's vector is therefore nodal).
    pub fn estimate(&mut self, state: &View<'_>) -> Result<LambdaEstimate, StabilityError> {
        self.rule_mut().estimate(state)
    }

    /// The certified bracket of λmax for `state` ([`CertifiedTracker::update`]).
    pub fn certified_estimate(
        &mut self,
        state: &View<'_>,
    ) -> Result<CertifiedEstimate, StabilityError> {
        self.rule_mut().certified_estimate(state)
    }
}

impl BandedEq56 {
    /// The rule with the given settings (validated).
    pub fn new(config: StabilityConfig) -> Result<Self, StabilityError> {
        check_safety(config.safety)?;
        if !(config.tol >= 0.0 && config.tol.is_finite()) {
            return Err(StabilityError::InvalidConfig {
                field: "tol",
                value: config.tol,
                reason: "must be non-negative and finite",
            });
        }
        let certified = match config.tracking {
            Tracking::Certified(c) => c,
            Tracking::Lanczos(r) => {
                r.validate()?;
                CertifiedConfig::default()
            }
        };
        Ok(Self {
            config,
            tracker: LambdaMaxTracker::new(config.lanczos)?,
            certified: CertifiedTracker::new(certified, config.lanczos)?,
            nodal: NodalOperator::default(),
            reference: None,
            current: None,
            fresh: false,
            proposals: 0,
        })
    }

    /// [`Stability::estimate`].
    fn estimate(&mut self, state: &View<'_>) -> Result<LambdaEstimate, StabilityError> {
        self.nodal.rebuild(state)?;
        self.tracker.update(&self.nodal)
    }

    /// [`Stability::certified_estimate`].
    fn certified_estimate(
        &mut self,
        state: &View<'_>,
    ) -> Result<CertifiedEstimate, StabilityError> {
        self.certified.update(state, &mut self.nodal)
    }
    /// Whether eq 58 is due on the trial of the latest proposal
    /// ([`StabilityConfig::bound58_every`]).
    fn bound58_due(&self) -> bool {
        let every = u64::from(self.config.bound58_every);
        every > 0 && (self.proposals.saturating_sub(1)).is_multiple_of(every)
    }

    /// The λmax estimate for `state` and the metrics of how it was obtained.
    fn tracked_estimate(
        &mut self,
        state: &View<'_>,
    ) -> Result<(LambdaEstimate, Metrics), StabilityError> {
        let mut metrics = Metrics::new();
        let refresh = match self.config.tracking {
            Tracking::Lanczos(r) => r,
            Tracking::Certified(_) => {
                let c = self.certified_estimate(state)?;
                metrics.insert("lambda_rayleigh".into(), c.rayleigh);
                metrics.insert(
                    "lambda_certified".into(),
                    if c.certified { 1.0 } else { 0.0 },
                );
                metrics.insert("lambda_factorisations".into(), c.factorisations as f64);
                metrics.insert(
                    "lanczos_applications".into(),
                    c.estimate.applications as f64,
                );
                return Ok((c.estimate, metrics));
            }
        };
        let cached = self.tracker.last().filter(|_| {
            self.reference
                .as_ref()
                .is_some_and(|r| !r.stale(state, &refresh))
        });
        let (est, fresh) = match cached {
            Some(est) => {
                if let Some(r) = self.reference.as_mut() {
                    r.proposals += 1;
                }
                (est, false)
            }
            None => {
                let est = self.estimate(state)?;
                let mut reference = RefreshReference::of(state);
                reference.proposals = 1;
                self.reference = Some(reference);
                (est, true)
            }
        };
        metrics.insert(
            "lanczos_applications".into(),
            if fresh { est.applications as f64 } else { 0.0 },
        );
        metrics.insert("lanczos_residual".into(), est.residual);
        Ok((est, metrics))
    }
}

/// The tracked state a checkpoint saves next to the safety: the trackers' warm starts and the
/// proposals' bookkeeping.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct BandedState {
    tracker: TrackerState,
    certified: CertifiedState,
    reference: Option<RefreshReference>,
    current: Option<LambdaEstimate>,
    fresh: bool,
    proposals: u64,
}

impl StabilityRule<Dim<1>> for BandedEq56 {
    type State = BandedState;

    fn critical(&mut self, state: &View<'_>, safety: f64) -> Result<Critical, LimitError> {
        let (est, mut metrics) = self
            .tracked_estimate(state)
            .map_err(|e| e.into_limit_error(STABILITY, state.t))?;
        self.current = Some(est);
        self.proposals += 1;
        self.fresh = self.bound58_due();
        metrics.insert("lambda_max".into(), est.lambda_hat);
        metrics.insert("dt_eq56".into(), est.dt_eq56);
        metrics.insert("safety".into(), safety);
        tracing::debug!(
            t = state.t,
            lambda_max = est.lambda_hat,
            dt_eq56 = est.dt_eq56,
            dt = safety * est.dt_eq56,
            applications = est.applications,
            "stability proposal"
        );
        Ok(Critical {
            dt: est.dt_eq56,
            metrics,
        })
    }

    /// Rejects a trial whose step exceeds `(1 + tol) dt_eq56` or, on the trials eq 58 is due
    /// on, whose eq 58 value exceeds `1 + tol` (module docs); suggests `safety · dt_eq56`.
    fn judge(
        &mut self,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
        safety: f64,
    ) -> Result<Judgement, LimitError> {
        let est = match self.current {
            Some(e) => e,
            None => {
                // Judged without a proposal: bound λmax of the committed state now.
                let (est, _) = self
                    .tracked_estimate(before)
                    .map_err(|e| e.into_limit_error(STABILITY, before.t))?;
                self.current = Some(est);
                self.proposals += 1;
                self.fresh = self.bound58_due();
                est
            }
        };
        // Eq 58 needs the Section 4 estimates: checked on the trial after every
        // `bound58_every`-th λmax update.
        let b = if self.fresh {
            bound58(after, dt, self.config.reading)
                .map_err(|e| e.into_limit_error(STABILITY, after.t))?
        } else {
            None
        };
        let mut metrics = Metrics::new();
        metrics.insert("lambda_max".into(), est.lambda_hat);
        metrics.insert("dt_eq56".into(), est.dt_eq56);
        let mut reject = dt > (1.0 + self.config.tol) * est.dt_eq56;
        if let Some(b) = b {
            metrics.insert("bound58".into(), b.value_energy);
            metrics.insert("bound58_euclidean".into(), b.value);
            reject |= b.value_energy > 1.0 + self.config.tol;
        }
        tracing::debug!(
            t = before.t,
            dt,
            dt_eq56 = est.dt_eq56,
            bound58 = b.map(|b| b.value_energy),
            reject,
            "stability judgement"
        );
        let verdict = if reject {
            Verdict::Reject {
                cause: RejectCause::Stability,
                suggested_dt: Some(safety * est.dt_eq56),
            }
        } else {
            Verdict::Accept
        };
        Ok(Judgement { verdict, metrics })
    }

    /// A 1D safety is any in `(0, 1]` ([`Stability::set_safety`]).
    fn safety_ceiling(&self) -> f64 {
        1.0
    }

    fn state(&self) -> Cow<'_, BandedState> {
        Cow::Owned(BandedState {
            tracker: self.tracker.state(),
            certified: self.certified.state(),
            reference: self.reference.clone(),
            current: self.current,
            fresh: self.fresh,
            proposals: self.proposals,
        })
    }

    fn restore(&mut self, saved: BandedState) -> Result<(), &'static str> {
        self.tracker.restore(saved.tracker);
        self.certified.restore(saved.certified);
        self.reference = saved.reference;
        self.current = saved.current;
        self.fresh = saved.fresh;
        self.proposals = saved.proposals;
        Ok(())
    }

    /// The λmax update reads `K_N` from the view when the stepper provides it: on every
    /// state, except that the certified tracker serving on the element bound asks only for
    /// the states it computes on `K_N` ([`CertifiedTracker::wants_nodal_stiffness`]).
    fn reads_nodal_stiffness(&self) -> bool {
        match self.config.tracking {
            Tracking::Certified(_) => self.certified.wants_nodal_stiffness(),
            Tracking::Lanczos(_) => true,
        }
    }

    /// The certified tracker serving on the element bound reads it
    /// ([`crate::stability::CertifiedConfig::on_bound`]).
    fn reads_element_bound(&self) -> bool {
        matches!(self.config.tracking, Tracking::Certified(c) if c.on_bound)
    }
}
