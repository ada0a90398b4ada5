//! The gradient metric `H_p = Σ_i ∇S_ip ∇S_ipᵀ / S_ip` of the element bound
//! ([`crate::limits_nd::element_bound`]) read off a particle's per-axis weight factors
//! ([`super::factors`]) without forming its row: O(D·n) per particle instead of O(nⁿ).
//!
//! With `S = Π_c s_c` and `∂_a S = s'_a Π_{c≠a} s_c` summed over the whole tensor-product
//! stencil,
//!
//! ```text
//! H_aa = (Σ_k s'_a[k]²/s_a[k]) · Π_{c≠a} Σ_k s_c[k],
//! H_ab = (Σ_k s'_a[k]) (Σ_k s'_b[k]) · Π_{c≠a,b} Σ_k s_c[k]      (a ≠ b).
//! ```
//!
//! Where the 1D weights sum to one and their derivatives to zero (a full stencil) this is
//! `diag(Σ_k s'_a²/s_a)`. The whole stencil is summed, inactive nodes included: the library's
//! metric leaves those out, and every left-out term is positive semi-definite, so the
//! metric here bounds it from above in the Loewner order and the bound built from it is
//! still an upper bound of `λmax(M⁻¹K)`. A 1D factor of zero weight and non-zero derivative
//! (a linear hat's particle on a node) makes the metric unbounded (`None`), unless the
//! derivative is a round-off residue (`|s'|·h ≤ 10⁻⁹`, as in
//! [`crate::limits_nd::element_bound`]).

use super::factors::AxisFactors;
use super::Vector;

/// One particle's `λ_p` of the element bound ([`crate::limits_nd::element_bound`]) from its gradient metric `H_p`, given as its largest
/// Gershgorin row sum `row_sum ≥ λmax(H_p)` and its trace, its `V_p/m_p` and its tangent
/// moduli: `(V_p/m_p)·min(row_sum·max(Dλ_t + 2μ_t, 2μ_t), tr(H_p)·max(λ_t + 2μ_t, 2μ_t))`.
/// What a stepper computes in its own pass to hand the bound over
/// ([`crate::nd::SummaryNd::element_bound`]): for tensor-product weights `H_p` is diagonal,
/// `H_aa = Σ_k s'_k²/s_k` over axis `a`'s weights; for MLS-MPM's gradients `H_p = (4/h²) I`.
#[inline]
pub fn from_metric<const D: usize>(row_sum: f64, trace: f64, per_mass: f64, l: f64, m: f64) -> f64 {
    let c_vol = (D as f64 * l + 2.0 * m).max(2.0 * m);
    let c_p = (l + 2.0 * m).max(2.0 * m);
    per_mass * (row_sum * c_vol).min(trace * c_p)
}

/// `|s'|·h` below which a derivative at a factor of zero weight counts as round-off.
const ROUND_OFF: f64 = 1e-9;

/// The largest Gershgorin row sum and the trace of the metric of factors `f` with `n`
/// nodes per axis (module docs); `h` the cell sizes. `None` where it is unbounded.
#[inline]
#[allow(clippy::needless_range_loop)] // a, b, c index several per-axis tables
pub fn gradient_metric<const D: usize>(
    f: &[AxisFactors; D],
    n: usize,
    h: &[f64; D],
) -> Option<(f64, f64)> {
    let mut sum_s = [0.0f64; D];
    let mut sum_d = [0.0f64; D];
    let mut quad = [0.0f64; D];
    for a in 0..D {
        for k in 0..n.min(3) {
            let (s, d) = (f[a].s[k], f[a].d[k]);
            sum_s[a] += s;
            sum_d[a] += d;
            if s > 0.0 {
                quad[a] += d * d / s;
            } else if d.abs() * h[a] > ROUND_OFF {
                return None;
            }
        }
    }
    let mut trace = 0.0;
    let mut row_max = 0.0f64;
    for a in 0..D {
        let mut diag = quad[a];
        for c in 0..D {
            if c != a {
                diag *= sum_s[c];
            }
        }
        trace += diag;
        let mut row = diag.abs();
        if sum_d[a] != 0.0 {
            for b in 0..D {
                if b == a {
                    continue;
                }
                let mut off = sum_d[a] * sum_d[b];
                for c in 0..D {
                    if c != a && c != b {
                        off *= sum_s[c];
                    }
                }
                row += off.abs();
            }
        }
        row_max = row_max.max(row);
    }
    Some((row_max, trace))
}

/// The element bound `max_p λ_p` and the speed-of-sound unit step
/// `min_p min_a h_a/(c_p + |v_{p,a}|)` accumulated particle by particle inside a pass that
/// forms the factors anyway (the reference solver's particle → grid pass), so that handing
/// them over ([`crate::nd::SummaryNd`]) costs no pass of its own.
#[derive(Clone, Debug)]
pub(crate) struct ParticleBounds<'a, const D: usize> {
    /// Tangent moduli `λ_t`, `μ_t` and density of the state's particles.
    pub lame_lambda: &'a [f64],
    pub lame_mu: &'a [f64],
    pub density: &'a [f64],
    /// Cell sizes.
    pub h: [f64; D],
    /// `max_p λ_p` so far (`+∞` once a metric is unbounded, NaN once a value is).
    pub bound: f64,
    /// Per axis, the largest signal speed `c_p + |v_{p,a}|` so far: the unit step is
    /// `min_a h_a / max_p (c_p + |v_{p,a}|)`, which equals `min_p min_a h_a/(c_p + |v_{p,a}|)`
    /// exactly (a correctly rounded division is monotone in its divisor) at one division
    /// per axis instead of one per particle and axis.
    pub fastest: [f64; D],
    /// Every wave speed so far is finite.
    pub speeds_finite: bool,
}

