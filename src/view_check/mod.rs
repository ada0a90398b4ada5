//! The view checked at the door: what the controller verifies of a stepper's view before
//! any limit reads it, and the typed [`ViewError`] it reports.
//!
//! A view ([`crate::View`] in 1D, [`crate::nd::ViewNd`] in 2D/3D) is a set of slices the
//! stepper hands over; the limits index them without further questions. A view that does
//! not describe one consistent state would make a limit panic (an array one element short),
//! or worse, silently propose a wrong step (weight gradients missing their `1/h` make
//! `λmax` `h²` too small). So the controller checks each view it reads, in two parts:
//!
//! **Shape** ([`crate::StateView::check_shape`], O(1), on *every* view the controller reads:
//! the committed view of every attempt and every trial view):
//!
//! * every particle array (`x`, `v`, `σ`, `F`, `V⁰`, `m`, the moduli, `ρ`, the weight
//!   rows, a split view's particle ids) has the particle count as length. The count is the
//!   length most particle arrays share (`x`'s on a tie), so that the one array that
//!   differs is the one named;
//! * every nodal array (`m_i`, `v_i`, `a_i`, the active flags, the weights' node count, a
//!   split view's node maps, a 1D `K_N`) has the node count as length, and that count is
//!   the grid's `n_nodes()` — else [`ViewError::Grid`] (a grid that does not describe the
//!   node arrays, e.g. one cell bigger).
//!
//! **Contents** ([`crate::StateView::check_contents`], O(particles × stencil + nodes), on
//! the first committed view a controller reads and then every [`VIEW_CHECK_CADENCE`]-th
//! step, see below):
//!
//! * the committed state is finite: `x`, `v`, `σ`, `F`, `V⁰`, `m`, the moduli, `ρ`, the
//!   nodal masses, velocities and accelerations (a NaN velocity at `t = 0` is named at
//!   once instead of costing a run of rejected trials);
//! * every weight row refers to stored nodes, and its weights and gradients are finite;
//! * the weights form a partition of unity and the gradients are complete, per particle
//!   `p` (sums over the row's nodes `i`, padding included):
//!
//! ```text
//! Σ_i S_ip = 1                                   (partition of unity)
//! Σ_i ∇S_ip = 0                                  (the gradient of that constant)
//! Σ_i (X_i − x_p) ⊗ ∇S_ip = I                    (linear completeness)
//! ```
//!
//! The last one is what catches gradients in the wrong units: gradients taken in cell
//! coordinates (a missing `1/h`) give `h I` instead of `I`. (On a grid with `h = 1` the
//! two are the same and nothing can tell them apart.) `X_i − x_p` is taken with the
//! minimum-image convention on periodic axes (the whole grid's periodicity for a
//! grid-decomposed view, whose window is unwrapped), so that a stencil wrapping around the
//! domain counts its nodes at their positions next to the particle; on a periodic axis of
//! fewer than 3 cells a node's offset from the particle is ambiguous, and the completeness
//! identity is not checked along that axis. Every shipped kernel satisfies the three:
//! linear hat, GIMP and quadratic B-spline tensor products (linear completeness of the
//! basis), and MLS-MPM's effective gradients `∇S_ip = (4/h²) S_ip (X_i − x_p)` of a
//! quadratic B-spline, for which `Σ_i S_ip (X_i − x_p) = 0` and
//! `Σ_i S_ip (X_i − x_p) ⊗ (X_i − x_p) = (h²/4) I`.
//!
//! Nodes are not judged beyond their array lengths and finite values: an empty, inactive,
//! constrained or ghost node is a legitimate state.
//!
//! **Tolerances** (relative, [`WEIGHT_TOLERANCE`] `= 10⁻⁶`): `|Σ_i S_ip − 1| ≤ tol`;
//! `|Σ_i ∂_a S_ip| ≤ tol · Σ_i |∂_a S_ip|`; `|Σ_i (X_i − x_p)_a ∂_b S_ip − δ_ab| ≤
//! tol · max(1, Σ_i |(X_i − x_p)_a ∂_b S_ip|)`. Round-off of kernels evaluated in `f64`
//! is ~10⁻¹⁵; `10⁻⁶` leaves room for kernels computed in single precision and for
//! coordinates far from the origin, and is still 10⁵ times below the errors these checks
//! exist for (a row summing to 0.5, a factor `h` in the gradients).
//!
//! **When.** The shape check costs a few comparisons (~0.1 µs) and runs on every view. The
//! contents check is one pass over the weight rows: measured against a bare reference step
//! (`try_step` + `accept`) of 10⁵ particles, side by side in one run (`cargo bench --bench
//! view_check`, medians of 11 interleaved rounds), it costs ~30 % of a step in 2D, ~40 % in
//! 3D and about one step in 1D, whose reference step is very cheap — far above the 2 % a
//! check on every view could be allowed. So it runs on the first committed view a
//! controller reads (whatever its step index: a controller restored from a checkpoint
//! checks its first view too) and then on the first attempt of every step whose index is a
//! multiple of [`VIEW_CHECK_CADENCE`] (64): about 1.5 % of the bare steps in 1D
//! (95 % / 64), under 1 % in 2D and 3D, and less of a controlled step, which adds the
//! limits' work. Trial views are checked for shape, and for finite particle fields
//! by the controller's trial scan as before (a non-finite trial is rejected and retried);
//! their weights are checked when they have become a committed view on the cadence.
//!
//! In a distributed run ([`crate::reduce`]) the processes agree on the outcome (one
//! [`crate::reduce::Reduce::any_flags`] per attempt when there is more than one process)
//! before any limit reads the view, whose collectives a process with a misshapen view
//! could not take part in: a
//! process whose view fails returns its [`ViewError`], the others
//! `ControllerError::OtherRank`.

