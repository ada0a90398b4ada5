//! The served step of [`super::certified::CertifiedTracker`]: one fused pass over the nodes
//! that reads the stepper's `K_N` bands in place.
//!
//! ```text
//! y = K_N z                      (pentadiagonal, indices wrapped on periodic grids)
//! ρ = Σ_i z_i y_i / Σ_{i active} m_i z_i²          (generalised Rayleigh quotient)
//! next_i = y_i / (m_i ρ_prev)  (active),  0  (inactive)      (power step z ← M⁻¹ K_N z)
//! above  = ∃ active i: K_N(i,i) > bound · m_i                 (a diagonal entry of C above λ̂)
//! stale  = ∃ inactive i: z_i ≠ 0                              (the mode lost a node)
//! ```
//!
//! **Layout of the loop.** The interior nodes `2 … n−3` run in chunks of [`LANES`]
//! consecutive nodes with [`LANES`] independent accumulators of each sum, maximum and flag,
//! every branch written as a select: the compiler turns a chunk into 4-wide vector
//! instructions (the band entries `K_N(i, i+1)`, `K_N(i, i+2)` are interleaved in storage and
//! deinterleaved by shuffles), so the divisions of the power step and the two reduction
//! chains no longer serialise the pass. The first and last two nodes (and the remainder of
//! the interior) go through the scalar wrapped row. The lanes are summed at the end, so the
//! quotient's rounding differs from a sequential sum by a few units in the last place (it is
//! deterministic: the same inputs give the same bits, on every CPU, since the AVX2 build uses
//! no FMA and the baseline build rounds each operation the same way).
//!
//! Like the particle pass of the reference solver ([`crate::mpm`]) the kernel is compiled
//! twice, for the baseline target and with AVX2, the build chosen at run time.
//!
//! Measured: README "Stability".

use crate::nodal_stiffness::NodalStiffness;

/// Independent lanes of the interior loop (one AVX2 vector of `f64`).
const LANES: usize = 4;

/// What one fused pass over the nodes finds (see [`power_pass`]).
pub(super) struct Pass {
    /// `zᵀ K_N z / zᵀ M z` of the vector before the step.
    pub rayleigh: f64,
    /// Whether some active node has `K_N(i,i) > bound · m_i`.
    pub diagonal_above: bool,
}

/// What the pass reads at every node.
struct Inputs<'a> {
    kd: &'a [f64],
    ko: &'a [[f64; 2]],
    mass: &'a [f64],
    active: &'a [bool],
    z: &'a [f64],
    /// `1/ρ_prev`, the power step's scaling.
    inv_rho: f64,
    /// The diagonal test `K(i,i) > bound · m_i`.
    bound: f64,
}

/// The running sums, extrema and flags of one lane.
#[derive(Clone, Copy)]
struct Lane {
    num: f64,
    den: f64,
    min_mass: f64,
    above: bool,
    stale: bool,
}

impl Lane {
    const EMPTY: Lane = Lane {
        num: 0.0,
        den: 0.0,
        min_mass: f64::INFINITY,
        above: false,
        stale: false,
    };

    /// Node `i` with `y = (K_N z)_i`: the sums, the checks, and the power step's value
    /// (`0` at inactive nodes), every branch a select.
    #[inline(always)]
    fn node(&mut self, inp: &Inputs<'_>, zi: f64, y: f64, kd: f64, m: f64, a: bool) -> f64 {
        self.num += zi * y;
        self.den += if a { m * zi * zi } else { 0.0 };
        self.min_mass = self.min_mass.min(if a { m } else { f64::INFINITY });
        self.above |= a & (kd > inp.bound * m);
        self.stale |= !a & (zi != 0.0);
        let step = y * inp.inv_rho / m;
        if a {
            step
        } else {
            0.0
        }
    }

    fn merge(self, other: Lane) -> Lane {
        Lane {
            num: self.num + other.num,
            den: self.den + other.den,
            min_mass: self.min_mass.min(other.min_mass),
            above: self.above | other.above,
            stale: self.stale | other.stale,
        }
    }
}

impl Inputs<'_> {
    /// `(K_N z)_i` with the indices wrapped (entries past a fixed grid's last node are zero
    /// in `K_N`'s storage, so the wrap adds nothing there).
    fn wrapped_row(&self, i: usize) -> f64 {
        let n = self.z.len() as isize;
        let w = |j: isize| j.rem_euclid(n) as usize;
        let (ii, z, ko) = (i as isize, self.z, self.ko);
        self.kd[i] * z[i]
            + ko[i][0] * z[w(ii + 1)]
            + ko[i][1] * z[w(ii + 2)]
            + ko[w(ii - 1)][0] * z[w(ii - 1)]
            + ko[w(ii - 2)][1] * z[w(ii - 2)]
    }

    /// One scalar node through the wrapped row.
    fn scalar_node(&self, lane: &mut Lane, i: usize, next: &mut [f64]) {
        let y = self.wrapped_row(i);
        next[i] = lane.node(self, self.z[i], y, self.kd[i], self.mass[i], self.active[i]);
    }
}

