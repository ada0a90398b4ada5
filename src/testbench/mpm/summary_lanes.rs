//! The pass summary's reductions inside the particle pass ([`crate::PassSummary`]).
//!
//! For every particle of the trial the pass computes, as the state's lazy cells would,
//!
//! ```text
//! E_t = E_t(F)              ρ = m / (F V⁰)            (written out: the view's fields)
//! c²  = max_p E_t/ρ         |v|max = max_p |v_p|      (maxima)
//! signal = max_p (√(E_t/ρ) + |v_p|)                   (the sound-speed limit's maximum)
//!
//! **The signal speed's square roots.** The AVX2 chunks take `√` only for a chunk where
//! some lane may raise its running maximum `S`: a particle with `|v| < S` and
//! `E_t/ρ < (S − |v|)² (1 − 10⁻¹²)` cannot (its `√(E_t/ρ) + |v|` rounds to at most `S`; the
//! margin covers the rounding of the test itself), so the maximum is the same bit for bit
//! as with a root for every particle, at a fraction of the roots once `S` is near its
//! final value (a uniform material after its first chunks).
//! energy = Σ_p ½ m v² + ½ σ² F V⁰ / E_t               (crate::controller::total_energy)
//! ok  = every E_t and ρ positive and finite
//! ```
//!
//! particle `p` in lane `p mod 4` ([`ENERGY_LANES`]), each lane receiving its particles in
//! order, so the energy has `total_energy`'s bits and the maxima (order-free) the scans'.
//!
//! **Two builds, the same bits.** The portable loops are what the baseline build runs; on a
//! CPU with AVX2 the full chunks of four particles run in explicit 4-wide intrinsics
//! ([`avx2::chunks`]) doing the same operations in the same order (no FMA; maxima and
//! minima as compare-and-select, which equal `f64::max`/`min` for values without NaN — a NaN
//! `E_t` or `ρ` fails `ok` and drops the summary). The compiler vectorised the portable
//! loops only partly: the intrinsics took the summary's cost in the pass at 10⁵ particles
//! from 0.3–0.4 ms to the figure in README "Controller overhead".

use super::material::Material;
use crate::controller::{particle_energy, sum_energy_lanes, ENERGY_LANES};
use crate::pass_summary::PassSummary;

/// Lanes of the reductions (one AVX2 vector of `f64`).
const L: usize = ENERGY_LANES;

/// What the pass found for the [`PassSummary`]: the reductions, and whether every particle's
/// `E_t` and `ρ` are positive and finite (the other particle checks are the pass's own
/// failure flags; the node checks come from `finalize`).
pub(super) struct SummaryParts {
    pub summary: PassSummary,
    pub ok: bool,
}

/// The summary's running reductions in the pass (module docs).
pub(super) struct SummaryLanes {
    c2: [f64; L],
    speed: [f64; L],
    signal: [f64; L],
    energy: [f64; L],
    ok: bool,
}

/// One block's per-lane reductions besides the running ones: `Σ 0·E_t + 0·ρ` (zero exactly
/// when all are finite) and `min(E_t, ρ)`.
struct Checks {
    zero: [f64; L],
    lo: [f64; L],
}

/// `x` if `x > acc`, else `acc`: `f64::max` for values without NaN, as one vector select.
#[inline(always)]
pub(super) fn greater(x: f64, acc: f64) -> f64 {
    if x > acc {
        x
    } else {
        acc
    }
}

/// `x` if `x < acc`, else `acc`.
#[inline(always)]
fn smaller(x: f64, acc: f64) -> f64 {
    if x < acc {
        x
    } else {
        acc
    }
}

/// The particle slices of one block: inputs, and the tangent moduli and densities written.
pub(super) struct Block<'a> {
    pub mass: &'a [f64],
    pub vol0: &'a [f64],
    pub v: &'a [f64],
    pub s: &'a [f64],
    pub f: &'a [f64],
    pub et_out: &'a mut [f64],
    pub rho_out: &'a mut [f64],
}

