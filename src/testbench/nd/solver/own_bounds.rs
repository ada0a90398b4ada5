//! The reference solver's side of the stepper contract ([`crate::nd::SummaryNd`]): the
//! element bound and the speed-of-sound step of a state, handed over with its totals so
//! that the stability and sound-speed limits make no pass of their own.
//!
//! Both are accumulated particle by particle ([`ParticleBounds`]) where the particle's
//! per-axis weight factors are formed anyway: in the particle → grid pass that derives a
//! trial's nodal fields ([`super::SolverNd::derive_state`]), with no stencil row formed
//! twice — each particle's `λ_p` from its gradient metric ([`crate::nd::factor_metric`],
//! an upper bound of the one the library would compute) and
//! [`crate::limits_nd::element_bound::from_metric`], and `min_a h_a/(c_p + |v_{p,a}|)`
//! exactly as [`crate::limits_nd::sound_speed::pass_unit_step`] forms it. A state the step did
//! not write (the initial one, one set by the user) takes a pass of its own. On a grid
//! split over processes both are the whole run's (two scalar reductions).

use super::{SolverNd, StateNd};
use crate::nd::factor_metric::ParticleBounds;
use crate::nd::kernels::axis_factors;

impl<const D: usize> SolverNd<D> {
    /// The accumulator of a pass over state `s`'s particles.
    pub(super) fn particle_bounds<'a>(&self, s: &'a StateNd<D>) -> ParticleBounds<'a, D> {
        let h: [f64; D] = std::array::from_fn(|a| self.grid.h[a]);
        ParticleBounds::new(&s.moduli.lambda, &s.moduli.mu, &s.density, h)
    }

    /// `(element bound, speed-of-sound unit step)` of state `s` by a pass of its own
    /// (module docs): the factors formed from the positions.
    pub(super) fn own_bounds_pass(&self, s: &StateNd<D>) -> (f64, f64) {
        let n = self.shape.nodes_per_axis();
        let strides: [usize; D] = std::array::from_fn(|a| self.grid.stride(a));
        let mut acc = self.particle_bounds(s);
        for p in 0..s.x.len() {
            let factors = axis_factors(
                &self.grid,
                self.shape,
                &strides,
                &s.x[p],
                &s.carried.domain[p],
            );
            let per_mass = crate::nd::det(&s.f[p]) * s.carried.volume0[p] / s.carried.mass[p];
            acc.add(p, &s.v[p], per_mass, factors.as_ref().map(|f| (f, n)));
        }
        acc.result()
    }

    /// The whole run's `(element bound, unit step)` from this process's `local` ones
    /// (`None`: this process has none, its trial failed): itself on an undivided grid,
    /// else the largest bound and the smallest step over the processes, `None` where some
    /// process had none or a NaN (every process takes part in the reductions).
    pub(super) fn whole_run_bounds(&self, local: Option<(f64, f64)>) -> (Option<f64>, Option<f64>) {
        let Some(slab) = self.split.slab() else {
            return match local {
                Some((b, u)) => (Some(b), Some(u)),
                None => (None, None),
            };
        };
        let (b, u) = local.unwrap_or((f64::NAN, f64::NAN));
        let reduce = slab.reduce();
        let (neg_max, bound_nan) =
            reduce.min_and_any(if b.is_nan() { 0.0 } else { -b }, b.is_nan());
        let (min_unit, unit_nan) =
            reduce.min_and_any(if u.is_nan() { f64::INFINITY } else { u }, u.is_nan());
        (
            (!bound_nan).then_some(-neg_max),
            (!unit_nan).then_some(min_unit),
        )
    }
}
