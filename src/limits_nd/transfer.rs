//! How a scheme's particle ↔ grid velocity transfer changes the eq 56 limit.
//!
//! Eq 56 analyses the USL step of the paper, whose particle velocity is updated by the
//! grid *increment* (FLIP): a nodal velocity pattern survives the particle → grid round
//! trip, and the stress part of the step, `I − dt² M⁻¹K`, sets the limit `dt² λ ≤ 2`.
//! PIC and APIC schemes (MLS-MPM among them) instead *replace* the particle velocity by
//! the grid's, `v_p = Σ_i S_ip v_i` (APIC adds `C_p = Σ_i v_i ⊗ ∇S_ip`), and the next
//! particle → grid pass projects it: `v ↦ P v` with, for APIC,
//!
//! ```text
//! (P v)_i = (1/m_i) Σ_p S_ip m_p (v_p + C_p (x_i − x_p)),   S_ip (x_i − x_p) = D_p ∇S_ip,
//! ```
//!
//! `D_p` the APIC inertia (`h_a²/4` per axis for quadratic B-splines, whose MLS gradient is
//! `∇S_ip = D_p⁻¹ S_ip (x_i − x_p)`). On one mode shared by `P` (eigenvalue `p`) and
//! `M⁻¹K` (eigenvalue `λ`) the step acts on the nodal velocity and acceleration `(v, a)`
//! as `u = v + dt a`, `v' = p u`, `a' = a − dt λ u`: a 2×2 matrix with determinant `p` and
//! trace `1 + p − dt²λ`, stable for `0 ≤ p ≤ 1` iff
//!
//! ```text
//! dt² λ ≤ 2 (1 + p).
//! ```
//!
//! With `p = 0` this is eq 56's own condition; a transfer that keeps part of the highest
//! mode allows a larger step. For quadratic B-splines at two particles per cell the
//! highest (Nyquist) mode keeps `p = 0.14` under PIC and `p = 0.61` under APIC (1D,
//! uniform), so APIC's limit is `√1.61 = 1.27` times eq 56's. On a general layout `P` and
//! `M⁻¹K` do not share modes; [`apic_gain`] takes `p` as the Rayleigh quotient of `P` on
//! the tracked top mode of `M⁻¹K` (in the mass inner product), clamped to `[0, 1]` — an
//! interpretation, exact on uniform periodic layouts, measured against the blow-up step of
//! an MLS-MPM scene in `examples/mls_mpm`.
//!
//! The stability limit applies the gain to solids only: once a refresh meets a particle
//! without shear stiffness (a fluid) it steps on eq 56 itself for the rest of the run
//! (`crate::limits_nd::bound_tracking`, "Under APIC": the mpm88 fluid, whose layout is
//! not frozen from step to step, grew at the gained step).

use super::stiffness::{inverse_sqrt_mass, NodalSpace};
use crate::nd::{Tensor, Vector, ViewNd};
use serde::{Deserialize, Serialize};

/// The velocity transfer of the scheme a stability limit analyses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TransferNd {
    /// The paper's USL step: particle velocities updated by the grid increment (eq 56 as
    /// it stands). The default.
    #[default]
    Flip,
    /// APIC (and MLS-MPM): particle velocities and affine matrices taken from the grid,
    /// with the inertia `D_p = inertia · h_a²` per axis (0.25 for quadratic B-splines).
    Apic {
        /// `D_p / h_a²`.
        inertia: f64,
    },
}