#[cfg_attr(not(feature = "reference"), allow(dead_code))] // used by the reference solvers
impl<'a, const D: usize> ParticleBounds<'a, D> {
    /// An empty accumulator for a pass that hands each particle's moduli and density to
    /// [`Self::add_values`] itself (it reads no particle fields of its own).
    pub fn detached(h: [f64; D]) -> Self {
        Self::new(&[], &[], &[], h)
    }

    /// An empty accumulator over these particle fields.
    pub fn new(
        lame_lambda: &'a [f64],
        lame_mu: &'a [f64],
        density: &'a [f64],
        h: [f64; D],
    ) -> Self {
        Self {
            lame_lambda,
            lame_mu,
            density,
            h,
            bound: 0.0,
            fastest: [0.0; D],
            speeds_finite: true,
        }
    }

    /// Adds particle `p` with velocity `v`, `V_p/m_p` = `per_mass` and its factors (`None`:
    /// its stencil could not be formed, the bound `+∞`). The wave speed and the unit step
    /// are formed exactly as [`crate::limits_nd::sound_speed::pass_unit_step`] forms them.
    #[inline(always)]
    pub fn add(
        &mut self,
        p: usize,
        v: &Vector<D>,
        per_mass: f64,
        factors: Option<(&[AxisFactors; D], usize)>,
    ) {
        let moduli = (self.lame_lambda[p], self.lame_mu[p]);
        self.add_values(moduli, self.density[p], v, per_mass, factors);
    }

    /// [`Self::add`] for a particle of tangent moduli `(λ_t, μ_t)` = `moduli` and
    /// density `density`, read by the caller (a pass that is writing them).
    #[inline(always)]
    pub fn add_values(
        &mut self,
        (l, m): (f64, f64),
        density: f64,
        v: &Vector<D>,
        per_mass: f64,
        factors: Option<(&[AxisFactors; D], usize)>,
    ) {
        let c = ((l + 2.0 * m) / density).sqrt();
        self.speeds_finite &= c.is_finite();
        for a in 0..D {
            // `max` skips a NaN as the per-particle `min` of the quotients did.
            self.fastest[a] = self.fastest[a].max(c + v[a].abs());
        }
        let lambda_p = match factors.and_then(|(f, n)| gradient_metric(f, n, &self.h)) {
            Some((row_sum, trace)) => from_metric::<D>(row_sum, trace, per_mass, l, m),
            None => f64::INFINITY,
        };
        // A NaN is kept once seen, so that the limit refuses it.
        if lambda_p.is_nan() || (!self.bound.is_nan() && lambda_p > self.bound) {
            self.bound = lambda_p;
        }
    }

    /// Takes in what `other` accumulated over other particles. The largest bound, the
    /// smallest step and the NaN rules do not depend on the order particles were added
    /// in, so accumulators merged in any order equal one that saw every particle.
    pub fn merge(&mut self, other: &Self) {
        if other.bound.is_nan() || (!self.bound.is_nan() && other.bound > self.bound) {
            self.bound = other.bound;
        }
        for a in 0..D {
            self.fastest[a] = self.fastest[a].max(other.fastest[a]);
        }
        self.speeds_finite &= other.speeds_finite;
    }

    /// `(bound, unit step)`, the unit step NaN where a wave speed was not finite.
    pub fn result(&self) -> (f64, f64) {
        let unit = if self.speeds_finite {
            (0..D).fold(f64::INFINITY, |u, a| u.min(self.h[a] / self.fastest[a]))
        } else {
            f64::NAN
        };
        (self.bound, unit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nd::factors::form_row;
    use crate::nd::Vector;

    /// The metric from the factors equals the one summed over the formed row.
    #[test]
    fn matches_the_formed_row() {
        let mut f = [AxisFactors::default(); 2];
        f[0].s = [0.2, 0.5, 0.3];
        f[0].d = [-1.1, 0.4, 0.9]; // not summing to 0: off-diagonal terms
        f[1].s = [0.125, 0.75, 0.125];
        f[1].d = [-0.5, 0.0, 0.5];
        let (mut nodes, mut s, mut g) = ([0u32; 9], [0.0; 9], [Vector::<2>::zeros(); 9]);
        form_row(&f, 3, &mut nodes, &mut s, &mut g);
        let mut h = [[0.0; 2]; 2];
        for m in 0..9 {
            for a in 0..2 {
                for b in 0..2 {
                    h[a][b] += g[m][a] * g[m][b] / s[m];
                }
            }
        }
        let (row, trace) = gradient_metric(&f, 3, &[1.0, 1.0]).unwrap();
        let row_ref = (0..2)
            .map(|a| h[a][0].abs() + h[a][1].abs())
            .fold(0.0f64, f64::max);
        assert!((trace - (h[0][0] + h[1][1])).abs() < 1e-12 * trace);
        assert!((row - row_ref).abs() < 1e-12 * row);
    }

    #[test]
    fn a_hat_on_a_node_is_unbounded() {
        let mut f = [AxisFactors::default(); 2];
        f[0].s = [1.0, 0.0, 0.0];
        f[0].d = [-1.0, 1.0, 0.0];
        f[1].s = [0.5, 0.5, 0.0];
        f[1].d = [-1.0, 1.0, 0.0];
        assert_eq!(gradient_metric(&f, 2, &[1.0, 1.0]), None);
    }
}
