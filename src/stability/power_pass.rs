//! The served step of [`super::certified::CertifiedTracker`]: one fused pass over the nodes
//! that reads the stepper's `K_N` bands in place and overwrites the mode `z` with its power
//! step.
//!
//! ```text
//! y = K_N z                      (pentadiagonal, indices wrapped on periodic grids)
//! ρ = Σ_i z_i y_i / Σ_{i active} m_i z_i²          (generalised Rayleigh quotient)
//! next_i = y_i / (m_i ρ_prev)  (active),  0  (inactive)      (power step z ← M⁻¹ K_N z)
//!          0  where |next_i| < floor                           (flushed, below)
//! above  = ∃ active i: K_N(i,i) > bound · m_i                 (a diagonal entry of C above λ̂)
//! stale  = ∃ inactive i: z_i ≠ 0                              (the mode lost a node)
//! max_abs = max_i |z_i|                                       (sets the next floor)
//! ```
//!
//! **Zero blocks.** Where the mode is zero (its flushed tails, below), `K_N z` is zero two
//! nodes away, and so is the power step; the sums get exact zeros. So the interior loop
//! tests each block of [`BLOCK`] nodes at once: when `z` is all `+0.0` bits on the block
//! and two nodes either side, the block only takes its diagonal tests (a light node
//! anywhere must be seen) and is left zero — the same bits as computing it, except that
//! `0·∞` or `0·NaN` in such a block's `K_N` no longer poisons the quotient (a non-finite
//! `K_N` is then reported at the next anchor, whose validation reads every entry; a
//! stepper's pass refuses non-finite particles before it could produce one), that an
//! infinite active mass there no longer does either (the caller's mass scan refuses it, or
//! a trusted summary excludes it), and that without a floor a computed zero may be `−0.0`
//! where the block leaves `+0.0`. On the 10⁵-particle standing wave the mode is non-zero
//! everywhere for about 100 steps, on 22 % of the nodes after 300 steps, 2.3 % after 1000
//! and 0.9 % after 2500, in two clusters (one across the periodic seam). Blocks, not
//! chunks: a test per chunk mispredicted on the patchy zeros of a mode still localising,
//! and made the pass 1.2–1.7× slower there (median over the first 300 steps, two runs).
//!
//! **Flushed tails.** On a long run the tracked mode localises: power steps on a clustered
//! top of the spectrum shrink its components away from the top mode's support
//! geometrically, and after 2000 steps of the 10⁵-particle standing wave 28 % of them were
//! subnormal numbers, whose arithmetic made the pass slower (median over a 3000-step run
//! 94–104 µs, against 76 µs with the flush). The caller passes `floor` = [`FLUSH_RELATIVE`]
//! times the previous pass's `max_abs`, and power-step values below it are stored as zero:
//! each such value's share of the quotient is below `FLUSH_RELATIVE² ≈ 10⁻³⁰`. Any vector's
//! Rayleigh quotient is a lower bound on λmax, so the flushed mode still gives one; its
//! quotient differs from the unflushed one's by at most about `n · FLUSH_RELATIVE²`
//! relative (`10⁻²⁵` at `5·10⁴` nodes), far below the quotient's own rounding. What the
//! flushed tails cannot do is grow back from below the floor into a new top mode far away;
//! the power step could not have either (from `10⁻¹⁵`, a mode 1 % above the tracked one
//! needs about 3500 steps to take over): finding a new top is the anchors' work (their
//! certificate fails, and Lanczos replaces the mode), and the diagonal test's between
//! anchors.
//!
//! **Layout of the loop.** The interior nodes `2 … n−3` run in chunks of [`LANES`]
//! consecutive nodes with [`LANES`] independent accumulators of each sum, maximum and flag,
//! every branch written as a select; a chunk is 4-wide vector instructions (explicit AVX2
//! intrinsics in that build, the portable lanes otherwise; the four off-diagonal entries of
//! the chunk's rows, `K_N(j, j+1)`, `K_N(j, j+2)`, `K_N(j−1, j)` and `K_N(j−2, j)`, are
//! four unaligned loads from the bands `upper1` and `upper2`), so the divisions of the
//! power step and the two reduction chains no longer serialise the pass. The first and last
//! two nodes (and the remainder of the interior) go through the scalar wrapped row. The
//! lanes are summed at the end, so the quotient's rounding differs from a sequential sum by
//! a few units in the last place (it is deterministic: the same inputs give the same bits,
//! on every CPU, since the AVX2 build uses no FMA and the baseline build rounds each
//! operation the same way). The AVX2 build runs block by block, a block's chunks in an inner
//! loop with no test in it (the block test once per block, each chunk's write through a
//! pointer): one straight run of instructions per chunk, where a test per chunk had split
//! the loop into four pieces and spilled a sum to the stack (same bits; the dense pass's
//! median 61 → 53 µs with its data in cache, 81 → 77 µs after a step: README "Stability").
//!
//! **In place.** The power step overwrites `z` as the pass goes, one chunk behind: a chunk
//! at `i` reads `z[i−2 .. i+6]`, and only then are the previous chunk's results written to
//! `z[i−4 .. i]`, which no later chunk reads; the first two nodes' results (read again,
//! wrapped, by the last two) and the last chunk's and the tail's are written after the
//! tail. So the pass streams `K_N`, the masses, the flags and `z` once and writes `z` back,
//! instead of writing a second mode buffer (measured: README "Stability").
//!
//! Like the particle pass of the reference solver ([`crate::mpm`]) the kernel is compiled
//! twice, for the baseline target and with AVX2, the build chosen at run time.
//!
//! Measured: README "Stability".