/// The pass (module docs). `None` when it cannot be trusted (sizes, under 4 nodes, a node
/// that became inactive under a non-zero `z_i`, a non-finite or non-positive value) — the
/// caller then anchors, whose full validation reports errors.
///
/// The power step `z ← M⁻¹K_N z` is the power iteration on `C = M^{1/2} K_N M^{1/2}` in the
/// variable `z = M^{1/2}u` (`C u = M^{1/2} K_N z`); for a positive semi-definite `C` the
/// Rayleigh quotients of power iterates never decrease, so the step can only improve the
/// tracked mode between anchors. `next` is only resized: every entry is written.
pub(super) fn power_pass(
    k: &NodalStiffness,
    mass: &[f64],
    active: &[bool],
    z: &[f64],
    next: &mut Vec<f64>,
    rho_prev: f64,
    bound: f64,
) -> Option<Pass> {
    let n = z.len();
    if k.diag.len() != n || k.off.len() != n || mass.len() != n || active.len() != n || n < 4 {
        return None;
    }
    next.resize(n, 0.0);
    let inputs = Inputs {
        kd: &k.diag[..n],
        ko: &k.off[..n],
        mass: &mass[..n],
        active: &active[..n],
        z: &z[..n],
        inv_rho: if rho_prev > 0.0 { 1.0 / rho_prev } else { 1.0 },
        bound,
    };
    let lane = dispatch(&inputs, &mut next[..n]);
    let rayleigh = lane.num / lane.den;
    let valid = !lane.stale && rayleigh.is_finite() && rayleigh >= 0.0 && lane.min_mass > 0.0;
    valid.then_some(Pass {
        rayleigh,
        diagonal_above: lane.above,
    })
}

/// The pass in the best build the CPU supports.
fn dispatch(inputs: &Inputs<'_>, next: &mut [f64]) -> Lane {
    #[cfg(target_arch = "x86_64")]
    if crate::mpm::has_avx2() {
        // SAFETY: `pass_avx2` only requires AVX2, which `has_avx2` has confirmed on this CPU.
        return unsafe { pass_avx2(inputs, next) };
    }
    pass(inputs, next)
}

/// The pass compiled for AVX2, its interior chunks in explicit 4-wide intrinsics that
/// perform the lane code's operations in the same order (no FMA), so both builds give the
/// same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn pass_avx2(inputs: &Inputs<'_>, next: &mut [f64]) -> Lane {
    // The closure inherits this function's target features, so the call is safe.
    pass_with(inputs, next, |inp, out| avx2::chunks(inp, out))
}

/// The pass in the baseline build.
fn pass(inputs: &Inputs<'_>, next: &mut [f64]) -> Lane {
    pass_with(inputs, next, chunks)
}

