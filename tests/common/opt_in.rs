//! [`OptIn`]: a 2D reference solver opting in to the stepper contract with the element
//! bound of its own views (computed by the library's function, so the numbers are the
//! ones the generic path computes), or, when not opting in, handing over no bound and no
//! speed-of-sound step at all (the generic path: the reference solver's own figures
//! stripped from its summaries). Shared by `tests/element_bound_nd.rs` and
//! `tests/config_dimensions.rs` (included by path).

use mpm_dt::limits_nd::element_bound::element_bound;
use mpm_dt::nd::{SolverNd, SummaryNd};
use mpm_dt::reduce::SingleProcess;
use mpm_dt::{StepError, Stepper, ViewNd};

/// The solver, handing over the element bound in its views' summaries when `on`.
pub struct OptIn {
    pub solver: SolverNd<2>,
    pub on: bool,
}

impl OptIn {
    fn with_bound<'a>(&self, view: ViewNd<'a, 2>) -> ViewNd<'a, 2> {
        let bound = self.on.then(|| element_bound(&view, &SingleProcess).lambda);
        ViewNd {
            summary: view.summary.map(|s| SummaryNd {
                element_bound: bound,
                sound_unit_step: None,
                ..s
            }),
            ..view
        }
    }
}

impl Stepper<2> for OptIn {
    fn time(&self) -> f64 {
        self.solver.time()
    }
    fn step_count(&self) -> u64 {
        self.solver.step_count()
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.solver.try_step(dt)
    }
    fn accept(&mut self) -> Result<(), StepError> {
        self.solver.accept()
    }
    fn reject(&mut self) {
        self.solver.reject()
    }
    fn view(&self) -> ViewNd<'_, 2> {
        self.with_bound(self.solver.view())
    }
    fn trial_view(&self) -> Option<ViewNd<'_, 2>> {
        self.solver.trial_view().map(|v| self.with_bound(v))
    }
    fn provide_summary(&mut self, on: bool) -> bool {
        self.solver.provide_summary(on)
    }
}
