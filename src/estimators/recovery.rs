//! Where the nodal derivatives of a *particle* field come from.
//!
//! The estimates of eqs 33 and 34 need `∂ᵏu/∂xᵏ(X_i)` of a field known only at particles.
//!
//! * [`Recovery::Mapped`] — the paper's way (Section 4.3): map the particle values to the
//!   nodes with eq 17 (`u_i = Σ_p S_ip m_p u_p / m_i`), then difference them with eqs 42/43
//!   ([`nodal_derivatives`]) over the active nodes
//!   that the grid does not constrain (values at walls are extrapolated).
//!   Exact enough on uniform layouts, where the eq 17 error is a smooth function of `X_i`
//!   and differencing it costs nothing in order. On non-uniform layouts the eq 17 error is
//!   `O(h)` and changes from node to node, and a `k`-th difference amplifies it by `h⁻ᵏ`:
//!   the third derivative becomes `O(h⁻²)` noise.
//! * [`Recovery::LeastSquares`] — fit a quartic `Σ_{k≤4} c_k ((x − X_i)/h)ᵏ` to the
//!   particle values within radius `r` of each node by weighted least squares (weight
//!   `(1 − (x̃/r)²)²`), `r = 3h` widened by `h/2` up to `8h` (one-sided fits at walls need
//!   the reach) until at least 7 particles have positive weight, and read `∂ᵏu/∂xᵏ(X_i) = k! c_k / hᵏ`. Samples are exact particle
//!   values, so the derivatives are accurate to `O(h^{5−k})` whatever the layout; near walls
//!   the fit is one-sided by construction. Our addition: the paper only tried uniform
//!   layouts.

use super::derivatives::{nodal_derivatives, NodalDerivatives};
use super::layout::Layout;
use super::EstimatorError;
use crate::grid::Boundary;
use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

/// How nodal derivatives of a particle field are obtained (see the module docs).
///
/// The default is [`Recovery::LeastSquares`]: it agrees with the paper's
/// [`Recovery::Mapped`] on uniform layouts and stays accurate once particles have moved.
/// Table 1 ([`super::table1`]) uses `Mapped` by default, to reproduce the paper.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Recovery {
    /// Eq 17 map to the nodes, then eqs 42/43 (the paper's choice).
    Mapped,
    /// Local weighted least-squares quartic fit of the particle values at each node.
    #[default]
    LeastSquares,
}

const DEGREE: usize = 4;
const NCOEF: usize = DEGREE + 1;
const MIN_POINTS: usize = NCOEF + 2;

impl Recovery {
    /// Nodal value and first four derivatives of the particle field `u` at every stored
    /// node. `Mapped` differences over the layout's active nodes (and extrapolates to the
    /// others); `LeastSquares` fits at every stored node.
    pub fn nodal_derivatives(
        self,
        layout: &Layout<'_>,
        u: &[f64],
    ) -> Result<NodalDerivatives, EstimatorError> {
        self.nodal_derivatives_pinned(layout, u, &[])
    }

    /// [`Recovery::nodal_derivatives`] with known nodal values (Dirichlet data, e.g. `v = 0`
    /// at a clamped wall): `pins` lists `(node, value)`. `Mapped` uses the pinned values in
    /// place of the eq 17 values and lets those nodes enter the difference stencils;
    /// `LeastSquares` adds each pin within reach of a fit as a sample at the node with
    /// 100 times the largest kernel weight (a near-exact constraint). Pinned nodes report
    /// their pinned value.
    pub fn nodal_derivatives_pinned(
        self,
        layout: &Layout<'_>,
        u: &[f64],
        pins: &[(usize, f64)],
    ) -> Result<NodalDerivatives, EstimatorError> {
        for &(node, value) in pins {
            if node >= layout.n_nodes() || !value.is_finite() {
                return Err(EstimatorError::InvalidValue {
                    field: "pins",
                    index: node,
                    value,
                });
            }
        }
        if u.len() != layout.n_particles() {
            return Err(EstimatorError::Length {
                field: "particle field",
                len: u.len(),
                expected: layout.n_particles(),
            });
        }
        if let Some((index, &value)) = u.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(EstimatorError::InvalidValue {
                field: "particle field",
                index,
                value,
            });
        }
        match self {
            Recovery::Mapped => {
                let mut nodal = layout.map_to_nodes(u);
                // Nodes the grid constrains (walls, ghosts) see particles on one side only:
                // their eq 17 values are first-order, so they are extrapolated instead.
                let mut usable: Vec<bool> = (0..layout.n_nodes())
                    .map(|i| layout.node_active[i] && !layout.grid.is_constrained(i))
                    .collect();
                for &(node, value) in pins {
                    nodal[node] = value;
                    usable[node] = true;
                }
                let mut d = nodal_derivatives(layout.grid, &nodal, &usable)?;
                for &(node, value) in pins {
                    d.value[node] = value;
                }
                Ok(d)
            }
            Recovery::LeastSquares => {
                let mut d = least_squares(layout, u, pins)?;
                for &(node, value) in pins {
                    d.value[node] = value;
                }
                Ok(d)
            }
        }
    }
}

