//! Tangent Lamé moduli `(λ_t, μ_t)` of common hyperelastic models, for a view's
//! [`lame_lambda`](crate::nd::ViewNd::lame_lambda) and [`lame_mu`](crate::nd::ViewNd::lame_mu).
//!
//! The limits read per particle an isotropic pair: `λ_t + 2μ_t` gives the P-wave speed
//! `√((λ_t + 2μ_t)/ρ)` of the sound-speed limit, `max(Dλ_t + 2μ_t, 2μ_t)` (the largest
//! eigenvalue of the isotropic `C` on symmetric tensors) the element bound. For a model whose
//! tangent is anisotropic the pair has to bound both from above.
//!
//! ```
//! use mpm_dt::nd::Tensor;
//! use mpm_dt::tangent;
//!
//! let f = Tensor::<2>::new(1.1, 0.2, 0.0, 0.9); // a particle's deformation gradient
//! let (lambda_t, mu_t) = tangent::fixed_corotated(10.0, 1.0, &f);
//! assert!(lambda_t.is_finite() && lambda_t + 2.0 * mu_t > 0.0);
//! // At rest both models give the small-strain pair back exactly.
//! assert_eq!(tangent::fixed_corotated(10.0, 1.0, &Tensor::<3>::identity()), (10.0, 1.0));
//! assert_eq!(tangent::neo_hookean(10.0, 1.0, &Tensor::<3>::identity()), (10.0, 1.0));
//! ```
//!
//! # Notation
//!
//! `P = ∂Ψ/∂F` the first Piola stress, `A = ∂P/∂F`, `J = det F`. The spatial tangent
//! `a_ijkl = (1/J) F_jJ F_lL A_iJkL` gives the stress-power form `δL : a : δL` per current
//! volume for a velocity-gradient perturbation `δL` (`δF = δL F`); the acoustic tensor is
//! `Q_ik(n) = a_ijkl n_j n_l`, and `ρc² ≤ max_n λmax(Q(n))` for every wave speed `c`. For a
//! hyperelastic model `a = c + δ_ik σ_jl`: the elasticity tensor `c` plus the initial-stress
//! term, so `Q(n) = c(n) + (n·σn) I`.
//!
//! # Neo-Hookean ([`neo_hookean`])
//!
//! For `σ = (μ/J)(F Fᵀ − I) + (λ/J) ln J · I` the spatial elasticity tensor is isotropic,
//! `c = λ_t I⊗I + 2μ_t 𝕀` with `λ_t = λ/J`, `μ_t = (μ − λ ln J)/J` (Bonet & Wood): exact,
//! the pair the reference solver reports. It does not contain the initial-stress term
//! `(n·σn) I` of the acoustic tensor (small next to `λ_t + 2μ_t` at moderate strains).
//!
//! # Fixed corotated ([`fixed_corotated`]): the bound and its derivation
//!
//! `Ψ = μ Σ_i (s_i − 1)² + λ/2 (J − 1)²` (Stomakhin et al. 2012), `s_i` the singular values
//! of `F = U Σ Vᵀ`, `ψ_i = ∂Ψ/∂s_i = 2μ(s_i − 1) + λ(J − 1)J/s_i`. In the principal frames
//! (`δL̂ = Uᵀ δL U`, `δF̂ = δL̂ Σ`) `A` splits into the Hessian `H_ij = ∂²Ψ/∂s_i∂s_j` on the
//! diagonal entries and, per pair `i < j`, the "twist" block
//! `[[α, β], [β, α]]` on `(δF̂_ij, δF̂_ji)` with `α = (s_iψ_i − s_jψ_j)/(s_i² − s_j²)
//! = 2μ(1 − 1/(s_i + s_j))`, `β = (s_jψ_i − s_iψ_j)/(s_i² − s_j²)
//! = 2μ/(s_i + s_j) − λ(J − 1)J/(s_i s_j)` (eigenvalues `(ψ_i ∓ ψ_j)/(s_i ∓ s_j)`). With
//! `Ĝ = ΣHΣ/J = diag(2μ s_i²/J − λ(J − 1)) + λ(2J − 1) 11ᵀ`:
//!
//! **Acoustic tensor.** For `δL = v⊗n` (unit `v`, `n`; `v̂ = Uᵀv`, `n̂ = Uᵀn`) put
//! `p_i = v̂_i n̂_i`, `q_ij = v̂_i n̂_j` (`i ≠ j`); `Σp_i² + Σq_ij² = 1` and `q_ij q_ji = p_i p_j`,
//! so the twist blocks' cross terms join the diagonal ones, exactly:
//! `v·Q(n)v = λJ (Σp_i)² + (2μ/J) pᵀMp + Σ_{i≠j} (α_ij s_j²/J) q_ij²` with
//! `M_ii = s_i²`, `M_ij = s_i s_j/(s_i + s_j)`. Writing `1/(s_i + s_j) = ∫₀^∞ e^{−t s_i}
//! e^{−t s_j} dt` and using Cauchy–Schwarz with `Σ|p_i| ≤ 1`:
//! `pᵀMp ≤ Σ (s_i² − s_i/2) p_i² + s_max/2`; with `(Σp_i)² ≤ 1`:
//!
//! `λmax(Q) ≤ P := λ⁺J + (μ/J)[s_max + max(max_i (2s_i² − s_i), max_{i≠j} 2(1 − 1/(s_i + s_j)) s_j²)]`.
//!
//! **Symmetric tensors.** On symmetric `δε̂` the form is block diagonal: `Ĝ` on the diagonal
//! entries, `g_ij = [μ(s_i² + s_j²) − μ(s_i − s_j)²/(s_i + s_j)]/J − λ(J − 1)` on each
//! `√2 δε̂_ij`; Weyl's inequality on `Ĝ` gives
//! `S := max(max_i 2μ s_i²/J − λ(J − 1) + D (λ(2J − 1))⁺, max_{i<j} g_ij)`.
//!
//! The pair is `λ_t = (S − P)/(D − 1)`, `μ_t = (P − λ_t)/2` (so `λ_t + 2μ_t = P`,
//! `Dλ_t + 2μ_t = S`); if that `λ_t < 0`, `(0, P/2)`; if that `μ_t < 0`, `(max(S/D, P), 0)`.
//! Both are non-negative: a negative `μ_t` would be exact in places (a dilation under
//! tension with `λ ≫ μ`, where the deviatoric eigenvalues `2μ s²/J − λ(J − 1)` of the
//! tangent are negative, much as the neo-Hookean `μ_t` is for `J > e^{μ/λ}`), but a
//! non-negative pair keeps the isotropic `C` positive semidefinite and every use of it
//! conservative; there the P-wave bound is `S/D` instead of `P`.
//!
//! **What is guaranteed** (for `J > 0`, `μ ≥ 0`, `D = 2, 3`, up to rounding):
//! `λ_t + 2μ_t ≥ max_{|n|=1} λmax(Q(n))` (the initial-stress term included) and
//! `max(Dλ_t + 2μ_t, 2μ_t) ≥ max_{|δε|=1, δε = δεᵀ} δε : a : δε`.
//! **Where it is tight:** exactly `(λ, μ)` at `F = I` (and any rotation, up to the
//! singular values' rounding) for `λ ≥ 0`; both bounds are exact for a pure dilation
//! `F = sR` with `J ≥ 1/2` where the pair needs no clamping. Under shear, stretch and compression with singular values in
//! `[0.5, 1.5]` and `λ/μ` in `[0, 10)` the P-wave bound was at most 1.19× (2D) and 1.40×
//! (3D) the largest acoustic eigenvalue found by finite differences, and reached it in places
//! (`tests/tangent_moduli.rs`).
//! **Not covered:** the isotropic `C` is *not* shown to dominate `a` as a quadratic form
//! (only its largest eigenvalue bounds `a`'s), so `K = Σ V Bᵀ C B` is not proved to bound
//! the model's stiffness in the Loewner order; for `λ < 0` the result uses `λ⁺ = max(λ, 0)`
//! and is not `(λ, μ)` at rest; an inverted or degenerate `F` (`J ≤ 0`), a negative `μ`,
//! non-finite input or `D ∉ {2, 3}` give `(NaN, NaN)`, which the controller's view check
//! rejects (naming `lame_lambda`) instead of stepping on a wrong bound.

