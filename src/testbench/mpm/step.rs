//! The fused update-stress-last step (eqs 17–29) and the nodal deposit (eqs 7, 17, 18).
//!
//! From a committed state `n` whose nodal arrays hold `m_i`, `v_i` (eq 17) and `a_i`
//! (eq 18) computed at `xⁿ`, one trial step of size `dt` is
//!
//! 1. **grid pass** — `v_iⁿ⁺¹ = v_i + dt a_i` (eq 19); constrained and inactive nodes
//!    carry `v_i = a_i = 0`, so they stay at rest;
//! 2. **one particle pass** — with the stencil (`S_ip`, `D_ip`) at `x_pⁿ`:
//!    `a_p = Σ_i S_ip a_i` (eq 21), `v_pⁿ⁺¹ = v_p + dt a_p` (eq 22),
//!    `L_p = Σ_i D_ip v_iⁿ⁺¹` (eq 24, the *updated* nodal velocity),
//!    `Fⁿ⁺¹ = Fⁿ (1 + dt L_p)` (eq 25 with a single `dt`: the paper prints it twice),
//!    `σⁿ⁺¹` from the material (eq 27 for linear elasticity), `x_pⁿ⁺¹ = x_p + dt v_pⁿ⁺¹`
//!    (eq 29, wrapped on periodic grids); then, with the stencil at `x_pⁿ⁺¹`, the particle
//!    deposits `S m_p`, `S m_p v_pⁿ⁺¹` and the internal force `−D σⁿ⁺¹ Fⁿ⁺¹ V⁰` (eq 6) on
//!    its nodes;
//! 3. **grid finalize** — `m_i`, `v_i = p_i/m_i` (eq 17) and `a_i = f_i/m_i` (eq 18) of the
//!    trial state, zero at constrained and inactive nodes.
//!
//! So every particle is read and written once per step, and the nodal sums the *next* step
//! needs are ready when the trial is accepted. Step 2 runs over blocks of `BLOCK` particles,
//! each in five phases: the stencils at `xⁿ` of the whole block into structure-of-arrays
//! scratch (a loop the compiler vectorises), the indexed gather, the particle update
//! (vectorised), the stencils at `xⁿ⁺¹` (vectorised), and the deposit from the
//! just-written, cache-resident trial fields. Every value is computed by the same IEEE
//! operations in the same order as one scalar loop — vector lanes round like scalar
//! instructions, no FMA is ever formed, and each nodal sum still receives the particles in
//! particle order — so the results are bit for bit those of the plain loop, and a restart
//! that recomputes the nodal sums from the particles reproduces them exactly. Stencils come
//! from the branch-free forms of `stencil.rs`. The deposit accumulators are padded to four
//! lanes `(m, p, f, 0)`, so one node takes one vector add (`f −= D sfv` written
//! `f += D (−sfv)`, the same IEEE result). The deposit adds into a register window of the
//! three slots under the particle's stencil (`slot_window.rs`), written to memory when the
//! window moves on, instead of a read-modify-write of memory per particle, whose
//! store-to-load chains bounded the pass (measured: bare step at 10⁵ particles 8–12 %
//! faster, min of 300 steps interleaved with the old binary). While the stencils' first
//! slots never decrease along the particles (particles sorted by `x − l_p/2`: by position
//! when the widths are equal) the sums are still the plain loop's bit for bit; a particle
//! out of that order (one that crossed a periodic end or a neighbour) splits its slots'
//! sums into partial sums, rounded
//! differently but the same for the same particle order, and the restart's set-up
//! deposit ([`deposit_state`]) uses the same window. With the stiffness on, the band
//! (`K_N`) is deposited in the same loop, in memory (a second window was slower there, and
//! slower still in a loop of its own: +0.5 against +0.4 ms at 10⁵ particles), 4-wide
//! like the accumulators (it was 9 scalar adds per particle).
//!
//! The pass is compiled twice: for the baseline target, and with AVX2 enabled (VEX-encoded
//! 4-wide vectors, `f64::floor` as one instruction; never FMA, so the bits stay equal). The
//! AVX2 build is chosen at run time by `is_x86_feature_detected!`, once per process; other
//! CPUs and architectures run the baseline build.
//!
//! Measured with `cargo bench --bench step -- --warm-up-time 1 --measurement-time 4`
//! (standing wave, GIMP, 2 particles per cell, periodic) on the development VM — an AMD
//! EPYC with 2 cores shared with other jobs, so noisy; old and new binaries run back to
//! back, figures are the best criterion samples (criterion's means in parentheses), in M
//! particle-steps/s:
//!
//! | particles | blocked scalar loop (before) | AVX2 dispatch only | this layout     |
//! |-----------|------------------------------|--------------------|-----------------|
//! | 10³       | 38 (36)                      |                    | 88 (80)         |
//! | 10⁴       | 38 (34)                      | 50                 | 87 (66)         |
//! | 10⁵       | 37 (34)                      |                    | 82 (61)         |
//! | 10⁶       | 35 (31)                      |                    | 63 (58)         |
//!
//! "AVX2 dispatch only" is `roundsd` floor, the hoisted periodic wrap and bounds checks
//! removed, without the vectorised phases. 10⁶ is bound by memory traffic (about 120
//! bytes per particle-step). The baseline (SSE2) build of this layout is 1.46× faster than
//! the old loop at 10⁵. Blocks of 128, 256 and 1024 particles measured the same within
//! noise.
//!
//! Failures are detected without branches in the loop (flags for a non-finite
//! `|x|+|v|+|σ|+|F|` of some particle, for `F ≤ 0`, for a particle out of a fixed domain) and
//! the first offending particle is located only when one fires. A failed trial leaves the
//! committed state and the scratch arrays as they were.
//!
//! # Extended lattice
//!
//! The hot loop indexes nodal scratch arrays by lattice index `j + 1` (`j ≥ −1`) on an
//! extended lattice of `N + 4` slots, for both boundaries. On a fixed grid this is exactly
//! the storage order (ghost, `X_0 … X_N`, ghost, one spare slot that only ever receives
//! zero weights); on a periodic grid the slots past the ends are images that are folded
//! onto their periodic nodes after the deposit and filled from them before the gather. The
//! loop therefore needs no modulo and no branch per node.

