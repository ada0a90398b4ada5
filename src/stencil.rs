//! Branch-free particle stencils for the hot loop of the step.
//!
//! These evaluate the same weights as [`Shape::stencil`] — GIMP
//! `S_ip = (1/l_p) ∫ N_i χ_p dx`, `D_ip = (1/l_p) ∫ N_i′ χ_p dx`, and linear hats — in a
//! form without branches or calls, which made the solver step about 1.4× faster. With the
//! first node `j = ⌊a/h⌋` of the particle domain `[a, b] = [x_p − l_p/2, x_p + l_p/2]`, the
//! domain ends in cell units `α = a/h − j ∈ [0, 1)`, `β = α + λ < 2` (`λ = l_p/h ≤ 1`),
//! `β_c = min(β, 1)` and `β_e = max(β − 1, 0)`, the hat's antiderivative gives for nodes
//! `j, j+1, j+2`
//!
//! ```text
//! S = [ (1−α)² − (1−β_c)²,  β_c² − α² + 2β_e − β_e²,  β_e² ] / (2λ)
//! D = [ α − β_c,            β_c − β_e − α,             β_e  ] / l_p
//! ```
//!
//! They agree with [`Shape::stencil`] to round-off (a few ulps of `x/h`, relative to the
//! weights' scale; checked by the property test below), not bit for bit. The weights of a
//! [`crate::View`] ([`crate::Weights::compute_into`]) use these forms too, so that the
//! estimators and limits read exactly the `S`, `D` the step uses. (They used
//! [`Shape::stencil`] until the view's weights were measured at 1.2 times the cost of a
//! whole solver step at 10⁵ particles — its branches and calls; with these forms the view
//! costs a fraction of a step. The switch moved the estimates by round-off.)
//!
//! `⌊·⌋` comes in two builds with equal results on every position a step can accept
//! (`|x/h| < 2⁶³`): [`floor_fast`] for the x86-64 baseline (SSE2, no rounding
//! instruction) and `f64::floor` (one `roundsd`/`vroundpd`) for code compiled with
//! SSE4.1 or later, selected by the `ROUND` parameter. [`Parts`] keeps the first node as
//! a float so that the step's block loops, which evaluate many stencils at once,
//! vectorise.

use crate::shape::ParticleStencil;
#[cfg(feature = "reference")]
use crate::shape::Shape;

/// `⌊q⌋` by truncation and correction: one conversion instead of a call to `floor` (the
/// x86-64 baseline has no rounding instruction). Equal to `q.floor()` for `|q| < 2⁶³`;
/// NaN gives 0, as `q.floor() as i64` does.
#[inline(always)]
fn floor_fast(q: f64) -> f64 {
    let t = q as i64 as f64;
    if t > q {
        t - 1.0
    } else {
        t
    }
}

/// `⌊q⌋`: with `ROUND` (code compiled for SSE4.1 or later, where it is one `roundsd`)
/// `q.floor()`, else [`floor_fast`]. Both are equal for `|q| < 2⁶³`, which covers every
/// particle that a step can accept (larger or non-finite positions only occur in trials
/// that are refused, whose deposit is discarded).
#[inline(always)]
fn floor<const ROUND: bool>(q: f64) -> f64 {
    if ROUND {
        q.floor()
    } else {
        floor_fast(q)
    }
}

/// A stencil whose first node is still a float (`⌊·⌋`, integral): the form the vectorised
/// block loops of the step store, converting `first` to an integer only when indexing.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Parts {
    pub first: f64,
    pub s: [f64; 3],
    pub d: [f64; 3],
}

impl Parts {
    #[inline(always)]
    fn stencil(self) -> ParticleStencil {
        ParticleStencil {
            first: self.first as i64,
            s: self.s,
            d: self.d,
        }
    }
}

/// GIMP weights of a particle at `x` (relative to the grid origin) of width
/// `0 < width ≤ h`, with `inv_h = 1/h` (see the module docs).
#[inline(always)]
pub(crate) fn gimp_parts<const ROUND: bool>(x: f64, width: f64, inv_h: f64) -> Parts {
    let lam = width * inv_h;
    let q = (x - 0.5 * width) * inv_h;
    let first = floor::<ROUND>(q);
    let alpha = q - first;
    let beta = alpha + lam;
    let bc = beta.min(1.0);
    let be = (beta - 1.0).max(0.0);
    let inv_lam = 1.0 / lam;
    let inv_l = inv_lam * inv_h;
    let (ma, mb) = (1.0 - alpha, 1.0 - bc);
    Parts {
        first,
        s: [
            0.5 * (ma * ma - mb * mb) * inv_lam,
            (0.5 * (bc * bc - alpha * alpha) + be - 0.5 * be * be) * inv_lam,
            0.5 * be * be * inv_lam,
        ],
        d: [(alpha - bc) * inv_l, (bc - be - alpha) * inv_l, be * inv_l],
    }
}

