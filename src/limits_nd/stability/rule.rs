//! The 2D/3D rule's side of the one stability limit ([`crate::stability::limit`]): the
//! dimension's [`StabilityDim`] and [`StabilitySettings`], the accessors of
//! [`Stability<D>`] that read the rule, and [`GuardedEq56`] as a [`StabilityRule`] (the
//! critical step it proposes, its checkpoint state, the hooks of the run).

use super::{GuardedEq56, TrackedNd};
use crate::config_error::ConfigError;
use crate::dimension::{Dim, Dimension};
#[cfg(doc)]
use crate::limit::StepLimit;
use crate::limit::{LimitCall, LimitError};
use crate::limits_nd::StabilityNdConfig;
use crate::nd::ViewNd;
use crate::reduce::Reduce;
use crate::stability::limit::{
    Critical, Stability, StabilityDim, StabilityRule, StabilitySettings,
};
use std::borrow::Cow;
use std::rc::Rc;

impl<const D: usize> StabilityDim for Dim<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    type Rule = GuardedEq56<D>;
}

impl<const D: usize> StabilitySettings<D> for StabilityNdConfig
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    type Error = ConfigError;

    /// Checked by [`StabilityNdConfig::validate`].
    fn build(self) -> Result<Stability<D>, ConfigError> {
        self.validate()?;
        Ok(Stability::unchecked(self))
    }
}

impl<const D: usize> Stability<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    /// A limit with `config` not checked (for builders whose caller validates it).
    pub(crate) fn unchecked(config: StabilityNdConfig) -> Self {
        Stability::with_rule(config.safety, GuardedEq56::unchecked(config))
    }

    /// The tracked bound on `λmax(M⁻¹K)`, once computed.
    pub fn lambda_max(&self) -> Option<f64> {
        self.rule().tracked.lambda
    }

    /// Lanczos refreshes so far.
    pub fn refreshes(&self) -> u64 {
        self.rule().tracked.refreshes
    }
}

impl<const D: usize> StabilityRule<Dim<D>> for GuardedEq56<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    type State = TrackedNd<D>;

    /// `dt_crit = √(2·gain/λ)`, `λ` the bound-mode, summary or tracked value (module docs).
    fn critical(&mut self, state: &ViewNd<'_, D>, _safety: f64) -> Result<Critical, LimitError> {
        let (lambda, refreshed, on_bound) = match self.bound_proposal(state) {
            Some(bound) => {
                self.tracked.tracking.bound_proposals += 1;
                (bound, false, true)
            }
            // A stepper handing over its arrays on demand ([`on_summary`]).
            None if !state.holds_arrays() => (self.summary_lambda(state)?, false, false),
            None => {
                let (lambda, refreshed) = self.tracked_lambda(state)?;
                (lambda, refreshed, false)
            }
        };
        self.tracked.age += 1;
        Ok(Critical {
            dt: (2.0 * self.proposal_gain(on_bound) / lambda).sqrt(),
            metrics: self.proposal_metrics(lambda, refreshed),
        })
    }

    /// The configured safety: a restored state's may be lowered, not raised.
    fn safety_ceiling(&self) -> f64 {
        self.config.safety
    }

    fn state(&self) -> Cow<'_, TrackedNd<D>> {
        Cow::Borrowed(&self.tracked)
    }

    fn restore(&mut self, state: TrackedNd<D>) -> Result<(), &'static str> {
        state.check()?;
        self.tracked = state;
        Ok(())
    }

    /// Only a proposal reads the arrays, and on a summary-only view only when it cannot be
    /// made from the summary ([`on_summary`](super::on_summary)).
    fn reads_arrays(&self, call: LimitCall, state: &ViewNd<'_, D>) -> bool {
        call == LimitCall::Propose && !self.serves_on_summary(state)
    }

    fn set_reduce(&mut self, reduce: Rc<dyn Reduce>) {
        self.reduce = reduce;
    }

    fn set_threads(&mut self, pool: Option<std::sync::Arc<rayon::ThreadPool>>) {
        self.pool = pool;
    }

    fn memory_bytes(&self) -> usize {
        self.tracked.memory_bytes()
    }
}