use super::material::Material;
use super::particle_pass::{particle_pass_dispatch, PassFlags};
use super::slot_window::SlotWindow;
use super::state::{is_active, Observed, State};
use super::stencil;
use super::summary_lanes::greater;
use crate::grid::{Boundary, Grid};
use crate::shape::{Shape, MAX_NODES};

/// Constants of a run that the kernel reads.
pub(crate) struct Ctx<'a> {
    pub grid: &'a Grid,
    pub shape: Shape,
    pub material: Material,
    pub mass: &'a [f64],
    pub volume0: &'a [f64],
    pub width: &'a [f64],
    /// Nodal mass at or below which a node is inactive.
    pub threshold: f64,
    /// Whether the deposit also accumulates the nodal stiffness `K_N` (eq 56 via
    /// [`crate::NodalStiffness`]) of the new state.
    pub stiffness: bool,
    /// Whether the pass also takes the [`crate::PassSummary`] of the new state and fills its
    /// tangent moduli, densities and node flags (`pass_summary.rs`).
    pub summary: bool,
    /// Whether that summary carries the element bound (GIMP only; `element_bound.rs`).
    pub bound: bool,
    /// The kick of this step when it differs from the drift `dt`: `(dt₋ + dt)/2` of the
    /// staggered kick ([`super::ReferenceStepper::set_staggered_kick`]); `None` kicks with `dt`.
    pub kick: Option<f64>,
}