/// Linear-hat weights of a particle at `x` (relative to the grid origin).
#[inline(always)]
pub(crate) fn linear_parts<const ROUND: bool>(x: f64, inv_h: f64) -> Parts {
    let q = x * inv_h;
    let first = floor::<ROUND>(q);
    let f = q - first;
    Parts {
        first,
        s: [1.0 - f, f, 0.0],
        d: [-inv_h, inv_h, 0.0],
    }
}

/// [`gimp_parts`] with an integer first node.
#[inline(always)]
pub(crate) fn gimp<const ROUND: bool>(x: f64, width: f64, inv_h: f64) -> ParticleStencil {
    gimp_parts::<ROUND>(x, width, inv_h).stencil()
}

/// [`linear_parts`] with an integer first node.
#[inline(always)]
pub(crate) fn linear<const ROUND: bool>(x: f64, inv_h: f64) -> ParticleStencil {
    linear_parts::<ROUND>(x, inv_h).stencil()
}

/// The stencil of `shape` through the fast forms.
#[inline(always)]
#[cfg(feature = "reference")]
pub(crate) fn of(shape: Shape, x: f64, width: f64, inv_h: f64) -> ParticleStencil {
    match shape {
        Shape::Gimp => gimp::<false>(x, width, inv_h),
        Shape::Linear => linear::<false>(x, inv_h),
    }
}

// Drives the reference solvers: tested with the `reference` feature.
#[cfg(all(test, feature = "reference"))]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Compares the fast stencil with `Shape::stencil` slot by slot. Both may choose a
    /// different first node only when `a/h` rounds across an integer; then the weight of the
    /// extra node is round-off and the stencils are compared node by node.
    fn agree(shape: Shape, x: f64, width: f64, h: f64) -> Result<(), TestCaseError> {
        let slow = shape.stencil(x, width, h);
        let fast = of(shape, x, width, 1.0 / h);
        let mut by_node = std::collections::BTreeMap::<i64, (f64, f64, f64, f64)>::new();
        for k in 0..3 {
            let e = by_node.entry(slow.first + k as i64).or_default();
            e.0 += slow.s[k];
            e.2 += slow.d[k];
            let e = by_node.entry(fast.first + k as i64).or_default();
            e.1 += fast.s[k];
            e.3 += fast.d[k];
        }
        // Both lose the low bits of x/h when forming the position inside the cell, so the
        // weights agree to a few ulps of |x|/h, scaled by 1/λ (S) and 1/l (D).
        let lam = width / h;
        let tol_s = 16.0 * f64::EPSILON * (x.abs() / h + 2.0) / lam;
        let tol_d = tol_s / h;
        for (node, (s0, s1, d0, d1)) in by_node {
            prop_assert!(
                (s0 - s1).abs() <= tol_s,
                "{shape:?} node {node}: S {s0} vs {s1}"
            );
            prop_assert!(
                (d0 - d1).abs() <= tol_d,
                "{shape:?} node {node}: D {d0} vs {d1}"
            );
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 2000, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E),
            failure_persistence: Some(Box::new(
                proptest::test_runner::FileFailurePersistence::Direct(
                    "proptest-regressions/mpm_stencil.txt",
                ),
            )),
            ..ProptestConfig::default()
        })]

        #[test]
        fn both_floors_agree(
            q in prop_oneof![-1e6f64..1e6, -4.0f64..4.0, (-1000i64..1000).prop_map(|k| k as f64)],
        ) {
            prop_assert_eq!(floor::<true>(q).to_bits(), floor::<false>(q).to_bits());
            prop_assert_eq!(
                gimp::<true>(q, 0.7, 1.3),
                gimp::<false>(q, 0.7, 1.3)
            );
        }

        #[test]
        fn fast_stencils_equal_shape_stencils(
            cell in -5i64..1000,
            frac in prop_oneof![4 => 0.0f64..1.0, 1 => Just(0.0), 1 => Just(0.5), 1 => 0.999_999f64..1.0],
            lam in prop_oneof![4 => 0.001f64..=1.0, 1 => Just(1.0), 1 => Just(0.5)],
            h in 1e-3f64..10.0,
        ) {
            let x = (cell as f64 + frac) * h;
            agree(Shape::Gimp, x, lam * h, h)?;
            agree(Shape::Linear, x, lam * h, h)?;
        }
    }
}
