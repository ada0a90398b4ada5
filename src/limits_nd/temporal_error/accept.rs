//! What [`TemporalErrorNd`] keeps of a judged trial, and how an accepted trial's rates
//! become the history: written over it in place, or — where particles changed process in
//! the trial — from a history of their own (the parent module's docs, "Memory").

use super::{Estimate, TemporalErrorNd};
use crate::limit::LimitError;
use crate::limits_nd::temporal_sweep::{rates_into, stamp, History};
use crate::nd::ViewNd;
use crate::temporal::deferral::Deferral;

/// The last judged trial: its start time and step, its estimate, and — only where
/// particles changed process in it — its rates (else they are written into the history
/// in place when it is accepted).
#[derive(Clone, Debug)]
pub(super) struct Judged<const D: usize> {
    pub t: f64,
    pub dt: f64,
    pub estimate: Estimate,
    pub rates: Option<History<D>>,
}

impl<const D: usize> TemporalErrorNd<D> {
    /// Whether particles changed process in the trial: a grid-decomposed run whose trial
    /// holds other run-wide ids than the committed state.
    pub(super) fn moved(before: &ViewNd<'_, D>, after: &ViewNd<'_, D>) -> bool {
        matches!((before.split, after.split), (Some(b), Some(a)) if a.particle_id != b.particle_id)
    }

    /// The estimate of a trial; where particles changed process in it, with its rates
    /// formed into a history of their own.
    pub(super) fn judge_trial(
        &mut self,
        before: &ViewNd<'_, D>,
        after: &ViewNd<'_, D>,
        dt: f64,
    ) -> Result<Judged<D>, LimitError> {
        let mut rates = Self::moved(before, after).then(|| self.take_buffer());
        match self.estimate(before, after, dt, rates.as_mut()) {
            Ok(estimate) => Ok(Judged {
                t: before.t,
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
    pub(super) fn install_in_place(
        &mut self,
        before: &ViewNd<'_, D>,
        after: &ViewNd<'_, D>,
        dt: f64,
        e: &Estimate,
    ) {
        let previous = self.history.as_ref().map(|h| h.defer);
        let mut h = self
            .history
            .take()
            .or_else(|| self.spare.take())
            .unwrap_or_default();
        rates_into(self.pool.as_deref(), before, after, dt, &mut h);
        stamp(&mut h, dt, e.v_scale, e.sigma_scale);
        h.defer = Deferral::after_check(previous, e.dsm, &self.config);
        self.history = Some(h);
    }

    /// Bytes of the per-particle arrays held (their capacities): the history, a judged
    /// trial's rates and a spare history (grid-decomposed runs where particles moved), the
    /// id table.
    pub fn memory_bytes(&self) -> usize {
        let judged = self.judged.as_ref().and_then(|j| j.rates.as_ref());
        [self.history.as_ref(), judged, self.spare.as_ref()]
            .into_iter()
            .flatten()
            .map(History::heap_bytes)
            .sum::<usize>()
            + self.slot_before.capacity() * std::mem::size_of::<u32>()
    }
}
