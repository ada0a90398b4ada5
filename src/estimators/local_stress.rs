//! The spatial part of the local stress error of one USL step (eq 44):
//!
//! ```text
//! leσ_p^{n+1} = dt E_p ( Ev_xp^{n+1} + dt Σ_i D_ip Ea_i^n )                        (eq 44)
//! ```
//!
//! the temporal terms of eqs 20 and 28 dropped. `Ev_xp` is the eq 24 gradient error of the
//! updated nodal velocity (eq 41, [`gradient_error`]), `Ea_i` the eq 18 acceleration error
//! (eq 33, [`stress_divergence_error_from`]), `E_p` the particle's tangent modulus. Sign:
//! true − computed, like eq 28.

use super::derivatives::nodal_derivatives;
use super::layout::Layout;
use super::node_to_particle::gradient_error;
use super::particle_to_node::stress_divergence_error_from;
use super::recovery::Recovery;
use super::EstimatorError;
use crate::stepper::View;
use crate::weights::WeightKind;

/// Eq 44 from its parts: `dt E_p (ev_xp[p] + dt Σ_i D_ip ea[i])` per particle.
pub fn local_stress_error_from(
    layout: &Layout<'_>,
    tangent_modulus: &[f64],
    dt: f64,
    ev_xp: &[f64],
    ea: &[f64],
) -> Result<Vec<f64>, EstimatorError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(EstimatorError::Argument {
            name: "dt",
            value: dt,
            reason: "must be positive and finite",
        });
    }
    let np = layout.n_particles();
    for (field, len, expected) in [
        ("tangent_modulus", tangent_modulus.len(), np),
        ("ev_xp", ev_xp.len(), np),
        ("ea", ea.len(), layout.n_nodes()),
    ] {
        if len != expected {
            return Err(EstimatorError::Length {
                field,
                len,
                expected,
            });
        }
    }
    let mut carried = vec![0.0; np];
    layout.weights.gather(WeightKind::D, ea, &mut carried);
    Ok((0..np)
        .map(|p| dt * tangent_modulus[p] * (ev_xp[p] + dt * carried[p]))
        .collect())
}

/// Eq 44 for a step of size `dt` from a solver's committed state: `Ea_i` from the view's
/// stresses (eq 33, nodal derivatives by `recovery`), `Ev_xp` from the updated nodal velocity
/// `v_i + dt a_i` (eq 19) differenced over the active nodes (eqs 42/43) and eq 41.
pub fn local_stress_error(
    view: &View<'_>,
    dt: f64,
    recovery: Recovery,
) -> Result<Vec<f64>, EstimatorError> {
    let layout = Layout::from_view(view)?;
    let ds = recovery.nodal_derivatives(&layout, view.sigma)?;
    let ea = stress_divergence_error_from(&layout, &ds)?;
    let nn = layout.n_nodes();
    for (field, len) in [
        ("node_velocity", view.node_velocity.len()),
        ("node_acceleration", view.node_acceleration.len()),
    ] {
        if len != nn {
            return Err(EstimatorError::Length {
                field,
                len,
                expected: nn,
            });
        }
    }
    let v_next: Vec<f64> = view
        .node_velocity
        .iter()
        .zip(view.node_acceleration)
        .map(|(v, a)| v + dt * a)
        .collect();
    let dv = nodal_derivatives(layout.grid, &v_next, &layout.node_active)?;
    let ev = gradient_error(&layout, &dv)?;
    local_stress_error_from(&layout, view.tangent_modulus, dt, &ev, &ea)
}
