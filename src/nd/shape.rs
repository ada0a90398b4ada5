//! Per-axis weight functions of the d-dimensional solver and their tensor products.
//!
//! Each axis uses a 1D function of the particle position relative to the grid origin:
//!
//! * [`ShapeNd::Gimp`]: uGIMP, the particle's domain of fixed length `l_a` on axis `a`,
//!   centred on `x_p` and never updated — exactly the 1D [`crate::Shape::Gimp`]
//!   (3 nodes per axis);
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
    fn stencil(x: f64, l: f64, h: f64) -> AxisStencil;
}

/// uGIMP ([`ShapeNd::Gimp`]).
pub(crate) struct GimpAxis;
/// Linear hats ([`ShapeNd::Linear`]).
pub(crate) struct LinearAxis;
/// Quadratic B-splines ([`ShapeNd::BSpline2`]).
pub(crate) struct BSplineAxis;

impl AxisShape for GimpAxis {
    const NODES: usize = 3;
    #[inline(always)]
    fn stencil(x: f64, l: f64, h: f64) -> AxisStencil {
        let st = Shape::Gimp.stencil(x, l, h);
        AxisStencil {
            first: st.first,
            s: st.s,
            d: st.d,
        }
    }
}

impl AxisShape for LinearAxis {
    const NODES: usize = 2;
    #[inline(always)]
    fn stencil(x: f64, l: f64, h: f64) -> AxisStencil {
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
    fn stencil(x: f64, _: f64, h: f64) -> AxisStencil {
        let inv_h = 1.0 / h;
        let q = x * inv_h;
        let base = crate::shape::floor(q - 0.5);
        let f = q - base; // in [0.5, 1.5)
        AxisStencil {
            first: base as i64,
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