/// The pass over all `n ≥ 4` nodes: the first two nodes, the interior chunks of
/// [`LANES`] by `interior` (which returns their lanes and where it stopped), the rest.
#[inline(always)]
fn pass_with(
    inp: &Inputs<'_>,
    next: &mut [f64],
    interior: impl FnOnce(&Inputs<'_>, &mut [f64]) -> (Lanes, usize),
) -> Lane {
    let n = inp.z.len();
    let mut edge = Lane::EMPTY;
    for i in [0, 1] {
        inp.scalar_node(&mut edge, i, next);
    }
    let (lanes, i) = interior(inp, next);
    let mut tail = Lane::EMPTY;
    for j in i..n {
        inp.scalar_node(&mut tail, j, next);
    }
    edge.merge(lanes.merge()).merge(tail)
}

/// The interior accumulators, one per lane and quantity; the flags as maxima of `f64`
/// values (set when `> 0`), so a chunk is arithmetic and selects only.
struct Lanes {
    num: [f64; LANES],
    den: [f64; LANES],
    min_mass: [f64; LANES],
    above: [f64; LANES],
    stale: [f64; LANES],
}

impl Lanes {
    const EMPTY: Lanes = Lanes {
        num: [0.0; LANES],
        den: [0.0; LANES],
        min_mass: [f64::INFINITY; LANES],
        above: [f64::NEG_INFINITY; LANES],
        stale: [0.0; LANES],
    };

    /// The lanes combined in lane order.
    fn merge(&self) -> Lane {
        (0..LANES)
            .map(|l| Lane {
                num: self.num[l],
                den: self.den[l],
                min_mass: self.min_mass[l],
                above: self.above[l] > 0.0,
                stale: self.stale[l] > 0.0,
            })
            .fold(Lane::EMPTY, Lane::merge)
    }
}

/// The interior chunks in portable code: nodes `2 … i−1` for the returned `i`.
#[inline(always)]
fn chunks(inp: &Inputs<'_>, next: &mut [f64]) -> (Lanes, usize) {
    let n = inp.z.len();
    let mut acc = Lanes::EMPTY;
    // Chunks start at i = 2 and need z[i−2 .. i+LANES+2] and K rows i−2 .. i+LANES, all
    // inside 0 .. n when i + LANES + 2 ≤ n.
    let mut i = 2;
    while i + LANES + 2 <= n {
        let Ok(zw) = <&[f64; LANES + 4]>::try_from(&inp.z[i - 2..i + LANES + 2]) else {
            break;
        };
        let Ok(kow) = <&[[f64; 2]; LANES + 2]>::try_from(&inp.ko[i - 2..i + LANES]) else {
            break;
        };
        let Ok(kd) = <&[f64; LANES]>::try_from(&inp.kd[i..i + LANES]) else {
            break;
        };
        let Ok(m) = <&[f64; LANES]>::try_from(&inp.mass[i..i + LANES]) else {
            break;
        };
        let Ok(a) = <&[bool; LANES]>::try_from(&inp.active[i..i + LANES]) else {
            break;
        };
        let Ok(out) = <&mut [f64; LANES]>::try_from(&mut next[i..i + LANES]) else {
            break;
        };
        let mut y = [0.0; LANES];
        for l in 0..LANES {
            // Node i + l: z_j is zw[l + 2], K row j is kow[l + 2].
            y[l] = kd[l] * zw[l + 2]
                + kow[l + 2][0] * zw[l + 3]
                + kow[l + 2][1] * zw[l + 4]
                + kow[l + 1][0] * zw[l + 1]
                + kow[l][1] * zw[l];
        }
        for l in 0..LANES {
            let (zi, al) = (zw[l + 2], a[l]);
            acc.num[l] += zi * y[l];
            acc.den[l] += if al { m[l] * zi * zi } else { 0.0 };
            acc.min_mass[l] = acc.min_mass[l].min(if al { m[l] } else { f64::INFINITY });
            acc.above[l] = acc.above[l].max(if al {
                kd[l] - inp.bound * m[l]
            } else {
                f64::NEG_INFINITY
            });
            acc.stale[l] = acc.stale[l].max(if al { 0.0 } else { zi.abs() });
            let step = y[l] * inp.inv_rho / m[l];
            out[l] = if al { step } else { 0.0 };
        }
        i += LANES;
    }
    (acc, i)
}

/// The interior chunks in AVX2 intrinsics.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Inputs, Lanes, LANES};
    use std::arch::x86_64::*;

    /// The interior chunks (as [`super::chunks`], the same operations in the same order, so
    /// the same bits): one 4-wide vector per quantity. The band entries of rows
    /// `i−2 … i+3` are 12 consecutive values `e₀ o₁ e₂ o₃ …` (`e` = `K(r, r+1)`,
    /// `o` = `K(r, r+2)`); four overlapping loads and in-lane unpacks with a cross-lane
    /// permute deinterleave the four band vectors each chunk needs.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn chunks(inp: &Inputs<'_>, next: &mut [f64]) -> (Lanes, usize) {
        let n = inp.z.len();
        let ko = inp.ko.as_flattened();
        let (kd, mass, active, z) = (inp.kd, inp.mass, inp.active, inp.z);
        let bound = _mm256_set1_pd(inp.bound);
        let inv_rho = _mm256_set1_pd(inp.inv_rho);
        let zero = _mm256_setzero_pd();
        let inf = _mm256_set1_pd(f64::INFINITY);
        let neg_inf = _mm256_set1_pd(f64::NEG_INFINITY);
        let abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
        let mut num = zero;
        let mut den = zero;
        let mut min_mass = inf;
        let mut above = neg_inf;
        let mut stale = zero;
        let mut i = 2;
        while i + LANES + 2 <= n {
            // Every slice below is in bounds: i − 2 ≥ 0 and i + LANES + 2 ≤ n; `ko` has 2n
            // entries and the chunk reads 2(i − 2) … 2(i − 2) + 11 < 2(i + LANES).
            let (Some(zs), Some(kos), Some(kds), Some(ms), Some(acts), Some(out)) = (
                z.get(i - 2..i + LANES + 2),
                ko.get(2 * (i - 2)..2 * (i + LANES)),
                kd.get(i..i + LANES),
                mass.get(i..i + LANES),
                active.get(i..i + LANES),
                next.get_mut(i..i + LANES),
            ) else {
                break;
            };
            // SAFETY: every pointer read or written below addresses the slices just checked
            // (`zs`: 8, `kos`: 12, `kds`, `ms`, `out`: 4 values, `acts`: 4 bytes).
            unsafe {
                let zp = zs.as_ptr();
                let (zm2, zm1, z0, z1, z2) = (
                    _mm256_loadu_pd(zp),
                    _mm256_loadu_pd(zp.add(1)),
                    _mm256_loadu_pd(zp.add(2)),
                    _mm256_loadu_pd(zp.add(3)),
                    _mm256_loadu_pd(zp.add(4)),
                );
                let kp = kos.as_ptr();
                let c = _mm256_loadu_pd(kp); // e0 o1 e2 o3
                let d = _mm256_loadu_pd(kp.add(2)); // e2 o3 e4 o5
                let a = _mm256_loadu_pd(kp.add(4)); // e4 o5 e6 o7
                let e = _mm256_loadu_pd(kp.add(6)); // e6 o7 e8 o9
                let b = _mm256_loadu_pd(kp.add(8)); // e8 o9 e10 o11
                const ORDER: i32 = 0b11_01_10_00; // (0, 2, 1, 3)
                                                  // K(j, j+1), K(j, j+2) of rows j = i … i+3; K(j−1, j), K(j−2, j).
                let k1 = _mm256_permute4x64_pd::<ORDER>(_mm256_unpacklo_pd(a, b));
                let k2 = _mm256_permute4x64_pd::<ORDER>(_mm256_unpackhi_pd(a, b));
                let km1 = _mm256_permute4x64_pd::<ORDER>(_mm256_unpacklo_pd(d, e));
                let km2 = _mm256_permute4x64_pd::<ORDER>(_mm256_unpackhi_pd(c, a));
                let kdv = _mm256_loadu_pd(kds.as_ptr());
                let m = _mm256_loadu_pd(ms.as_ptr());
                let flags = u32::from_le_bytes([
                    u8::from(acts[0]),
                    u8::from(acts[1]),
                    u8::from(acts[2]),
                    u8::from(acts[3]),
                ]);
                let act = _mm256_castsi256_pd(_mm256_cmpgt_epi64(
                    _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(flags as i32)),
                    _mm256_setzero_si256(),
                ));
                let mut y = _mm256_mul_pd(kdv, z0);
                y = _mm256_add_pd(y, _mm256_mul_pd(k1, z1));
                y = _mm256_add_pd(y, _mm256_mul_pd(k2, z2));
                y = _mm256_add_pd(y, _mm256_mul_pd(km1, zm1));
                y = _mm256_add_pd(y, _mm256_mul_pd(km2, zm2));
                num = _mm256_add_pd(num, _mm256_mul_pd(z0, y));
                let mzz = _mm256_mul_pd(_mm256_mul_pd(m, z0), z0);
                den = _mm256_add_pd(den, _mm256_blendv_pd(zero, mzz, act));
                // (x, acc) operand order: a NaN x leaves acc, as `f64::min/max` ignore NaN.
                min_mass = _mm256_min_pd(_mm256_blendv_pd(inf, m, act), min_mass);
                let gap = _mm256_sub_pd(kdv, _mm256_mul_pd(bound, m));
                above = _mm256_max_pd(_mm256_blendv_pd(neg_inf, gap, act), above);
                let za = _mm256_and_pd(z0, abs_mask);
                stale = _mm256_max_pd(_mm256_blendv_pd(za, zero, act), stale);
                let step = _mm256_div_pd(_mm256_mul_pd(y, inv_rho), m);
                _mm256_storeu_pd(out.as_mut_ptr(), _mm256_blendv_pd(zero, step, act));
            }
            i += LANES;
        }
        let mut acc = Lanes::EMPTY;
        // SAFETY: each destination is an array of LANES = 4 f64.
        unsafe {
            _mm256_storeu_pd(acc.num.as_mut_ptr(), num);
            _mm256_storeu_pd(acc.den.as_mut_ptr(), den);
            _mm256_storeu_pd(acc.min_mass.as_mut_ptr(), min_mass);
            _mm256_storeu_pd(acc.above.as_mut_ptr(), above);
            _mm256_storeu_pd(acc.stale.as_mut_ptr(), stale);
        }
        (acc, i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Random bands, masses and activity (about one node in 8 inactive, its `z` zero or not).
    fn case(n: usize, seed: u64, stale: bool) -> (NodalStiffness, Vec<f64>, Vec<bool>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let k = NodalStiffness {
            diag: (0..n).map(|_| rng.random_range(0.5..2.0)).collect(),
            off: (0..n)
                .map(|_| [rng.random_range(-1.0..0.0), rng.random_range(-0.2..0.2)])
                .collect(),
            c2_ref: 1.0,
        };
        let mass: Vec<f64> = (0..n).map(|_| rng.random_range(0.1..1.0)).collect();
        let active: Vec<bool> = (0..n).map(|_| rng.random::<f64>() > 0.125).collect();
        let z = (0..n)
            .map(|i| {
                let v = rng.random_range(-1.0..1.0);
                if active[i] || stale {
                    v
                } else {
                    0.0
                }
            })
            .collect();
        (k, mass, active, z)
    }

    /// The pass by one sequential scalar loop over the wrapped rows (the definition).
    fn reference(
        k: &NodalStiffness,
        mass: &[f64],
        active: &[bool],
        z: &[f64],
        rho_prev: f64,
        bound: f64,
    ) -> (f64, bool, bool, Vec<f64>) {
        let inp = Inputs {
            kd: &k.diag,
            ko: &k.off,
            mass,
            active,
            z,
            inv_rho: 1.0 / rho_prev,
            bound,
        };
        let (mut num, mut den, mut above, mut stale) = (0.0, 0.0, false, false);
        let next = (0..z.len())
            .map(|i| {
                let y = inp.wrapped_row(i);
                num += z[i] * y;
                if active[i] {
                    den += mass[i] * z[i] * z[i];
                    above |= k.diag[i] > bound * mass[i];
                    y * inp.inv_rho / mass[i]
                } else {
                    stale |= z[i] != 0.0;
                    0.0
                }
            })
            .collect();
        (num / den, above, stale, next)
    }

    #[test]
    fn the_vector_builds_agree_bit_for_bit_and_match_the_sequential_definition() {
        for (n, seed) in [(4, 1), (5, 2), (9, 3), (10, 4), (11, 5), (64, 6), (1001, 7)] {
            let (k, mass, active, z) = case(n, seed, false);
            let (rho_prev, bound) = (1.3, 2.5);
            let (mut fast, mut portable) = (Vec::new(), Vec::new());
            let p =
                power_pass(&k, &mass, &active, &z, &mut fast, rho_prev, bound).expect("valid pass");
            let inputs = Inputs {
                kd: &k.diag,
                ko: &k.off,
                mass: &mass,
                active: &active,
                z: &z,
                inv_rho: 1.0 / rho_prev,
                bound,
            };
            portable.resize(n, f64::NAN);
            let lane = pass(&inputs, &mut portable);
            assert_eq!(fast, portable, "n = {n}: power steps differ between builds");
            assert_eq!(
                p.rayleigh.to_bits(),
                (lane.num / lane.den).to_bits(),
                "n = {n}: quotients differ"
            );
            let (rho, above, stale, next) = reference(&k, &mass, &active, &z, rho_prev, bound);
            assert!(!stale);
            assert_eq!(p.diagonal_above, above, "n = {n}");
            assert_eq!(
                fast, next,
                "n = {n}: power step differs from the definition"
            );
            assert!(
                (p.rayleigh - rho).abs() <= 1e-12 * rho.abs().max(1.0),
                "n = {n}: quotient {} vs sequential {rho}",
                p.rayleigh
            );
        }
    }

    #[test]
    fn a_nonzero_mode_at_an_inactive_node_and_bad_sizes_are_refused() {
        let (k, mass, active, z) = case(64, 8, true);
        assert!(active.iter().any(|&a| !a));
        let mut next = Vec::new();
        assert!(power_pass(&k, &mass, &active, &z, &mut next, 1.0, 10.0).is_none());
        let (k, mass, active, z) = case(64, 9, false);
        assert!(power_pass(&k, &mass[..63], &active, &z, &mut next, 1.0, 10.0).is_none());
        assert!(power_pass(&k, &mass[..3], &active[..3], &z[..3], &mut next, 1.0, 1.0).is_none());
        // The diagonal test fires on one heavy diagonal entry at an active node in a chunk.
        let mut k2 = k.clone();
        let j = (2..60)
            .find(|&j| active[j])
            .expect("an active interior node");
        k2.diag[j] = 1e3 * mass[j];
        let p = power_pass(&k2, &mass, &active, &z, &mut next, 1.0, 100.0).expect("valid");
        assert!(p.diagonal_above);
    }
}
