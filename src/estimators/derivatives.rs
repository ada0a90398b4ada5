//! Nodal derivatives by finite differences (eqs 42, 43), with one-sided stencils at walls.
//!
//! On the uniform grid `X_i = a + i h`, from nodal values `u_i`:
//!
//! ```text
//! ∂u/∂x   (X_i) ≈ (u_{i+1} − u_{i−1}) / (2h)
//! ∂²u/∂x² (X_i) ≈ (u_{i+1} − 2u_i + u_{i−1}) / h²                              (eq 42)
//! ∂³u/∂x³ (X_i) ≈ (u_{i+2} − 2u_{i+1} + 2u_{i−1} − u_{i−2}) / (2h³)            (eq 43, corrected)
//! ∂⁴u/∂x⁴ (X_i) ≈ (u_{i+2} − 4u_{i+1} + 6u_i − 4u_{i−1} + u_{i−2}) / h⁴
//! ```
//!
//! all second-order accurate. (The fourth derivative is needed by case 5 of Table 1, whose
//! field is itself a derivative.) **Eq 43 as printed**, `(σ_{i+2} − 2σ_{i+1} + 2σ_{i−1} + σ_{i−2})/h³`,
//! is not a difference operator: its weights sum to 2, so it does not annihilate constants
//! and grows like `2σ/h³`. The formula above is the standard central third difference.
//!
//! **Walls** ("appropriate modifications at the boundaries", Section 4.3): where the
//! central stencil would leave the run of usable nodes, the derivative of order `m` uses the
//! `m + 2` consecutive usable nodes nearest to `X_i`, with weights from Fornberg's algorithm
//! — one-sided formulas of the same (second) order, e.g. `(2u_0 − 5u_1 + 4u_2 − u_3)/h²` for
//! eq 42 at a wall. Nodes outside the usable run (a fixed grid's constrained ends and ghosts,
//! when the caller excludes them) get values and derivatives extrapolated the same way, so
//! that eq 40 can interpolate them to particles near a wall.
//!
//! Periodic grids (eq 5) wrap the central stencils and need at least 5 cells.

use super::EstimatorError;
use crate::grid::{Boundary, Grid};

/// A nodal field and its first four derivatives at every stored node.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodalDerivatives {
    /// The value `u_i` (extrapolated at nodes outside the usable run).
    pub value: Vec<f64>,
    /// `∂u/∂x (X_i)`.
    pub first: Vec<f64>,
    /// `∂²u/∂x² (X_i)` (eq 42).
    pub second: Vec<f64>,
    /// `∂³u/∂x³ (X_i)` (eq 43, corrected).
    pub third: Vec<f64>,
    /// `∂⁴u/∂x⁴ (X_i)`.
    pub fourth: Vec<f64>,
}

impl NodalDerivatives {
    /// Zeroes for `n` nodes.
    pub fn zeros(n: usize) -> Self {
        Self {
            value: vec![0.0; n],
            first: vec![0.0; n],
            second: vec![0.0; n],
            third: vec![0.0; n],
            fourth: vec![0.0; n],
        }
    }

    /// The derivatives of `∂u/∂x` (orders 0–3 of it; its fourth derivative is unknown and set
    /// to 0): what eq 41 needs when the mapped field is itself a derivative (case 5).
    pub fn shifted(&self) -> Self {
        Self {
            value: self.first.clone(),
            first: self.second.clone(),
            second: self.third.clone(),
            third: self.fourth.clone(),
            fourth: vec![0.0; self.fourth.len()],
        }
    }

    /// Derivative of order `k` (0 ≤ k ≤ 4) at every node; `None` for `k > 4`.
    pub fn order(&self, k: usize) -> Option<&[f64]> {
        match k {
            0 => Some(&self.value),
            1 => Some(&self.first),
            2 => Some(&self.second),
            3 => Some(&self.third),
            4 => Some(&self.fourth),
            _ => None,
        }
    }
}

/// Weights of the finite-difference approximation of the derivatives of orders `0..=m` at
/// `z` from values at the points `xs` (Fornberg 1988): `out[k][j]` multiplies `u(xs[j])`.
pub fn fornberg_weights(z: f64, xs: &[f64], m: usize) -> Vec<Vec<f64>> {
    let n = xs.len();
    let mut c = vec![vec![0.0; n]; m + 1];
    if n == 0 {
        return c;
    }
    let mut c1 = 1.0;
    let mut c4 = xs[0] - z;
    c[0][0] = 1.0;
    for i in 1..n {
        let mn = i.min(m);
        let mut c2 = 1.0;
        let c5 = c4;
        c4 = xs[i] - z;
        for j in 0..i {
            let c3 = xs[i] - xs[j];
            c2 *= c3;
            if j == i - 1 {
                for k in (1..=mn).rev() {
                    c[k][i] = c1 * (k as f64 * c[k - 1][i - 1] - c5 * c[k][i - 1]) / c2;
                }
                c[0][i] = -c1 * c5 * c[0][i - 1] / c2;
            }
            for k in (1..=mn).rev() {
                c[k][j] = (c4 * c[k][j] - k as f64 * c[k - 1][j]) / c3;
            }
            c[0][j] *= c4 / c3;
        }
        c1 = c2;
    }
    c
}

/// Central stencil half-width for derivative order `m` (1, 2: ±1; 3, 4: ±2; 0: the point).
fn central_half_width(m: usize) -> i64 {
    match m {
        0 => 0,
        1 | 2 => 1,
        _ => 2,
    }
}

