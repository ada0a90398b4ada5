//! [`ConfigError`]: a setting out of its range, of the controller or of any limit. The
//! limits validate their own settings with it, and the controller's config
//! ([`crate::controller::ControllerConfig`]) reports every field's error through it, so it
//! sits below both.

/// A configuration value out of its range. `field` is the JSON path of the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// A number is outside its allowed range.
    #[error("controller config: {field} = {} is invalid: must be {expected}", crate::fmt_num::Num(*value))]
    OutOfRange {
        /// Field path, e.g. `"safety"` or `"temporal.rtol"`.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range in words.
        expected: &'static str,
    },
    /// Two fields contradict each other.
    #[error("controller config: {field} = {} contradicts {other} = {}", crate::fmt_num::Num(*value), crate::fmt_num::Num(*other_value))]
    Inconsistent {
        /// The field reported.
        field: &'static str,
        /// Its value.
        value: f64,
        /// The field it contradicts.
        other: &'static str,
        /// That field's value.
        other_value: f64,
    },
    /// A field that does not apply in the run's dimension was set
    /// ([`crate::controller::ControllerConfig::validate_for`]).
    #[error("controller config: {field} does not apply in {dim}D runs (it is a setting of {applies}); remove it")]
    NotInDimension {
        /// Field path, e.g. `"stability.bound58_every"`.
        field: &'static str,
        /// The run's dimension.
        dim: usize,
        /// Where the field applies, in words.
        applies: &'static str,
    },
    /// A per-axis field has a component count other than the run's dimension
    /// ([`crate::controller::ControllerConfig::validate_for`]).
    #[error("controller config: {field} has {len} components; a {dim}D run needs {dim}")]
    WrongLength {
        /// Field path, e.g. `"gravity"`.
        field: &'static str,
        /// The number of components given.
        len: usize,
        /// The run's dimension.
        dim: usize,
    },
    /// The JSON could not be parsed into a config.
    #[error("controller config: {message}")]
    Parse {
        /// The serde message (names the unknown or mistyped field).
        message: String,
    },
}

pub(crate) fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    expected: &'static str,
) -> Result<(), ConfigError> {
    if ok && !value.is_nan() {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            field,
            value,
            expected,
        })
    }
}