mod error;
mod nd;
mod one_d;
mod rows;

pub use error::ViewError;
pub(crate) use one_d::first_nonfinite;

/// Every how many steps the controller checks a committed view's contents (besides the
/// first view it reads): the step index `n` of the view with `n % VIEW_CHECK_CADENCE == 0`.
pub const VIEW_CHECK_CADENCE: u64 = 64;

/// Relative tolerance of the weight identities (module docs).
pub const WEIGHT_TOLERANCE: f64 = 1e-6;

/// The length most of `lens` share (the first listed on a tie): the count the others are
/// checked against, so that the one array that differs is the one named.
fn majority(lens: &[(&'static str, usize)]) -> usize {
    let mut best = (lens.first().map_or(0, |l| l.1), 0usize);
    for &(_, len) in lens {
        let votes = lens.iter().filter(|l| l.1 == len).count();
        if votes > best.1 {
            best = (len, votes);
        }
    }
    best.0
}

/// The first of `lens` whose length is not `expected`, as a [`ViewError::Length`].
fn first_mismatch(
    lens: &[(&'static str, usize)],
    expected: usize,
    count: &'static str,
) -> Result<(), ViewError> {
    match lens.iter().find(|l| l.1 != expected) {
        Some(&(array, len)) => Err(ViewError::Length {
            array,
            len,
            expected,
            count,
        }),
        None => Ok(()),
    }
}

/// Particle arrays against their majority length, nodal arrays against theirs and that
/// against the grid's node count (module docs). Returns the particle count.
fn check_counts(
    particle: &[(&'static str, usize)],
    nodal: &[(&'static str, usize)],
    grid_nodes: usize,
    cells: &[usize],
) -> Result<usize, ViewError> {
    let n = majority(particle);
    first_mismatch(particle, n, "particles")?;
    let nn = majority(nodal);
    if nn != grid_nodes && nodal.iter().all(|l| l.1 == nn) {
        return Err(ViewError::Grid {
            grid_nodes,
            array_nodes: nn,
            cells: cells.to_vec(),
        });
    }
    first_mismatch(nodal, grid_nodes, "nodes")?;
    Ok(n)
}

/// The first non-finite value of `values` (flattened `width` per element) as a
/// [`ViewError::NonFinite`] naming `array`, the element and the value. A vectorised pass
/// confirms the normal case; only a failing array is searched element by element.
fn finite(array: &'static str, values: &[f64], width: usize) -> Result<(), ViewError> {
    if all_finite(values) {
        return Ok(());
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(k) => Err(ViewError::NonFinite {
            array,
            index: k / width.max(1),
            value: values[k],
        }),
        None => Ok(()),
    }
}

/// Lanes of [`all_finite`]'s sums.
const FINITE_LANES: usize = 8;

/// Whether every value is finite (no NaN, no ±∞): lane-wise sums of `0·x`, which are 0
/// exactly when all values are finite (vectorised over [`FINITE_LANES`] lanes).
pub(crate) fn all_finite(values: &[f64]) -> bool {
    let mut bad = [0.0_f64; FINITE_LANES];
    let mut chunks = values.chunks_exact(FINITE_LANES);
    for c in chunks.by_ref() {
        for k in 0..FINITE_LANES {
            bad[k] += c[k] * 0.0;
        }
    }
    for &x in chunks.remainder() {
        bad[0] += x * 0.0;
    }
    bad.iter().all(|&b| b == 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_odd_array_out_is_named() {
        let lens = [("x", 9), ("v", 10), ("mass", 10), ("density", 10)];
        assert_eq!(majority(&lens), 10);
        assert_eq!(
            first_mismatch(&lens, 10, "particles"),
            Err(ViewError::Length {
                array: "x",
                len: 9,
                expected: 10,
                count: "particles"
            })
        );
        // A tie keeps the first listed.
        assert_eq!(majority(&[("x", 3), ("v", 4)]), 3);
    }

    #[test]
    fn a_grid_that_disagrees_with_every_nodal_array_is_named() {
        let nodal = [("node_mass", 12), ("node_velocity", 12)];
        let e = check_counts(&[("x", 1)], &nodal, 15, &[2, 3]).unwrap_err();
        assert!(
            matches!(
                e,
                ViewError::Grid {
                    grid_nodes: 15,
                    array_nodes: 12,
                    ..
                }
            ),
            "{e}"
        );
        let nodal = [
            ("node_mass", 15),
            ("node_velocity", 12),
            ("node_active", 15),
        ];
        let e = check_counts(&[("x", 1)], &nodal, 15, &[2, 3]).unwrap_err();
        assert_eq!(e.array(), "node_velocity");
    }
}