mod batch;
mod singular3;

use crate::nd::{det, Tensor};
pub use batch::fixed_corotated_many;
#[cfg(test)]
use nalgebra::Matrix2;
use nalgebra::Matrix3;

/// Tangent moduli of the neo-Hookean model `σ = (μ/J)(F Fᵀ − I) + (λ/J) ln J · I`:
/// `(λ/J, (μ − λ ln J)/J)`, `J = det F`.
///
/// Exact: the model's spatial elasticity tensor is `λ_t I⊗I + 2μ_t 𝕀` (Bonet & Wood); the
/// acoustic tensor adds the initial-stress term `(n·σn) I` (module docs). `(λ, μ)` at
/// `F = I`; `J ≤ 0` gives NaN.
pub fn neo_hookean<const D: usize>(lambda: f64, mu: f64, f: &Tensor<D>) -> (f64, f64) {
    let j = det(f);
    if j <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    (lambda / j, (mu - lambda * j.ln()) / j)
}

/// An isotropic pair `(λ_t, μ_t)` bounding the fixed-corotated model's tangent at `F`
/// (`Ψ = μ Σ(s_i − 1)² + λ/2 (J − 1)²`, Stomakhin et al. 2012): `λ_t + 2μ_t` is at least the
/// largest eigenvalue of the acoustic tensor over all directions and `max(Dλ_t + 2μ_t, 2μ_t)`
/// at least the largest eigenvalue of the spatial tangent on symmetric tensors (per current
/// volume). `(λ, μ)` exactly at `F = I` (`λ ≥ 0`); the derivation, where it is tight and
/// what it does not cover (`J ≤ 0` gives NaN) are in the [module docs](self).
pub fn fixed_corotated<const D: usize>(lambda: f64, mu: f64, f: &Tensor<D>) -> (f64, f64) {
    let nan = (f64::NAN, f64::NAN);
    let j = det(f);
    if !(j > 0.0 && mu >= 0.0 && lambda.is_finite() && mu.is_finite() && j.is_finite()) {
        return nan;
    }
    let Some(s) = singular_values(f) else {
        return nan;
    };
    let s = &s[..D];
    let lp = lambda.max(0.0);
    let s_max = s.iter().fold(0.0f64, |m, &x| m.max(x));
    // The P-wave bound P = λ⁺ + 2μ + dp and the symmetric-tensor bound S = Dλ⁺ + 2μ + ds,
    // written as excesses over the rest values so that both vanish exactly at F = I.
    // Over unordered pairs: `α_ij`'s factor `2(1 − 1/(s_i + s_j))` and `g_ij` are symmetric;
    // two divisions per particle in 2D (`1/J`, `1/(s_0 + s_1)`), as a solver forms the
    // pair for every particle in every step.
    let inv_j = 1.0 / j;
    let mut m = f64::NEG_INFINITY;
    let mut ds_pairs = f64::NEG_INFINITY;
    for (i, &si) in s.iter().enumerate() {
        m = m.max(2.0 * si * si - si);
        for &sk in &s[i + 1..] {
            let inv_sum = 1.0 / (si + sk);
            let twist = 2.0 * (1.0 - inv_sum);
            m = m.max(twist * sk * sk).max(twist * si * si);
            let g = (si * si + sk * sk - (si - sk) * (si - sk) * inv_sum) * inv_j;
            ds_pairs = ds_pairs.max(mu * (g - 2.0) - lambda * (j - 1.0));
        }
    }
    let dp = lp * (j - 1.0) + mu * ((s_max + m) * inv_j - 2.0);
    let s2_max = s.iter().fold(0.0f64, |a, &x| a.max(x * x));
    let ds_diag = 2.0 * mu * (s2_max * inv_j - 1.0) - lambda * (j - 1.0)
        + D as f64 * ((lambda * (2.0 * j - 1.0)).max(0.0) - lp);
    let ds = ds_diag.max(ds_pairs - D as f64 * lp);
    let p_bound = (lp + 2.0 * mu + dp).max(0.0);
    let s_bound = (D as f64 * lp + 2.0 * mu + ds).max(0.0);
    let lambda_t = lp + (ds - dp) / (D as f64 - 1.0);
    let mu_t = mu + (dp - (lambda_t - lp)) / 2.0;
    if !(lambda_t.is_finite() && mu_t.is_finite()) {
        nan
    } else if lambda_t < 0.0 {
        (0.0, 0.5 * p_bound)
    } else if mu_t < 0.0 {
        ((s_bound / D as f64).max(p_bound), 0.0)
    } else {
        (lambda_t, mu_t)
    }
}

