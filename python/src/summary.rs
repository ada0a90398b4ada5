//! The optional `"summary"` of a state dict: totals a solver computes in its own passes
//! over the particles (`mpm_dt::nd::SummaryNd`), so that the controller's limits make no
//! pass of their own for them.
//!
//! ```text
//! "summary": {
//!     "kinetic": Σ_p ½ m_p |v_p|²,
//!     "strain": the stored energy the growth monitor watches (below),
//!     "first_moment": Σ_p m_p x_p  (d,)          the gravitational potential is −g·Σ m x
//!     "element_bound": max_p λ_p   (optional)    an upper bound on λmax(M⁻¹K)
//!     "sound_unit_step": min_p min_a h_a/(c_p + |v_p,a|)   (optional)
//! }
//! ```
//!
//! * `strain`: without a summary the growth monitor sums the complementary energy
//!   `½ σ_p : C_p⁻¹ : σ_p · det(F_p) V⁰_p` with the state's tangent moduli
//!   (`mpm_dt::growth::Growth::energies`); a solver hands over the same sum to
//!   keep the monitor's judgement unchanged, or its material's own stored energy.
//! * `element_bound`: `λ_p = (V_p/m_p) min(λ̄(H_p) max(dλ + 2μ, 2μ), tr(H_p) max(λ + 2μ, 2μ))`
//!   with `H_p = Σ_i ∇S_ip ∇S_ipᵀ/S_ip` (`mpm_dt::limits_nd::element_bound::from_metric`);
//!   for MLS-MPM's gradients `H_p = (4/h²) I`, so
//!   `λ_p = (4/h²)(V_p/m_p) min(max(dλ + 2μ, 2μ), d max(λ + 2μ, 2μ))`, O(1) per particle.
//!   It must bound what the library would compute from the state: a smaller value makes
//!   the stability limit propose steps that are too large. Without it the limit makes its
//!   pass.
//! * `sound_unit_step`: the speed-of-sound step at α = 1 with `c_p = √((λ + 2μ)/ρ_p)`;
//!   without it the sound-speed limit makes its pass.
//!
//! The package checks every value of `x`, `v`, `F` and the stress itself when it reads a
//! state, so the summary is marked finite once the state is read. A NaN (or, for the
//! totals, an infinite) value in a trial's summary is a blow-up, retried with a smaller
//! step; a malformed summary (a missing or unknown key, a wrong type or shape, a negative
//! bound or a step that is not positive) ends the run with a `StateError` /
//! `StateTypeError`. `None` for the whole summary is the same as no summary.

use crate::arrays::with_values;
use crate::errors::{state_error, state_type_error};
use crate::state::Fault;
use mpm_dt::nd::{SummaryNd, Vector};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The keys a summary may hold.
const KEYS: [&str; 5] = [
    "kinetic",
    "strain",
    "first_moment",
    "element_bound",
    "sound_unit_step",
];

/// A float of the summary dict, `None` when the key is absent or `None`.
fn optional_number(summary: &Bound<'_, PyDict>, key: &str) -> PyResult<Option<f64>> {
    match summary.get_item(key)? {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => v.extract::<f64>().map(Some).map_err(|_| {
            state_type_error(
                summary.py(),
                format!("state[\"summary\"][{key:?}] must be a number or None"),
            )
        }),
    }
}

/// A required float of the summary dict.
fn number(summary: &Bound<'_, PyDict>, key: &str) -> PyResult<f64> {
    optional_number(summary, key)?.ok_or_else(|| {
        state_error(
            summary.py(),
            format!("state[\"summary\"] needs {key:?} (a number)"),
        )
    })
}

/// Refuses a key the summary does not know (a typo would silently cost the saving).
fn check_keys(summary: &Bound<'_, PyDict>) -> PyResult<()> {
    for key in summary.keys() {
        let name: String = key.extract().unwrap_or_else(|_| format!("{key}"));
        if !KEYS.contains(&name.as_str()) {
            return Err(state_error(
                summary.py(),
                format!("state[\"summary\"] has an unknown key {name:?}; it may hold {KEYS:?}"),
            ));
        }
    }
    Ok(())
}

/// The state dict's `"summary"` (module docs), `None` without one. Read after the state's
/// own checks, so that a trial that failed them is named for what failed.
pub fn read_summary<const D: usize>(
    dict: &Bound<'_, PyDict>,
) -> Result<Option<SummaryNd<D>>, Fault> {
    let py = dict.py();
    let Some(obj) = dict.get_item("summary")? else {
        return Ok(None);
    };
    if obj.is_none() {
        return Ok(None);
    }
    let summary = obj
        .downcast::<PyDict>()
        .map_err(|_| state_type_error(py, "state[\"summary\"] must be a dict or None".into()))?;
    read_totals(summary).map(Some)
}

/// A summary dict's totals (module docs): the `"summary"` of a state dict, or what a
/// stepper handing over on demand returns from `summary(trial)`.
pub fn read_totals<const D: usize>(summary: &Bound<'_, PyDict>) -> Result<SummaryNd<D>, Fault> {
    let py = summary.py();
    check_keys(summary)?;
    let kinetic = number(summary, "kinetic")?;
    let strain = number(summary, "strain")?;
    let moment = summary.get_item("first_moment")?.ok_or_else(|| {
        state_error(
            py,
            format!("state[\"summary\"] needs \"first_moment\" ({D} numbers)"),
        )
    })?;
    let first_moment = with_values(&moment, "summary.first_moment", &[D], |s| {
        Vector::<D>::from_column_slice(s)
    })?;
    let element_bound = optional_number(summary, "element_bound")?;
    let sound_unit_step = optional_number(summary, "sound_unit_step")?;
    if !(kinetic.is_finite() && strain.is_finite() && first_moment.iter().all(|v| v.is_finite())) {
        return Err(Fault::NonFiniteSummary("summary (energies, first moment)"));
    }
    // The library's own passes may give +∞ (a bound with a weight of zero at a node, a
    // material at rest with zero moduli): passed on as they are.
    if element_bound.is_some_and(f64::is_nan) {
        return Err(Fault::NonFiniteSummary("summary[\"element_bound\"]"));
    }
    if sound_unit_step.is_some_and(f64::is_nan) {
        return Err(Fault::NonFiniteSummary("summary[\"sound_unit_step\"]"));
    }
    if let Some(b) = element_bound.filter(|&b| b < 0.0) {
        return Err(state_error(
            py,
            format!("state[\"summary\"][\"element_bound\"] = {b} is negative"),
        )
        .into());
    }
    if let Some(s) = sound_unit_step.filter(|&s| s <= 0.0) {
        return Err(state_error(
            py,
            format!("state[\"summary\"][\"sound_unit_step\"] = {s} is not a positive number"),
        )
        .into());
    }
    Ok(SummaryNd {
        finite: true,
        kinetic,
        strain,
        first_moment,
        element_bound,
        sound_unit_step,
    })
}
