//! The 1D stability limit wrapped to time each proposal (the bench's real-run figure).

use mpm_dt::stability::Stability;
use mpm_dt::{Judgement, LimitError, Proposal, RejectCause, StepLimit, View};
use std::cell::RefCell;
use std::rc::Rc;
use std::time::{Duration, Instant};

/// `Stability` as the controller runs it, timed: its `propose` per step.
pub(crate) struct Timed {
    pub inner: Stability,
    /// (wall time, factorisations, Lanczos applications) of each proposal.
    pub log: Rc<RefCell<Vec<(Duration, f64, f64)>>>,
}

impl StepLimit for Timed {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn propose(&mut self, state: &View<'_>) -> Result<Proposal, LimitError> {
        let start = Instant::now();
        let p = self.inner.propose(state);
        let elapsed = start.elapsed();
        if let Ok(p) = &p {
            let metric = |k: &str| p.metrics.get(k).copied().unwrap_or(0.0);
            self.log.borrow_mut().push((
                elapsed,
                metric("lambda_factorisations"),
                metric("lanczos_applications"),
            ));
        }
        p
    }
    fn judge(
        &mut self,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
    ) -> Result<Judgement, LimitError> {
        self.inner.judge(before, after, dt)
    }
    fn accepted(&mut self, before: &View<'_>, after: &View<'_>, dt: f64) {
        self.inner.accepted(before, after, dt)
    }
    fn reads_nodal_stiffness(&self) -> bool {
        self.inner.reads_nodal_stiffness()
    }
    fn reads_element_bound(&self) -> bool {
        self.inner.reads_element_bound()
    }
    fn rejected(&mut self, dt: f64, cause: RejectCause) {
        self.inner.rejected(dt, cause)
    }
    fn scale_safety(&mut self, factor: f64) {
        self.inner.scale_safety(factor)
    }
}
