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
    /// The JSON could not be parsed into a config, or a limit refused a setting in a way
    /// no other variant describes.
    #[error("controller config: {message}")]
    Parse {
        /// The message (for JSON, serde's: it names the unknown or mistyped field).
        message: String,
        /// The JSON reader's error, kept with its line and column, when the text or value
        /// could not be read ([`JsonError::get`]).
        #[source]
        source: Option<JsonError>,
    },
}

impl ConfigError {
    /// The error of a JSON text or value that could not be read into a config.
    pub(crate) fn json(e: serde_json::Error) -> Self {
        Self::Parse {
            message: e.to_string(),
            source: Some(JsonError::from(e)),
        }
    }
}

/// A JSON reader's error (`serde_json::Error`) kept as the source of the library's errors
/// ([`ConfigError::Parse`], [`crate::limit::LimitError::Restore`]), shared so that they stay
/// `Clone`; two are equal when their messages are (line and column included).
#[derive(Clone, Debug)]
pub struct JsonError(std::sync::Arc<serde_json::Error>);

impl JsonError {
    /// The reader's error: its line, column and category
    /// ([`serde_json::Error::line`], [`serde_json::Error::classify`]).
    pub fn get(&self) -> &serde_json::Error {
        &self.0
    }
}

impl From<serde_json::Error> for JsonError {
    fn from(e: serde_json::Error) -> Self {
        Self(std::sync::Arc::new(e))
    }
}

impl std::fmt::Display for JsonError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for JsonError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

impl PartialEq for JsonError {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0) || self.0.to_string() == other.0.to_string()
    }
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
