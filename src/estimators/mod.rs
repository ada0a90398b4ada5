//! Computable estimates of the spatial errors of the MPM mappings (Section 4, eqs 31–44).
//!
//! Every MPM mapping between particles and nodes is a weighted sum. Expanding the field in
//! a Taylor series about the point where the result lives (eq 31 about the node `X_i`, eq 35
//! about the particle `x_p`) turns the error of the mapping into a sum of *moments* of the
//! weights times derivatives of the field:
//!
//! ```text
//! Σ_p w_ip u(x_p) = Σ_k  M_ik u⁽ᵏ⁾(X_i) / k!,     M_ik = Σ_p w_ip (x_p − X_i)^k     (eq 31)
//! Σ_i w_ip u(X_i) = Σ_k  N_pk u⁽ᵏ⁾(x_p) / k!,     N_pk = Σ_i w_ip (X_i − x_p)^k     (eq 35)
//! ```
//!
//! The paper assumes the weights reproduce constants and linears (`M_0`, `M_1` take their
//! exact values) and truncates after the cubic term. These estimators keep the series up to
//! and including the cubic term **and also the `k = 0, 1` consistency defects**: for the
//! uniform layouts of the paper they vanish to rounding (so the paper's formulas are
//! recovered bit for bit up to rounding), while on jittered layouts, fixed-width GIMP domains
//! that overlap or leave gaps, and at walls they are the leading error and the paper's
//! truncation would miss it.
//!
//! | mapping | computed quantity | estimate | file |
//! |---|---|---|---|
//! | eq 17, p→n values | `v_i = Σ_p S_ip m_p v_p / m_i` | eq 34 | [`particle_to_node`] |
//! | eq 18, p→n divergence | `a_i = −Σ_p D_ip σ_p V_p / m_i` | eq 33 | [`particle_to_node`] |
//! | eq 21, n→p values | `a_p = Σ_i S_ip a_i` | eq 37 | [`node_to_particle`] |
//! | eq 24, n→p gradient | `∂v/∂x(x_p) = Σ_i D_ip v_i` | eqs 39, 41 | [`node_to_particle`] |
//! | eqs 18 then 24 | `D` then `Dᵀ` (Table 1 case 5) | eq 41 on `∂v/∂x` + `Dᵀ` of eq 33 | [`node_to_particle`] |
//! | eq 28 | the local stress error | eq 44 | [`local_stress`] |
//!
//! The derivatives the estimates need are estimated at the nodes, by finite differences of
//! nodal values (eqs 42, 43, [`derivatives`]) or by a local least-squares fit to particle
//! values ([`recovery`]), and interpolated to particles by eq 40
//! ([`node_to_particle::to_particles`]).
//!
//! # Conventions
//!
//! * **Sign**: every error and estimate is *true − computed*, the convention of eqs 20, 36
//!   and 38. (Eq 33 is printed with the opposite sign, that of computed − true; eq 34 is
//!   printed true − computed.)
//! * **Units**: the error of eq 18 is an acceleration (`Ea_i`, eq 20); the error of the plain
//!   derivative map (case 2 of Table 1 compares `ρ_i a_i` with `∂σ/∂x`) is returned by
//!   [`particle_to_node::divergence_error`] in gradient units.
//! * **Norms**: the L∞ vector norm (eq 48), [`linf`], over the nodes or particles compared.
//! * Nodes that are inactive (`node_active = false`, including the constrained ends and
//!   ghosts of a fixed grid) get estimate 0: the solver does not use their values.
//!
//! # Using the estimators from a solver
//!
//! [`stress_divergence_error`] (`Ea_i` of eq 20 per node) and [`eq33_bracket`] (the
//! bracket `Δσ` of eq 33 per particle–node pair, used by eqs 57–58) read a
//! [`View`](crate::View) of any [`Stepper`](crate::Stepper). [`local_stress::local_stress_error`]
//! gives eq 44. Lower-level functions take a [`Layout`] and nodal derivatives explicitly.
//!
//! [`table1`] is the paper's Table 1 experiment as a library function.

pub mod derivatives;
pub mod layout;
pub mod local_stress;
pub mod node_to_particle;
pub mod particle_to_node;
pub mod recovery;
pub mod table1;

pub use derivatives::{nodal_derivatives, NodalDerivatives};
pub use layout::Layout;
pub use particle_to_node::{eq33_bracket, eq33_bracket_nearest_node, stress_divergence_error};
pub use recovery::Recovery;

/// Why an estimate could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EstimatorError {
    /// Two inputs that must have the same length do not.
    #[error("{field} has length {len}, expected {expected}")]
    Length {
        /// Which input.
        field: &'static str,
        /// Its length.
        len: usize,
        /// The length it must have.
        expected: usize,
    },
    /// An input value is NaN or infinite, or a mass or volume is not positive.
    #[error("invalid {field} at index {index}: {value}")]
    InvalidValue {
        /// Which input.
        field: &'static str,
        /// Particle or node index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// Too few usable nodes for the finite-difference stencils of eqs 42/43.
    #[error("{usable} usable nodes; the difference stencils of eqs 42/43 need at least {needed}")]
    TooFewNodes {
        /// Usable nodes found.
        usable: usize,
        /// Nodes needed.
        needed: usize,
    },
    /// The usable nodes of a fixed grid are not one contiguous run.
    #[error("usable nodes are not contiguous (gap at node {node})")]
    Gap {
        /// First unusable node inside the run.
        node: usize,
    },
    /// The least-squares fit at a node had too few particles near it.
    #[error("least-squares recovery at node {node}: {points} particles within {radius_cells} cells, need {needed}")]
    Recovery {
        /// Node index.
        node: usize,
        /// Particles found.
        points: usize,
        /// Search radius reached, in cells.
        radius_cells: f64,
        /// Particles needed.
        needed: usize,
    },
    /// An argument is out of its valid range.
    #[error("invalid argument {name} = {value}: {reason}")]
    Argument {
        /// Argument name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What is required.
        reason: &'static str,
    },
}

/// The L∞ vector norm `max_k |e_k|` (eq 48). Zero for an empty slice; NaN propagates.
pub fn linf(e: &[f64]) -> f64 {
    e.iter().fold(0.0_f64, |m, &v| {
        if v.is_nan() || m.is_nan() {
            f64::NAN
        } else {
            m.max(v.abs())
        }
    })
}
