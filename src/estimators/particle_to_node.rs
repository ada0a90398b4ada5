//! Particle→node errors: the value map of eq 17 (estimate eq 34) and the divergence map of
//! eq 18 (estimate eq 33).
//!
//! With `x̃ = x_p − X_i` and the field expanded about the node (eq 31):
//!
//! * **eq 17 / eq 34.** `v_i = Σ_p S_ip m_p v_p / m_i`. With `M_k = Σ_p S_ip m_p x̃^k / m_i`
//!   (`M_0 = 1`),
//!   `EI_i = v(X_i) − v_i ≈ −M_1 v′ − M_2 v″/2 − M_3 v‴/6`.
//!   Eq 34 is the `k = 2, 3` part, printed with `S_pi` where the map has `S_pi m_p/m_i` (equal
//!   for equal masses and uniform nodal masses only). `M_1 = 0` for layouts symmetric about
//!   the node, as in the paper; otherwise it is the leading, first-order, term.
//! * **eq 18 / eq 33.** `a_i = −(1/m_i) Σ_p D_ip σ_p V_p`, `V_p = F_p V_p⁰`. The exact
//!   acceleration is `∂σ/∂x(X_i)/ρ_i` (eq 2), `ρ_i = m_i/V_i`. With
//!   `c_k = Σ_p D_ip V_p x̃^k`,
//!   `Ea_i = ∂σ/∂x(X_i)/ρ_i − a_i ≈ (1/m_i) [ c_0 σ_i + (c_1 + V_i) σ′_i + c_2 σ″_i/2 + c_3 σ‴_i/6 ]`.
//!   The weights of the paper differentiate constants and linears exactly (`c_0 = 0`,
//!   `c_1 = −V_i`), which leaves eq 33, `Ea_i ≈ (1/m_i) Σ_p D_ip V_p [x̃²/2 σ″ + x̃³/6 σ‴]`.
//!   **Sign**: eq 33 is printed as `−(1/m̃_i) Σ …`, which is computed − true; here it is
//!   true − computed like eq 20. Eq 33 also omits the volume `V_p` (`F_p V_p⁰` of eq 18)
//!   from the sum; it is restored. On uniform layouts `c_0`, `c_1 + V_i` vanish to rounding;
//!   on jittered GIMP layouts (domains overlap or leave gaps) and next to walls they are the
//!   leading error and are kept.
//!
//! The bracket `Δσ_{pi} = x̃²/2 σ″(X_i) + x̃³/6 σ‴(X_i)` of eq 33 is what eqs 57–58 call
//! `Δσ`; [`eq33_bracket`] returns it per particle–node pair.

use super::derivatives::NodalDerivatives;
use super::layout::Layout;
use super::recovery::Recovery;
use super::EstimatorError;
use crate::stepper::View;

fn check_derivs(layout: &Layout<'_>, d: &NodalDerivatives) -> Result<(), EstimatorError> {
    let nn = layout.n_nodes();
    for k in 0..=3 {
        let len = d.order(k).map_or(0, <[f64]>::len);
        if len != nn {
            return Err(EstimatorError::Length {
                field: "nodal derivatives",
                len,
                expected: nn,
            });
        }
    }
    Ok(())
}

/// Eq 34 (with its `k = 1` term): estimated error `v(X_i) − v_i` of the eq 17 map, per
/// stored node, from the nodal derivatives `d` of the mapped field. 0 at inactive nodes.
pub fn value_mapping_error(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    check_derivs(layout, d)?;
    let mut moments = vec![[0.0_f64; 4]; layout.n_nodes()];
    for p in 0..layout.n_particles() {
        let mp = layout.mass[p];
        for (i, s, _) in layout.weights.row(p) {
            if s == 0.0 {
                continue;
            }
            let xt = layout.dx_from_node(i, p);
            let w = s * mp;
            moments[i][1] += w * xt;
            moments[i][2] += w * xt * xt;
            moments[i][3] += w * xt * xt * xt;
        }
    }
    Ok((0..layout.n_nodes())
        .map(|i| {
            if !layout.node_active[i] {
                return 0.0;
            }
            let m = &moments[i];
            -(m[1] * d.first[i] + m[2] * d.second[i] / 2.0 + m[3] * d.third[i] / 6.0)
                / layout.node_mass[i]
        })
        .collect())
}

