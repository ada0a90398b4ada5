//! What [`TemporalError`] keeps for a controller checkpoint
//! ([`StepLimit::save_state`](crate::limit::StepLimit::save_state)): the history of rates
//! of the last checked step (with its deferral schedule), and — where a part of the norm is
//! left out because it did not fall with the step ([`crate::temporal::non_smooth`]) — that
//! state beside it, as `{"history", "non_smooth"}`. A checkpoint without the latter (every
//! checkpoint saved before it existed, and every one where no part is left out) is the
//! history alone.

use super::{EstimatorOf, HistoryOf, TemporalDim, TemporalError, TemporalEstimator};
use crate::dimension::Dim;
use crate::limit::LimitError;
use crate::temporal::deferral::Scheduled;
use crate::temporal::non_smooth::NonSmooth;
use crate::temporal::TEMPORAL_ERROR;

impl<const D: usize> TemporalError<D>
where
    Dim<D>: TemporalDim,
{
    /// The limit's state for a checkpoint (module docs).
    pub(super) fn saved(&self) -> Option<serde_json::Value> {
        match self.non_smooth.excluded == [false; 2] {
            true => serde_json::to_value(&self.history).ok(),
            false => Some(serde_json::json!({
                "history": serde_json::to_value(&self.history).ok()?,
                "non_smooth": serde_json::to_value(self.non_smooth).ok()?,
            })),
        }
    }

    /// Restores [`Self::saved`]'s state; one that does not read, or whose history is not
    /// consistent, is an error and leaves the limit as it was.
    pub(super) fn restore(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        let error = |e: serde_json::Error| LimitError::Restore {
            limit: TEMPORAL_ERROR.to_string(),
            source: e.into(),
        };
        let (state, non_smooth) = match state.get("non_smooth") {
            Some(n) => (
                &state["history"],
                serde_json::from_value(n.clone()).map_err(error)?,
            ),
            None => (state, NonSmooth::default()),
        };
        let history: Option<HistoryOf<D>> = serde_json::from_value(state.clone()).map_err(error)?;
        if history
            .as_ref()
            .is_some_and(|h| !EstimatorOf::<D>::consistent(h))
        {
            return Err(Self::other(EstimatorOf::<D>::INCONSISTENT.to_string()));
        }
        self.non_smooth = non_smooth;
        // A schedule saved under a larger `max_deferred` defers no more than this one.
        self.history = history.map(|mut h| {
            h.schedule().clamp(self.config.max_deferred);
            h
        });
        Ok(())
    }
}
