//! [`OptIn`]: a 2D or 3D reference solver opting in to the stepper contract with the element
//! bound of its own views (computed by the library's function, so the numbers are the
//! ones the generic path computes), or, when not opting in, handing over no bound and no
//! speed-of-sound step at all (the generic path: the reference solver's own figures
//! stripped from its summaries). Shared by `tests/element_bound_nd.rs` and
//! `tests/config_dimensions.rs` (included by path).

use mpm_dt::limits_nd::element_bound::element_bound;
use mpm_dt::nd::{SolverNd, SummaryNd};
use mpm_dt::reduce::SingleProcess;
use mpm_dt::{Dim, Dimension, StepError, Stepper, ViewNd};

/// The solver, handing over the element bound in its views' summaries when `on`.
pub struct OptIn<const D: usize = 2> {
    pub solver: SolverNd<D>,
    pub on: bool,
}

impl<const D: usize> OptIn<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    fn with_bound<'a>(&self, view: ViewNd<'a, D>) -> ViewNd<'a, D> {
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

impl<const D: usize> Stepper<D> for OptIn<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
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
    fn view(&self) -> ViewNd<'_, D> {
        self.with_bound(self.solver.view())
    }
    fn trial_view(&self) -> Option<ViewNd<'_, D>> {
        self.solver.trial_view().map(|v| self.with_bound(v))
    }
    fn provide_summary(&mut self, on: bool) -> bool {
        self.solver.provide_summary(on)
    }
}
