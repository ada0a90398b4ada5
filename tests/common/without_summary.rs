//! [`WithoutSummary`]: the reference solver declining the pass summary, shared by
//! `tests/solver_summary.rs` and `benches/controller.rs` (included by path: a bench cannot
//! use the tests' `common` module).

use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::{StepError, Stepper, View};

/// A reference solver that declines the summary (`Stepper::provide_summary` keeps its
/// default, `false`), so that every limit scans its views as with a stepper that does not
/// provide one.
pub struct WithoutSummary(pub ReferenceStepper);

impl Stepper for WithoutSummary {
    fn time(&self) -> f64 {
        self.0.time()
    }
    fn step_count(&self) -> u64 {
        self.0.step_count()
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.0.try_step(dt)
    }
    fn accept(&mut self) -> Result<(), StepError> {
        self.0.accept()
    }
    fn reject(&mut self) {
        self.0.reject()
    }
    fn view(&self) -> View<'_> {
        self.0.view()
    }
    fn trial_view(&self) -> Option<View<'_>> {
        self.0.trial_view()
    }
    fn provide_nodal_stiffness(&mut self, on: bool) -> bool {
        self.0.provide_nodal_stiffness(on)
    }
}
