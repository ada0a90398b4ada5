//! The element bound of the 1D reference step, taken in its particle pass
//! ([`crate::PassSummary::element_bound`]).
//!
//! With particles as elements, the element eigenvalue inequality bounds the eq 56 operator
//! (`K_N = Σ_p k_p d_p d_pᵀ`, `k_p = E_t,p F_p V⁰_p`, lumped masses `m_i = Σ_p m_p S_ip`):
//!
//! ```text
//! λmax(M⁻¹ K_N) ≤ max_p λmax(M_p⁻¹ K_p) = max_p (k_p/m_p) Σ_i D_ip²/S_ip,   M_p = diag(m_p S_ip)
//! ```
//!
//! (`K_p = k_p d_p d_pᵀ` has rank one, so its generalised eigenvalue is `d_pᵀ M_p⁻¹ d_p`).
//! Per particle this is one division: over its three stencil nodes,
//!
//! ```text
//! Σ_k d_k²/s_k = (d₀² s₁ s₂ + d₁² s₀ s₂ + d₂² s₀ s₁) / (s₀ s₁ s₂),   s_k → 1 where d_k = 0
//! ```
//!
//! (a node the particle's gradient does not reach contributes nothing, whatever its
//! weight; the numerator is set to 1 when it vanishes while some `d_k ≠ 0`, which happens
//! only when two weightless nodes have gradients). A node with `S_ip = 0` and `D_ip ≠ 0` — linear hats with a particle on a node —
//! makes the bound `+∞`, as it is: `M_p` is singular there. The reference solver takes it for
//! GIMP only (`step.rs`), whose `D_ip` vanishes with `S_ip` at the edge of the support.
//!
//! Particle `i` of a block goes to lane `i mod 4` (maxima by compare-and-select: any order
//! gives the same value; a NaN bound is skipped, and the trial's own finiteness check
//! fails such a state).

use super::summary_lanes::greater;
use crate::shape::MAX_NODES;

/// One block's particles: their stencils at the new positions (structure of arrays) and the
/// fields of `k_p/m_p`.
pub(super) struct BoundInputs<'a> {
    pub s: &'a [[f64; super::particle_pass::BLOCK]; MAX_NODES],
    pub d: &'a [[f64; super::particle_pass::BLOCK]; MAX_NODES],
    pub tangent: &'a [f64],
    pub f: &'a [f64],
    pub volume0: &'a [f64],
    pub mass: &'a [f64],
}

/// `Σ_k d_k²/s_k` of one stencil as `(numerator, denominator)` (module docs).
#[inline(always)]
fn stencil_ratio(s: [f64; MAX_NODES], d: [f64; MAX_NODES]) -> (f64, f64) {
    let s0 = if d[0] == 0.0 { 1.0 } else { s[0] };
    let s1 = if d[1] == 0.0 { 1.0 } else { s[1] };
    let s2 = if d[2] == 0.0 { 1.0 } else { s[2] };
    let num = d[0] * d[0] * (s1 * s2) + d[1] * d[1] * (s0 * s2) + d[2] * d[2] * (s0 * s1);
    // Two weightless nodes with gradients make both products vanish: `1/0`, not `0/0`.
    let num = if num == 0.0 && d.iter().any(|&g| g != 0.0) {
        1.0
    } else {
        num
    };
    (num, s0 * s1 * s2)
}

/// Adds the block's `B_p` to the lane maxima `lanes`, in chunks of four written out so
/// that the divisions run as one vector division (a loop indexing `lanes[i % 4]` compiles
/// to a scalar division per particle).
#[inline(always)]
pub(super) fn add_block(b: &BoundInputs<'_>, lanes: &mut [f64; 4]) {
    let n = b
        .tangent
        .len()
        .min(b.f.len())
        .min(b.volume0.len())
        .min(b.mass.len());
    let full = n - n % 4;
    for c in (0..full).step_by(4) {
        let mut chunk = [0.0; 4];
        for (l, out) in chunk.iter_mut().enumerate() {
            *out = particle_bound(b, c + l);
        }
        for l in 0..4 {
            lanes[l] = greater(chunk[l], lanes[l]);
        }
    }
    for i in full..n {
        lanes[i % 4] = greater(particle_bound(b, i), lanes[i % 4]);
    }
}

/// `B_p` of particle `i` of the block.
#[inline(always)]
fn particle_bound(b: &BoundInputs<'_>, i: usize) -> f64 {
    let s = [b.s[0][i], b.s[1][i], b.s[2][i]];
    let d = [b.d[0][i], b.d[1][i], b.d[2][i]];
    let (num, den) = stencil_ratio(s, d);
    (b.tangent[i] * b.f[i] * b.volume0[i] * num) / (b.mass[i] * den)
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