/// The first four derivatives of the nodal field `values` at every stored node of `grid`,
/// by eqs 42/43 (see the module docs). `usable[i]` says which nodal values may enter a
/// stencil; on a fixed grid they must form one contiguous run of at least 6 nodes, on a
/// periodic grid every node must be usable and there must be at least 5.
pub fn nodal_derivatives(
    grid: &Grid,
    values: &[f64],
    usable: &[bool],
) -> Result<NodalDerivatives, EstimatorError> {
    let nn = grid.n_nodes();
    check_inputs(nn, values, usable)?;
    let h = grid.h;
    match grid.boundary {
        Boundary::Periodic => periodic_derivatives(values, usable, h),
        Boundary::Fixed => fixed_derivatives(values, usable, h),
    }
}

/// Checks that `values` and `usable` have one entry per node and usable values are finite.
fn check_inputs(nn: usize, values: &[f64], usable: &[bool]) -> Result<(), EstimatorError> {
    for (field, len) in [("values", values.len()), ("usable", usable.len())] {
        if len != nn {
            return Err(EstimatorError::Length {
                field,
                len,
                expected: nn,
            });
        }
    }
    for (index, &value) in values.iter().enumerate() {
        if usable[index] && !value.is_finite() {
            return Err(EstimatorError::InvalidValue {
                field: "values",
                index,
                value,
            });
        }
    }
    Ok(())
}

/// Derivatives on a periodic grid by the wrapped central stencils (every node usable, ≥ 5).
fn periodic_derivatives(
    values: &[f64],
    usable: &[bool],
    h: f64,
) -> Result<NodalDerivatives, EstimatorError> {
    let nn = values.len();
    let mut out = NodalDerivatives::zeros(nn);
    if let Some(node) = usable.iter().position(|&u| !u) {
        return Err(EstimatorError::Gap { node });
    }
    if nn < 5 {
        return Err(EstimatorError::TooFewNodes {
            usable: nn,
            needed: 5,
        });
    }
    let u = |j: i64| values[j.rem_euclid(nn as i64) as usize];
    for i in 0..nn {
        let k = i as i64;
        out.value[i] = u(k);
        out.first[i] = (u(k + 1) - u(k - 1)) / (2.0 * h);
        out.second[i] = (u(k + 1) - 2.0 * u(k) + u(k - 1)) / (h * h);
        out.third[i] = (u(k + 2) - 2.0 * u(k + 1) + 2.0 * u(k - 1) - u(k - 2)) / (2.0 * h * h * h);
        out.fourth[i] =
            (u(k + 2) - 4.0 * u(k + 1) + 6.0 * u(k) - 4.0 * u(k - 1) + u(k - 2)) / (h * h * h * h);
    }
    Ok(out)
}

/// Derivatives on a fixed grid: central stencils inside the usable run, one-sided near its ends.
fn fixed_derivatives(
    values: &[f64],
    usable: &[bool],
    h: f64,
) -> Result<NodalDerivatives, EstimatorError> {
    let nn = values.len();
    let mut out = NodalDerivatives::zeros(nn);
    let (lo, hi) = usable_run(usable)?;
    let (lo, hi) = (lo as i64, hi as i64);
    for i in 0..nn {
        let k = i as i64;
        for m in 0..=4usize {
            let d = fixed_stencil_derivative(values, k, m, lo, hi, h);
            match m {
                0 => out.value[i] = d,
                1 => out.first[i] = d,
                2 => out.second[i] = d,
                3 => out.third[i] = d,
                _ => out.fourth[i] = d,
            }
        }
    }
    Ok(out)
}

/// The first and last usable node, checking they bound one gap-free run of at least 6.
fn usable_run(usable: &[bool]) -> Result<(usize, usize), EstimatorError> {
    let lo = usable
        .iter()
        .position(|&u| u)
        .ok_or(EstimatorError::TooFewNodes {
            usable: 0,
            needed: 6,
        })?;
    let hi = usable.iter().rposition(|&u| u).unwrap_or(lo);
    if let Some(gap) = (lo..=hi).find(|&i| !usable[i]) {
        return Err(EstimatorError::Gap { node: gap });
    }
    if hi + 1 - lo < 6 {
        return Err(EstimatorError::TooFewNodes {
            usable: hi + 1 - lo,
            needed: 6,
        });
    }
    Ok((lo, hi))
}

/// Derivative of order `m` at node `k` from the usable run `lo..=hi` (central or one-sided).
fn fixed_stencil_derivative(values: &[f64], k: i64, m: usize, lo: i64, hi: i64, h: f64) -> f64 {
    let hw = central_half_width(m);
    let (start, len) = if k - hw >= lo && k + hw <= hi {
        (k - hw, 2 * hw + 1)
    } else {
        // One-sided: m + 2 points (4 for the extrapolated value), the run
        // nearest to node k.
        let len = if m == 0 { 4 } else { m as i64 + 2 };
        ((k - len / 2).clamp(lo, hi - len + 1), len)
    };
    let xs: Vec<f64> = (start..start + len).map(|j| (j - k) as f64).collect();
    let w = fornberg_weights(0.0, &xs, m);
    (start..start + len)
        .zip(&w[m])
        .map(|(j, c)| c * values[j as usize])
        .sum::<f64>()
        / h.powi(m as i32)
}
