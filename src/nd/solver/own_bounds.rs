//! The reference solver's side of the stepper contract ([`crate::nd::SummaryNd`]): the
//! element bound and the speed-of-sound step of a state, handed over with its totals so
//! that the stability and sound-speed limits make no pass of their own.
//!
//! Both come from one pass over the particles' positions (their per-axis weight factors
//! formed again, as every pass of this solver forms them), moduli, density and velocity,
//! with no stencil row formed: each particle's `λ_p` from its gradient metric
//! ([`crate::nd::factor_metric`], an upper bound of the one the library would compute) and
//! [`crate::limits_nd::element_bound::from_metric`], and `min_a h_a/(c_p + |v_{p,a}|)`
//! exactly as [`crate::limits_nd::SoundSpeedNd::unit_step`] forms it. On a grid split over
//! processes both are the whole run's (two scalar reductions).

use super::{SolverNd, StateNd};
use crate::limits_nd::element_bound::from_metric;
use crate::nd::factor_metric::gradient_metric;
use crate::nd::kernels::axis_factors;

impl<const D: usize> SolverNd<D> {
    /// `(element bound, speed-of-sound unit step)` of state `s` (module docs), the whole
    /// run's on a split grid (every process takes part in the reductions). A particle whose metric is
    /// unbounded makes the bound `+∞`; a non-finite wave speed makes the unit step NaN
    /// (the sound-speed limit then makes its own pass and names the particle).
    /// With `failed` (this process's trial failed) it computes nothing and only takes part
    /// in the reductions.
    pub(super) fn own_bounds(&self, s: &StateNd<D>, failed: bool) -> (Option<f64>, Option<f64>) {
        let local = match failed {
            true => (None, None),
            false => self.own_bounds_local(s),
        };
        let Some(slab) = self.split.slab() else {
            return local;
        };
        // Every process reduces, whether or not it has factors: NaN marks "none here".
        let (bound, unit) = local;
        let reduce = slab.reduce();
        let b = bound.unwrap_or(f64::NAN);
        let (neg_max, bound_nan) =
            reduce.min_and_any(if b.is_nan() { 0.0 } else { -b }, b.is_nan());
        let u = unit.unwrap_or(f64::NAN);
        let (min_unit, unit_nan) =
            reduce.min_and_any(if u.is_nan() { f64::INFINITY } else { u }, u.is_nan());
        let bound = (!bound_nan).then_some(-neg_max);
        let unit = (!unit_nan).then_some(min_unit);
        (bound, unit)
    }

    /// [`Self::own_bounds`] of this process's particles.
    fn own_bounds_local(&self, s: &StateNd<D>) -> (Option<f64>, Option<f64>) {
        let n = self.shape.nodes_per_axis();
        let strides: [usize; D] = std::array::from_fn(|a| self.grid.stride(a));
        let h: [f64; D] = std::array::from_fn(|a| self.grid.h[a]);
        let mut bound = 0.0f64;
        let mut unit = f64::INFINITY;
        let mut speeds_finite = true;
        for p in 0..s.x.len() {
            let (l, m) = (s.moduli.lambda[p], s.moduli.mu[p]);
            let c = ((l + 2.0 * m) / s.density[p]).sqrt();
            speeds_finite &= c.is_finite();
            for (a, &ha) in h.iter().enumerate() {
                unit = unit.min(ha / (c + s.v[p][a].abs()));
            }
            let factors = axis_factors(
                &self.grid,
                self.shape,
                &strides,
                &s.x[p],
                &s.carried.domain[p],
            );
            let lambda_p = match factors.and_then(|f| gradient_metric(&f, n, &h)) {
                Some((row_sum, trace)) => {
                    let per_mass =
                        crate::nd::det(&s.f[p]) * s.carried.volume0[p] / s.carried.mass[p];
                    from_metric::<D>(row_sum, trace, per_mass, l, m)
                }
                None => f64::INFINITY,
            };
            // A NaN is kept once seen, so that the limit refuses it.
            if lambda_p.is_nan() || (!bound.is_nan() && lambda_p > bound) {
                bound = lambda_p;
            }
        }
        (
            Some(bound),
            Some(if speeds_finite { unit } else { f64::NAN }),
        )
    }
}
