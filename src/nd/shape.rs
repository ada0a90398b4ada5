//! Per-axis weight functions of the d-dimensional solver and their tensor products.
//!
//! Each axis uses a 1D function of the particle position relative to the grid origin:
//!
//! * [`ShapeNd::Gimp`]: uGIMP, the particle's domain of fixed length `l_a` on axis `a`,
//!   centred on `x_p` and never updated — the weights of the 1D [`crate::Shape::Gimp`],
//!   evaluated in closed form (`GimpAxis`; equal to round-off) (3 nodes per axis);
//! * [`ShapeNd::Linear`]: the hat `N(r) = max(0, 1 − |r|/h)` with the 1D one-sided
//!   derivative at a node (2 nodes per axis);
//! * [`ShapeNd::BSpline2`]: the quadratic B-spline `N(r) = ¾ − r²` (`|r| < ½`),
//!   `½(3/2 − |r|)²` (`½ ≤ |r| < 3/2`), 0 otherwise, `r` in cells (3 nodes per axis;
//!   periodic axes only, since near a wall it needs the boundary-modified splines that
//!   this solver does not implement).
//!
//! The d-dimensional weight is the product `S_ip = Π_a s_a` and its gradient
//! `∂_a S_ip = s'_a Π_{b≠a} s_b`.

use crate::shape::Shape;
use serde::{Deserialize, Serialize};

/// Which particle–node weights the d-dimensional solver uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeNd {
    /// uGIMP per axis with fixed particle domain lengths.
    Gimp,
    /// Linear hats.
    Linear,
    /// Quadratic B-splines (periodic axes only).
    #[serde(rename = "bspline2")]
    BSpline2,
}

/// The 1D weights of one particle on one axis: first lattice node and up to three weights
/// and derivatives (units 1/length).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisStencil {
    /// Lattice index of the first node.
    pub first: i64,
    /// Weights of nodes `first, first + 1, first + 2`.
    pub s: [f64; 3],
    /// Derivatives of the weights with respect to the particle position.
    pub d: [f64; 3],
}

impl ShapeNd {
    /// Nodes per axis in a particle's stencil: 3 (GIMP, B-spline) or 2 (linear).
    pub fn nodes_per_axis(self) -> usize {
        match self {
            ShapeNd::Linear => 2,
            ShapeNd::Gimp | ShapeNd::BSpline2 => 3,
        }
    }

    /// Entries per particle in `D` dimensions, `nodes_per_axis^D`.
    pub fn width(self, d: usize) -> usize {
        self.nodes_per_axis().pow(d as u32)
    }

    /// The 1D weights on an axis of spacing `h` of a particle at `x` (relative to the
    /// grid origin) with GIMP domain length `l` (ignored by the other shapes).
    #[inline(always)]
    pub fn axis(self, x: f64, l: f64, h: f64) -> AxisStencil {
        match self {
            ShapeNd::Gimp => GimpAxis::stencil(x, l, h),
            ShapeNd::Linear => LinearAxis::stencil(x, l, h),
            ShapeNd::BSpline2 => BSplineAxis::stencil(x, l, h),
        }
    }
}

/// One shape's 1D weights as a type, so that a pass over many particles can be compiled
/// for one shape ([`ShapeNd::axis`] chooses among them per call).
pub(crate) trait AxisShape {
    /// Nodes per axis ([`ShapeNd::nodes_per_axis`]).
    const NODES: usize;
    /// [`ShapeNd::axis`] of this shape.
    #[inline(always)]
    fn stencil(x: f64, l: f64, h: f64) -> AxisStencil {
        Self::stencil_inv(x, l, h, 1.0 / l, 1.0 / h)
    }
    /// [`Self::stencil`] with the reciprocals `inv_l = 1/l` and `inv_h = 1/h` given, so
    /// that a pass forms them once per particle (`1/l`, used by its gather and its
    /// scatter) or once per grid (`1/h`) rather than per stencil: the same quotients, so
    /// the same weights bit for bit.
    fn stencil_inv(x: f64, l: f64, h: f64, inv_l: f64, inv_h: f64) -> AxisStencil;
}

/// uGIMP ([`ShapeNd::Gimp`]).
pub(crate) struct GimpAxis;
/// Linear hats ([`ShapeNd::Linear`]).
pub(crate) struct LinearAxis;
/// Quadratic B-splines ([`ShapeNd::BSpline2`]).
pub(crate) struct BSplineAxis;

