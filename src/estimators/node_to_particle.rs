//! Node→particle errors: interpolation (eq 21, estimate eq 37), gradient (eq 24, estimates
//! eqs 39 and 41), the interpolation of nodal derivatives to particles (eq 40), and the
//! two-map "D then Dᵀ" second derivative of Table 1's case 5.
//!
//! Expanding nodal values about the particle (eq 35) with `N_k = Σ_i S_ip (X_i − x_p)^k` and
//! `N^D_k = Σ_i D_ip (X_i − x_p)^k`:
//!
//! * **eq 21 / eq 37.** `a_p = Σ_i S_ip a_i`;
//!   `Ea_p = a(x_p) − a_p ≈ −[(N_0 − 1) a + N_1 a′ + N_2 a″/2 + N_3 a‴/6]`.
//!   The paper's weights have `N_0 = 1`, `N_1 = 0` (kept as defects here, zero to rounding
//!   for GIMP and linear hats). **Eq 37 as printed** has `∂²a/∂x`; it is `∂²a/∂x²`.
//! * **eq 24 / eqs 39, 41.** `∂v/∂x(x_p) = Σ_i D_ip v_i`;
//!   `Ev_xp ≈ −[N^D_0 v + (N^D_1 − 1) v′ + N^D_2 v″/2 + N^D_3 v‴/6]`. **Eq 41 as printed** has
//!   cubic coefficient `1/3`; the Taylor coefficient is `1/6` as in eq 39.
//! * **eq 40.** Particle values of the derivatives are interpolated from nodal ones,
//!   `u⁽ᵏ⁾(x_p) ≈ Σ_i S_ip u⁽ᵏ⁾(X_i)` ([`to_particles`]).
//! * **D then Dᵀ (case 5, Section 4.4).** Particle velocities are differentiated to the
//!   nodes by the eq 18 operator, `g_i = −(1/V_i) Σ_p D_ip V_p v_p`, and back to the
//!   particles by eq 24, `s_p = Σ_i D_ip g_i ≈ ∂²v/∂x²(x_p)`. The error splits exactly as
//!   `v″(x_p) − s_p = [v″(x_p) − Σ_i D_ip v′(X_i)] + Σ_i D_ip [v′(X_i) − g_i]`: the first
//!   part is eq 41 applied to the field `v′` (so it needs `v‴`, `v⁗`: "replacing the velocity
//!   values by their spatial derivatives", Section 4.4), the second is `Dᵀ` applied to the
//!   eq 33-type error of the first map ([`second_derivative_error`]).

use super::derivatives::NodalDerivatives;
use super::layout::Layout;
use super::particle_to_node::divergence_error;
use super::EstimatorError;
use crate::weights::WeightKind;

/// Eq 40: a nodal field interpolated to the particles, `u_p = Σ_i S_ip u_i`.
pub fn to_particles(layout: &Layout<'_>, nodal: &[f64]) -> Result<Vec<f64>, EstimatorError> {
    if nodal.len() != layout.n_nodes() {
        return Err(EstimatorError::Length {
            field: "nodal field",
            len: nodal.len(),
            expected: layout.n_nodes(),
        });
    }
    let mut out = vec![0.0; layout.n_particles()];
    layout.weights.gather(WeightKind::S, nodal, &mut out);
    Ok(out)
}

/// `[u, u′, u″, u‴]` at every particle by eq 40.
fn derivatives_at_particles(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<[Vec<f64>; 4], EstimatorError> {
    Ok([
        to_particles(layout, &d.value)?,
        to_particles(layout, &d.first)?,
        to_particles(layout, &d.second)?,
        to_particles(layout, &d.third)?,
    ])
}

fn taylor_error(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
    kind: WeightKind,
) -> Result<Vec<f64>, EstimatorError> {
    let [u0, u1, u2, u3] = derivatives_at_particles(layout, d)?;
    // Exact values of the moments N_0, N_1 for a consistent map.
    let (n0_exact, n1_exact) = match kind {
        WeightKind::S => (1.0, 0.0),
        WeightKind::D => (0.0, 1.0),
    };
    Ok((0..layout.n_particles())
        .map(|p| {
            let mut n = [0.0_f64; 4];
            for (i, s, dw) in layout.weights.row(p) {
                let w = match kind {
                    WeightKind::S => s,
                    WeightKind::D => dw,
                };
                if w == 0.0 {
                    continue;
                }
                let r = -layout.dx_from_node(i, p); // X_i − x_p
                n[0] += w;
                n[1] += w * r;
                n[2] += w * r * r;
                n[3] += w * r * r * r;
            }
            -((n[0] - n0_exact) * u0[p]
                + (n[1] - n1_exact) * u1[p]
                + n[2] * u2[p] / 2.0
                + n[3] * u3[p] / 6.0)
        })
        .collect())
}

/// Eq 37: estimated error `u(x_p) − Σ_i S_ip u_i` of the eq 21 interpolation, per particle,
/// from nodal derivatives `d` of the field (interpolated to particles by eq 40).
pub fn interpolation_error(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    taylor_error(layout, d, WeightKind::S)
}

/// Eq 41 (cubic coefficient 1/6, see module docs): estimated error
/// `∂u/∂x(x_p) − Σ_i D_ip u_i` of the eq 24 gradient, per particle, from nodal derivatives
/// `d` of the field (interpolated to particles by eq 40).
pub fn gradient_error(
    layout: &Layout<'_>,
    d: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    taylor_error(layout, d, WeightKind::D)
}

/// The nodal derivative `g_i = −(1/V_i) Σ_p D_ip V_p v_p` (eq 18's operator applied to a
/// particle field) and the second derivative at particles `s_p = Σ_i D_ip g_i` (eq 24
/// applied to `g`): the two maps of Table 1's case 5. `g` is 0 at inactive nodes.
pub fn second_derivative(layout: &Layout<'_>, v: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let g = layout.derivative_to_nodes(v);
    let mut s = vec![0.0; layout.n_particles()];
    layout.weights.gather(WeightKind::D, &g, &mut s);
    (g, s)
}

/// Estimated error `∂²v/∂x²(x_p) − s_p` of [`second_derivative`] (case 5), per particle:
/// eq 41 applied to the field `∂v/∂x` with its nodal derivatives `dv_dx` (orders 0–3 of
/// `∂v/∂x`), plus `Σ_i D_ip Eg_i` with `Eg_i` the eq 33-type error of the first map
/// ([`divergence_error`]) from the nodal derivatives `v` of the velocity.
pub fn second_derivative_error(
    layout: &Layout<'_>,
    v: &NodalDerivatives,
    dv_dx: &NodalDerivatives,
) -> Result<Vec<f64>, EstimatorError> {
    let mut e = gradient_error(layout, dv_dx)?;
    let eg = divergence_error(layout, v)?;
    let mut carried = vec![0.0; layout.n_particles()];
    layout.weights.gather(WeightKind::D, &eg, &mut carried);
    for (e, c) in e.iter_mut().zip(&carried) {
        *e += c;
    }
    Ok(e)
}
