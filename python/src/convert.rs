//! Rust values to Python: a serde value (a `Decision`) to plain dicts, lists and floats.

use mpm_dt::controller::{Decision, Stats};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde_json::Value;

/// A JSON value as Python objects (`null` → `None`, numbers → `int` or `float`).
pub fn json_to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_u64(), n.as_i64()) {
            (Some(u), _) => u.into_pyobject(py)?.into_any(),
            (None, Some(i)) => i.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(a) => {
            let list = PyList::empty(py);
            for x in a {
                list.append(json_to_py(py, x)?)?;
            }
            list.into_any()
        }
        Value::Object(o) => {
            let dict = PyDict::new(py);
            for (k, x) in o {
                dict.set_item(k, json_to_py(py, x)?)?;
            }
            dict.into_any()
        }
    })
}

/// A [`Decision`] as a dict with the same fields (`step`, `attempt`, `t`, `dt`, `limits`,
/// `filter_dt`, `binding`, `bound58`, `lambda_max`, `dsm`, `outcome`, `cause`,
/// `rejected_by`, `message`).
pub fn decision_dict<'py>(py: Python<'py>, d: &Decision) -> PyResult<Bound<'py, PyAny>> {
    let value = serde_json::to_value(d)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    json_to_py(py, &value)
}

/// The run summary: `steps_accepted`, `steps_rejected`, `dt_mean`, `dt_min`, `dt_max`,
/// `t_final`, `binding` (accepted steps per binding bound), `rejected_by_cause`,
/// `growth_events`.
pub fn summary_dict<'py>(py: Python<'py>, s: &Stats, t_final: f64) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("steps_accepted", s.accepted)?;
    d.set_item("steps_rejected", s.rejected)?;
    d.set_item("dt_mean", s.dt_mean())?;
    d.set_item("dt_min", s.dt_min)?;
    d.set_item("dt_min_chosen", s.dt_min_chosen)?;
    d.set_item("dt_max", s.dt_max)?;
    d.set_item("t_final", t_final)?;
    let binding = PyDict::new(py);
    for (k, n) in &s.binding {
        binding.set_item(k, n)?;
    }
    d.set_item("binding", binding)?;
    let causes = PyDict::new(py);
    for (k, n) in &s.rejected_by_cause {
        causes.set_item(k.as_str(), n)?;
    }
    d.set_item("rejected_by_cause", causes)?;
    d.set_item("growth_events", s.growth_events)?;
    Ok(d)
}
