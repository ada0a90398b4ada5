//! The weight identities of the door check, written once for the 1D rows (`S`, `D`) and
//! the d-dimensional ones (`S`, `∇S`): node indices in range, finite entries,
//!
//! ```text
//! Σ_i S_ip = 1,   Σ_i ∇S_ip = 0,   Σ_i (X_i − x_p) ⊗ ∇S_ip = I
//! ```
//!
//! with the relative tolerances of [`super::WEIGHT_TOLERANCE`] (module docs of [`super`]).

use super::{ViewError, WEIGHT_TOLERANCE};

/// One view's weight rows as the check reads them: the dimension's storage behind three
/// accessors and the offsets `X_i − x_p`.
pub(super) trait Rows<const D: usize> {
    /// Number of particles (rows).
    fn n_particles(&self) -> usize;
    /// Number of nodes the rows index.
    fn n_nodes(&self) -> usize;
    /// Node indices and weights of particle `p`'s row.
    fn row(&self, p: usize) -> (&[u32], &[f64]);
    /// Gradient of entry `k` of particle `p`'s row.
    fn grad(&self, p: usize, k: usize) -> [f64; D];
    /// `X_i − x_p` for node `node` (minimum image on periodic axes).
    fn offset(&self, p: usize, node: usize) -> [f64; D];
    /// Whether the completeness identity is checked along axis `a` (module docs: not on a
    /// periodic axis of fewer than 3 cells).
    fn complete_along(&self, a: usize) -> bool;
}

/// Checks every row of `rows` (module docs); the first failure, by particle, is returned.
pub(super) fn check_rows<const D: usize>(rows: &impl Rows<D>) -> Result<(), ViewError> {
    let n_nodes = rows.n_nodes();
    let along: [bool; D] = std::array::from_fn(|a| rows.complete_along(a));
    for p in 0..rows.n_particles() {
        let (nodes, s) = rows.row(p);
        let mut sum = 0.0;
        let mut gsum = [0.0; D];
        let mut gabs = [0.0; D];
        let mut moment = [[0.0; D]; D];
        let mut mabs = [[0.0; D]; D];
        for (k, (&node, &w)) in nodes.iter().zip(s).enumerate() {
            let node = node as usize;
            if node >= n_nodes {
                return Err(ViewError::NodeOutOfRange {
                    particle: p,
                    node,
                    n_nodes,
                });
            }
            let g = rows.grad(p, k);
            let d = rows.offset(p, node);
            sum += w;
            for b in 0..D {
                gsum[b] += g[b];
                gabs[b] += g[b].abs();
                for a in 0..D {
                    let m = d[a] * g[b];
                    moment[a][b] += m;
                    mabs[a][b] += m.abs();
                }
            }
        }
        judge_row(rows, p, sum, &gsum, &gabs, &moment, &mabs, &along)?;
    }
    Ok(())
}

/// The verdict on one row's sums (written so that a NaN fails every comparison); a
/// non-finite entry is named as such before any identity.
#[allow(clippy::too_many_arguments)]
fn judge_row<const D: usize>(
    rows: &impl Rows<D>,
    p: usize,
    sum: f64,
    gsum: &[f64; D],
    gabs: &[f64; D],
    moment: &[[f64; D]; D],
    mabs: &[[f64; D]; D],
    along: &[bool; D],
) -> Result<(), ViewError> {
    let tol = WEIGHT_TOLERANCE;
    let partition = (sum - 1.0).abs() <= tol;
    let gradients = (0..D).all(|b| gsum[b].abs() <= tol * gabs[b]);
    let complete = (0..D).filter(|&a| along[a]).all(|a| {
        (0..D).all(|b| {
            let delta = if a == b { 1.0 } else { 0.0 };
            (moment[a][b] - delta).abs() <= tol * mabs[a][b].max(1.0)
        })
    });
    if partition && gradients && complete {
        return Ok(());
    }
    non_finite_entry(rows, p)?;
    if !partition {
        return Err(ViewError::PartitionOfUnity { particle: p, sum });
    }
    if let Some(axis) = (0..D).find(|&b| !(gsum[b].abs() <= tol * gabs[b])) {
        return Err(ViewError::GradientSum {
            particle: p,
            axis,
            sum: gsum[axis],
        });
    }
    for a in (0..D).filter(|&a| along[a]) {
        for b in 0..D {
            let expected = if a == b { 1.0 } else { 0.0 };
            if !((moment[a][b] - expected).abs() <= tol * mabs[a][b].max(1.0)) {
                return Err(ViewError::GradientMoment {
                    particle: p,
                    row: a,
                    col: b,
                    value: moment[a][b],
                    expected,
                });
            }
        }
    }
    Ok(())
}

/// The first non-finite weight or gradient of particle `p`'s row.
fn non_finite_entry<const D: usize>(rows: &impl Rows<D>, p: usize) -> Result<(), ViewError> {
    let (_, s) = rows.row(p);
    for (k, &w) in s.iter().enumerate() {
        if !w.is_finite() {
            return Err(ViewError::NonFinite {
                array: "weights.s",
                index: p,
                value: w,
            });
        }
        if let Some(&g) = rows.grad(p, k).iter().find(|g| !g.is_finite()) {
            return Err(ViewError::NonFinite {
                array: "weights.grad",
                index: p,
                value: g,
            });
        }
    }
    Ok(())
}