/// Scratch arrays on the extended lattice, allocated once per solver.
#[derive(Clone, Debug, Default)]
pub(crate) struct Workspace {
    /// `(a_i, v_iⁿ⁺¹)` for the gather.
    pub(super) gather: Vec<[f64; 2]>,
    /// `(m_i, p_i, f_i, 0)` accumulated by the deposit (padded to 32 bytes: one vector
    /// add per node).
    pub(super) acc: Vec<[f64; 4]>,
    /// `(K_N(j, j), K_N(j, j+1), K_N(j, j+2), 0)` accumulated by the deposit when
    /// [`Ctx::stiffness`] is set (zero otherwise).
    pub(super) band: Vec<[f64; 4]>,
    /// Buffers the pass fills with the trial's observed data when [`Ctx::summary`] is set,
    /// swapped with the trial's spare storage afterwards (no allocation in a run).
    pub(super) observed: Observed,
}

impl Workspace {
    pub fn new(grid: &Grid) -> Self {
        let n = ext_len(grid);
        Self {
            gather: vec![[0.0; 2]; n],
            acc: vec![[0.0; 4]; n],
            band: vec![[0.0; 4]; n],
            observed: Observed::default(),
        }
    }
}

/// What went wrong in a particle pass (the stepper adds `t`, `step`, `dt`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Failure {
    NonFinite { field: &'static str, index: usize },
    Inverted { index: usize, f: f64 },
    OutOfDomain { index: usize, x: f64 },
}

/// Number of slots of the extended lattice.
#[inline]
fn ext_len(grid: &Grid) -> usize {
    grid.cells + 4
}

/// Storage index of extended slot `e` (lattice `j = e − 1`), `None` past a fixed grid.
#[inline]
fn ext_to_storage(grid: &Grid, e: usize) -> Option<usize> {
    let n = grid.cells;
    match grid.boundary {
        Boundary::Periodic => Some(if (1..=n).contains(&e) {
            e - 1
        } else {
            (e as i64 - 1).rem_euclid(n as i64) as usize
        }),
        Boundary::Fixed => (e < n + 3).then_some(e),
    }
}

/// First extended slot of a stencil, clamped so that `MAX_NODES` slots always fit
/// (in-domain particles never need the clamp; it keeps NaN and infinite positions —
/// whose `first` is 0 or saturated at `i64::MAX`/`MIN` — from indexing out of bounds).
#[inline(always)]
pub(super) fn base_slot(first: i64, max_base: i64) -> usize {
    first.saturating_add(1).clamp(0, max_base) as usize
}

/// Adds one particle's mass, momentum and internal force (eq 6) to the accumulators.
/// `f_i −= D sfv` is written `f_i += D (−sfv)`: the same IEEE result, and one vector
/// operation per node with the padding lane (which stays 0).
#[inline(always)]
pub(super) fn deposit(
    slots: &mut [[f64; 4]; MAX_NODES],
    s: &[f64; MAX_NODES],
    d: &[f64; MAX_NODES],
    m: f64,
    mv: f64,
    sfv: f64,
) {
    let q = [m, mv, -sfv, 0.0];
    for ((slot, &s), &d) in slots.iter_mut().zip(s).zip(d) {
        let w = [s, s, d, 0.0];
        for k in 0..4 {
            slot[k] += w[k] * q[k];
        }
    }
}

/// A particle's weight in `K_N`, `k = E_t(F) F V⁰`, and its `E_t/ρ = k/m` (for `c²_ref`).
#[inline(always)]
fn stiffness_weight(tangent: f64, f: f64, volume0: f64, mass: f64) -> (f64, f64) {
    let k = tangent * f * volume0;
    (k, k / mass)
}

