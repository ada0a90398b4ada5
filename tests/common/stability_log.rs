//! The stability limit's log of a controlled run, for the `stability_nd` sweeps in 2D
//! (`tests/config_dimensions.rs`) and 3D (`tests/config_stability_nd_3d.rs`).

use mpm_dt::controller::{standard_limits, Controller, ControllerConfig, ControllerError};
use mpm_dt::limits_nd::STABILITY;
use mpm_dt::nd::Vector;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};

/// What a controlled run of `stepper` to `t_end` under the standard limits of `c` (no body
/// force) did: every decision's outcome, step and the stability limit's numbers (λmax,
/// refreshes, Lanczos products, bound proposals). A run ended by the growth monitor is
/// logged up to its end; any other error fails the test.
pub fn stability_log<const D: usize>(
    c: &ControllerConfig,
    stepper: &mut dyn Stepper<D>,
    t_end: f64,
) -> Vec<String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let limits = standard_limits::<D>(c, Vector::<D>::zeros());
    let mut controller = Controller::<D>::new(c.clone(), limits).unwrap();
    let mut log = Vec::new();
    let mut record = |d: &mpm_dt::controller::Decision| {
        let stability: Vec<String> = d
            .limits
            .iter()
            .filter(|l| l.name == STABILITY)
            .flat_map(|l| l.metrics.iter().map(|(k, v)| format!("{k}={v:e}")))
            .collect();
        log.push(format!(
            "{:?} {:e} {}",
            d.outcome,
            d.dt,
            stability.join(",")
        ));
    };
    match controller.run_until(stepper, t_end, &mut record) {
        Ok(_) | Err(ControllerError::GrowthPersists { .. }) => {}
        Err(e) => panic!("run failed: {e}"),
    }
    log
}
