//! The error type of the stability module.

use crate::limit::LimitError;

/// Why a stability quantity could not be computed. Bad input is reported, never panicked on.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StabilityError {
    /// A field of the view holds a value the analysis cannot use (NaN stress, a modulus,
    /// density, volume or deformation gradient that is not positive and finite, …).
    #[error("invalid {field} at index {index}: {value}")]
    InvalidField {
        /// Which field (`"sigma"`, `"tangent_modulus"`, `"node_mass"`, …).
        field: &'static str,
        /// Particle or node index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A slice of the view has the wrong length.
    #[error("{field} has length {len}, expected {expected}")]
    LengthMismatch {
        /// Which field.
        field: &'static str,
        /// Its length.
        len: usize,
        /// The expected length.
        expected: usize,
    },
    /// The view has no particles.
    #[error("the state has no particles")]
    NoParticles,
    /// No node is active (every node empty or constrained): the operator is zero.
    #[error("no active node: every node is empty or constrained")]
    NoActiveNodes,
    /// A time step is not positive and finite.
    #[error("invalid time step {dt}")]
    InvalidDt {
        /// The offending step.
        dt: f64,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration {field} = {value}: {reason}")]
    InvalidConfig {
        /// Which field.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// The admissible range.
        reason: &'static str,
    },
    /// A dense eigenvalue or singular value computation did not converge.
    #[error("dense {what} did not converge")]
    NoConvergence {
        /// Which decomposition.
        what: &'static str,
    },
    /// A solver run needed by the empirical critical step could not be set up.
    #[error("setting up a run failed: {0}")]
    Setup(String),
    /// A search for a critical step found no bracket.
    #[error("no bracket for the critical step: stable up to dt = {stable}, tried up to {tried}")]
    NoBracket {
        /// Largest step found stable.
        stable: f64,
        /// Largest step tried.
        tried: f64,
    },
}

impl StabilityError {
    /// Converts to the [`LimitError`] a [`crate::limit::StepLimit`] returns.
    pub fn into_limit_error(self, limit: &str, t: f64) -> LimitError {
        match self {
            StabilityError::InvalidField {
                field,
                index,
                value,
            } => LimitError::InvalidState {
                limit: limit.to_owned(),
                field,
                index,
                value,
                t,
            },
            other => LimitError::Other {
                limit: limit.to_owned(),
                message: other.to_string(),
            },
        }
    }
}

/// Checks the fields the stability analysis reads: lengths, finite `x`, `v`, `σ`, positive
/// finite `F`, `V⁰`, `m_p`, `E_t`, `ρ`, and positive finite mass at every active node, and at
/// least one active node.
pub(crate) fn check_view(view: &crate::stepper::View<'_>) -> Result<(), StabilityError> {
    let n = view.n_particles();
    if n == 0 {
        return Err(StabilityError::NoParticles);
    }
    let nn = view.grid.n_nodes();
    let particle_fields: [(&'static str, &[f64], bool); 8] = [
        ("x", view.x, false),
        ("v", view.v, false),
        ("sigma", view.sigma, false),
        ("F", view.f, true),
        ("volume0", view.volume0, true),
        ("mass", view.mass, true),
        ("tangent_modulus", view.tangent_modulus, true),
        ("density", view.density, true),
    ];
    for (field, values, positive) in particle_fields {
        if values.len() != n {
            return Err(StabilityError::LengthMismatch {
                field,
                len: values.len(),
                expected: n,
            });
        }
        if let Some((index, &value)) = values
            .iter()
            .enumerate()
            .find(|(_, &v)| !v.is_finite() || (positive && v <= 0.0))
        {
            return Err(StabilityError::InvalidField {
                field,
                index,
                value,
            });
        }
    }
    if view.weights.n_particles() != n {
        return Err(StabilityError::LengthMismatch {
            field: "weights",
            len: view.weights.n_particles(),
            expected: n,
        });
    }
    for (field, len) in [
        ("weights (nodes)", view.weights.n_nodes()),
        ("node_mass", view.node_mass.len()),
        ("node_velocity", view.node_velocity.len()),
        ("node_acceleration", view.node_acceleration.len()),
        ("node_active", view.node_active.len()),
    ] {
        if len != nn {
            return Err(StabilityError::LengthMismatch {
                field,
                len,
                expected: nn,
            });
        }
    }
    let mut any = false;
    for (i, (&m, &active)) in view.node_mass.iter().zip(view.node_active).enumerate() {
        if active {
            if !(m.is_finite() && m > 0.0) {
                return Err(StabilityError::InvalidField {
                    field: "node_mass",
                    index: i,
                    value: m,
                });
            }
            any = true;
        }
    }
    if !any {
        return Err(StabilityError::NoActiveNodes);
    }
    Ok(())
}

/// Checks that `dt` is positive and finite.
pub(crate) fn check_dt(dt: f64) -> Result<(), StabilityError> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(StabilityError::InvalidDt { dt })
    }
}
