//! The tangent pairs of many particles at once ([`fixed_corotated_many`]): the 2D
//! fixed-corotated bound written branch-free, so that the loop over particles runs in SIMD
//! lanes (AVX2 where the CPU has it, [`crate::cpu`]).
//!
//! Every value is the one [`super::fixed_corotated`] returns for the same particle, bit
//! for bit: the same operations in the same order (Rust does not contract `a·b + c` into a
//! fused multiply–add, and SIMD square roots and divisions round as the scalar ones do);
//! the branches of the scalar version become selects between values computed anyway.

use crate::nd::Tensor;

/// The 2D fixed-corotated pair of one particle, branch-free (module docs): the formulas of
/// [`super::fixed_corotated`] for `D = 2`, with the singular values of
/// `[[a, b], [c, d]]` in closed form, for `D = 2` (the leading 2×2 block otherwise).
/// `lambda`, `mu` are checked by the caller (finite, `μ ≥ 0`).
#[inline(always)]
pub(super) fn fixed_corotated_2d<const D: usize>(
    lambda: f64,
    mu: f64,
    f: &Tensor<D>,
) -> (f64, f64) {
    let (a, b, c, d) = (f[(0, 0)], f[(0, 1)], f[(1, 0)], f[(1, 1)]);
    let j = a * d - b * c;
    let q = ((a + d) * (a + d) + (c - b) * (c - b)).sqrt();
    let r = ((a - d) * (a - d) + (b + c) * (b + c)).sqrt();
    let (s0, s1) = (0.5 * (q + r), (0.5 * (q - r)).abs());
    let lp = lambda.max(0.0);
    let s_max = 0.0f64.max(s0).max(s1);
    let inv_j = 1.0 / j;
    let inv_sum = 1.0 / (s0 + s1);
    let twist = 2.0 * (1.0 - inv_sum);
    let m = f64::NEG_INFINITY
        .max(2.0 * s0 * s0 - s0)
        .max(twist * s1 * s1)
        .max(twist * s0 * s0)
        .max(2.0 * s1 * s1 - s1);
    let g = (s0 * s0 + s1 * s1 - (s0 - s1) * (s0 - s1) * inv_sum) * inv_j;
    let ds_pairs = f64::NEG_INFINITY.max(mu * (g - 2.0) - lambda * (j - 1.0));
    let dp = lp * (j - 1.0) + mu * ((s_max + m) * inv_j - 2.0);
    let s2_max = 0.0f64.max(s0 * s0).max(s1 * s1);
    let ds_diag = 2.0 * mu * (s2_max * inv_j - 1.0) - lambda * (j - 1.0)
        + 2.0 * ((lambda * (2.0 * j - 1.0)).max(0.0) - lp);
    let ds = ds_diag.max(ds_pairs - 2.0 * lp);
    let p_bound = (lp + 2.0 * mu + dp).max(0.0);
    let s_bound = (2.0 * lp + 2.0 * mu + ds).max(0.0);
    let lambda_t = lp + (ds - dp) / 1.0;
    let mu_t = mu + (dp - (lambda_t - lp)) / 2.0;
    let valid = j > 0.0 && j.is_finite() && lambda_t.is_finite() && mu_t.is_finite();
    let clamp_lambda = lambda_t < 0.0;
    let clamp_mu = !clamp_lambda && mu_t < 0.0;
    let l = select(
        clamp_lambda,
        0.0,
        select(clamp_mu, (s_bound / 2.0).max(p_bound), lambda_t),
    );
    let m = select(clamp_lambda, 0.5 * p_bound, select(clamp_mu, 0.0, mu_t));
    (select(valid, l, f64::NAN), select(valid, m, f64::NAN))
}

/// `if c { x } else { y }` on values already computed (a select, not a branch).
#[inline(always)]
fn select(c: bool, x: f64, y: f64) -> f64 {
    if c {
        x
    } else {
        y
    }
}

/// The loop of [`fixed_corotated_many`] for 2D.
#[inline(always)]
fn many_2d<const D: usize>(
    lambda: f64,
    mu: f64,
    f: &[Tensor<D>],
    out_lambda: &mut [f64],
    out_mu: &mut [f64],
) {
    for ((f, l), m) in f.iter().zip(out_lambda.iter_mut()).zip(out_mu.iter_mut()) {
        (*l, *m) = fixed_corotated_2d(lambda, mu, f);
    }
}