use crate::nodal_stiffness::NodalStiffness;

/// Independent lanes of the interior loop (one AVX2 vector of `f64`).
const LANES: usize = 4;

/// Power-step values below this fraction of the previous mode's largest component are
/// stored as zero (module docs, "Flushed tails"): about `4.5ε`; each flushed value's share
/// of the quotient is below `10⁻³⁰`, and the mode keeps clear of subnormal numbers.
pub(super) const FLUSH_RELATIVE: f64 = 1e-15;

/// Nodes per block of the zero-block test (module docs, "Zero blocks"): a multiple of
/// [`LANES`].
const BLOCK: usize = 64;

/// Tail nodes at most: the interior loop stops when fewer than `LANES + 2` nodes remain.
const MAX_TAIL: usize = LANES + 1;

/// What one fused pass over the nodes finds (see [`power_pass`]).
pub(super) struct Pass {
    /// `zᵀ K_N z / zᵀ M z` of the vector before the step.
    pub rayleigh: f64,
    /// Whether some active node has `K_N(i,i) > bound · m_i`.
    pub diagonal_above: bool,
    /// `max_i |z_i|` of the vector before the step (the caller's next `floor`, scaled by
    /// [`FLUSH_RELATIVE`]).
    pub max_abs: f64,
}

/// What the pass reads at every node besides the mode.
struct Inputs<'a> {
    kd: &'a [f64],
    /// `K_N(i, i+1)`.
    k1: &'a [f64],
    /// `K_N(i, i+2)`.
    k2: &'a [f64],
    mass: &'a [f64],
    active: &'a [bool],
    /// `1/ρ_prev`, the power step's scaling.
    inv_rho: f64,
    /// The diagonal test `K(i,i) > bound · m_i`.
    bound: f64,
    /// Power-step values below it are stored as zero.
    floor: f64,
}

/// The running sums, extrema and flags of one lane.
#[derive(Clone, Copy)]
struct Lane {
    num: f64,
    den: f64,
    above: bool,
    stale: bool,
    max_abs: f64,
}

impl Lane {
    const EMPTY: Lane = Lane {
        num: 0.0,
        den: 0.0,
        above: false,
        stale: false,
        max_abs: 0.0,
    };

    /// Node `i` with `y = (K_N z)_i`: the sums, the checks, and the power step's value
    /// (`0` at inactive nodes), every branch a select.
    #[inline(always)]
    fn node(&mut self, inp: &Inputs<'_>, zi: f64, y: f64, kd: f64, m: f64, a: bool) -> f64 {
        self.num += zi * y;
        self.den += if a { m * zi * zi } else { 0.0 };
        self.above |= a & (kd > inp.bound * m);
        self.stale |= !a & (zi != 0.0);
        self.max_abs = self.max_abs.max(zi.abs());
        let step = y * inp.inv_rho / m;
        if a && step.abs() >= inp.floor {
            step
        } else {
            0.0
        }
    }