/// uGIMP in closed form. With the domain `[a, b] = [x − l/2, x + l/2]` in cell units
/// relative to its first node, `ξ_a = a/h − ⌊a/h⌋ ∈ [0, 1)` and `ξ_b = ξ_a + l/h < 2`
/// (as `l ≤ h`), the antiderivative differences of [`crate::Shape::Gimp`]
/// (`S_k = (Φ(ξ_b − k) − Φ(ξ_a − k))·h/l`, `D_k = (N(ξ_b − k) − N(ξ_a − k))/l`) are, with
/// `t = min(ξ_b, 1)` and `u = max(ξ_b − 1, 0)`,
///
/// ```text
/// S_0 = ½((1 − ξ_a)² − (1 − t)²)·h/l,   S_2 = ½u²·h/l,   S_1 = 1 − S_0 − S_2,
/// D_0 = (ξ_a − t)/l,                   D_2 = u/l,       D_1 = −(D_0 + D_2)
/// ```
///
/// (the domain inside one cell: `u = 0`; across a node: `t = 1`). The same weights as the
/// 1D function's to round-off, without its twelve clamped evaluations; the weights sum
/// to one and the derivatives to zero by construction.
impl AxisShape for GimpAxis {
    const NODES: usize = 3;
    #[inline(always)]
    fn stencil_inv(x: f64, l: f64, h: f64, inv_l: f64, inv_h: f64) -> AxisStencil {
        let h_over_l = h * inv_l;
        let qa = (x - 0.5 * l) * inv_h;
        let (first, first_index) = crate::shape::floor_index(qa);
        let xa = qa - first;
        let xb = xa + l * inv_h;
        let t = xb.min(1.0);
        let u = (xb - 1.0).max(0.0);
        let s0 = 0.5 * ((1.0 - xa) * (1.0 - xa) - (1.0 - t) * (1.0 - t)) * h_over_l;
        let s2 = 0.5 * u * u * h_over_l;
        let d0 = (xa - t) * inv_l;
        let d2 = u * inv_l;
        AxisStencil {
            first: first_index,
            s: [s0, 1.0 - s0 - s2, s2],
            d: [d0, -(d0 + d2), d2],
        }
    }
}

impl AxisShape for LinearAxis {
    const NODES: usize = 2;
    #[inline(always)]
    fn stencil_inv(x: f64, l: f64, h: f64, _: f64, _: f64) -> AxisStencil {
        let st = Shape::Linear.stencil(x, l, h);
        AxisStencil {
            first: st.first,
            s: st.s,
            d: st.d,
        }
    }
}

impl AxisShape for BSplineAxis {
    const NODES: usize = 3;
    #[inline(always)]
    fn stencil_inv(x: f64, _: f64, _: f64, _: f64, inv_h: f64) -> AxisStencil {
        let q = x * inv_h;
        let (base, first) = crate::shape::floor_index(q - 0.5);
        let f = q - base; // in [0.5, 1.5)
        AxisStencil {
            first,
            s: [
                0.5 * (1.5 - f) * (1.5 - f),
                0.75 - (f - 1.0) * (f - 1.0),
                0.5 * (f - 0.5) * (f - 0.5),
            ],
            d: [
                -(1.5 - f) * inv_h,
                -2.0 * (f - 1.0) * inv_h,
                (f - 0.5) * inv_h,
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form uGIMP weights equal the 1D antiderivative form to round-off, over
    /// positions across several cells and domains from a tenth of a cell to a whole one,
    /// with the same first node.
    #[test]
    fn closed_form_gimp_is_the_1d_gimp_to_round_off() {
        let h = 0.37;
        let mut checked = 0;
        for i in 0..4000 {
            let x = -0.9 + i as f64 * 0.001_234_567;
            for l in [0.1 * h, 0.25 * h, 0.5 * h, 0.999 * h, h] {
                let ours = GimpAxis::stencil(x, l, h);
                let one_d = Shape::Gimp.stencil(x, l, h);
                assert_eq!(ours.first, one_d.first, "x {x} l {l}");
                // Both forms difference numbers of the size of the position in cells and
                // divide by l/h: their round-off grows with both.
                let tol = 4.0 * f64::EPSILON * (2.0 + x.abs() / h) * (h / l);
                for k in 0..3 {
                    assert!((ours.s[k] - one_d.s[k]).abs() <= tol, "S x {x} l {l} k {k}");
                    assert!(
                        (ours.d[k] - one_d.d[k]).abs() * l <= tol,
                        "D x {x} l {l} k {k}"
                    );
                }
                let sum: f64 = ours.s.iter().sum();
                assert!(
                    (sum - 1.0).abs() <= 4.0 * f64::EPSILON,
                    "x {x} l {l}: Σ S = {sum}"
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 20_000);
    }
}