/// [`many_2d`] compiled with AVX2 enabled.
///
/// # Safety
/// The CPU must support AVX2 ([`crate::cpu::has_avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn many_2d_avx2<const D: usize>(
    lambda: f64,
    mu: f64,
    f: &[Tensor<D>],
    out_lambda: &mut [f64],
    out_mu: &mut [f64],
) {
    many_2d(lambda, mu, f, out_lambda, out_mu)
}

/// The pairs [`super::fixed_corotated`] gives for every `F` in `f`, written to `out_lambda`
/// and `out_mu` (bit for bit the same values, several particles per instruction: about
/// 4× the one-at-a-time rate in 2D, `benches/tangent.rs`). For a solver that forms the
/// pair of all its particles in every step, before its particle → grid pass. In 3D the
/// particles are taken one at a time.
///
/// # Panics
/// If `out_lambda` or `out_mu` is not as long as `f`.
pub fn fixed_corotated_many<const D: usize>(
    lambda: f64,
    mu: f64,
    f: &[Tensor<D>],
    out_lambda: &mut [f64],
    out_mu: &mut [f64],
) {
    assert!(
        out_lambda.len() == f.len() && out_mu.len() == f.len(),
        "fixed_corotated_many: {} gradients, {} and {} outputs",
        f.len(),
        out_lambda.len(),
        out_mu.len()
    );
    let parameters_valid = mu >= 0.0 && lambda.is_finite() && mu.is_finite();
    match D == 2 && parameters_valid {
        #[cfg(target_arch = "x86_64")]
        true if crate::cpu::has_avx2() => {
            // SAFETY: the CPU has AVX2 (checked above).
            unsafe { many_2d_avx2(lambda, mu, f, out_lambda, out_mu) }
        }
        true => many_2d(lambda, mu, f, out_lambda, out_mu),
        false => {
            for (p, f) in f.iter().enumerate() {
                (out_lambda[p], out_mu[p]) = super::fixed_corotated(lambda, mu, f);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit patterns of a pair, so that NaNs compare equal.
    fn bits((l, m): (f64, f64)) -> (u64, u64) {
        (l.to_bits(), m.to_bits())
    }

    #[test]
    fn many_equals_one_at_a_time_bit_for_bit() {
        let mut uniform = super::super::uniform(0x5851_f42d_4c95_7f2d);
        let mut next = || uniform() - 0.5;
        // Near the rest state, strongly deformed, inverted, degenerate and non-finite.
        let mut f: Vec<Tensor<2>> = (0..2000)
            .map(|k| {
                let scale = [0.05, 0.5, 2.0][k % 3];
                Tensor::<2>::identity() + Tensor::<2>::from_fn(|_, _| scale * next())
            })
            .collect();
        f.extend([
            Tensor::<2>::zeros(),
            Tensor::<2>::new(-1.0, 0.0, 0.0, 1.0),
            Tensor::<2>::new(f64::NAN, 0.0, 0.0, 1.0),
            Tensor::<2>::new(f64::INFINITY, 0.0, 0.0, 1.0),
            Tensor::<2>::new(1e-300, 0.0, 0.0, 1e-300),
        ]);
        for &(lambda, mu) in &[(400.0, 200.0), (0.0, 3.5), (-0.3, 1.0), (5.0, 0.0)] {
            let (mut l, mut m) = (vec![0.0; f.len()], vec![0.0; f.len()]);
            fixed_corotated_many(lambda, mu, &f, &mut l, &mut m);
            for (p, f) in f.iter().enumerate() {
                let one = super::super::fixed_corotated(lambda, mu, f);
                assert_eq!(
                    bits((l[p], m[p])),
                    bits(one),
                    "F = {f}, (λ, μ) = ({lambda}, {mu})"
                );
            }
        }
    }

    #[test]
    fn invalid_parameters_give_nan_for_every_particle() {
        let f = vec![Tensor::<2>::identity(); 3];
        let (mut l, mut m) = (vec![0.0; 3], vec![0.0; 3]);
        fixed_corotated_many(1.0, -1.0, &f, &mut l, &mut m);
        assert!(l.iter().chain(&m).all(|x| x.is_nan()));
        fixed_corotated_many(f64::NAN, 1.0, &f, &mut l, &mut m);
        assert!(l.iter().chain(&m).all(|x| x.is_nan()));
    }
}
