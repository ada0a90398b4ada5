//! The full map of a 1D state for `critical_dt`: from the nodes, with the dense map as a
//! cross-check on small layouts.

use mpm_dt::stability::nodal_full_map::{
    critical_dt_nodal_1d, NodalCritical, NODAL_FULL_MAP_LIMIT,
};
use mpm_dt::stability::{FullMap, FullMapConfig};

pub(super) type FullMap1d = (Option<NodalCritical>, Option<f64>, Option<String>);

/// The full map of a 1D state: from the nodes (`None` above the reduction's limit or when
/// its Lanczos iteration does not settle), the dense cross-check on `small` layouts, and
/// why the former is `null` when it is.
pub(super) fn full_map_1d(
    view: &mpm_dt::View<'_>,
    dt_eq56: f64,
    small: bool,
) -> Result<FullMap1d, Box<dyn std::error::Error>> {
    let nodal_small = view.node_active.iter().filter(|&&a| a).count() <= NODAL_FULL_MAP_LIMIT;
    let full = critical_dt_nodal_1d(view)?.filter(|c| c.converged);
    let dense = if small {
        Some(FullMap::new(view)?.critical_dt(0.5 * dt_eq56, FullMapConfig::default())?)
    } else {
        None
    };
    tracing::info!(dt_full = ?full.map(|c| c.dt), ?dense, "full map");
    let skipped = match (nodal_small, full) {
        (false, _) => Some(format!(
            "dt_full_map above {NODAL_FULL_MAP_LIMIT} active nodal unknowns"
        )),
        (true, None) => {
            Some("dt_full_map: no result (the Lanczos iteration did not settle)".into())
        }
        (true, Some(_)) => None,
    };
    Ok((full, dense, skipped))
}
