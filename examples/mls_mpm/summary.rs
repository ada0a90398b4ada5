//! What the MLS-MPM solver hands the library from its own particle → grid pass when it
//! opts in ([`mpm_dt::nd::SummaryNd`]): the energies the growth monitor reads (its own
//! definition, [`PassTotals::complementary_energy`]), the
//! finiteness the controller checks, the speed-of-sound step and the element bound on
//! `λmax` — so that no limit makes a pass over the particles of its own.

use super::solver::Model;
use mpm_dt::limits_nd::element_bound::from_metric;
use mpm_dt::nd::{SummaryNd, Vector};
use nalgebra::{Matrix2, Vector2};

/// Totals accumulated particle by particle inside the pass.
pub struct PassTotals {
    finite: bool,
    kinetic: f64,
    strain: f64,
    first_moment: Vector2<f64>,
    element_bound: f64,
    unit_step: f64,
    /// `4/h²`, MLS-MPM's `D_p⁻¹` for quadratic B-splines.
    inv: f64,
    h: f64,
    /// The model's small-strain Lamé parameters (the growth monitor's energy).
    lambda: f64,
    mu: f64,
}

/// One particle's fields, as the pass has them.
pub struct ParticleFields<'a> {
    pub mass: f64,
    pub volume0: f64,
    pub x: &'a Vector2<f64>,
    pub v: &'a Vector2<f64>,
    pub f: &'a Matrix2<f64>,
    pub sigma: &'a Matrix2<f64>,
    pub density: f64,
    /// Its tangent pair `(λ_t, μ_t)` ([`Model::tangent`]).
    pub lame: (f64, f64),
}

impl PassTotals {
    /// Empty totals for a grid of spacing `h` and the material `model`.
    pub fn new(h: f64, model: &Model) -> Self {
        let (lambda, mu) = model.lame();
        Self {
            finite: true,
            kinetic: 0.0,
            strain: 0.0,
            first_moment: Vector2::zeros(),
            element_bound: 0.0,
            unit_step: f64::INFINITY,
            inv: 4.0 / (h * h),
            h,
            lambda,
            mu,
        }
    }

    /// Adds one particle. Its element bound is `(4/h²)(V_p/m_p)(2λ_t + 2μ_t)` with
    /// `V_p = det(F_p) V⁰_p` and its tangent pair: MLS-MPM's gradient metric is
    /// `(4/h²) I` (`mpm_dt::limits_nd::element_bound`), so this is what the library's pass
    /// would compute, in O(1); its signal speed takes `c_p = √((λ_t + 2μ_t)/ρ_p)`.
    #[inline]
    pub fn add(&mut self, p: &ParticleFields<'_>) {
        // One non-finite entry makes the sum non-finite.
        self.finite &= (p.x.sum() + p.v.sum() + p.f.sum() + p.sigma.sum()).is_finite();
        self.kinetic += 0.5 * p.mass * p.v.norm_squared();
        self.strain += self.complementary_energy(p);
        self.first_moment += p.mass * p.x;
        let volume = p.f.determinant() * p.volume0;
        // MLS-MPM's gradient metric is `(4/h²) I`: row sum `4/h²`, trace `2·4/h²`.
        let bound = from_metric::<2>(
            self.inv,
            2.0 * self.inv,
            volume / p.mass,
            p.lame.0,
            p.lame.1,
        );
        if bound.is_nan() || bound > self.element_bound {
            self.element_bound = bound;
        }
        let c = ((p.lame.0 + 2.0 * p.lame.1) / p.density).sqrt();
        let step = self.h / (c + p.v.amax());
        if step.is_nan() || step < self.unit_step {
            self.unit_step = step;
        }
    }

    /// `½ σ:C⁻¹:σ · det(F) V⁰` with the model's small-strain moduli: the energy the
    /// library's growth monitor sums in its own pass (`growth::Growth::energies`)
    /// at rest moduli — with the view's tangent pair its pass weighs the same stress by a
    /// slightly different `C⁻¹` (the generic path, `--generic`), while this one keeps a
    /// fixed quadratic form of the stress, which an elastic rebound does not raise. (The fluid's own
    /// stored energy `E (J − 1 − ln J)` is no indicator of stability: mpm88 advects `J`
    /// without conserving it, and splashing particles drift to large `J`; measured, it
    /// stopped the controlled run with 22 false growth detections.)
    #[inline]
    fn complementary_energy(&self, p: &ParticleFields<'_>) -> f64 {
        let (l, m) = (self.lambda, self.mu);
        let s = p.sigma;
        let volume = p.f.determinant() * p.volume0;
        if m > 0.0 {
            let tr = s.trace();
            0.5 * volume * (s.norm_squared() - l * tr * tr / (2.0 * m + 2.0 * l)) / (2.0 * m)
        } else if l > 0.0 {
            let pr = s.trace() / 2.0;
            0.5 * volume * 2.0 * pr * pr / (2.0 * l)
        } else {
            0.0
        }
    }

    /// The summary the view carries.
    pub fn finish(self) -> SummaryNd<2> {
        SummaryNd {
            finite: self.finite && self.element_bound.is_finite() && self.unit_step.is_finite(),
            kinetic: self.kinetic,
            strain: self.strain,
            first_moment: Vector::<2>::new(self.first_moment[0], self.first_moment[1]),
            element_bound: Some(self.element_bound),
            sound_unit_step: Some(self.unit_step),
        }
    }
}
