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
    if crate::cpu::has_avx2() {
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
mod avx2;

#[cfg(test)]
mod tests;
