//! A guaranteed upper bound on `λmax(M⁻¹K)` from one pass over the particles: the
//! element eigenvalue inequality with particles as elements.
//!
//! # The bound
//!
//! The eq 56 operator of [`super::stiffness`] is assembled particle by particle:
//! `K = Σ_p K_p` with `K_p = V_p B_pᵀ C_p B_p`, and the lumped mass likewise,
//! `M = Σ_p M_p` with `M_p = diag(m_p S_ip)`. For any nodal velocity `u`,
//! `uᵀKu = Σ_p uᵀK_p u ≤ Σ_p λ_p uᵀM_p u ≤ (max_p λ_p) uᵀMu`, where `λ_p` is the largest
//! generalised eigenvalue of the pair `(K_p, M_p)` (Irons' element eigenvalue theorem, as
//! finite-element codes use it for the element-by-element time step). So
//!
//! ```text
//! λmax(M⁻¹K) ≤ max_p λ_p.
//! ```
//!
//! Restricting `u` to the active nodes (the operator's space) only lowers the left side.
//!
//! **One particle's `λ_p`.** With `L = Σ_i u_i ⊗ ∇S_ip` and `ε = sym L`,
//! `uᵀK_p u = V_p ε:C_p:ε` and `uᵀM_p u = m_p Σ_i S_ip |u_i|²`. The smallest weighted norm
//! that produces a given `L` is `m_p tr(L H_p⁻¹ Lᵀ)` with the particle's *gradient metric*
//!
//! ```text
//! H_p = Σ_i ∇S_ip ∇S_ipᵀ / S_ip        (a D×D symmetric matrix),
//! ```
//!
//! so `λ_p = (V_p/m_p) max_L ε:C_p:ε / tr(L H_p⁻¹ Lᵀ)`. Two upper bounds follow, and the
//! smaller is used:
//!
//! * `tr(L H⁻¹ Lᵀ) ≥ |L|²/λmax(H_p)` and `ε:C:ε ≤ c_vol |ε|²` with
//!   `c_vol = max(Dλ_t + 2μ_t, 2μ_t)` (the largest eigenvalue of the isotropic `C_p` on
//!   symmetric tensors): `λ_p ≤ (V_p/m_p) λmax(H_p) c_vol`, with `λmax(H_p)` bounded by
//!   its largest Gershgorin row sum;
//! * `|tr ε|, |ε| ≤ Σ_i |u_i||∇S_ip|` and Cauchy–Schwarz:
//!   `λ_p ≤ (V_p/m_p) tr(H_p) c_P`, `c_P = max(λ_t + 2μ_t, 2μ_t)`, i.e. `c_p² tr(H_p)`.
//!
//! For MLS-MPM's gradients `∇S_ip = (4/h²) S_ip (x_i − x_p)` the metric is exactly
//! `H_p = (4/h²) I` (the quadratic B-spline's second moment is `h²/4` per axis), so
//! `λ_p = (4/h²)(V_p/m_p) min(max(Dλ_t + 2μ_t, 2μ_t), D max(λ_t + 2μ_t, 2μ_t))` — that is
//! `(4/h²)(V_p/m_p)(Dλ_t + 2μ_t)` for `λ_t ≥ 0`, `(4/h²)(V_p/m_p) 2μ_t` for `λ_t < 0`
//! ([`from_metric`]): the bound is read off the particle's moduli and
//! density alone, and a solver can supply it from its own pass for nothing
//! ([`crate::nd::SummaryNd::element_bound`]).
//!
//! A node with `S_ip = 0` and `∇S_ip ≠ 0` (the linear hat's one-sided derivative at a
//! particle sitting on a node) makes `H_p` unbounded and the bound `+∞`: true, useless, and
//! reported as such (the stability limit then falls back to its motion guard). A gradient
//! with `|∇S_ip|·h ≤ 10⁻⁹` at a node of zero weight is the round-off residue of one that
//! vanishes with its weight (GIMP at the edge of a particle's domain) and is left out.
//!
//! # How tight
//!
//! An upper bound, not an estimate: on a uniform layout the true top mode spreads over
//! many particles and sits below the largest element's eigenvalue (measured ratios are in
//! `docs/performance.md`); for an isolated particle — a splash, a body's corner — the bound
//! *is* the eigenvalue. The stability limit uses it to decide when `λmax` must be
//! recomputed and as a ceiling on its cached value, not as its proposal.

