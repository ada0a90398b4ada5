//! [`SafetyScaled`]: gives any limit a run-time safety factor that the growth monitor can
//! lower.
//!
//! When the [`super::GrowthMonitor`] detects the slow instability of moving particles, the
//! controller calls [`StepLimit::scale_safety`] on every limit. A limit with a safety factor
//! of its own implements that method; for one that does not (a user's limit, or a stability
//! limit written before the hook existed), wrapping it in `SafetyScaled` makes the back-off
//! reach it: the wrapper multiplies the inner proposal by its factor (initially 1), and
//! `scale_safety(f)` multiplies the factor by `f`. The wrapper does not forward
//! `scale_safety` (the factor is applied once, here).

use crate::dimension::{Dim, Dimension, ViewOf};
use crate::limit::{Judgement, LimitError, Proposal, RejectCause, StepLimit};

/// A limit whose proposal is scaled by a factor the controller can lower.
#[derive(Debug)]
pub struct SafetyScaled<L> {
    inner: L,
    factor: f64,
}

impl<L> SafetyScaled<L> {
    /// Wraps `inner` with factor 1.
    pub fn new(inner: L) -> Self {
        Self { inner, factor: 1.0 }
    }

    /// The current factor.
    pub fn factor(&self) -> f64 {
        self.factor
    }

    /// The wrapped limit.
    pub fn inner(&self) -> &L {
        &self.inner
    }
}

impl<L: StepLimit<D>, const D: usize> StepLimit<D> for SafetyScaled<L>
where
    Dim<D>: Dimension,
{
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn propose(&mut self, state: &ViewOf<'_, D>) -> Result<Proposal, LimitError> {
        let mut p = self.inner.propose(state)?;
        p.dt *= self.factor;
        if self.factor < 1.0 {
            p.metrics.insert("safety_scale".into(), self.factor);
        }
        Ok(p)
    }

    fn judge(
        &mut self,
        before: &ViewOf<'_, D>,
        after: &ViewOf<'_, D>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        self.inner.judge(before, after, dt)
    }

    fn accepted(&mut self, before: &ViewOf<'_, D>, after: &ViewOf<'_, D>, dt: f64) {
        self.inner.accepted(before, after, dt);
    }

    fn rejected(&mut self, dt: f64, cause: RejectCause) {
        self.inner.rejected(dt, cause);
    }

    fn reads_nodal_stiffness(&self) -> bool {
        self.inner.reads_nodal_stiffness()
    }

    fn reads_arrays(&self, call: crate::limit::LimitCall, state: &ViewOf<'_, D>) -> bool {
        self.inner.reads_arrays(call, state)
    }

    fn reads_nodal(&self, call: crate::limit::LimitCall, state: &ViewOf<'_, D>) -> bool {
        self.inner.reads_nodal(call, state)
    }

    fn reads_element_bound(&self) -> bool {
        self.inner.reads_element_bound()
    }

    fn memory_bytes(&self) -> usize {
        self.inner.memory_bytes()
    }

    fn set_reduce(&mut self, reduce: std::rc::Rc<dyn crate::reduce::Reduce>) {
        self.inner.set_reduce(reduce);
    }

    fn set_threads(&mut self, pool: Option<std::sync::Arc<rayon::ThreadPool>>) {
        self.inner.set_threads(pool);
    }

    fn scale_safety(&mut self, factor: f64) {
        if factor.is_finite() && factor > 0.0 {
            self.factor *= factor;
        }
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        Some(serde_json::json!({
            "factor": self.factor,
            "inner": self.inner.save_state(),
        }))
    }

    fn restore_state(&mut self, state: &serde_json::Value) -> Result<(), LimitError> {
        let bad = || LimitError::Other {
            limit: self.inner.name().to_string(),
            message: "cannot restore SafetyScaled state".to_string(),
        };
        self.factor = state
            .get("factor")
            .and_then(|f| f.as_f64())
            .ok_or_else(bad)?;
        match state.get("inner") {
            Some(serde_json::Value::Null) | None => Ok(()),
            Some(inner) => self.inner.restore_state(inner),
        }
    }
}