impl SummaryLanes {
    pub(super) fn new() -> Self {
        Self {
            c2: [0.0; L],
            speed: [0.0; L],
            signal: [0.0; L],
            energy: [0.0; L],
            ok: true,
        }
    }

    /// One particle into lane `l`: the portable reference of every build.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn particle(
        &mut self,
        checks: &mut Checks,
        l: usize,
        tangent: &impl Fn(f64) -> f64,
        (m, v0, v, s, f): (f64, f64, f64, f64, f64),
        et_out: &mut f64,
        rho_out: &mut f64,
    ) {
        let et = tangent(f);
        let rho = m / (f * v0);
        (*et_out, *rho_out) = (et, rho);
        let q = et / rho;
        self.c2[l] = greater(q, self.c2[l]);
        self.signal[l] = greater(q.sqrt() + v.abs(), self.signal[l]);
        checks.zero[l] += et * 0.0 + rho * 0.0;
        checks.lo[l] = smaller(smaller(et, rho), checks.lo[l]);
        self.speed[l] = greater(v.abs(), self.speed[l]);
        self.energy[l] += particle_energy(m, v, s, f, v0, et);
    }

    /// Adds the particles of one block (`BLOCK` is a multiple of 4, so particle
    /// `start + i` is in lane `i mod 4`; the last, partial chunk — last block only — goes to
    /// lanes `0, 1, …` in order, which is still `p mod 4`). `tangent` is `material`'s
    /// `E_t(F)` without its `match`, for the portable loop.
    #[inline(always)]
    pub(super) fn add(&mut self, material: Material, tangent: impl Fn(f64) -> f64, b: Block<'_>) {
        #[cfg(target_arch = "x86_64")]
        let avx2 = crate::cpu::has_avx2();
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        let checks = self.add_block(material, tangent, b, avx2);
        let zero = checks.zero.iter().fold(0.0, |a, &z| a + z);
        let lo = checks.lo.iter().fold(f64::INFINITY, |a, &x| a.min(x));
        self.ok &= zero == 0.0 && lo > 0.0;
    }

    /// [`Self::add`] without folding the block's checks into `ok`; the full chunks in AVX2
    /// when `avx2` is set (the caller has detected it) on x86-64, else all portable.
    #[inline(always)]
    fn add_block(
        &mut self,
        material: Material,
        tangent: impl Fn(f64) -> f64,
        mut b: Block<'_>,
        avx2: bool,
    ) -> Checks {
        let n = b.mass.len().min(b.vol0.len()).min(b.v.len()).min(b.s.len());
        let n = n.min(b.f.len()).min(b.et_out.len()).min(b.rho_out.len());
        let full = n - n % L;
        let mut checks = Checks {
            zero: [0.0; L],
            lo: [f64::INFINITY; L],
        };
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: `avx2::chunks` only requires AVX2, which the caller detected.
            unsafe { avx2::chunks(self, &mut checks, material, &mut b, full) };
            done = full;
        }
        let _ = (material, avx2);
        for p in done..n {
            let inputs = (b.mass[p], b.vol0[p], b.v[p], b.s[p], b.f[p]);
            let (et, rho) = (&mut b.et_out[p], &mut b.rho_out[p]);
            self.particle(&mut checks, p % L, &tangent, inputs, et, rho);
        }
        checks
    }

    pub(super) fn finish(self) -> SummaryParts {
        let max = |l: [f64; L]| l.iter().fold(0.0_f64, |a, &b| a.max(b));
        SummaryParts {
            summary: PassSummary::new(max(self.c2), max(self.speed), sum_energy_lanes(self.energy))
                .with_signal_speed(max(self.signal)),
            ok: self.ok,
        }
    }
}