/// The singular values of `f` (the first `D` entries) for `D = 2, 3`.
fn singular_values<const D: usize>(f: &Tensor<D>) -> Option<[f64; 3]> {
    match D {
        2 => Some(singular_values_2x2(
            f[(0, 0)],
            f[(0, 1)],
            f[(1, 0)],
            f[(1, 1)],
        )),
        3 => Some(singular3::singular_values_3x3(&Matrix3::from_fn(|r, c| {
            f[(r, c)]
        }))),
        _ => None,
    }
}

/// The singular values of `[[a, b], [c, d]]` in closed form, largest first:
/// `(√((a + d)² + (c − b)²) ± √((a − d)² + (b + c)²))/2` (the half-sum and half-difference
/// of the norms of the matrix's conformal and anti-conformal parts); a few flops where an
/// iterative SVD takes about a hundred nanoseconds, which counts when a solver forms the
/// pair for every particle in every step. The smaller is `|q − r|/2`, exact also for `det < 0`.
fn singular_values_2x2(a: f64, b: f64, c: f64, d: f64) -> [f64; 3] {
    let q = ((a + d) * (a + d) + (c - b) * (c - b)).sqrt();
    let r = ((a - d) * (a - d) + (b + c) * (b + c)).sqrt();
    [0.5 * (q + r), (0.5 * (q - r)).abs(), 0.0]
}