    fn merge(self, other: Lane) -> Lane {
        Lane {
            num: self.num + other.num,
            den: self.den + other.den,
            above: self.above | other.above,
            stale: self.stale | other.stale,
            max_abs: self.max_abs.max(other.max_abs),
        }
    }
}

impl<'a> Inputs<'a> {
    /// The inputs of a pass over `K_N`'s bands and the nodes' masses and flags, with the
    /// previous quotient (its reciprocal scales the power step; `1` unless positive), the
    /// diagonal test's bound and the flush floor.
    fn new(
        k: &'a NodalStiffness,
        (mass, active): (&'a [f64], &'a [bool]),
        (rho_prev, bound, floor): (f64, f64, f64),
    ) -> Self {
        Inputs {
            kd: &k.diag,
            k1: &k.upper1,
            k2: &k.upper2,
            mass,
            active,
            inv_rho: if rho_prev > 0.0 { 1.0 / rho_prev } else { 1.0 },
            bound,
            floor,
        }
    }

    /// The diagonal test's margin at a node, `K(i,i) − bound · m_i` (`−∞` at an inactive
    /// node): the test fires when the lanes' maximum is positive.
    #[inline(always)]
    fn diagonal_gap(&self, kd: f64, m: f64, active: bool) -> f64 {
        if active {
            kd - self.bound * m
        } else {
            f64::NEG_INFINITY
        }
    }

    /// `(K_N z)_i` with the indices wrapped (entries past a fixed grid's last node are zero
    /// in `K_N`'s storage, so the wrap adds nothing there).
    fn wrapped_row(&self, z: &[f64], i: usize) -> f64 {
        let n = z.len() as isize;
        let w = |j: isize| j.rem_euclid(n) as usize;
        let (ii, k1, k2) = (i as isize, self.k1, self.k2);
        self.kd[i] * z[i]
            + k1[i] * z[w(ii + 1)]
            + k2[i] * z[w(ii + 2)]
            + k1[w(ii - 1)] * z[w(ii - 1)]
            + k2[w(ii - 2)] * z[w(ii - 2)]
    }

    /// One scalar node through the wrapped row: its power step's value (not written).
    fn scalar_node(&self, lane: &mut Lane, z: &[f64], i: usize) -> f64 {
        let y = self.wrapped_row(z, i);
        lane.node(self, z[i], y, self.kd[i], self.mass[i], self.active[i])
    }
}

/// Whether every active node has a positive finite mass: the precondition of [`power_pass`]
/// that a trusted [`crate::PassSummary`] guarantees, checked by this scan otherwise (an
/// infinite mass would make the quotient 0 and a zero block would hide it; a zero or
/// negative one trips the diagonal test, a `NaN` the quotient, but not by design).
pub(super) fn active_masses_positive(mass: &[f64], active: &[bool]) -> bool {
    // A fold without early exit, so that it vectorises.
    mass.iter().zip(active).fold(true, |ok, (&m, &a)| {
        ok & (!a | (m > 0.0 && m < f64::INFINITY))
    })
}

/// The pass (module docs): the quotient and checks of the mode `z` on entry, and `z`
/// overwritten by its power step. The caller makes sure that every active mass is positive
/// ([`active_masses_positive`]; a trusted pass summary guarantees it): the pass does not
/// test it (it did, at about 13 % of its time). `None` when it cannot be trusted (sizes, under 4
/// nodes, a node that became inactive under a non-zero `z_i`, a non-finite or negative
/// quotient) — the caller then anchors, whose full validation reports errors and which
/// replaces `z`. `z` is untouched only when the sizes do not fit.
///
/// The power step `z ← M⁻¹K_N z` is the power iteration on `C = M^{1/2} K_N M^{1/2}` in the
/// variable `z = M^{1/2}u` (`C u = M^{1/2} K_N z`); for a positive semi-definite `C` the
/// Rayleigh quotients of power iterates never decrease, so the step can only improve the
/// tracked mode between anchors.
pub(super) fn power_pass(
    k: &NodalStiffness,
    mass: &[f64],
    active: &[bool],
    z: &mut [f64],
    rho_prev: f64,
    bound: f64,
    floor: f64,
) -> Option<Pass> {
    let n = z.len();
    if !k.has_len(n) || mass.len() != n || active.len() != n || n < 4 {
        return None;
    }
    let inputs = Inputs::new(k, (mass, active), (rho_prev, bound, floor));
    let lane = dispatch(&inputs, z);
    let rayleigh = lane.num / lane.den;
    let valid = !lane.stale && rayleigh.is_finite() && rayleigh >= 0.0;
    valid.then_some(Pass {
        rayleigh,
        diagonal_above: lane.above,
        max_abs: lane.max_abs,
    })
}

