//! The interior chunks of [`super::power_pass`] in AVX2 intrinsics (the CPU-specific
//! kernel; the portable lanes are in the parent module).

use super::{Inputs, Interior, Lanes, BLOCK, LANES};
use std::arch::x86_64::*;

/// Whether the `BLOCK + 4` values from `p` are all `+0.0` bits, reading them four
/// vectors at a time and stopping at the first group that is not (on a dense mode,
/// after the first). Like [`active_mask`] it has no `target_feature` of its own: it is
/// only called from, and always inlined into, the AVX2 `chunks`, whose features its
/// intrinsics then use.
///
/// # Safety
/// The CPU must support AVX2, and `p .. p + BLOCK + 4` must be readable.
#[inline(always)]
unsafe fn zero_window(p: *const f64) -> bool {
    const GROUP: usize = 4 * LANES;
    const _: () = assert!((BLOCK + 4).is_multiple_of(LANES) && (BLOCK + 4) % GROUP == LANES);
    // SAFETY: every load is inside `p .. p + BLOCK + 4` (the caller's guarantee).
    unsafe {
        let zero = |v: __m256d| {
            let bits = _mm256_castpd_si256(v);
            _mm256_testz_si256(bits, bits) == 1
        };
        let load = |c: usize| _mm256_loadu_pd(p.add(c));
        for c in (0..BLOCK).step_by(GROUP) {
            let v = _mm256_or_pd(
                _mm256_or_pd(load(c), load(c + LANES)),
                _mm256_or_pd(load(c + 2 * LANES), load(c + 3 * LANES)),
            );
            if !zero(v) {
                return false;
            }
        }
        zero(load(BLOCK))
    }
}

/// All-ones lanes where the four flags from `ap` are set.
///
/// # Safety
/// The CPU must support AVX2, and `ap .. ap + 4` must be readable.
#[inline(always)]
unsafe fn active_mask(ap: *const bool) -> __m256d {
    // SAFETY: the caller guarantees four readable flags and AVX2.
    unsafe {
        let flags = u32::from_le_bytes([
            u8::from(*ap),
            u8::from(*ap.add(1)),
            u8::from(*ap.add(2)),
            u8::from(*ap.add(3)),
        ]);
        _mm256_castsi256_pd(_mm256_cmpgt_epi64(
            _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(flags as i32)),
            _mm256_setzero_si256(),
        ))
    }
}

/// The running vectors of the interior loop: the sums, maxima and flags (`above` as a
/// lane mask), and the last chunk's power step with where it goes.
struct Run {
    num: __m256d,
    den: __m256d,
    above: __m256d,
    stale: __m256d,
    max_abs: __m256d,
    pending: __m256d,
    /// Where `pending` is written when the next chunk has read its window: `z[i − 4 ..
    /// i]` of the chunk at `i`, or a scratch array before the first chunk.
    dst: *mut f64,
}

/// The loop's constants.
#[derive(Clone, Copy)]
struct Consts {
    bound: __m256d,
    inv_rho: __m256d,
    floor: __m256d,
    abs_mask: __m256d,
}

/// The diagonal test of four nodes as a lane mask: set where `act` is and
/// `kd > bound · m`. Set exactly where [`super::Inputs::diagonal_gap`] is positive (for
/// finite operands `a − b > 0 ⇔ a > b`, an overflowing difference is `+∞`, and `NaN`,
/// `∞ − ∞` included, is neither), so the flag is the portable build's.
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn diagonal_mask(kdv: __m256d, m: __m256d, act: __m256d, bound: __m256d) -> __m256d {
    _mm256_and_pd(
        act,
        _mm256_cmp_pd::<_CMP_GT_OQ>(kdv, _mm256_mul_pd(bound, m)),
    )
}