/// A deterministic sequence in `[0, 1)` (xorshift64) for the tests of this module and its
/// submodules: no random-number crate in the library's tests.
#[cfg(test)]
fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rest_state_gives_the_small_strain_pair() {
        for &(l, m) in &[(10.0, 1.0), (0.0, 3.5), (1.3e9, 2.7e8), (0.7, 0.0)] {
            assert_eq!(fixed_corotated(l, m, &Tensor::<2>::identity()), (l, m));
            assert_eq!(fixed_corotated(l, m, &Tensor::<3>::identity()), (l, m));
            assert_eq!(neo_hookean(l, m, &Tensor::<2>::identity()), (l, m));
            assert_eq!(neo_hookean(l, m, &Tensor::<3>::identity()), (l, m));
        }
    }

    #[test]
    fn inverted_or_degenerate_f_gives_nan() {
        let inverted = Tensor::<2>::new(-1.0, 0.0, 0.0, 1.0);
        assert!(fixed_corotated(1.0, 1.0, &inverted).0.is_nan());
        assert!(neo_hookean(1.0, 1.0, &inverted).0.is_nan());
        assert!(fixed_corotated(1.0, 1.0, &Tensor::<3>::zeros()).1.is_nan());
        assert!(fixed_corotated(1.0, -1.0, &Tensor::<3>::identity())
            .0
            .is_nan());
    }

    #[test]
    fn closed_form_singular_values_match_the_svd() {
        let mut uniform = super::uniform(0x9e37_79b9_7f4a_7c15);
        let mut next = || uniform() * 4.0 - 2.0;
        for _ in 0..1000 {
            let (a, b, c, d) = (next(), next(), next(), next());
            let svd = Matrix2::new(a, b, c, d).singular_values();
            let (big, small) = (svd[0].max(svd[1]), svd[0].min(svd[1]));
            let s = singular_values_2x2(a, b, c, d);
            assert!((s[0] - big).abs() <= 1e-12 * big.max(1.0), "{s:?} {svd:?}");
            assert!(
                (s[1] - small).abs() <= 1e-12 * big.max(1.0),
                "{s:?} {svd:?}"
            );
        }
    }

    #[test]
    fn pure_dilation_is_exact() {
        // F = s I, J = s³ ≥ 1/2: the longitudinal wave's modulus P = λJ + 2μ s²/J and the
        // volumetric eigenvalue S = 2μ s²/J − λ(J − 1) + 3λ(2J − 1), both exactly.
        for &(s, l) in &[(0.8, 4.0), (1.0, 4.0), (1.3, 0.5)] {
            let m = 1.5;
            let (lt, mt) = fixed_corotated(l, m, &(Tensor::<3>::identity() * s));
            let j: f64 = s * s * s;
            let p = l * j + 2.0 * m * s * s / j;
            let sv = 2.0 * m * s * s / j - l * (j - 1.0) + 3.0 * l * (2.0 * j - 1.0);
            assert!((lt + 2.0 * mt - p).abs() < 1e-12 * p, "s = {s}");
            assert!((3.0 * lt + 2.0 * mt - sv).abs() < 1e-12 * sv, "s = {s}");
        }
    }
}
