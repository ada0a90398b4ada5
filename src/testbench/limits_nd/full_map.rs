//! The frozen-particle full map in d dimensions: the exact critical step of the whole
//! linearised USL step, velocity and stress, for small layouts (verification; the 1D
//! counterpart is [`crate::stability::FullMap`]).
//!
//! Freeze the weights, the volumes `V_p = det(F_p) V⁰_p`, the tangent moduli and the nodal
//! masses of a state, and linearise the step of the reference solver in the particle state
//! `z = (v_p, σ_p)` (`σ_p` by its `d(d+1)/2` symmetric components):
//!
//! ```text
//! v_i  = (1/m_i) Σ_p S_ip m_p v_p                  (0 at inactive and constrained nodes)
//! a_i  = −(1/m_i) Σ_p V_p σ_p ∇S_ip                (0 there too)
//! v_i' = v_i + dt a_i
//! v_p' = v_p + dt Σ_i S_ip a_i
//! σ_p' = σ_p + dt (λ_t tr ε I + 2 μ_t ε),  ε = sym(Σ_i v_i' ⊗ ∇S_ip)
//! ```
//!
//! so `z' = T(dt) z` with `T = T₀ + dt T₁ + dt² T₂`, assembled densely by applying the step
//! to unit vectors (at `dt = 0, ±1`). Its critical step is the first `dt` at which the
//! spectral radius exceeds `1 + 10⁻⁶` (the 1D tool's search and its treatment of the
//! eigenvalues exactly 1: rigid modes, velocity patterns with zero nodal momentum, stress
//! patterns the divergence does not see). Eq 56 analyses the stress part of this map
//! alone (`I − dt² M⁻¹K` on nodal velocities); the full map also carries the particle
//! velocity update and the projection between particles and nodes.

use crate::nd::{Tensor, Vector, ViewNd};
use crate::stability::{FullMap, FullMapConfig, StabilityError};
use faer::Mat;

/// Above this many unknowns `d + d(d+1)/2` per particle the map is not assembled: a dense
/// eigenvalue problem of that size takes about 0.05 s, and the search needs some 25.
pub const FULL_MAP_LIMIT: usize = 400;

/// Number of symmetric stress components.
const fn sym(d: usize) -> usize {
    d * (d + 1) / 2
}

/// The `(a, b)` pair of symmetric component `k` (`a ≤ b`, row by row).
fn pair(d: usize, k: usize) -> (usize, usize) {
    let mut k = k;
    for a in 0..d {
        let row = d - a;
        if k < row {
            return (a, a + k);
        }
        k -= row;
    }
    (d - 1, d - 1)
}

/// One linear step of `z = (v, σ)` with step `dt` on a frozen view.
fn step<const D: usize>(view: &ViewNd<'_, D>, dt: f64, z: &[f64], out: &mut [f64]) {
    let n = view.n_particles();
    let nn = view.n_nodes();
    let ns = sym(D);
    let w = view.weights;
    let v = |p: usize| Vector::<D>::from_fn(|a, _| z[p * D + a]);
    let sigma = |p: usize| {
        let mut t = Tensor::<D>::zeros();
        for k in 0..ns {
            let (a, b) = pair(D, k);
            t[(a, b)] = z[n * D + p * ns + k];
            t[(b, a)] = t[(a, b)];
        }
        t
    };
    let mut node_v = vec![Vector::<D>::zeros(); nn];
    let mut node_a = vec![Vector::<D>::zeros(); nn];
    for p in 0..n {
        let mv = v(p) * view.mass[p];
        let vs = sigma(p) * (-view.volume(p));
        w.with_row(p, |nodes, s, grad| {
            for ((&i, &s), g) in nodes.iter().zip(s).zip(grad) {
                node_v[i as usize] += mv * s;
                node_a[i as usize] += vs * g;
            }
        });
    }
    for i in 0..nn {
        let inv = if view.node_active[i] {
            1.0 / view.node_mass[i]
        } else {
            0.0
        };
        node_a[i] *= inv;
        node_v[i] = node_v[i] * inv + node_a[i] * dt;
    }
    for p in 0..n {
        let (acc, l) = w.with_row(p, |nodes, s, grad| {
            let mut acc = Vector::<D>::zeros();
            let mut l = Tensor::<D>::zeros();
            for ((&i, &s), g) in nodes.iter().zip(s).zip(grad) {
                acc += node_a[i as usize] * s;
                l += node_v[i as usize] * g.transpose();
            }
            (acc, l)
        });
        let vp = v(p) + acc * dt;
        let eps = (l + l.transpose()) * 0.5;
        let sp = sigma(p)
            + (Tensor::<D>::identity() * (view.lame_lambda[p] * eps.trace())
                + eps * (2.0 * view.lame_mu[p]))
                * dt;
        for a in 0..D {
            out[p * D + a] = vp[a];
        }
        for k in 0..ns {
            let (a, b) = pair(D, k);
            out[n * D + p * ns + k] = sp[(a, b)];
        }
    }
}

/// `T(dt)` of a view, column by column.
fn dense<const D: usize>(view: &ViewNd<'_, D>, dt: f64) -> Mat<f64> {
    let dim = view.n_particles() * (D + sym(D));
    let mut t = Mat::<f64>::zeros(dim, dim);
    let mut e = vec![0.0; dim];
    let mut out = vec![0.0; dim];
    for j in 0..dim {
        e[j] = 1.0;
        step(view, dt, &e, &mut out);
        e[j] = 0.0;
        for (i, &x) in out.iter().enumerate() {
            t[(i, j)] = x;
        }
    }
    t
}

/// The full map of a view, or `None` above [`FULL_MAP_LIMIT`] unknowns.
pub fn full_map<const D: usize>(view: &ViewNd<'_, D>) -> Option<FullMap> {
    let dim = view.n_particles() * (D + sym(D));
    if dim == 0 || dim > FULL_MAP_LIMIT {
        return None;
    }
    // T(dt) is quadratic in dt: its coefficients from dt = 0, ±1.
    let t0 = dense(view, 0.0);
    let tp = dense(view, 1.0);
    let tm = dense(view, -1.0);
    let t1 = Mat::from_fn(dim, dim, |i, j| 0.5 * (tp[(i, j)] - tm[(i, j)]));
    let t2 = Mat::from_fn(dim, dim, |i, j| {
        0.5 * (tp[(i, j)] + tm[(i, j)]) - t0[(i, j)]
    });
    Some(FullMap::from_coefficients(t0, t1, t2))
}

/// The frozen-particle critical step of a small view: the search of
/// [`FullMap::critical_dt`] from `0.8·dt_eq56` upward in steps of 2 %, bisected to 10⁻⁷.
/// `None` above [`FULL_MAP_LIMIT`] unknowns; an error when the search brackets no
/// critical step.
pub fn critical_dt<const D: usize>(
    view: &ViewNd<'_, D>,
    dt_eq56: f64,
) -> Option<Result<f64, StabilityError>> {
    let map = full_map(view)?;
    let config = FullMapConfig {
        scan_factor: 1.02,
        ..FullMapConfig::default()
    };
    Some(map.critical_dt(0.8 * dt_eq56, config))
}

#[cfg(test)]
mod tests {
    use super::pair;

    #[test]
    fn symmetric_components_run_row_by_row() {
        assert_eq!(
            (0..3).map(|k| pair(2, k)).collect::<Vec<_>>(),
            [(0, 0), (0, 1), (1, 1)]
        );
        assert_eq!(
            (0..6).map(|k| pair(3, k)).collect::<Vec<_>>(),
            [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
        );
    }
}