/// The full chunks in AVX2 intrinsics.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Block, Checks, Material, SummaryLanes, L};
    use std::arch::x86_64::*;

    /// `x > acc ? x : acc` lane-wise (the portable `greater`).
    #[inline(always)]
    unsafe fn greater(x: __m256d, acc: __m256d) -> __m256d {
        _mm256_blendv_pd(acc, x, _mm256_cmp_pd::<_CMP_GT_OQ>(x, acc))
    }

    /// `x < acc ? x : acc` lane-wise (the portable `smaller`).
    #[inline(always)]
    unsafe fn smaller(x: __m256d, acc: __m256d) -> __m256d {
        _mm256_blendv_pd(acc, x, _mm256_cmp_pd::<_CMP_LT_OQ>(x, acc))
    }

    /// Particles `0 .. full` (`full` a multiple of 4, within every slice of `b`), lane `l`
    /// of a vector being particle `4c + l`, with the portable code's operations in its
    /// order: `E_t` (`E`, or `(0.5 E)(F + 1/F)`), `ρ = m/(F V⁰)`, then the reductions, and
    /// the energy term `((0.5 m) v) v + ((((0.5 σ) σ) F) V⁰)/E_t'` with `E_t' = E_t > 0 ?
    /// E_t : +∞` (`controller::particle_energy`).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn chunks(
        lanes: &mut SummaryLanes,
        checks: &mut Checks,
        material: Material,
        b: &mut Block<'_>,
        full: usize,
    ) {
        let lens = [b.mass.len(), b.vol0.len(), b.v.len(), b.s.len(), b.f.len()];
        let outs = [b.et_out.len(), b.rho_out.len()];
        if !full.is_multiple_of(L) || lens.iter().chain(&outs).any(|&n| n < full) {
            return; // not reached: the caller sized `full`
        }
        let (neo, e) = match material {
            Material::LinearElastic { youngs_modulus } => (false, youngs_modulus),
            Material::NeoHookean { youngs_modulus } => (true, youngs_modulus),
        };
        let et_out = b.et_out.as_mut_ptr();
        let rho_out = b.rho_out.as_mut_ptr();
        // SAFETY (all blocks): every access is at `c + 0 .. c + 4` with `c + 4 ≤ full`, within
        // every slice (checked above); the outputs are written through the pointers of the
        // caller's exclusive slices only.
        unsafe {
            let e_vec = _mm256_set1_pd(e);
            let half_e = _mm256_set1_pd(0.5 * e);
            let (one, half, zero_v) = (
                _mm256_set1_pd(1.0),
                _mm256_set1_pd(0.5),
                _mm256_setzero_pd(),
            );
            let inf = _mm256_set1_pd(f64::INFINITY);
            let below_one = _mm256_set1_pd(1.0 - 1e-12);
            let abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
            let mut c2 = _mm256_loadu_pd(lanes.c2.as_ptr());
            let mut speed = _mm256_loadu_pd(lanes.speed.as_ptr());
            let mut signal = _mm256_loadu_pd(lanes.signal.as_ptr());
            let mut energy = _mm256_loadu_pd(lanes.energy.as_ptr());
            let mut zero = _mm256_loadu_pd(checks.zero.as_ptr());
            let mut lo = _mm256_loadu_pd(checks.lo.as_ptr());
            let mut c = 0;
            while c + L <= full {
                let m = _mm256_loadu_pd(b.mass.as_ptr().add(c));
                let v0 = _mm256_loadu_pd(b.vol0.as_ptr().add(c));
                let v = _mm256_loadu_pd(b.v.as_ptr().add(c));
                let s = _mm256_loadu_pd(b.s.as_ptr().add(c));
                let f = _mm256_loadu_pd(b.f.as_ptr().add(c));
                let et = if neo {
                    _mm256_mul_pd(half_e, _mm256_add_pd(f, _mm256_div_pd(one, f)))
                } else {
                    e_vec
                };
                let rho = _mm256_div_pd(m, _mm256_mul_pd(f, v0));
                _mm256_storeu_pd(et_out.add(c), et);
                _mm256_storeu_pd(rho_out.add(c), rho);
                let q = _mm256_div_pd(et, rho);
                c2 = greater(q, c2);
                let z = _mm256_add_pd(_mm256_mul_pd(et, zero_v), _mm256_mul_pd(rho, zero_v));
                zero = _mm256_add_pd(zero, z);
                lo = smaller(smaller(et, rho), lo);
                let v_abs = _mm256_and_pd(v, abs_mask);
                speed = greater(v_abs, speed);
                // Roots only where a lane may raise its maximum (module docs).
                let gap = _mm256_sub_pd(signal, v_abs);
                let bar = _mm256_mul_pd(_mm256_mul_pd(gap, gap), below_one);
                let may = _mm256_or_pd(
                    _mm256_cmp_pd::<_CMP_LE_OQ>(gap, zero_v),
                    _mm256_cmp_pd::<_CMP_NLT_UQ>(q, bar),
                );
                if _mm256_movemask_pd(may) != 0 {
                    signal = greater(_mm256_add_pd(_mm256_sqrt_pd(q), v_abs), signal);
                }
                let kinetic = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(half, m), v), v);
                let et_pos = _mm256_blendv_pd(inf, et, _mm256_cmp_pd::<_CMP_GT_OQ>(et, zero_v));
                let ss = _mm256_mul_pd(_mm256_mul_pd(half, s), s);
                let stored = _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(ss, f), v0), et_pos);
                energy = _mm256_add_pd(energy, _mm256_add_pd(kinetic, stored));
                c += L;
            }
            _mm256_storeu_pd(lanes.c2.as_mut_ptr(), c2);
            _mm256_storeu_pd(lanes.speed.as_mut_ptr(), speed);
            _mm256_storeu_pd(lanes.signal.as_mut_ptr(), signal);
            _mm256_storeu_pd(lanes.energy.as_mut_ptr(), energy);
            _mm256_storeu_pd(checks.zero.as_mut_ptr(), zero);
            _mm256_storeu_pd(checks.lo.as_mut_ptr(), lo);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The AVX2 chunks and the portable loop give the same bits, for both materials and
    /// every remainder length.
    #[test]
    fn avx2_and_portable_agree_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for material in [
            Material::LinearElastic {
                youngs_modulus: 3.0,
            },
            Material::NeoHookean {
                youngs_modulus: 0.7,
            },
        ] {
            for n in [0usize, 1, 3, 4, 5, 8, 13, 256, 4096] {
                let gen = |rng: &mut ChaCha8Rng, lo: f64, hi: f64| -> Vec<f64> {
                    (0..n).map(|_| rng.random_range(lo..hi)).collect()
                };
                let (mass, vol0) = (gen(&mut rng, 0.1, 2.0), gen(&mut rng, 0.1, 2.0));
                let (v, s) = (gen(&mut rng, -1.0, 1.0), gen(&mut rng, -1.0, 1.0));
                let f = gen(&mut rng, 0.5, 1.5);
                let tangent = |f: f64| material.tangent_modulus(f);
                let run = |avx: bool| {
                    let (mut et, mut rho) = (vec![0.0; n], vec![0.0; n]);
                    let mut lanes = SummaryLanes::new();
                    let b = Block {
                        mass: &mass,
                        vol0: &vol0,
                        v: &v,
                        s: &s,
                        f: &f,
                        et_out: &mut et,
                        rho_out: &mut rho,
                    };
                    #[cfg(target_arch = "x86_64")]
                    let avx = avx && crate::cpu::has_avx2();
                    let checks = lanes.add_block(material, tangent, b, avx);
                    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    (
                        bits(&lanes.c2),
                        bits(&lanes.speed),
                        bits(&lanes.signal),
                        bits(&lanes.energy),
                        bits(&checks.zero),
                        bits(&checks.lo),
                        bits(&et),
                        bits(&rho),
                    )
                };
                assert_eq!(run(true), run(false), "{material:?} n = {n}");
            }
        }
    }
}
