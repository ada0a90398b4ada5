//! The weights and nodal fields of one state from its particle fields, for a view built by
//! a solver that keeps only particles (a foreign solver, a binding to another language):
//! the reference solver's own kernels, public.
//!
//! * [`compute_weights`] — `S_ip = Π_a s_a(x_p,a − X_i,a)` and `∂_a S_ip = s'_a Π_{b≠a} s_b`
//!   at the particle positions ([`ShapeNd`]);
//! * [`NodalFieldsNd::compute`] — `m_i = Σ_p S_ip m_p` (eq 7), `v_i = Σ_p S_ip m_p v_p / m_i`
//!   (eq 17), `a_i = (−Σ_p V_p σ_p ∇S_ip)/m_i + g` (eq 18) with `V_p = det(F_p) V⁰_p`; a node
//!   that is constrained (on or beyond a fixed wall) or has `m_i ≤ threshold` is inactive,
//!   with `v_i = a_i = 0`.

use super::{kernels, GridNd, ShapeNd, Tensor, Vector, WeightsNd};

/// Relative nodal-mass threshold of the reference solver: nodes with
/// `m_i ≤ 1e-14 · min_p m_p` are inactive (a `threshold` for [`NodalFieldsNd::compute`]).
pub const INACTIVE_MASS_RATIO: f64 = 1e-14;

/// Fills `weights` with `S_ip`, `∇S_ip` of `shape` at positions `x` on `grid` (`domain`:
/// the GIMP particle domain lengths per axis, ignored by the other shapes). On error, the
/// first particle whose stencil leaves the stored nodes (past a fixed wall).
pub fn compute_weights<const D: usize>(
    grid: &GridNd<D>,
    shape: ShapeNd,
    x: &[Vector<D>],
    domain: &[Vector<D>],
    weights: &mut WeightsNd<D>,
) -> Result<(), usize> {
    kernels::compute_weights(grid, shape, x, domain, weights)
}

/// The nodal fields of one state (module docs), in reusable buffers.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodalFieldsNd<const D: usize> {
    /// `m_i` (eq 7).
    pub mass: Vec<f64>,
    /// `v_i` (eq 17); zero at inactive nodes.
    pub velocity: Vec<Vector<D>>,
    /// `a_i` (eq 18); zero at inactive nodes.
    pub acceleration: Vec<Vector<D>>,
    /// Constrained nodes (on or beyond a fixed wall), per stored node of the grid.
    pub constrained: Vec<bool>,
    /// Whether a node is active.
    pub active: Vec<bool>,
    /// The grid `constrained` was computed for.
    constrained_on: Option<GridNd<D>>,
}

/// The particle fields [`NodalFieldsNd::compute`] reads.
#[derive(Clone, Copy, Debug)]
pub struct ParticleFieldsNd<'a, const D: usize> {
    /// Masses `m_p`.
    pub mass: &'a [f64],
    /// Initial volumes `V⁰_p`.
    pub volume0: &'a [f64],
    /// Velocities `v_p`.
    pub v: &'a [Vector<D>],
    /// Cauchy stresses `σ_p`.
    pub sigma: &'a [Tensor<D>],
    /// Deformation gradients `F_p`.
    pub f: &'a [Tensor<D>],
}

impl<const D: usize> NodalFieldsNd<D> {
    /// Overwrites the fields with those of `particles` under `weights` on `grid`, with body
    /// force `gravity` and inactive-mass `threshold` (module docs).
    pub fn compute(
        &mut self,
        grid: &GridNd<D>,
        weights: &WeightsNd<D>,
        particles: ParticleFieldsNd<'_, D>,
        gravity: &Vector<D>,
        threshold: f64,
    ) {
        if self.constrained_on.as_ref() != Some(grid) {
            self.constrained = (0..grid.n_nodes())
                .map(|i| grid.is_constrained(i))
                .collect();
            self.constrained_on = Some(grid.clone());
        }
        // Stored weights: every row is there.
        let _ = kernels::particle_to_grid(
            &weights.into(),
            particles.mass,
            particles.volume0,
            particles.v,
            particles.sigma,
            particles.f,
            gravity,
            &self.constrained,
            threshold,
            &mut self.mass,
            &mut self.velocity,
            &mut self.acceleration,
            &mut self.active,
            &|_, _, _| {},
            None,
        );
    }
}
