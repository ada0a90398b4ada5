//! The controller the examples run on a 2D/3D scenario: the standard controller
//! (`Controller::<D>::standard`) with the scenario's controller config and gravity.

use mpm_dt::controller::{Controller, ControllerConfig, StandardLimits};
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::reduce::Reduce;
use mpm_dt::{Dim, Dimension};
use std::rc::Rc;

/// The controller of a 2D/3D scenario: the standard limits with its config and, unless
/// the config sets its own, the scenario's gravity; the processes' reductions on a split
/// run. A config gravity other than the scenario's is an error.
pub fn controller_for<const D: usize>(
    scenario: &ScenarioNd,
    mut config: ControllerConfig,
    reduce: Option<&Rc<dyn Reduce>>,
) -> Result<Controller<D>, String>
where
    Dim<D>: Dimension + StandardLimits<D>,
{
    // The solver's body force: the scenario's gravity, zero when it has none.
    let applied = scenario.gravity.clone().unwrap_or_else(|| vec![0.0; D]);
    match &config.gravity {
        Some(set) if *set != applied => {
            return Err(format!(
                "controller.gravity = {set:?} contradicts the scenario's gravity = {applied:?}"
            ))
        }
        Some(_) => {}
        None => config.gravity = scenario.gravity.clone(),
    }
    let mut controller = Controller::<D>::standard(config).map_err(|e| e.to_string())?;
    if let Some(r) = reduce {
        controller = controller.with_reduce(Rc::clone(r));
    }
    Ok(controller)
}