use crate::nd::{Vector, ViewNd};
use crate::reduce::Reduce;

/// `|∇S_ip|·h` below which a gradient at a node of zero weight counts as round-off.
const ROUND_OFF: f64 = 1e-9;

/// The element bound of a state (module docs) and the particle that sets it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementBound {
    /// `max_p λ_p ≥ λmax(M⁻¹K)` (1/s²); `+∞` when some particle's gradient metric is
    /// unbounded, `NaN` when a particle's fields are not finite, 0 without particles.
    pub lambda: f64,
    /// This process's particle with the largest `λ_p` (`None` without particles or
    /// when another process's particle sets the bound).
    pub particle: Option<usize>,
}

/// One particle's `λ_p ≥` the largest generalised eigenvalue of `(K_p, M_p)` (module
/// docs). Nodes where `skip(i)` holds (inactive nodes, outside the operator's space) are
/// left out.
pub fn particle_bound<const D: usize>(
    view: &ViewNd<'_, D>,
    p: usize,
    skip: impl Fn(usize) -> bool,
) -> f64 {
    let h_max = view.grid.h.iter().fold(0.0f64, |m, &x| m.max(x));
    let metric = view.weights.with_row(p, |nodes, s, grad| {
        let mut h = [[0.0f64; D]; D];
        for ((&i, &s), g) in nodes.iter().zip(s).zip(grad) {
            if skip(i as usize) || *g == Vector::<D>::zeros() {
                continue;
            }
            if s <= 0.0 {
                // A round-off residue of a gradient that vanishes with its weight (GIMP at
                // the edge of a particle's domain) is left out; a real one is unbounded.
                if g.amax() * h_max <= ROUND_OFF {
                    continue;
                }
                return None;
            }
            for a in 0..D {
                for b in 0..D {
                    h[a][b] += g[a] * g[b] / s;
                }
            }
        }
        Some(h)
    });
    let Some(h) = metric else {
        return f64::INFINITY;
    };
    let trace: f64 = (0..D).map(|a| h[a][a]).sum();
    let row_sum = (0..D)
        .map(|a| h[a].iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0f64, f64::max);
    let per_mass = view.volume(p) / view.mass[p];
    from_metric::<D>(
        row_sum,
        trace,
        per_mass,
        view.lame_lambda[p],
        view.lame_mu[p],
    )
}

/// One particle's `λ_p` from its gradient metric (defined beside the metric's kernels,
/// which the solvers' own passes use too).
pub use crate::nd::factor_metric::from_metric;

/// The element bound of `view` (module docs): one pass over the particles' weights. In a
/// run split over processes the largest over every process (one reduction with `reduce`).
pub fn element_bound<const D: usize>(view: &ViewNd<'_, D>, reduce: &dyn Reduce) -> ElementBound {
    let inactive = |i: usize| !view.node_active[i];
    let mut lambda = 0.0f64;
    let mut particle = None;
    for p in 0..view.n_particles() {
        let l = particle_bound(view, p, inactive);
        // A NaN is kept once seen, so that it propagates.
        if l.is_nan() || (!lambda.is_nan() && l > lambda) {
            lambda = l;
            particle = Some(p);
        }
    }
    let mine = if lambda.is_nan() { 0.0 } else { lambda };
    let (neg_max, any_nan) = reduce.min_and_any(-mine, lambda.is_nan());
    let agreed = if any_nan { f64::NAN } else { -neg_max };
    ElementBound {
        lambda: agreed,
        particle: particle.filter(|_| lambda.is_nan() || lambda >= agreed),
    }
}
