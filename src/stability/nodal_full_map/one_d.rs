//! The 1D operators of the full map reduced to the nodes ([`super`]): with `D_ip` the
//! weight gradients, `S_ip` the weights and `V_p = F_p V⁰_p`,
//!
//! ```text
//! (A_s u)_i = s_i Σ_p D_ip V_p E_p Σ_j D_jp s_j u_j,   (Q_s u)_i = s_i Σ_p S_ip m_p Σ_j S_jp s_j u_j,
//! ```
//!
//! `s_i = 1/√m_i` at active nodes and 0 at inactive and constrained ones (as in the dense
//! map, [`crate::stability::full_map`]).

use super::{
    active_unknowns, nodal_critical_dt, NodalCritical, NodalLanczos, NodalPencil,
    NODAL_FULL_MAP_LIMIT,
};
use crate::stability::error::check_view;
use crate::stability::StabilityError;
use crate::stepper::View;
use crate::weights::{WeightKind, Weights};

/// The reduced operators of one frozen 1D state.
pub struct NodalPencil1d<'a> {
    weights: &'a Weights,
    /// `m_p`.
    mass: &'a [f64],
    /// `V_p E_p`.
    stiffness: Vec<f64>,
    /// `1/√m_i` at active nodes, 0 elsewhere.
    inv_sqrt_m: Vec<f64>,
    active: &'a [bool],
}

impl<'a> NodalPencil1d<'a> {
    /// The operators of `view`'s state (typed errors on invalid fields).
    pub fn new(view: &View<'a>) -> Result<Self, StabilityError> {
        check_view(view)?;
        Ok(Self {
            weights: view.weights.get(),
            mass: view.mass,
            stiffness: (0..view.x.len())
                .map(|p| view.f[p] * view.volume0[p] * view.tangent_modulus[p])
                .collect(),
            inv_sqrt_m: view
                .node_mass
                .iter()
                .zip(view.node_active)
                .map(|(&m, &a)| if a { 1.0 / m.sqrt() } else { 0.0 })
                .collect(),
            active: view.node_active,
        })
    }

    /// `y = s ⊙ Kindᵀ (c ⊙ Kind (s ⊙ u))` for the weights of `kind` and particle factors `c`.
    fn sandwich(&self, kind: WeightKind, c: &[f64], u: &[f64], y: &mut [f64]) {
        let su: Vec<f64> = u.iter().zip(&self.inv_sqrt_m).map(|(u, s)| u * s).collect();
        let mut particle = vec![0.0; c.len()];
        self.weights.gather(kind, &su, &mut particle);
        particle.iter_mut().zip(c).for_each(|(x, c)| *x *= c);
        self.weights.scatter(kind, &particle, y);
        y.iter_mut()
            .zip(&self.inv_sqrt_m)
            .for_each(|(y, s)| *y *= s);
    }
}

impl NodalPencil for NodalPencil1d<'_> {
    fn len(&self) -> usize {
        self.inv_sqrt_m.len()
    }

    fn is_active(&self, k: usize) -> bool {
        self.active[k]
    }

    fn stiffness(&self, u: &[f64], y: &mut [f64]) {
        self.sandwich(WeightKind::D, &self.stiffness, u, y);
    }

    fn consistent_mass(&self, u: &[f64], y: &mut [f64]) {
        self.sandwich(WeightKind::S, self.mass, u, y);
    }
}

/// The full map's critical step of a 1D state from the nodes ([`super`]), Lanczos to a
/// relative residual of `1e-10` (or settled); `Ok(None)` when the operator vanishes or the
/// state has more than [`NODAL_FULL_MAP_LIMIT`] active nodes.
pub fn critical_dt_nodal_1d(view: &View<'_>) -> Result<Option<NodalCritical>, StabilityError> {
    let pencil = NodalPencil1d::new(view)?;
    if active_unknowns(&pencil) > NODAL_FULL_MAP_LIMIT {
        return Ok(None);
    }
    Ok(nodal_critical_dt(&pencil, NodalLanczos::default()))
}