/// `1 + p` of the module docs for the nodal mode `y` (in the `M^{1/2}`-scaled coordinates
/// of `A = M^{-1/2} K M^{-1/2}`, `D` components per node): `p = ⟨v, P v⟩_M / ⟨v, v⟩_M`
/// with `v = M^{-1/2} y`, clamped to `[0, 1]`. One pass over the particles' weights; on a
/// split view the nodal sums and the products are completed over the processes.
pub fn apic_gain<const D: usize>(
    view: &ViewNd<'_, D>,
    space: &NodalSpace<'_, '_, D>,
    y: &[f64],
    inertia: f64,
) -> f64 {
    let nn = view.n_nodes();
    let inv_sqrt_m = inverse_sqrt_mass(view);
    // v = M^{-1/2} y (zero at inactive nodes), and y on the active nodes.
    let vs: Vec<f64> = (0..nn * D).map(|c| y[c] * inv_sqrt_m[c / D]).collect();
    let ys: Vec<f64> = (0..nn * D)
        .map(|c| if view.node_active[c / D] { y[c] } else { 0.0 })
        .collect();
    let v = |i: usize| Vector::<D>::from_column_slice(&vs[i * D..(i + 1) * D]);
    let h2 = Vector::<D>::from_fn(|a, _| inertia * view.grid.h[a] * view.grid.h[a]);
    let mut momentum = vec![0.0; nn * D];
    let w = view.weights;
    for p in 0..view.n_particles() {
        w.with_row(p, |nodes, s, grad| {
            let mut vp = Vector::<D>::zeros();
            let mut cp = Tensor::<D>::zeros();
            for ((&i, &s), g) in nodes.iter().zip(s).zip(grad) {
                let vi = v(i as usize);
                vp += vi * s;
                cp += vi * g.transpose();
            }
            let m = view.mass[p];
            for ((&i, &s), g) in nodes.iter().zip(s).zip(grad) {
                let dpos = g.component_mul(&h2);
                let add = (vp * s + cp * dpos) * m;
                for a in 0..D {
                    momentum[i as usize * D + a] += add[a];
                }
            }
        });
    }
    space.complete(&mut momentum);
    // ⟨v, P v⟩_M = Σ_i v_i · (momentum_i): the mass cancels; ⟨v, v⟩_M = |y|² on active nodes.
    let p = space.dot(&vs, &momentum) / space.dot(&ys, &ys);
    1.0 + if p.is_finite() {
        p.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

// Drives the reference solvers: tested with the `reference` feature.
#[cfg(all(test, feature = "reference"))]
mod tests {
    use super::*;
    use crate::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, WeightsNd};
    use crate::reduce::SingleProcess;
    use crate::{Boundary, Stepper};

    /// On a uniform periodic layout of quadratic B-splines at two particles per cell, with
    /// MLS gradients `∇S = (4/h²) S (x_i − x_p)`, the highest mode along one axis keeps
    /// `p = 157/256` under APIC (module docs; the 1D symbol, as the other axis is uniform).
    #[test]
    fn apic_keeps_157_256_of_the_nyquist_mode() {
        let grid = GridNd::<2>::new([Boundary::Periodic; 2], [16, 16], [1.0, 1.0]);
        let material = MaterialNd::LinearElastic {
            youngs_modulus: 1.0,
            poisson_ratio: 0.3,
        };
        let particles = ParticlesNd::uniform(&grid, [2, 2], 1.0, material);
        let solver = SolverNd::new(
            grid.clone(),
            ShapeNd::BSpline2,
            particles,
            Vector::<2>::zeros(),
        )
        .unwrap();
        let view = solver.view();
        let w = view.weights;
        let h = grid.h[0];
        let (mut nodes, mut s, mut grad) = (Vec::new(), Vec::new(), Vec::new());
        for p in 0..view.n_particles() {
            w.with_row(p, |row_nodes, row_s, _| {
                for (&i, &sv) in row_nodes.iter().zip(row_s) {
                    let mut d = grid.node_position(i as usize) - view.x[p];
                    for a in 0..2 {
                        // The periodic image nearest the particle.
                        d[a] -= (d[a] / grid.length(a)).round() * grid.length(a);
                    }
                    nodes.push(i);
                    s.push(sv);
                    grad.push(d * (4.0 / (h * h) * sv));
                }
            });
        }
        let mls = WeightsNd::from_rows(w.n_nodes(), w.width(), nodes, s, grad).unwrap();
        let view = ViewNd {
            weights: (&mls).into(),
            ..view
        };
        let y: Vec<f64> = (0..view.n_nodes())
            .flat_map(|i| {
                let j = grid.lattice_of(i);
                let sign = if j[0].rem_euclid(2) == 0 { 1.0 } else { -1.0 };
                [sign * view.node_mass[i].sqrt(), 0.0]
            })
            .collect();
        let space = NodalSpace::new(&view, &SingleProcess);
        let gain = apic_gain(&view, &space, &y, 0.25);
        assert!((gain - (1.0 + 157.0 / 256.0)).abs() < 1e-12, "gain {gain}");
        // PIC keeps less: inertia 0 drops APIC's affine term.
        let pic = apic_gain(&view, &space, &y, 0.0);
        assert!((pic - (1.0 + 36.0 / 256.0)).abs() < 1e-12, "PIC gain {pic}");
    }
}
