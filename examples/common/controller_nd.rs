//! The controller the examples run on a 2D/3D scenario: the standard limits
//! (`mpm_dt::limits_nd::standard_limits`) with the scenario's gravity and controller config.

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::limits_nd::standard_limits;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::reduce::Reduce;
use mpm_dt::{Dim, Dimension, ViewNd};
use std::rc::Rc;

/// The controller of a 2D/3D scenario: its standard limits with its gravity and its
/// config, and the processes' reductions on a split run.
pub fn controller_for<const D: usize>(
    scenario: &ScenarioNd,
    config: ControllerConfig,
    reduce: Option<&Rc<dyn Reduce>>,
) -> Result<Controller<D>, String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let gravity = scenario
        .gravity
        .as_ref()
        .map(|g| mpm_dt::nd::Vector::<D>::from_fn(|a, _| g[a]))
        .unwrap_or_else(mpm_dt::nd::Vector::<D>::zeros);
    let limits = standard_limits::<D>(&config, gravity);
    let mut controller = Controller::<D>::new(config, limits).map_err(|e| e.to_string())?;
    if let Some(r) = reduce {
        controller = controller.with_reduce(Rc::clone(r));
    }
    Ok(controller)
}
