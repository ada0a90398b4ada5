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
//! Per particle this is one division, by the library's formula
//! (`crate::stability::element_bound`, which takes the same value from a view's weights,
//! bit for bit). A node with `S_ip = 0` and `D_ip ≠ 0` — linear hats with a particle on a node —
//! makes the bound `+∞`, as it is: `M_p` is singular there. The reference solver takes it for
//! GIMP only (`step.rs`), whose `D_ip` vanishes with `S_ip` at the edge of the support.
//!
//! Particle `i` of a block goes to lane `i mod 4` (maxima by compare-and-select: any order
//! gives the same value; a NaN bound is skipped, and the trial's own finiteness check
//! fails such a state).

use super::summary_lanes::greater;
use crate::shape::MAX_NODES;
use crate::stability::element_bound::{self, stencil_ratio};

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
            *out = block_bound(b, c + l);
        }
        for l in 0..4 {
            lanes[l] = greater(chunk[l], lanes[l]);
        }
    }
    for i in full..n {
        lanes[i % 4] = greater(block_bound(b, i), lanes[i % 4]);
    }
}

/// `B_p` of particle `i` of the block.
#[inline(always)]
fn block_bound(b: &BoundInputs<'_>, i: usize) -> f64 {
    let s = [b.s[0][i], b.s[1][i], b.s[2][i]];
    let d = [b.d[0][i], b.d[1][i], b.d[2][i]];
    element_bound::particle_bound(
        b.tangent[i],
        b.f[i],
        b.volume0[i],
        b.mass[i],
        stencil_ratio(s, d),
    )
}

#[cfg(test)]
mod tests {
    use crate::scenario::Scenario;
    use crate::stability::element_bound::of_view;
    use crate::Stepper;

    /// The bound the pass takes is the library's from the view's weights, bit for bit
    /// (what lets a restored run, whose first state has no summary, continue as before).
    #[test]
    fn the_pass_takes_the_librarys_bound_bit_for_bit() {
        for text in [
            r#"{"cells": 301, "particles": {"per_cell": 2}}"#,
            r#"{"cells": 37, "boundary": "fixed", "material": "neo_hookean",
                "initial": {"standing_wave": {"amplitude": 0.05, "mode": 0.5}}}"#,
            r#"{"cells": 4, "particles": {"positions": [0.01, 0.2, 0.33, 0.5, 0.61, 0.9, 0.99]}}"#,
        ] {
            let scenario = Scenario::from_json(text).unwrap();
            let mut s = scenario.build().unwrap();
            assert!(s.provide_summary(true) && s.provide_element_bound(true));
            let dt = 0.3 * s.grid().h / scenario.wave_speed();
            for _ in 0..12 {
                s.try_step(dt).unwrap();
                s.accept().unwrap();
                let view = s.view();
                let taken = view.summary.and_then(|p| p.element_bound).unwrap();
                let library = of_view(&view).unwrap();
                assert!(taken > 0.0 && taken.is_finite(), "{text}: {taken}");
                assert_eq!(taken.to_bits(), library.to_bits(), "{text}");
            }
        }
    }
}
