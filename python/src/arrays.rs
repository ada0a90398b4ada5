//! Reading the arrays of a state dict.
//!
//! A field is read in one pass into the package's own storage (the cache the library's
//! view borrows): a float64 C-contiguous array is read in place, with no intermediate
//! copy; a float32 array, a float64 array that is not C-contiguous, a list or a tuple is
//! first converted by `numpy.ascontiguousarray(obj, dtype=float64)` (one more pass, in C,
//! and one temporary array of the field's size). Any other dtype is a `StateTypeError`
//! (a `TypeError`): integers and complex numbers are not silently converted.

use crate::errors::{state_error, state_type_error};
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `(n, …)` with `-1` for "any" in the shape a field must have.
fn shape_text(shape: &[usize]) -> String {
    let parts: Vec<String> = shape.iter().map(|s| s.to_string()).collect();
    if parts.len() == 1 {
        format!("({},)", parts[0])
    } else {
        format!("({})", parts.join(", "))
    }
}

/// The item `key` of `dict`, or a `StateError` naming it.
pub fn item<'py>(dict: &Bound<'py, PyDict>, key: &str) -> PyResult<Bound<'py, PyAny>> {
    dict.get_item(key)?
        .ok_or_else(|| state_error(dict.py(), format!("state: missing key {key:?}")))
}

/// Calls `f` with the values of `obj` (field `name`) in C order, after checking that its
/// shape is `shape` (module docs for what is copied).
pub fn with_values<R>(
    obj: &Bound<'_, PyAny>,
    name: &str,
    shape: &[usize],
    f: impl FnOnce(&[f64]) -> R,
) -> PyResult<R> {
    let py = obj.py();
    let check = |got: &[usize]| -> PyResult<()> {
        if got == shape {
            Ok(())
        } else {
            Err(state_error(
                py,
                format!(
                    "state[{name:?}] has shape {}, expected {}",
                    shape_text(got),
                    shape_text(shape)
                ),
            ))
        }
    };
    if let Ok(a) = obj.downcast::<PyArrayDyn<f64>>() {
        check(a.shape())?;
        // `as_slice` also accepts Fortran order (memory order ≠ C order): C only here.
        if a.is_c_contiguous() {
            if let Ok(s) = a.readonly().as_slice() {
                return Ok(f(s));
            }
        }
    } else if let Ok(a) = obj.downcast::<PyArrayDyn<f32>>() {
        check(a.shape())?;
    } else if let Ok(a) = obj.downcast::<PyUntypedArray>() {
        return Err(state_type_error(
            py,
            format!(
                "state[{name:?}] has dtype {}; mpm_dt reads float64 (in place) or float32 \
                 (converted)",
                a.dtype()
            ),
        ));
    }
    // float32, a strided float64 array, a list, a tuple or a number: numpy converts it
    // into a C-contiguous float64 array (one pass in C, one allocation of its size).
    let np = py.import("numpy")?;
    let arr = np
        .call_method1("ascontiguousarray", (obj, np.getattr("float64")?))
        .map_err(|e| {
            state_type_error(
                py,
                format!("state[{name:?}] is not an array of floats: {e}"),
            )
        })?;
    let a = arr.downcast::<PyArrayDyn<f64>>()?;
    check(a.shape())?;
    let ro = a.readonly();
    let s = ro
        .as_slice()
        .map_err(|e| state_error(py, format!("state[{name:?}]: {e}")))?;
    Ok(f(s))
}

/// The shape of an array-like field (numpy arrays without conversion).
pub fn shape_of(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<usize>> {
    if let Ok(a) = obj.downcast::<PyUntypedArray>() {
        return Ok(a.shape().to_vec());
    }
    let py = obj.py();
    let np = py.import("numpy")?;
    let shape = np
        .call_method1("shape", (obj,))
        .map_err(|e| state_type_error(py, format!("state[{name:?}]: {e}")))?;
    shape.extract()
}

/// A float field of shape `shape` copied into `out` (resized).
pub fn read_into(
    dict: &Bound<'_, PyDict>,
    key: &str,
    shape: &[usize],
    out: &mut Vec<f64>,
) -> PyResult<()> {
    let obj = item(dict, key)?;
    with_values(&obj, key, shape, |s| {
        out.clear();
        out.extend_from_slice(s);
    })
}

/// A number (a Python float or int, a numpy scalar, or a 0-d array).
pub fn scalar(dict: &Bound<'_, PyDict>, key: &str) -> PyResult<f64> {
    let obj = item(dict, key)?;
    obj.extract::<f64>().map_err(|_| {
        state_type_error(
            obj.py(),
            format!("state[{key:?}] must be a number, got {}", type_name(&obj)),
        )
    })
}

/// The Python type name of `obj`, for messages.
pub fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}
