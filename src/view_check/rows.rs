//! The weight identities of the door check, written once for the 1D rows (`S`, `D`) and
//! the d-dimensional ones (`S`, `∇S`): node indices in range, finite entries,
//!
//! ```text
//! Σ_i S_ip = 1,   Σ_i ∇S_ip = 0,   Σ_i (X_i − x_p) ⊗ ∇S_ip = I
//! ```
//!
//! with the relative tolerances of [`super::WEIGHT_TOLERANCE`] (module docs of [`super`]).
//!
//! The pass over the rows is the check's cost, so its normal case is kept lean: the
//! completeness sums are first compared with the absolute tolerance (which implies the
//! relative one, whose scale is at least 1), and only a row that fails it is summed again
//! with the magnitudes that scale the relative tolerance; the minimum image is one
//! comparison per axis, not a rounding.

use super::{ViewError, WEIGHT_TOLERANCE};

/// One view's weight rows as the check reads them.
pub(super) trait Rows<const D: usize> {
    /// A gradient as stored (`f64` in 1D, a vector in 2D/3D).
    type Grad: Copy;
    /// Number of particles (rows).
    fn n_particles(&self) -> usize;
    /// Number of nodes the rows index.
    fn n_nodes(&self) -> usize;
    /// Calls `f` with the node indices, weights and gradients of particle `p`'s row.
    fn with_row<T>(&self, p: usize, f: impl FnOnce(&[u32], &[f64], &[Self::Grad]) -> T) -> T;
    /// The components of a gradient.
    fn components(g: Self::Grad) -> [f64; D];
    /// Position `X_i` of node `i`.
    fn node(&self, i: usize) -> [f64; D];
    /// Position `x_p` of particle `p`.
    fn particle(&self, p: usize) -> [f64; D];
    /// The period of each axis that wraps around (`None`: the axis does not).
    fn period(&self) -> [Option<f64>; D];
    /// Whether the completeness identity is checked along axis `a` (module docs of
    /// `super`: not on a periodic axis of fewer than 3 cells, where offsets are ambiguous).
    fn complete_along(&self, a: usize) -> bool;
}

/// The row sums of one particle.
struct Sums<const D: usize> {
    s: f64,
    g: [f64; D],
    g_abs: [f64; D],
    /// `Σ_i (X_i − x_p)_a ∂_b S_ip`, `[a][b]`.
    moment: [[f64; D]; D],
    /// `Σ_i |(X_i − x_p)_a ∂_b S_ip|` (only summed for a row that fails the fast test).
    moment_abs: [[f64; D]; D],
}

/// Checks every row of `rows` (module docs); the first failure, by particle, is returned.
pub(super) fn check_rows<const D: usize, R: Rows<D>>(rows: &R) -> Result<(), ViewError> {
    let n_nodes = rows.n_nodes();
    let period = rows.period();
    let half: [f64; D] = std::array::from_fn(|a| period[a].map_or(f64::INFINITY, |l| 0.5 * l));
    let along: [bool; D] = std::array::from_fn(|a| rows.complete_along(a));
    let out_of_range = |p: usize, node: u32| ViewError::NodeOutOfRange {
        array: "weights.nodes",
        index: p,
        node: node as usize,
        n_nodes,
    };
    for p in 0..rows.n_particles() {
        // The node range is checked in the same visit of the row as the sums.
        let sums = row_sums(rows, p, &period, &half, false).map_err(|n| out_of_range(p, n))?;
        if !passes(&sums, &along, false) {
            let sums = row_sums(rows, p, &period, &half, true).map_err(|n| out_of_range(p, n))?;
            judge(rows, p, &sums, &along)?;
        }
    }
    Ok(())
}

