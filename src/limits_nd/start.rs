//! The cold start of the stability limit's Lanczos runs.

use super::stiffness::NodalSpace;
use crate::nd::ViewNd;

/// A cold start close to the top of the spectrum: in component `a`, the checkerboard along
/// axis `a`, `(−1)^(j_a)` (the P wave of the highest wavenumber along each axis, which
/// carries `λmax` on uniform GIMP and linear-hat layouts: across the other axes the
/// weights sum to one, where the full checkerboard's alternating sums nearly cancel),
/// plus half the full checkerboard `(−1)^(Σ_b j_b)` and a small seeded perturbation so
/// that no mode is missed; all functions of the node in the whole grid. On the 3D GIMP
/// wave of 10⁵ particles the first Rayleigh quotient is 0.82 of `λmax`, against 0.20 for
/// the previous start (the full checkerboard plus the diagonal bump), and Lanczos settles
/// in 2 products instead of 20.
pub(super) fn checkerboard_start<const D: usize>(
    view: &ViewNd<'_, D>,
    space: &NodalSpace<'_, '_, D>,
) -> Vec<f64> {
    let n = view.n_nodes();
    let whole = view.split.as_ref().map_or(view.grid, |s| s.whole);
    let mut out = Vec::with_capacity(n * D);
    for local in 0..n {
        let i = space.global(local);
        let j = whole.lattice_of(i);
        let sign = if j.iter().sum::<i64>().rem_euclid(2) == 0 {
            1.0
        } else {
            -1.0
        };
        for (a, &ja) in j.iter().enumerate() {
            let noise = ((i * D + a) * 7919 % 101) as f64 / 101.0 - 0.5;
            let along = if ja.rem_euclid(2) == 0 { 1.0 } else { -1.0 };
            out.push(along + 0.5 * sign + 0.1 * noise);
        }
    }
    out
}