/// The moment-expanded error of the derivative map `G_i[u] = −(1/V_i) Σ_p D_ip V_p u_p`, in
/// gradient units: estimated `∂u/∂x(X_i) − G_i[u]` per stored node (see the module docs;
/// this is eq 33 times `ρ_i`, with the `k = 0, 1` defects). 0 at inactive nodes.
pub fn divergence_error(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    check_derivs(layout, d)?;
    let mut c = vec![[0.0_f64; 4]; layout.n_nodes()];
    for p in 0..layout.n_particles() {
        let vp = layout.volume[p];
        for (i, _, dw) in layout.weights.row(p) {
            if dw == 0.0 {
                continue;
            }
            let xt = layout.dx_from_node(i, p);
            let w = dw * vp;
            c[i][0] += w;
            c[i][1] += w * xt;
            c[i][2] += w * xt * xt;
            c[i][3] += w * xt * xt * xt;
        }
    }
    Ok((0..layout.n_nodes())
        .map(|i| {
            if !layout.node_active[i] {
                return 0.0;
            }
            let c = &c[i];
            let vi = layout.node_volume[i];
            (c[0] * d.value[i]
                + (c[1] + vi) * d.first[i]
                + c[2] * d.second[i] / 2.0
                + c[3] * d.third[i] / 6.0)
                / vi
        })
        .collect())
}

/// Eq 33 (sign true − computed, with the `k = 0, 1` defects): estimated error
/// `Ea_i = ∂σ/∂x(X_i)/ρ_i − a_i` of the eq 18 acceleration, per stored node, in acceleration
/// units, from the nodal derivatives `d` of the stress. 0 at inactive nodes.
pub fn stress_divergence_error_from(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    let mut e = divergence_error(layout, d)?;
    for (i, ei) in e.iter_mut().enumerate() {
        let rho = layout.node_density(i);
        *ei = if rho > 0.0 { *ei / rho } else { 0.0 };
    }
    Ok(e)
}

/// The bracket of eq 33, `Δσ_{pi} = x̃²/2 σ″(X_i) + x̃³/6 σ‴(X_i)` with `x̃ = x_p − X_i`, for
/// every stored weight entry, in the weights' particle-major order: entry `p·w + k` belongs
/// to particle `p` and node `weights.nodes_of(p)[k]` (`w = weights.width()`).
pub fn eq33_bracket_from(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    check_derivs(layout, d)?;
    let mut out = Vec::with_capacity(layout.n_particles() * layout.weights.width());
    for p in 0..layout.n_particles() {
        for (i, _, _) in layout.weights.row(p) {
            let xt = layout.dx_from_node(i, p);
            out.push(xt * xt / 2.0 * d.second[i] + xt * xt * xt / 6.0 * d.third[i]);
        }
    }
    Ok(out)
}

/// The bracket of eq 33 for each particle at its nearest node (the stored node of its
/// stencil with the smallest `|x_p − X_i|`): one value per particle.
pub fn eq33_bracket_nearest_node_from(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    check_derivs(layout, d)?;
    Ok((0..layout.n_particles())
        .map(|p| {
            let (i, xt) = layout
                .weights
                .nodes_of(p)
                .iter()
                .map(|&i| (i as usize, layout.dx_from_node(i as usize, p)))
                .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .unwrap_or((0, 0.0));
            xt * xt / 2.0 * d.second[i] + xt * xt * xt / 6.0 * d.third[i]
        })
        .collect())
}

/// `Ea_i` of eq 20 (eq 33, true − computed, acceleration units) for a solver's state: one
/// value per stored node, 0 at inactive nodes. Stress derivatives at the nodes come from
/// [`Recovery::default`].
pub fn stress_divergence_error(view: &View<'_>) -> Result<Vec<f64>, EstimatorError> {
    stress_divergence_error_with(view, Recovery::default())
}

/// [`stress_divergence_error`] with a chosen way of recovering nodal stress derivatives.
pub fn stress_divergence_error_with(
    view: &View<'_>,
    recovery: Recovery,
) -> Result<Vec<f64>, EstimatorError> {
    let layout = Layout::from_view(view)?;
    let d = recovery.nodal_derivatives(&layout, view.sigma)?;
    stress_divergence_error_from(&layout, &d)
}

/// The eq 33 bracket `Δσ_{pi}` (see [`eq33_bracket_from`]) for a solver's state, per stored
/// weight entry in the weights' particle-major order, with [`Recovery::default`].
pub fn eq33_bracket(view: &View<'_>) -> Result<Vec<f64>, EstimatorError> {
    let layout = Layout::from_view(view)?;
    let d = Recovery::default().nodal_derivatives(&layout, view.sigma)?;
    eq33_bracket_from(&layout, &d)
}

/// The eq 33 bracket at each particle's nearest node (see
/// [`eq33_bracket_nearest_node_from`]) for a solver's state, with [`Recovery::default`].
pub fn eq33_bracket_nearest_node(view: &View<'_>) -> Result<Vec<f64>, EstimatorError> {
    let layout = Layout::from_view(view)?;
    let d = Recovery::default().nodal_derivatives(&layout, view.sigma)?;
    eq33_bracket_nearest_node_from(&layout, &d)
}
