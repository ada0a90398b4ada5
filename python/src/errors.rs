//! The package's exceptions (defined in Python, `mpm_dt._errors`) and the mapping of the
//! library's errors onto them.

use crate::convert::decision_dict;
use mpm_dt::controller::ControllerError;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyType;

/// The exception class `name` of `mpm_dt._errors`.
pub fn class<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyType>> {
    let cls = py.import("mpm_dt._errors")?.getattr(name)?;
    Ok(cls.downcast_into::<PyType>()?)
}

/// An exception of class `name` with `message` (a `RuntimeError` if the class cannot be
/// found, which only a broken installation can cause).
pub fn error(py: Python<'_>, name: &str, message: String) -> PyErr {
    match class(py, name) {
        Ok(cls) => PyErr::from_type(cls, message),
        Err(e) => PyRuntimeError::new_err(format!("{message} (mpm_dt._errors.{name}: {e})")),
    }
}

/// A `StateError`: an invalid state dict.
pub fn state_error(py: Python<'_>, message: String) -> PyErr {
    error(py, "StateError", message)
}

/// A `StateTypeError`: a field of a type or dtype the package does not read.
pub fn state_type_error(py: Python<'_>, message: String) -> PyErr {
    error(py, "StateTypeError", message)
}

/// Whether `err` is a `StepFailed` (a retryable failure raised by a stepper).
pub fn is_step_failed(py: Python<'_>, err: &PyErr) -> bool {
    class(py, "StepFailed").is_ok_and(|cls| err.is_instance(py, &cls))
}

/// The Python exception for a library error: its class by kind, the Rust message, and the
/// last decision as `decision` when the error carries one.
pub fn controller_error(py: Python<'_>, e: &ControllerError) -> PyErr {
    let (name, last) = match e {
        ControllerError::Config(_) => ("ConfigError", None),
        ControllerError::TooManyRejections { last, .. } => {
            ("TooManyRejections", Some(last.as_ref()))
        }
        ControllerError::StepTooSmall { last, .. } => ("StepTooSmall", last.as_deref()),
        ControllerError::GrowthPersists { .. } => ("GrowthPersists", None),
        ControllerError::InvalidEnd { .. } => ("InvalidEnd", None),
        ControllerError::NoProgress { .. } => ("NoProgress", None),
        ControllerError::Stepper { .. } => ("StepperError", None),
        _ => ("ControllerError", None),
    };
    let err = error(py, name, e.to_string());
    if let Some(d) = last {
        if let Ok(dict) = decision_dict(py, d) {
            // Best effort: the message says it all already.
            let _ = err.value(py).setattr("decision", dict);
        }
    }
    err
}