/// The sums of particle `p`'s row; the magnitudes of the moment terms if `magnitudes`.
/// `Err(node)`: the row refers to a node past the grid's (nothing summed).
#[inline]
fn row_sums<const D: usize, R: Rows<D>>(
    rows: &R,
    p: usize,
    period: &[Option<f64>; D],
    half: &[f64; D],
    magnitudes: bool,
) -> Result<Sums<D>, u32> {
    let n_nodes = rows.n_nodes();
    rows.with_row(p, |nodes, s, grad| {
        if let Some(&bad) = nodes.iter().find(|&&i| i as usize >= n_nodes) {
            return Err(bad);
        }
        let x = rows.particle(p);
        let mut sums = Sums {
            s: 0.0,
            g: [0.0; D],
            g_abs: [0.0; D],
            moment: [[0.0; D]; D],
            moment_abs: [[0.0; D]; D],
        };
        for ((&node, &w), &g) in nodes.iter().zip(s).zip(grad) {
            let g = R::components(g);
            let xi = rows.node(node as usize);
            let d: [f64; D] = std::array::from_fn(|a| {
                let d = xi[a] - x[a];
                match period[a] {
                    Some(l) if d > half[a] => d - l,
                    Some(l) if d < -half[a] => d + l,
                    _ => d,
                }
            });
            sums.s += w;
            for (b, &gb) in g.iter().enumerate() {
                sums.g[b] += gb;
                sums.g_abs[b] += gb.abs();
                for (a, &da) in d.iter().enumerate() {
                    sums.moment[a][b] += da * gb;
                    if magnitudes {
                        sums.moment_abs[a][b] += (da * gb).abs();
                    }
                }
            }
        }
        Ok(sums)
    })
}

/// Whether a row's sums pass (written so that a NaN fails every comparison). With
/// `relative`, the completeness tolerance is scaled by the magnitudes; without, it is
/// absolute (stricter: the scale is at least 1).
#[inline]
fn passes<const D: usize>(sums: &Sums<D>, along: &[bool; D], relative: bool) -> bool {
    let tol = WEIGHT_TOLERANCE;
    let partition = (sums.s - 1.0).abs() <= tol;
    let gradients = (0..D).all(|b| sums.g[b].abs() <= tol * sums.g_abs[b]);
    partition && gradients && (0..D).all(|a| !along[a] || moment_ok(sums, a, relative))
}

/// `|x| ≤ tol`, false for a NaN.
#[inline]
fn within(x: f64, tol: f64) -> bool {
    x.abs() <= tol
}

/// Row `a` of the completeness identity holds.
fn moment_ok<const D: usize>(sums: &Sums<D>, a: usize, relative: bool) -> bool {
    (0..D).all(|b| {
        let delta = if a == b { 1.0 } else { 0.0 };
        let scale = if relative {
            sums.moment_abs[a][b].max(1.0)
        } else {
            1.0
        };
        (sums.moment[a][b] - delta).abs() <= WEIGHT_TOLERANCE * scale
    })
}

/// The verdict on a row that failed the fast test: a non-finite entry first, then the
/// identities in order, with the relative tolerances.
fn judge<const D: usize, R: Rows<D>>(
    rows: &R,
    p: usize,
    sums: &Sums<D>,
    along: &[bool; D],
) -> Result<(), ViewError> {
    if passes(sums, along, true) {
        return Ok(());
    }
    non_finite_entry(rows, p)?;
    let tol = WEIGHT_TOLERANCE;
    if !within(sums.s - 1.0, tol) {
        return Err(ViewError::PartitionOfUnity {
            particle: p,
            sum: sums.s,
        });
    }
    if let Some(axis) = (0..D).find(|&b| !within(sums.g[b], tol * sums.g_abs[b])) {
        return Err(ViewError::GradientSum {
            particle: p,
            axis,
            sum: sums.g[axis],
        });
    }
    for a in (0..D).filter(|&a| along[a]) {
        for b in 0..D {
            let expected = if a == b { 1.0 } else { 0.0 };
            let value = sums.moment[a][b];
            if !within(value - expected, tol * sums.moment_abs[a][b].max(1.0)) {
                return Err(ViewError::GradientMoment {
                    particle: p,
                    row: a,
                    col: b,
                    value,
                    expected,
                });
            }
        }
    }
    Ok(())
}

/// The first non-finite weight or gradient of particle `p`'s row.
fn non_finite_entry<const D: usize, R: Rows<D>>(rows: &R, p: usize) -> Result<(), ViewError> {
    rows.with_row(p, |_, s, grad| {
        for (&w, &g) in s.iter().zip(grad) {
            if !w.is_finite() {
                return Err(ViewError::NonFinite {
                    array: "weights.s",
                    index: p,
                    value: w,
                });
            }
            if let Some(&g) = R::components(g).iter().find(|g| !g.is_finite()) {
                return Err(ViewError::NonFinite {
                    array: "weights.grad",
                    index: p,
                    value: g,
                });
            }
        }
        Ok(())
    })
}
