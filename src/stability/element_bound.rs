//! The 1D element bound `B = max_p (E_t,p V_p/m_p) Σ_i D_ip²/S_ip ≥ λmax(C)` of a state
//! (the element eigenvalue inequality with particles as elements; its derivation and the
//! one-division form are in the 1D reference solver's `testbench/mpm/element_bound.rs`,
//! which takes the same value in its pass, bit for bit).
//!
//! The certified tracker serving on the bound ([`super::CertifiedConfig::on_bound`]) reads
//! it from the stepper's summary ([`crate::PassSummary::element_bound`]); for a view without
//! one (a stepper that does not take it, or the first state of a run restored from a
//! checkpoint) it takes it here from the view's own weights, in a pass over the particles,
//! when they are GIMP weights the library computes (deferred weights of
//! [`crate::Shape::Gimp`]).

use crate::shape::MAX_NODES;
use crate::stepper::View;

/// `Σ_k d_k²/s_k` of one three-node stencil as `(numerator, denominator)`:
///
/// ```text
/// Σ_k d_k²/s_k = (d₀² s₁ s₂ + d₁² s₀ s₂ + d₂² s₀ s₁) / (s₀ s₁ s₂),   s_k → 1 where d_k = 0
/// ```
///
/// (a node the particle's gradient does not reach contributes nothing, whatever its
/// weight); the numerator is 1 when it vanishes while some `d_k ≠ 0` (two weightless nodes
/// with gradients), so that the ratio is `+∞` and never `0/0`.
#[inline(always)]
pub(crate) fn stencil_ratio(s: [f64; MAX_NODES], d: [f64; MAX_NODES]) -> (f64, f64) {
    let s0 = if d[0] == 0.0 { 1.0 } else { s[0] };
    let s1 = if d[1] == 0.0 { 1.0 } else { s[1] };
    let s2 = if d[2] == 0.0 { 1.0 } else { s[2] };
    let num = d[0] * d[0] * (s1 * s2) + d[1] * d[1] * (s0 * s2) + d[2] * d[2] * (s0 * s1);
    let num = if num == 0.0 && d.iter().any(|&g| g != 0.0) {
        1.0
    } else {
        num
    };
    (num, s0 * s1 * s2)
}

/// `B_p = (E_t F V⁰ · num) / (m · den)` of one particle, in the order both passes use.
#[inline(always)]
pub(crate) fn particle_bound(
    tangent: f64,
    f: f64,
    volume0: f64,
    mass: f64,
    (num, den): (f64, f64),
) -> f64 {
    (tangent * f * volume0 * num) / (mass * den)
}

/// `B` of a view from its own weights, when the library computes them as GIMP weights
/// (`None` otherwise: linear hats have an infinite or wildly varying bound wherever a
/// particle nears a node, and weights handed over ready have no known shape).
pub(crate) fn of_view(view: &View<'_>) -> Option<f64> {
    if view.weights.shape() != Some(crate::shape::Shape::Gimp) {
        return None;
    }
    let weights = view.weights.get();
    if weights.width() != MAX_NODES {
        return None;
    }
    let n = view.n_particles();
    let mut bound = 0.0_f64;
    for p in 0..n {
        let (s, d) = (weights.s_of(p), weights.d_of(p));
        let ratio = stencil_ratio([s[0], s[1], s[2]], [d[0], d[1], d[2]]);
        let b = particle_bound(
            view.tangent_modulus[p],
            view.f[p],
            view.volume0[p],
            view.mass[p],
            ratio,
        );
        bound = if b > bound { b } else { bound };
    }
    Some(bound)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ratio_is_the_sum_of_squared_gradients_over_weights() {
        let (s, d) = ([0.2, 0.5, 0.3], [-1.5, 0.25, 1.25]);
        let (num, den) = stencil_ratio(s, d);
        let direct: f64 = (0..3).map(|k| d[k] * d[k] / s[k]).sum();
        assert!((num / den - direct).abs() <= 1e-14 * direct);
    }

    #[test]
    fn a_node_without_gradient_adds_nothing_and_one_without_weight_is_infinite() {
        let (num, den) = stencil_ratio([0.0, 0.6, 0.4], [0.0, -2.0, 2.0]);
        assert!((num / den - (4.0 / 0.6 + 4.0 / 0.4)).abs() < 1e-12);
        let (num, den) = stencil_ratio([0.0, 1.0, 0.0], [-1.0, 0.0, 1.0]);
        let bound = num / den;
        assert!(bound.is_infinite() && bound > 0.0, "{bound}");
    }
}