/// Lattice cell of a position (clamped into the grid for fixed ends).
fn cell_of(layout: &Layout<'_>, x: f64) -> usize {
    let g = layout.grid;
    let c = ((x - g.origin) / g.h).floor();
    match g.boundary {
        Boundary::Periodic => (c as i64).rem_euclid(g.cells as i64) as usize,
        Boundary::Fixed => c.clamp(0.0, (g.cells - 1) as f64) as usize,
    }
}

fn least_squares(
    layout: &Layout<'_>,
    u: &[f64],
    pins: &[(usize, f64)],
) -> Result<NodalDerivatives, EstimatorError> {
    let g = layout.grid;
    let h = g.h;
    let cells = g.cells;
    // Particles bucketed by cell.
    let mut start = vec![0usize; cells + 1];
    let cell: Vec<usize> = layout.x.iter().map(|&x| cell_of(layout, x)).collect();
    for &c in &cell {
        start[c + 1] += 1;
    }
    for c in 0..cells {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut order = vec![0usize; u.len()];
    for (p, &c) in cell.iter().enumerate() {
        order[fill[c]] = p;
        fill[c] += 1;
    }
    let nn = layout.n_nodes();
    let mut out = NodalDerivatives::zeros(nn);
    let mut visited = vec![0usize; cells];
    let mut stamp = 0usize;
    for i in 0..nn {
        let xi = g.node_x(i);
        let lattice = ((xi - g.origin) / h).round() as i64;
        let mut radius = 3.0;
        loop {
            stamp += 1;
            let r = radius * h;
            let reach = radius.ceil() as i64 + 1;
            // The normal matrix is a Hankel matrix of the weighted power sums
            // `Σ w ξ^k`, k = 0…2·DEGREE; accumulate those and `Σ w u ξ^k`.
            let mut sums = [0.0_f64; 2 * DEGREE + 1];
            let mut b = SVector::<f64, NCOEF>::zeros();
            let mut points = 0;
            for j in lattice - reach..lattice + reach {
                let c = match g.boundary {
                    Boundary::Periodic => j.rem_euclid(cells as i64) as usize,
                    Boundary::Fixed => {
                        if j < 0 || j >= cells as i64 {
                            continue;
                        }
                        j as usize
                    }
                };
                if visited[c] == stamp {
                    continue;
                }
                visited[c] = stamp;
                for &p in &order[start[c]..start[c + 1]] {
                    let xt = layout.dx_from_node(i, p);
                    let q = xt / r;
                    if q.abs() >= 1.0 {
                        continue;
                    }
                    let w = (1.0 - q * q).powi(2);
                    accumulate(&mut sums, &mut b, w, xt / h, u[p]);
                    points += 1;
                }
            }
            for &(node, value) in pins {
                let xt = g.offset(node, xi); // X_node − X_i
                if (xt / r).abs() < 1.0 {
                    accumulate(&mut sums, &mut b, 100.0, xt / h, value);
                }
            }
            let a = SMatrix::<f64, NCOEF, NCOEF>::from_fn(|j, k| sums[j + k]);
            let solved = if points >= MIN_POINTS {
                a.cholesky().map(|c| c.solve(&b))
            } else {
                None
            };
            match solved {
                Some(c) => {
                    out.value[i] = c[0];
                    out.first[i] = c[1] / h;
                    out.second[i] = 2.0 * c[2] / (h * h);
                    out.third[i] = 6.0 * c[3] / (h * h * h);
                    out.fourth[i] = 24.0 * c[4] / (h * h * h * h);
                    break;
                }
                None if radius < 8.0 => radius += 0.5,
                None => {
                    return Err(EstimatorError::Recovery {
                        node: i,
                        points,
                        radius_cells: radius,
                        needed: MIN_POINTS,
                    })
                }
            }
        }
    }
    Ok(out)
}

/// Adds one sample `(ξ, u)` of weight `w` to the power sums and the right-hand side.
#[inline]
fn accumulate(
    sums: &mut [f64; 2 * DEGREE + 1],
    b: &mut SVector<f64, NCOEF>,
    w: f64,
    xi: f64,
    u: f64,
) {
    let mut pw = w;
    for (k, s) in sums.iter_mut().enumerate() {
        *s += pw;
        if k < NCOEF {
            b[k] += pw * u;
        }
        pw *= xi;
    }
}
