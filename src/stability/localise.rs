//! Localising a Lanczos mode before the certified tracker serves it.
//!
//! The tracker's served pass ([`super::power_pass`]) skips every block of 64 nodes where its
//! mode is zero, so its cost follows the mode's support: on the 10⁵-particle standing wave,
//! 0.052–0.059 of a solver step on a mode that is non-zero everywhere, 0.023–0.038 on one
//! non-zero on under 1 % of the nodes (README "Stability"). A Lanczos Ritz vector is
//! non-zero everywhere, and power steps from it take ~100–300 steps of the run to shrink
//! its far components to zero. But the top of the nodal spectrum is a cluster of nearly
//! equal eigenvalues whose modes concentrate where the local wave speed is highest, so the
//! Ritz vector tapered to a window around its largest component keeps nearly all of its
//! Rayleigh quotient, and often more (its far parts have lower local quotients):
//!
//! ```text
//! k     = argmax_i u_i²                          (u: the Lanczos vector of C, ‖u‖ = 1)
//! w_i   = u_i sin²(π (d + ½) / W)   for i = k − W/2 + d, d = 0 … W−1  (wrapped on periodic
//!         grids, dropped past a fixed grid's ends), 0 elsewhere          (a Hann taper)
//! ρ(w)  = wᵀ C w / wᵀ w                          (one application of C)
//! use w when ρ(w) ≥ (1 − loss) θ                 (θ: the Ritz value of u)
//! ```
//!
//! Any vector's Rayleigh quotient is a lower bound on `λmax(C)`, so the windowed mode is as
//! valid a mode as the Ritz vector; what it may lose is at most `loss` of the quotient, and
//! the anchor's certificate (an `LDLᵀ` inertia test, independent of the mode) is unchanged.
//! Measured on the 10⁵-particle standing wave (`W = 512`, a temporary harness): the cold
//! start's Ritz vector windowed loses `1.9·10⁻⁵` of its quotient on the uniform layout, and
//! gains `1.3·10⁻⁴` on a jittered one; windows of the served mode one and two steps later
//! change its quotient by `−7.7·10⁻⁵` to `+7.5·10⁻³` (uniform layouts at amplitudes `10⁻²`
//! and `10⁻³`, a jittered one at `10⁻²`).

use super::lambda_max::{dot, SymmetricOperator};
use super::nodal::NodalOperator;

/// Width in nodes of the window (eight of the served pass's zero-test blocks).
pub(super) const WINDOW: usize = 512;

/// Whether [`localised`] tries a window on `n` nodes with Ritz value `theta` (it then applies
/// `C` once): at least `4 ·` [`WINDOW`] nodes, `theta` positive and finite.
pub(super) fn worth_trying(n: usize, theta: f64) -> bool {
    n >= 4 * WINDOW && theta > 0.0 && theta.is_finite()
}

/// The Lanczos vector `u` of `op` (Ritz value `theta`) tapered to [`WINDOW`] nodes around its
/// largest component, with its Rayleigh quotient on `op`, when that quotient is at least
/// `(1 − loss) θ` (module docs). `None` on grids under `4 ·` [`WINDOW`] nodes (the window
/// would cover too much of them to gain anything), for a non-positive or non-finite `θ` or
/// quotient, or when the window loses more than `loss`.
pub(super) fn localised(
    op: &NodalOperator,
    u: &[f64],
    theta: f64,
    loss: f64,
) -> Option<(Vec<f64>, f64)> {
    let n = op.dim();
    if u.len() != n || !worth_trying(n, theta) {
        return None;
    }
    let (peak, _) =
        u.iter().enumerate().fold(
            (0, 0.0),
            |(k, best), (i, &v)| {
                if v * v > best {
                    (i, v * v)
                } else {
                    (k, best)
                }
            },
        );
    let mut w = vec![0.0; n];
    let start = peak as isize - (WINDOW / 2) as isize;
    for d in 0..WINDOW {
        let j = start + d as isize;
        let i = if op.is_periodic() {
            j.rem_euclid(n as isize) as usize
        } else if (0..n as isize).contains(&j) {
            j as usize
        } else {
            continue;
        };
        let taper = (std::f64::consts::PI * (d as f64 + 0.5) / WINDOW as f64).sin();
        w[i] = u[i] * taper * taper;
    }
    let rho = rayleigh_quotient(op, &w);
    (rho.is_finite() && rho > 0.0 && rho >= (1.0 - loss) * theta).then_some((w, rho))
}