/// The particles' weights in `K_N` (into `k_w`) and `c²_ref` as lane maxima (particle `i` in
/// lane `i mod 4`), in chunks of four written out so that the divisions `k/m` run as one
/// vector division (a loop indexing `lanes[i % 4]` compiled to a scalar division per
/// particle).
#[inline(always)]
pub(super) fn stiffness_weights<Tg: Fn(f64) -> f64>(
    tangent: Tg,
    (f, vol0, mass): (&[f64], &[f64], &[f64]),
    k_w: &mut [f64],
    lanes: &mut [f64; 4],
) {
    debug_assert!(f.len() == k_w.len() && vol0.len() == k_w.len() && mass.len() == k_w.len());
    let mut out = k_w.chunks_exact_mut(4);
    let (fs, vs, ms) = (
        f.chunks_exact(4),
        vol0.chunks_exact(4),
        mass.chunks_exact(4),
    );
    let tails = (fs.remainder(), vs.remainder(), ms.remainder());
    for (((kc, fc), vc), mc) in (&mut out).zip(fs).zip(vs).zip(ms) {
        for l in 0..4 {
            let (k, c2) = stiffness_weight(tangent(fc[l]), fc[l], vc[l], mc[l]);
            kc[l] = k;
            lanes[l] = greater(c2, lanes[l]);
        }
    }
    // The last particles, `i mod 4 = l` as in the chunks.
    let (ft, vt, mt) = tails;
    for (l, (((k, &fl), &vl), &ml)) in out
        .into_remainder()
        .iter_mut()
        .zip(ft)
        .zip(vt)
        .zip(mt)
        .enumerate()
    {
        let (kl, c2) = stiffness_weight(tangent(fl), fl, vl, ml);
        *k = kl;
        lanes[l] = greater(c2, lanes[l]);
    }
}

/// The `MAX_NODES` band slots from `base` (`base ≤ max_base`, so always in bounds).
#[inline(always)]
pub(super) fn band_slots(band: &mut [[f64; 4]], base: usize) -> &mut [[f64; 4]; MAX_NODES] {
    let slots = &mut band[base..base + MAX_NODES];
    slots.try_into().expect("MAX_NODES slots")
}

/// Adds one particle's `k d dᵀ` (`k = E_t F V⁰`, `d` its `D_ip`) to the stiffness band:
/// node `base + a` gets `k d_a (d_a, d_{a+1}, d_{a+2})`. Like [`deposit`], one 4-wide
/// add per node: the padding lane receives `k d_a · 0` and is never read.
#[inline(always)]
pub(super) fn deposit_band(slots: &mut [[f64; 4]; MAX_NODES], d: &[f64; MAX_NODES], k: f64) {
    let ext = [d[0], d[1], d[2], 0.0, 0.0, 0.0];
    for (a, slot) in slots.iter_mut().enumerate() {
        let kd = k * ext[a];
        let w = [ext[a], ext[a + 1], ext[a + 2], 0.0];
        for o in 0..4 {
            slot[o] += kd * w[o];
        }
    }
}

/// Folds the image slots of a periodic grid's extended lattice (lattice −1, N, N+1, N+2)
/// onto their nodes, or clears the spare last slot of a fixed grid (it only ever receives zero
/// weights), and returns the slot of stored node 0: 1 (periodic, lattice `j = i`) or 0 (fixed,
/// storage order). Lanes are added one by one, in the same order for every accumulator.
fn fold_images(grid: &Grid, slots: &mut [[f64; 4]]) -> usize {
    let n_nodes = grid.n_nodes();
    match grid.boundary {
        Boundary::Periodic => {
            for e in [0, n_nodes + 1, n_nodes + 2, n_nodes + 3] {
                if let Some(i) = ext_to_storage(grid, e) {
                    let a = std::mem::take(&mut slots[e]);
                    let slot = &mut slots[i + 1];
                    for k in 0..3 {
                        slot[k] += a[k];
                    }
                }
            }
            1
        }
        Boundary::Fixed => {
            slots[n_nodes] = [0.0; 4];
            0
        }
    }
}