/// One chunk at `i` (as a chunk of [`super::chunks`], the same operations in the same
/// order); then the previous chunk's power step is written to `run.dst`, and this one's
/// kept in `run.pending` for `z[i .. i + 4]`.
///
/// # Safety
/// The CPU must support AVX2; `i ≥ 2`, `i + 6 ≤ n` and every slice of `inp` holds `n`
/// values; `zp` points to the `n` values of `z`, and `run.dst` to four writable values
/// that no later chunk reads (the scratch array, or `z[i − 4 .. i]`).
#[inline(always)]
unsafe fn chunk(inp: &Inputs<'_>, c: Consts, zp: *mut f64, i: usize, run: &mut Run) {
    // SAFETY: the chunk reads z[i−2 .. i+6], upper1[i−1 .. i+4], upper2[i−2 .. i+4],
    // kd, mass and active [i .. i+4] — inside the slices by the caller's guarantee —
    // and writes `run.dst` after those reads.
    unsafe {
        let zc = zp.add(i - 2);
        let (zm2, zm1, z0, z1, z2) = (
            _mm256_loadu_pd(zc),
            _mm256_loadu_pd(zc.add(1)),
            _mm256_loadu_pd(zc.add(2)),
            _mm256_loadu_pd(zc.add(3)),
            _mm256_loadu_pd(zc.add(4)),
        );
        // K(j, j+1), K(j, j+2) of rows j = i … i+3; K(j−1, j), K(j−2, j).
        let (u1, u2) = (inp.k1.as_ptr().add(i), inp.k2.as_ptr().add(i));
        let k1v = _mm256_loadu_pd(u1);
        let k2v = _mm256_loadu_pd(u2);
        let km1 = _mm256_loadu_pd(u1.sub(1));
        let km2 = _mm256_loadu_pd(u2.sub(2));
        let kdv = _mm256_loadu_pd(inp.kd.as_ptr().add(i));
        let m = _mm256_loadu_pd(inp.mass.as_ptr().add(i));
        let act = active_mask(inp.active.as_ptr().add(i));
        let mut y = _mm256_mul_pd(kdv, z0);
        y = _mm256_add_pd(y, _mm256_mul_pd(k1v, z1));
        y = _mm256_add_pd(y, _mm256_mul_pd(k2v, z2));
        y = _mm256_add_pd(y, _mm256_mul_pd(km1, zm1));
        y = _mm256_add_pd(y, _mm256_mul_pd(km2, zm2));
        run.num = _mm256_add_pd(run.num, _mm256_mul_pd(z0, y));
        // `and` with the mask is the portable build's select of `+0.0`.
        let mzz = _mm256_mul_pd(_mm256_mul_pd(m, z0), z0);
        run.den = _mm256_add_pd(run.den, _mm256_and_pd(act, mzz));
        run.above = _mm256_or_pd(run.above, diagonal_mask(kdv, m, act, c.bound));
        let za = _mm256_and_pd(z0, c.abs_mask);
        // (x, acc) operand order: a NaN x leaves acc, as `f64::max` ignores NaN.
        run.stale = _mm256_max_pd(_mm256_andnot_pd(act, za), run.stale);
        run.max_abs = _mm256_max_pd(za, run.max_abs);
        let step = _mm256_div_pd(_mm256_mul_pd(y, c.inv_rho), m);
        _mm256_storeu_pd(run.dst, run.pending);
        // Ordered `≥`: false for NaN, as the scalar comparison.
        let kept = _mm256_cmp_pd::<_CMP_GE_OQ>(_mm256_and_pd(step, c.abs_mask), c.floor);
        run.pending = _mm256_and_pd(step, _mm256_and_pd(act, kept));
        run.dst = zp.add(i);
    }
}

