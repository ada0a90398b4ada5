//! The d-dimensional operators of the full map reduced to the nodes
//! ([`crate::stability::nodal_full_map`]): `A_s = M^{-1/2} K M^{-1/2}` (eq 56's operator,
//! [`super::stiffness`]) and the scaled consistent mass `Q_s = M^{-1/2} Sᵀ diag(m_p) S M^{-1/2}`,
//! both on the free active nodes (inactive and constrained nodes drop out, as in the dense
//! map [`super::full_map`]).
//!
//! `Q` couples a node's component `a` only with the same component of the nodes that share
//! a particle: `(Q u)_(ia) = Σ_p m_p S_ip Σ_j S_jp u_(ja)`.

use super::stiffness::{apply_scaled, inverse_sqrt_mass};
use crate::nd::{Vector, ViewNd};
use crate::stability::nodal_full_map::{
    nodal_critical_dt, NodalCritical, NodalLanczos, NodalPencil, NODAL_FULL_MAP_LIMIT,
};

/// The reduced operators of one frozen state.
pub struct NodalPencilNd<'v, 'a, const D: usize> {
    view: &'v ViewNd<'a, D>,
    inv_sqrt_m: Vec<f64>,
}

impl<'v, 'a, const D: usize> NodalPencilNd<'v, 'a, D> {
    /// The operators of `view`'s state (one process: the critical-step tools).
    pub fn new(view: &'v ViewNd<'a, D>) -> Self {
        Self {
            view,
            inv_sqrt_m: inverse_sqrt_mass(view),
        }
    }
}

impl<const D: usize> NodalPencil for NodalPencilNd<'_, '_, D> {
    fn len(&self) -> usize {
        self.view.n_nodes() * D
    }

    fn is_active(&self, k: usize) -> bool {
        self.view.node_active[k / D]
    }

    fn stiffness(&self, u: &[f64], y: &mut [f64]) {
        apply_scaled(self.view, &self.inv_sqrt_m, u, y);
    }

    fn consistent_mass(&self, u: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        let s = &self.inv_sqrt_m;
        let view = self.view;
        for p in 0..view.n_particles() {
            let m = view.mass[p];
            view.weights.with_row(p, |nodes, w, _| {
                // The particle's velocity interpolated from the scaled nodal vector.
                let mut vp = Vector::<D>::zeros();
                for (&i, &w) in nodes.iter().zip(w) {
                    let i = i as usize;
                    vp += Vector::<D>::from_fn(|a, _| u[i * D + a]) * (w * s[i]);
                }
                for (&i, &w) in nodes.iter().zip(w) {
                    let i = i as usize;
                    let c = m * w * s[i];
                    for a in 0..D {
                        y[i * D + a] += c * vp[a];
                    }
                }
            });
        }
    }
}

/// Number of active nodal unknowns of a view (`d` per active node): the size of the
/// reduced problem.
pub fn active_unknowns<const D: usize>(view: &ViewNd<'_, D>) -> usize {
    view.node_active.iter().filter(|&&a| a).count() * D
}

/// The full map's critical step of a view from the nodes
/// ([`crate::stability::nodal_full_map`]), Lanczos to a relative residual of `1e-10` (or
/// settled). `None` when no node is active, or above [`NODAL_FULL_MAP_LIMIT`] active nodal
/// unknowns.
pub fn critical_dt_nodal<const D: usize>(view: &ViewNd<'_, D>) -> Option<NodalCritical> {
    if active_unknowns(view) > NODAL_FULL_MAP_LIMIT {
        return None;
    }
    nodal_critical_dt(&NodalPencilNd::new(view), NodalLanczos::default())
}