/// Folds the stiffness band onto the stored nodes into `to.stiffness` (band storage of
/// [`crate::NodalStiffness`]) and zeroes it. Periodic images fold like the accumulators: the
/// pair `(j, j+o)` of an image slot is the pair `(i, i+o mod N)` of its node.
/// Without [`Ctx::stiffness`] it only marks the state's `K_N` as not provided.
fn finalize_band(ctx: &Ctx<'_>, band: &mut [[f64; 4]], c2_ref: f64, to: &mut State) {
    if !ctx.stiffness {
        to.stiffness_valid = false;
        return;
    }
    let n_nodes = ctx.grid.n_nodes();
    let offset = fold_images(ctx.grid, band);
    let k = &mut to.stiffness;
    // Sized once, then written in place (a loop the compiler vectorises; `push` kept a
    // capacity check per node).
    k.diag.resize(n_nodes, 0.0);
    k.upper1.resize(n_nodes, 0.0);
    k.upper2.resize(n_nodes, 0.0);
    let slots = &mut band[offset..offset + n_nodes];
    let bands = k.diag.iter_mut().zip(&mut k.upper1).zip(&mut k.upper2);
    for (slot, ((d, u1), u2)) in slots.iter_mut().zip(bands) {
        let [kd, o1, o2, _] = std::mem::take(slot);
        (*d, *u1, *u2) = (kd, o1, o2);
    }
    k.c2_ref = c2_ref;
    to.stiffness_valid = true;
}

/// Folds the accumulators onto the stored nodes, computes `m_i`, `v_i = p_i/m_i`,
/// `a_i = f_i/m_i` (zero at inactive and constrained nodes) and leaves the accumulators
/// zeroed for the next deposit, in one pass over the nodes. With `flags`, also writes each
/// node's activity there and returns whether the summary's node checks hold (some node
/// active, every active mass finite); without, returns `false`.
fn finalize(
    ctx: &Ctx<'_>,
    acc: &mut [[f64; 4]],
    to: &mut State,
    mut flags: Option<&mut Vec<bool>>,
) -> bool {
    let grid = ctx.grid;
    let n_nodes = grid.n_nodes();
    let offset = fold_images(grid, acc);
    let nodes = to
        .node_mass
        .iter_mut()
        .zip(to.node_velocity.iter_mut())
        .zip(to.node_acceleration.iter_mut());
    let (mut any_active, mut all_finite) = (false, true);
    if let Some(f) = flags.as_mut() {
        f.clear();
    }
    for (i, (((m, v), a), slot)) in nodes.zip(&mut acc[offset..offset + n_nodes]).enumerate() {
        let [mi, pi, fi, _] = std::mem::take(slot);
        *m = mi;
        let active = is_active(grid, i, mi, ctx.threshold);
        if active {
            let inv = 1.0 / mi;
            *v = pi * inv;
            *a = fi * inv;
        } else {
            *v = 0.0;
            *a = 0.0;
        }
        if let Some(f) = flags.as_mut() {
            f.push(active);
            any_active |= active;
            all_finite &= !active || mi.is_finite();
        }
    }
    flags.is_some() && any_active && all_finite
}

/// Computes the nodal arrays of `state` from its particle fields (eqs 7, 17, 18): used
/// once at set-up; the step does this inside its particle pass.
pub(crate) fn deposit_state(ctx: &Ctx<'_>, ws: &mut Workspace, state: &mut State) {
    ws.acc.fill([0.0; 4]);
    ws.band.fill([0.0; 4]);
    let mut c2_ref = 0.0_f64;
    let (inv_h, origin) = (1.0 / ctx.grid.h, ctx.grid.origin);
    let max_base = (ext_len(ctx.grid) - MAX_NODES) as i64;
    let mut acc_window = SlotWindow::new();
    for p in 0..state.x.len() {
        let st = stencil::of(ctx.shape, state.x[p] - origin, ctx.width[p], inv_h);
        let base = base_slot(st.first, max_base);
        let m = ctx.mass[p];
        let sfv = state.sigma[p] * state.f[p] * ctx.volume0[p];
        let slots = acc_window.at(&mut ws.acc, base);
        deposit(slots, &st.s, &st.d, m, m * state.v[p], sfv);
        if ctx.stiffness {
            let f = state.f[p];
            let (k, c2) = stiffness_weight(ctx.material.tangent_modulus(f), f, ctx.volume0[p], m);
            c2_ref = c2_ref.max(c2);
            deposit_band(band_slots(&mut ws.band, base), &st.d, k);
        }
    }
    acc_window.flush(&mut ws.acc);
    finalize(ctx, &mut ws.acc, state, None);
    finalize_band(ctx, &mut ws.band, c2_ref, state);
}