/// The pass in the best build the CPU supports.
fn dispatch(inputs: &Inputs<'_>, z: &mut [f64]) -> Lane {
    #[cfg(target_arch = "x86_64")]
    if crate::mpm::has_avx2() {
        // SAFETY: `pass_avx2` only requires AVX2, which `has_avx2` has confirmed on this CPU.
        return unsafe { pass_avx2(inputs, z) };
    }
    pass(inputs, z)
}

/// The pass compiled for AVX2, its interior chunks in explicit 4-wide intrinsics that
/// perform the lane code's operations in the same order (no FMA), so both builds give the
/// same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn pass_avx2(inputs: &Inputs<'_>, z: &mut [f64]) -> Lane {
    // The closure inherits this function's target features, so the call is safe.
    pass_with(inputs, z, |inp, z| avx2::chunks(inp, z))
}

/// The pass in the baseline build.
fn pass(inputs: &Inputs<'_>, z: &mut [f64]) -> Lane {
    pass_with(inputs, z, chunks)
}

/// The pass over all `n ≥ 4` nodes: the first two nodes, the interior chunks of [`LANES`]
/// by `interior` (which returns their lanes, where it stopped, and the last chunk's results
/// not yet written), the tail; then the delayed writes (module docs).
#[inline(always)]
fn pass_with(
    inp: &Inputs<'_>,
    z: &mut [f64],
    interior: impl FnOnce(&Inputs<'_>, &mut [f64]) -> Interior,
) -> Lane {
    let n = z.len();
    let mut edge = Lane::EMPTY;
    let first = [
        inp.scalar_node(&mut edge, z, 0),
        inp.scalar_node(&mut edge, z, 1),
    ];
    let done = interior(inp, z);
    let mut tail = Lane::EMPTY;
    let mut tail_steps = [0.0; MAX_TAIL];
    for (slot, j) in tail_steps.iter_mut().zip(done.end..n) {
        *slot = inp.scalar_node(&mut tail, z, j);
    }
    if let Some((at, last)) = done.pending {
        z[at..at + LANES].copy_from_slice(&last);
    }
    let rest = n - done.end;
    z[done.end..].copy_from_slice(&tail_steps[..rest]);
    z[..2].copy_from_slice(&first);
    edge.merge(done.lanes.merge()).merge(tail)
}

/// What the interior chunks leave: their lanes, the first node they did not process, and
/// the last chunk's power step with its position (written by the caller after the tail).
struct Interior {
    lanes: Lanes,
    end: usize,
    pending: Option<(usize, [f64; LANES])>,
}

/// The interior accumulators, one per lane and quantity; the flags as maxima of `f64`
/// values (set when `> 0`), so a chunk is arithmetic and selects only.
struct Lanes {
    num: [f64; LANES],
    den: [f64; LANES],
    above: [f64; LANES],
    stale: [f64; LANES],
    max_abs: [f64; LANES],
}

impl Lanes {
    const EMPTY: Lanes = Lanes {
        num: [0.0; LANES],
        den: [0.0; LANES],
        above: [f64::NEG_INFINITY; LANES],
        stale: [0.0; LANES],
        max_abs: [0.0; LANES],
    };

    /// The lanes combined in lane order.
    fn merge(&self) -> Lane {
        (0..LANES)
            .map(|l| Lane {
                num: self.num[l],
                den: self.den[l],
                above: self.above[l] > 0.0,
                stale: self.stale[l] > 0.0,
                max_abs: self.max_abs[l],
            })
            .fold(Lane::EMPTY, Lane::merge)
    }
}

/// The interior chunks in portable code, from node 2 while `i + LANES + 2 ≤ n`, each
/// chunk's power step written one chunk late (module docs).
#[inline(always)]
fn chunks(inp: &Inputs<'_>, z: &mut [f64]) -> Interior {
    let n = z.len();
    let mut acc = Lanes::EMPTY;
    let mut pending: Option<(usize, [f64; LANES])> = None;
    let mut i = 2;
    while i + LANES + 2 <= n {
        // A zero block (module docs): its diagonal tests only.
        if (i - 2) % BLOCK == 0
            && i + BLOCK + 2 <= n
            && z[i - 2..i + BLOCK + 2].iter().all(|v| v.to_bits() == 0)
        {
            if let Some((at, prev)) = pending.take() {
                z[at..at + LANES].copy_from_slice(&prev);
            }
            for j in (i..i + BLOCK).step_by(LANES) {
                for l in 0..LANES {
                    let gap = inp.diagonal_gap(inp.kd[j + l], inp.mass[j + l], inp.active[j + l]);
                    acc.above[l] = acc.above[l].max(gap);
                }
            }
            i += BLOCK;
            continue;
        }
        let Ok(zw) = <[f64; LANES + 4]>::try_from(&z[i - 2..i + LANES + 2]) else {
            break;
        };
        let Ok(k1w) = <&[f64; LANES + 1]>::try_from(&inp.k1[i - 1..i + LANES]) else {
            break;
        };
        let Ok(k2w) = <&[f64; LANES + 2]>::try_from(&inp.k2[i - 2..i + LANES]) else {
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
        let mut y = [0.0; LANES];
        for l in 0..LANES {
            // Node j = i + l: z_j is zw[l + 2], K(j, j+1) is k1w[l + 1], K(j, j+2) k2w[l + 2].
            y[l] = kd[l] * zw[l + 2]
                + k1w[l + 1] * zw[l + 3]
                + k2w[l + 2] * zw[l + 4]
                + k1w[l] * zw[l + 1]
                + k2w[l] * zw[l];
        }
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            let (zi, al) = (zw[l + 2], a[l]);
            acc.num[l] += zi * y[l];
            acc.den[l] += if al { m[l] * zi * zi } else { 0.0 };
            acc.above[l] = acc.above[l].max(inp.diagonal_gap(kd[l], m[l], al));
            acc.stale[l] = acc.stale[l].max(if al { 0.0 } else { zi.abs() });
            acc.max_abs[l] = acc.max_abs[l].max(zi.abs());
            let step = y[l] * inp.inv_rho / m[l];
            out[l] = if al && step.abs() >= inp.floor {
                step
            } else {
                0.0
            };
        }
        if let Some((at, prev)) = pending {
            z[at..at + LANES].copy_from_slice(&prev);
        }
        pending = Some((i, out));
        i += LANES;
    }
    Interior {
        lanes: acc,
        end: i,
        pending,
    }
}

/// The interior chunks in AVX2 intrinsics.
#[cfg(target_arch = "x86_64")]
mod avx2 {
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
                        // A zero block (module docs): its diagonal tests only.
                        _mm256_storeu_pd(run.dst, run.pending);
                        run.pending = zero;
                        run.dst = zp.add(i + BLOCK - LANES);
                        for j in (i..i + BLOCK).step_by(LANES) {
                            let kdv = _mm256_loadu_pd(kd.as_ptr().add(j));
                            let m = _mm256_loadu_pd(mass.as_ptr().add(j));
                            let act = active_mask(active.as_ptr().add(j));
                            run.above =
                                _mm256_or_pd(run.above, diagonal_mask(kdv, m, act, c.bound));
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
            upper1: (0..n).map(|_| rng.random_range(-1.0..0.0)).collect(),
            upper2: (0..n).map(|_| rng.random_range(-0.2..0.2)).collect(),
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

    /// The pass by one sequential scalar loop over the wrapped rows (the definition):
    /// quotient, diagonal flag, stale flag, `max |z|` and the power step.
    fn reference(
        k: &NodalStiffness,
        mass: &[f64],
        active: &[bool],
        z: &[f64],
        (rho_prev, bound, floor): (f64, f64, f64),
    ) -> (f64, bool, bool, f64, Vec<f64>) {
        let inp = Inputs::new(k, (mass, active), (rho_prev, bound, floor));
        let (mut num, mut den, mut above, mut stale) = (0.0, 0.0, false, false);
        let next = (0..z.len())
            .map(|i| {
                let y = inp.wrapped_row(z, i);
                num += z[i] * y;
                if active[i] {
                    den += mass[i] * z[i] * z[i];
                    above |= k.diag[i] > bound * mass[i];
                    let step = y * inp.inv_rho / mass[i];
                    if step.abs() >= floor {
                        step
                    } else {
                        0.0
                    }
                } else {
                    stale |= z[i] != 0.0;
                    0.0
                }
            })
            .collect();
        let max_abs = z.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        (num / den, above, stale, max_abs, next)
    }

    /// The pass in both builds on one case: the dispatched build (AVX2 where the CPU has
    /// it) and the portable one, each on its own copy of `z`.
    fn both_builds(
        k: &NodalStiffness,
        (mass, active): (&[f64], &[bool]),
        z: &[f64],
        scalars: (f64, f64, f64),
    ) -> [(Lane, Vec<f64>); 2] {
        let inputs = Inputs::new(k, (mass, active), scalars);
        let (mut fast, mut portable) = (z.to_vec(), z.to_vec());
        let lane = dispatch(&inputs, &mut fast);
        [(lane, fast), (pass(&inputs, &mut portable), portable)]
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn the_vector_builds_agree_bit_for_bit_and_match_the_sequential_definition() {
        // Sizes with no chunk (4–7 nodes), one chunk, every tail length, and long runs;
        // each without flushing and with a floor that flushes about half of the power step.
        // Zero stretches: from 64 nodes in the middle, whole zero blocks from 134 nodes —
        // the first block (134: nodes 0–69 zero), the last interior step (135: nodes
        // 60–134 zero), and blocks inside (1001).
        let sizes = [4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 64, 134, 135, 1001];
        for (seed, n) in sizes.into_iter().enumerate() {
            for flush in [false, true] {
                let (mut k, mass, active, mut z) = case(n, seed as u64, false);
                let zero = match n {
                    134 => 0..70,
                    135 => 60..135,
                    _ if n >= 64 => n / 4..n / 2,
                    _ => 0..0,
                };
                z[zero.clone()].fill(0.0);
                // A NaN in `K_N` well inside a zero block is never multiplied: proof that
                // the block was skipped (a computed block would poison the quotient).
                let skipped = (n >= 134).then(|| {
                    let j = zero.start + 8;
                    k.upper1[j] = f64::NAN;
                    j
                });
                let (rho_prev, bound) = (1.3, 2.5);
                let floor = if flush {
                    let (.., unflushed) = reference(&k, &mass, &active, &z, (rho_prev, bound, 0.0));
                    let mut sizes: Vec<f64> = unflushed.iter().map(|v| v.abs()).collect();
                    sizes.sort_by(f64::total_cmp);
                    sizes[sizes.len() / 2]
                } else {
                    0.0
                };
                let scalars = (rho_prev, bound, floor);
                let [(fast, fz), (portable, pz)] = both_builds(&k, (&mass, &active), &z, scalars);
                let case = format!("n = {n}, flush {flush}");
                assert_eq!(
                    bits(&fz),
                    bits(&pz),
                    "{case}: power steps differ between builds"
                );
                for (a, b) in [
                    (fast.num, portable.num),
                    (fast.den, portable.den),
                    (fast.max_abs, portable.max_abs),
                ] {
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "{case}: sums differ between builds"
                    );
                }
                assert_eq!((fast.above, fast.stale), (portable.above, portable.stale));
                let p = power_pass(&k, &mass, &active, &mut z.clone(), rho_prev, bound, floor)
                    .expect("valid pass");
                assert_eq!(p.rayleigh.to_bits(), (fast.num / fast.den).to_bits());
                if let Some(j) = skipped {
                    assert!(
                        p.rayleigh.is_finite(),
                        "{case}: the block at {j} was computed"
                    );
                    k.upper1[j] = 0.0;
                }
                // The in-place pass computes from the mode on entry, as an out-of-place one
                // (equal values; a skipped block's zeros are `+0.0` where the definition may
                // give `−0.0` without a floor).
                let (rho, above, _, max_abs, next) = reference(&k, &mass, &active, &z, scalars);
                assert_eq!(p.diagonal_above, above, "{case}");
                assert_eq!(p.max_abs.to_bits(), max_abs.to_bits(), "{case}");
                if flush {
                    let zeros = next.iter().filter(|&&v| v == 0.0).count();
                    assert!(
                        zeros >= n / 2 && zeros < n,
                        "{case}: {zeros} values flushed"
                    );
                }
                assert_eq!(fz, next, "{case}: power step differs from the definition");
                assert!(
                    (p.rayleigh - rho).abs() <= 1e-12 * rho.abs().max(1.0),
                    "{case}: quotient {} vs sequential {rho}",
                    p.rayleigh
                );
            }
        }
    }

    #[test]
    fn the_mass_scan_refuses_what_a_zero_block_would_hide() {
        // An infinite mass at an active node inside a zero block: the pass serves (the block
        // is not computed, the diagonal test cannot fire), so the caller's scan must refuse.
        let (k, mut mass, active, mut z) = case(1001, 11, false);
        z[300..600].fill(0.0);
        let j = (400..500).find(|&j| active[j]).expect("an active node");
        mass[j] = f64::INFINITY;
        assert!(power_pass(&k, &mass, &active, &mut z, 1.0, 100.0, 0.0).is_some());
        assert!(!active_masses_positive(&mass, &active));
        for bad in [0.0, -1.0, f64::NAN] {
            mass[j] = bad;
            assert!(!active_masses_positive(&mass, &active), "{bad}");
        }
        mass[j] = 0.5;
        assert!(active_masses_positive(&mass, &active));
        // Inactive nodes may hold anything.
        let i = (0..1001).find(|&i| !active[i]).expect("an inactive node");
        mass[i] = f64::INFINITY;
        assert!(active_masses_positive(&mass, &active));
    }

    #[test]
    fn a_nonzero_mode_at_an_inactive_node_and_bad_sizes_are_refused() {
        let (k, mass, active, mut z) = case(64, 8, true);
        assert!(active.iter().any(|&a| !a));
        assert!(power_pass(&k, &mass, &active, &mut z, 1.0, 10.0, 0.0).is_none());
        let (k, mass, active, z) = case(64, 9, false);
        // Sizes that do not fit leave the mode untouched.
        let mut untouched = z.clone();
        assert!(power_pass(&k, &mass[..63], &active, &mut untouched, 1.0, 10.0, 0.0).is_none());
        assert_eq!(untouched, z);
        let mut short = z[..3].to_vec();
        assert!(power_pass(&k, &mass[..3], &active[..3], &mut short, 1.0, 1.0, 0.0).is_none());
        // The diagonal test fires on one heavy diagonal entry at an active node in a chunk.
        let mut k2 = k.clone();
        let j = (2..60)
            .find(|&j| active[j])
            .expect("an active interior node");
        k2.diag[j] = 1e3 * mass[j];
        // … and in a zero block, where only the diagonal test runs.
        let (mut k3, mass3, active3, mut z3) = case(1001, 10, false);
        z3[300..600].fill(0.0);
        let j3 = (400..500).find(|&j| active3[j]).expect("an active node");
        k3.diag[j3] = 1e3 * mass3[j3];
        for (kd, expect) in [(1e3 * mass3[j3], true), (0.0, false)] {
            k3.diag[j3] = kd;
            let builds = both_builds(&k3, (&mass3, &active3), &z3, (1.0, 100.0, 0.0));
            for (lane, _) in builds {
                assert_eq!(lane.above, expect);
            }
            let p3 = power_pass(&k3, &mass3, &active3, &mut z3.clone(), 1.0, 100.0, 0.0);
            assert_eq!(p3.expect("valid").diagonal_above, expect);
        }
        let mut z2 = z.clone();
        let p = power_pass(&k2, &mass, &active, &mut z2, 1.0, 100.0, 0.0).expect("valid");
        assert!(p.diagonal_above);
    }
}