/// `xᵀ C x / xᵀ x` (one application of `C`).
fn rayleigh_quotient(op: &NodalOperator, x: &[f64]) -> f64 {
    let mut cx = vec![0.0; x.len()];
    op.apply(x, &mut cx, &mut Vec::new());
    dot(x, &cx) / dot(x, x)
}

// Drives the reference solvers: tested with the `reference` feature.
#[cfg(all(test, feature = "reference"))]
mod tests {
    use super::*;
    use crate::mpm::{Material, ReferenceStepper};
    use crate::problems::StandingWave;
    use crate::{Boundary, Grid, Shape, Stepper};

    fn operator(cells: usize, boundary: Boundary, amplitude: f64) -> NodalOperator {
        let grid = Grid::new(boundary, cells, 1.0);
        let wave = StandingWave::new(amplitude, 1.0, 1.0, 1.0, 1.0);
        let init = wave.uniform_particles(&grid, 2);
        let material = Material::LinearElastic {
            youngs_modulus: 1.0,
        };
        let s = ReferenceStepper::new(grid, Shape::Gimp, material, init).expect("valid set-up");
        NodalOperator::new(&s.view()).expect("valid view")
    }

    #[test]
    fn a_window_keeps_the_quotient_within_the_loss_or_is_refused() {
        // The uniform layout's top mode is the checkerboard, spread over the whole bar: a
        // window must lose some of its quotient (its edges), so a zero loss refuses it and
        // a 10⁻² loss takes it; the window's quotient is then the one returned.
        let op = operator(4096, Boundary::Periodic, 0.0);
        let n = op.dim();
        let u: Vec<f64> = (0..n)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 } / (n as f64).sqrt())
            .collect();
        let theta = rayleigh_quotient(&op, &u);
        assert!(localised(&op, &u, theta, 0.0).is_none());
        let (w, rho) = localised(&op, &u, theta, 1e-2).expect("within 1 %");
        assert!(rho < theta && rho >= 0.99 * theta, "{rho} vs {theta}");
        assert_eq!(rho.to_bits(), rayleigh_quotient(&op, &w).to_bits());
        let support: Vec<usize> = (0..n).filter(|&i| w[i] != 0.0).collect();
        assert_eq!(support.len(), WINDOW);
        // Too small a grid, or no positive Ritz value: no window.
        let small = operator(1024, Boundary::Periodic, 0.0);
        let us = vec![1.0; small.dim()];
        assert!(localised(&small, &us, rayleigh_quotient(&small, &us), 1.0).is_none());
        assert!(localised(&op, &u, 0.0, 1.0).is_none());
        assert!(localised(&op, &u, f64::NAN, 1.0).is_none());
    }

    #[test]
    fn the_window_is_centred_on_the_largest_component_and_clipped_at_fixed_ends() {
        // A vector peaked near the left end of a fixed bar: the window is cut at node 0, so
        // it covers fewer than WINDOW nodes, all of them within WINDOW / 2 of the peak.
        let packet = |n: usize, peak: usize| -> Vec<f64> {
            (0..n)
                .map(|i| {
                    // The distance around the ring (the fixed bar's window ignores the far end).
                    let d = i.abs_diff(peak).min(n - i.abs_diff(peak)) as f64;
                    (-(d * d) / 2000.0).exp() * if i % 2 == 0 { 1.0 } else { -1.0 }
                })
                .collect()
        };
        let op = operator(4096, Boundary::Fixed, 0.01);
        let n = op.dim();
        let peak = 40;
        let u = packet(n, peak);
        let theta = rayleigh_quotient(&op, &u);
        let (w, _) = localised(&op, &u, theta, 1.0).expect("a loss of 100 % takes any window");
        let support: Vec<usize> = (0..n).filter(|&i| w[i] != 0.0).collect();
        assert_eq!(support.first(), Some(&0));
        assert_eq!(support.last(), Some(&(peak + WINDOW / 2 - 1)));
        // On a periodic bar the same peak wraps across the seam.
        let op = operator(4096, Boundary::Periodic, 0.01);
        let n = op.dim();
        let u = packet(n, peak);
        let (w, _) = localised(&op, &u, rayleigh_quotient(&op, &u), 1.0).expect("any window");
        assert!(w[n - 1].abs() > 0.0);
        assert_eq!(w[peak + WINDOW / 2].to_bits(), 0);
        assert_eq!(w.iter().filter(|&&v| v != 0.0).count(), WINDOW);
    }
}