/// The interior chunks (as [`super::chunks`], the same operations in the same order, so
/// the same bits): one 4-wide vector per quantity; the four band vectors of a chunk at
/// `i` are unaligned loads of `upper1` from `i` and `i − 1` and of `upper2` from `i` and
/// `i − 2`. The loop runs block by block: a block that is not zero runs its
/// [`BLOCK`]` / 4` chunks in an inner loop without tests, and the write of each chunk's
/// power step goes through a pointer (a scratch array before the first chunk), so no
/// chunk branches (before, the per-chunk block test and first-chunk test kept the loop
/// in four pieces and spilled an accumulator to the stack).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) fn chunks(inp: &Inputs<'_>, z: &mut [f64]) -> Interior {
    let n = z.len();
    let (kd, mass, active) = (inp.kd, inp.mass, inp.active);
    let lengths = [
        kd.len(),
        inp.k1.len(),
        inp.k2.len(),
        mass.len(),
        active.len(),
    ];
    if lengths.iter().any(|&len| len != n) {
        // Not reached (the caller checked the sizes); the portable chunks check their own.
        return super::chunks(inp, z);
    }
    let zp = z.as_mut_ptr();
    let c = Consts {
        bound: _mm256_set1_pd(inp.bound),
        inv_rho: _mm256_set1_pd(inp.inv_rho),
        floor: _mm256_set1_pd(inp.floor),
        abs_mask: _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX)),
    };
    let zero = _mm256_setzero_pd();
    let mut scratch = [0.0; LANES];
    let mut run = Run {
        num: zero,
        den: zero,
        above: zero,
        stale: zero,
        max_abs: zero,
        pending: zero,
        dst: scratch.as_mut_ptr(),
    };
    let mut i = 2;
    while i + LANES + 2 <= n {
        let stop = if i + BLOCK + 2 <= n {
            // SAFETY: z[i−2 .. i+BLOCK+2] is inside z (i ≥ 2, i + BLOCK + 2 ≤ n), and so
            // are kd, mass and active [i .. i+BLOCK]; `run.dst` is the scratch array or
            // z[i−4 .. i], which the block does not read.
            unsafe {
                if zero_window(zp.add(i - 2)) {
                    // A zero block (module docs of `power_pass`): its diagonal tests only.
                    _mm256_storeu_pd(run.dst, run.pending);
                    run.pending = zero;
                    run.dst = zp.add(i + BLOCK - LANES);
                    for j in (i..i + BLOCK).step_by(LANES) {
                        let kdv = _mm256_loadu_pd(kd.as_ptr().add(j));
                        let m = _mm256_loadu_pd(mass.as_ptr().add(j));
                        let act = active_mask(active.as_ptr().add(j));
                        run.above = _mm256_or_pd(run.above, diagonal_mask(kdv, m, act, c.bound));
                    }
                    i += BLOCK;
                    continue;
                }
            }
            i + BLOCK
        } else {
            // The last chunk at `i` has i + LANES + 2 ≤ n.
            n - LANES - 1
        };
        while i < stop {
            // SAFETY: i ≥ 2 and i + LANES + 2 ≤ n (both bounds of `stop`), every slice
            // holds n values (checked above), and `run.dst` is the scratch array or the
            // previous chunk's z[i−4 .. i].
            unsafe { chunk(inp, c, zp, i, &mut run) };
            i += LANES;
        }
    }
    let mut acc = Lanes::EMPTY;
    let mut last = [0.0; LANES];
    // SAFETY: each destination is an array of LANES = 4 f64.
    unsafe {
        _mm256_storeu_pd(acc.num.as_mut_ptr(), run.num);
        _mm256_storeu_pd(acc.den.as_mut_ptr(), run.den);
        // The mask as the portable lanes' flag: `1` where set (`> 0`), `0` where not.
        let above = _mm256_and_pd(run.above, _mm256_set1_pd(1.0));
        _mm256_storeu_pd(acc.above.as_mut_ptr(), above);
        _mm256_storeu_pd(acc.stale.as_mut_ptr(), run.stale);
        _mm256_storeu_pd(acc.max_abs.as_mut_ptr(), run.max_abs);
        _mm256_storeu_pd(last.as_mut_ptr(), run.pending);
    }
    Interior {
        lanes: acc,
        end: i,
        pending: (i > 2).then(|| (i - LANES, last)),
    }
}
