//! [`ScenarioError`]: why a scenario file of any dimension (1D [`super::Scenario`], 2D/3D
//! [`crate::nd::scenario::ScenarioNd`]) could not be loaded or built, and the two helpers
//! that name the field of a bad value.

use crate::mpm::SetupError;
use crate::nd::problems::PlaneWaveError;
use serde::de::DeserializeOwned;
use std::path::PathBuf;

/// Why a scenario could not be loaded or built (module docs).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("cannot read scenario {}: {message}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        message: String,
    },
    /// The text is not a JSON object.
    #[error("scenario is not a JSON object (line {line}, column {column}): {message}")]
    Syntax {
        /// Line of the error (1-based; 0 if unknown).
        line: usize,
        /// Column of the error (1-based; 0 if unknown).
        column: usize,
        /// The parser's message.
        message: String,
    },
    /// A field the format does not have (at the top level, or nested: the message of a
    /// nested error names it).
    #[error("unknown scenario field `{field}`")]
    UnknownField {
        /// The field's name.
        field: String,
    },
    /// A field whose value has the wrong type or shape (including unknown nested fields).
    #[error("scenario field `{field}`: {reason}")]
    Type {
        /// The field.
        field: &'static str,
        /// The parser's message.
        reason: String,
    },
    /// Malformed JSON, an unknown field or a value of the wrong type in a 2D/3D scenario
    /// (serde's message names the field).
    #[error("scenario: {0}")]
    Parse(String),
    /// A field whose value is not allowed.
    #[error("invalid scenario field `{field}`: {reason}")]
    Invalid {
        /// The field (`"cells"`, `"particles.positions"`, `"bodies[0].box"`, …).
        field: String,
        /// Why.
        reason: String,
    },
    /// The solver rejected the particle data (in 1D this should not happen after
    /// validation; in 2D/3D the particles may not fit the grid).
    #[error("scenario field `particles`: {0}")]
    Setup(#[from] SetupError),
    /// The 2D/3D plane wave is not valid.
    #[error("scenario field `initial`: {0}")]
    Wave(#[from] PlaneWaveError),
}

/// A [`ScenarioError::Invalid`] for `field`.
pub(super) fn invalid(field: &'static str, reason: impl Into<String>) -> ScenarioError {
    ScenarioError::Invalid {
        field: field.to_string(),
        reason: reason.into(),
    }
}

/// Moves `field` out of `obj` into `into` when present; a value of the wrong type is a
/// [`ScenarioError::Type`] naming the field.
pub(super) fn take<T: DeserializeOwned>(
    obj: &mut serde_json::Map<String, serde_json::Value>,
    field: &'static str,
    into: &mut T,
) -> Result<(), ScenarioError> {
    if let Some(value) = obj.remove(field) {
        *into = serde_json::from_value(value).map_err(|e| ScenarioError::Type {
            field,
            reason: e.to_string(),
        })?;
    }
    Ok(())
}