/// One trial step of size `dt` from `from` into `to` (see the module docs). `to`'s
/// particle and nodal arrays must have the lengths of `from`'s.
pub(crate) fn advance(
    ctx: &Ctx<'_>,
    ws: &mut Workspace,
    from: &State,
    to: &mut State,
    dt: f64,
) -> Result<(), Failure> {
    // 1. Grid pass (eq 19) onto the extended lattice.
    let kick = ctx.kick.unwrap_or(dt);
    for (e, g) in ws.gather.iter_mut().enumerate() {
        *g = match ext_to_storage(ctx.grid, e) {
            Some(i) => {
                let a = from.node_acceleration[i];
                [a, from.node_velocity[i] + kick * a]
            }
            None => [0.0, 0.0],
        };
    }
    // The accumulators are zero here: `finalize` (or a failed pass, below) cleared them.

    // 2. Fused particle pass, monomorphised over instruction set, shape, boundary and
    // material.
    let flags = particle_pass_dispatch(ctx, ws, from, to, dt);

    if let Some(failure) = first_failure(&flags, to) {
        // Leave the accumulators clean for the next attempt.
        ws.acc.fill([0.0; 4]);
        if ctx.stiffness {
            ws.band.fill([0.0; 4]);
        }
        return Err(failure);
    }

    // 3. Grid finalize of the trial state.
    let node_flags = ctx.summary.then_some(&mut ws.observed.node_active);
    let nodes_ok = finalize(ctx, &mut ws.acc, to, node_flags);
    finalize_band(ctx, &mut ws.band, flags.c2_ref, to);
    to.summary = None;
    if let Some(parts) = flags.summary {
        let observed = std::mem::take(&mut ws.observed);
        let (spare, installed) = to.install_observed(observed);
        ws.observed = spare;
        let summary = match flags.element_bound {
            Some(bound) => parts.summary.with_element_bound(bound),
            None => parts.summary,
        };
        to.summary = (parts.ok && nodes_ok && installed).then_some(summary);
    }
    Ok(())
}

/// The first failure of a trial, most basic first: non-finite values, then inversion,
/// then a particle outside a fixed domain.
fn first_failure(flags: &PassFlags, to: &State) -> Option<Failure> {
    if flags.maybe_non_finite {
        let fields: [(&'static str, &[f64]); 4] = [
            ("x", &to.x),
            ("v", &to.v),
            ("sigma", &to.sigma),
            ("F", &to.f),
        ];
        let first = fields
            .iter()
            .filter_map(|(field, vals)| {
                vals.iter()
                    .position(|v| !v.is_finite())
                    .map(|index| (index, *field))
            })
            .min_by_key(|&(index, _)| index);
        // A finite state whose |values| merely overflowed the sum is not a failure.
        if let Some((index, field)) = first {
            return Some(Failure::NonFinite { field, index });
        }
    }
    if let Some(index) = flags.first_inverted {
        return Some(Failure::Inverted {
            index,
            f: to.f[index],
        });
    }
    if let Some(index) = flags.first_out {
        return Some(Failure::OutOfDomain {
            index,
            x: to.x[index],
        });
    }
    None
}
