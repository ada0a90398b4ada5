//! The fused particle pass itself ([`super`]): block by block, the gather at `xⁿ`, the
//! particle update, the summary and the deposit at `xⁿ⁺¹` — each phase a function of its
//! own, all inlined into the one monomorphised loop, which keeps its scratch, flags and
//! deposit window as locals (so in registers) and hands them to the phases as arguments:
//! the same operations in the same order as one function, so the same bits.

use super::super::element_bound::{self, BoundInputs};
use super::super::material::Material;
use super::super::slot_window::SlotWindow;
use super::super::state::{Observed, State};
use super::super::step::{
    band_slots, base_slot, deposit, deposit_band, stiffness_weights, Ctx, Workspace,
};
use super::super::summary_lanes::{Block, SummaryLanes};
use super::{wrap_periodic, BlockStencils, PassFlags, Stencil, BLOCK};
use crate::grid::Grid;
use crate::shape::{Shape, MAX_NODES};

/// The grid's extent as the pass reads it.
#[derive(Clone, Copy)]
struct Span {
    origin: f64,
    length: f64,
    upper: f64,
}

impl Span {
    /// The extent of `grid`.
    #[inline(always)]
    fn of(grid: &Grid) -> Self {
        let origin = grid.origin;
        let length = grid.length();
        Self {
            origin,
            length,
            upper: origin + length,
        }
    }
}

/// Branch-free flags: the first offending particle is located afterwards, only when a
/// flag is raised.
#[derive(Clone, Copy, Default)]
struct Flags {
    maybe_non_finite: bool,
    any_inverted: bool,
    any_out: bool,
}

/// The fused particle pass (step 2 of the module docs of [`super::super::step`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn particle_pass<St, Up, Tg, const PERIODIC: bool>(
    ctx: &Ctx<'_>,
    ws: &mut Workspace,
    from: &State,
    to: &mut State,
    dt: f64,
    stencil: St,
    update_stress: Up,
    tangent: Tg,
) -> PassFlags
where
    St: Stencil,
    Up: Fn(f64, f64, f64) -> f64,
    Tg: Fn(f64) -> f64 + Copy,
{
    let span = Span::of(ctx.grid);
    let origin = span.origin;
    let gather = ws.gather.as_slice();
    let acc = ws.acc.as_mut_slice();
    let band = ws.band.as_mut_slice();
    let n = from.x.len();
    // The trial's tangent moduli and densities, written here when a summary is asked for.
    let (et_out, rho_out) = observed_outputs(&mut ws.observed, n, ctx.summary);
    let mut summary = ctx.summary.then(SummaryLanes::new);
    let take_bound = ctx.summary && ctx.bound && matches!(ctx.shape, Shape::Gimp);
    let mut bound_lanes = [0.0_f64; 4];
    // From the slice lengths (both `ext_len`), so that the compiler sees every
    // `base..base + MAX_NODES` in bounds.
    let max_base = (gather.len().min(acc.len()).min(band.len()) - MAX_NODES) as i64;

    let (x0, v0, s0, f0) = (&from.x[..n], &from.v[..n], &from.sigma[..n], &from.f[..n]);
    let (mass, vol0, width) = (&ctx.mass[..n], &ctx.volume0[..n], &ctx.width[..n]);
    let (x1, v1, s1, f1) = (
        &mut to.x[..n],
        &mut to.v[..n],
        &mut to.sigma[..n],
        &mut to.f[..n],
    );

    let mut flags = Flags::default();
    let mut stencils = BlockStencils::new();
    let mut a_p = [0.0; BLOCK];
    let mut k_w = [0.0; BLOCK];
    // The deposit's register window (slot_window.rs), kept across blocks. The stiffness
    // band is added in memory: a second window measured slower (register pressure).
    let mut acc_window = SlotWindow::new();
    let mut c2_lanes = [0.0_f64; 4];
    let mut grad_v = [0.0; BLOCK];
    let mut y = [0.0; BLOCK];
    let mut start = 0;
    while start < n {
        let end = (start + BLOCK).min(n);
        let len = end - start;
        let (x0, v0) = (&x0[start..end], &v0[start..end]);
        let (s0, f0) = (&s0[start..end], &f0[start..end]);
        let (x1, v1) = (&mut x1[start..end], &mut v1[start..end]);
        let (s1, f1) = (&mut s1[start..end], &mut f1[start..end]);
        let (mass, vol0, width) = (&mass[start..end], &vol0[start..end], &width[start..end]);

        // Gather at xⁿ (eqs 21, 24): stencils (vectorised), then the indexed sums.
        stencils.fill(&stencil, x0, width, origin);
        gather_block(&stencils, gather, max_base, len, &mut a_p, &mut grad_v);
        let kick = ctx.kick.unwrap_or(dt);
        let (rule, rates) = ((&update_stress, dt, kick, span), (&a_p, &grad_v));
        let trial = (&mut *x1, &mut *v1, &mut *s1, &mut *f1);
        update_block::<_, PERIODIC>(rule, (x0, v0, s0, f0), rates, trial, (&mut y, &mut flags));
        let particles = (
            &mass[..len],
            &vol0[..len],
            &v1[..len],
            &s1[..len],
            &f1[..len],
        );
        if let Some(lanes) = summary.as_mut() {
            let observed = (&mut et_out[start..end], &mut rho_out[start..end]);
            add_summary(lanes, (ctx.material, tangent), particles, observed);
        }

        // Deposit at xⁿ⁺¹ (eqs 6, 7, 17) from the just-written, cache-hot trial fields.
        // Out-of-domain or non-finite particles deposit on clamped slots: harmless,
        // because such a trial is refused before finalizing.
        stencils.fill(&stencil, x1, width, origin);
        if take_bound {
            add_bound(&stencils, &et_out[start..end], particles, &mut bound_lanes);
        }
        let stiffness = ctx.stiffness.then_some((tangent, &mut k_w, &mut c2_lanes));
        let window = (&mut *acc, &mut *band, &mut acc_window);
        deposit_block(&stencils, max_base, particles, window, stiffness);
        start = end;
    }
    acc_window.flush(acc);
    let element_bound = take_bound.then(|| bound_lanes.iter().fold(0.0_f64, |a, &b| a.max(b)));
    finish(flags, span, (&*x1, &*f1), c2_lanes, summary, element_bound)
}

/// The trial's tangent-modulus and density outputs (`n` long) when a summary is taken,
/// else empty.
#[inline(always)]
fn observed_outputs(o: &mut Observed, n: usize, summary: bool) -> (&mut [f64], &mut [f64]) {
    if summary {
        o.tangent_modulus.resize(n, 0.0);
        o.density.resize(n, 0.0);
        (&mut o.tangent_modulus[..n], &mut o.density[..n])
    } else {
        (&mut [][..], &mut [][..])
    }
}

/// The indexed sums of the gather at xⁿ (eqs 21, 24) from the block's stencils:
/// `a_p = Σ S a_i`, `grad_v = Σ D v_i`.
#[inline(always)]
fn gather_block(
    stencils: &BlockStencils,
    gather: &[[f64; 2]],
    max_base: i64,
    len: usize,
    a_p: &mut [f64; BLOCK],
    grad_v: &mut [f64; BLOCK],
) {
    for i in 0..len {
        let base = base_slot(stencils.first[i] as i64, max_base);
        let g = &gather[base..base + MAX_NODES];
        let (s, d) = (stencils.s(i), stencils.d(i));
        let mut a = 0.0;
        let mut gv = 0.0;
        for k in 0..MAX_NODES {
            a += s[k] * g[k][0];
            gv += d[k] * g[k][1];
        }
        a_p[i] = a;
        grad_v[i] = gv;
    }
}

/// The block's four fields `x, v, σ, F`.
type Fields<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64]);
/// The same, written.
type FieldsMut<'a> = (&'a mut [f64], &'a mut [f64], &'a mut [f64], &'a mut [f64]);

/// Particle update (eqs 22, 25, 27, 29), vectorised: the trial's fields from `a_p`,
/// `grad_v`, and the flags raised.
#[inline(always)]
fn update_block<Up: Fn(f64, f64, f64) -> f64, const PERIODIC: bool>(
    (update_stress, dt, kick, span): (&Up, f64, f64, Span),
    (x0, v0, s0, f0): Fields<'_>,
    (a_p, grad_v): (&[f64; BLOCK], &[f64; BLOCK]),
    (x1, v1, s1, f1): FieldsMut<'_>,
    (y, flags): (&mut [f64; BLOCK], &mut Flags),
) {
    let Span {
        origin,
        length,
        upper,
    } = span;
    let len = x0.len();
    let Flags {
        mut maybe_non_finite,
        mut any_inverted,
        mut any_out,
    } = *flags;
    let mut wrap = false;
    for i in 0..len {
        let v_new = v0[i] + kick * a_p[i];
        let dt_l = dt * grad_v[i];
        let f_new = f0[i] * (1.0 + dt_l);
        let s_new = update_stress(s0[i], f_new, dt_l);
        let x_new = x0[i] + dt * v_new;
        let sum = x_new.abs() + v_new.abs() + s_new.abs() + f_new.abs();
        maybe_non_finite |= !sum.is_finite();
        any_inverted |= f_new <= 0.0;
        if PERIODIC {
            let yi = x_new - origin;
            wrap |= !(yi >= 0.0 && yi < length);
            y[i] = yi;
            x1[i] = origin + yi;
        } else {
            any_out |= !(x_new >= origin && x_new <= upper);
            x1[i] = x_new;
        }
        v1[i] = v_new;
        s1[i] = s_new;
        f1[i] = f_new;
    }
    *flags = Flags {
        maybe_non_finite,
        any_inverted,
        any_out,
    };
    if PERIODIC && wrap {
        for (x, &y) in x1.iter_mut().zip(&y[..len]) {
            *x = wrap_periodic(y, origin, length);
        }
    }
}

/// The block's `(m, V⁰, v, σ, F)` of the trial, for the summary and the deposit.
type Deposited<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64], &'a [f64]);

/// The summary (pass_summary.rs), vectorised: `E_t` and `ρ` as the state's lazy cells
/// compute them, into `observed` (the block's tangent moduli and densities), particle
/// `start + i` in lane `i mod 4` (`BLOCK` is a multiple of 4).
#[inline(always)]
fn add_summary<Tg: Fn(f64) -> f64>(
    lanes: &mut SummaryLanes,
    (material, tangent): (Material, Tg),
    (mass, vol0, v, s, f): Deposited<'_>,
    (et_out, rho_out): (&mut [f64], &mut [f64]),
) {
    let block = Block {
        mass,
        vol0,
        v,
        s,
        f,
        et_out,
        rho_out,
    };
    lanes.add(material, tangent, block);
}

/// The block's part of the element bound (`element_bound.rs`) from its stencils at
/// `xⁿ⁺¹` and tangent moduli `tangent`, into `lanes`.
#[inline(always)]
fn add_bound(
    stencils: &BlockStencils,
    tangent: &[f64],
    (mass, volume0, _, _, f): Deposited<'_>,
    lanes: &mut [f64; 4],
) {
    let inputs = BoundInputs {
        s: &stencils.s,
        d: &stencils.d,
        tangent,
        f,
        volume0,
        mass,
    };
    element_bound::add_block(&inputs, lanes);
}

/// The deposit of the block's trial at xⁿ⁺¹ (eqs 6, 7, 17: mass, momentum, internal
/// force) into `acc` through its window, and with `stiffness` (the tangent, the weights'
/// scratch and the `c²_ref` lanes) the nodal stiffness band too.
#[inline(always)]
fn deposit_block<Tg: Fn(f64) -> f64>(
    stencils: &BlockStencils,
    max_base: i64,
    (mass, vol0, v1, s1, f1): Deposited<'_>,
    (acc, band, acc_window): (&mut [[f64; 4]], &mut [[f64; 4]], &mut SlotWindow),
    stiffness: Option<(Tg, &mut [f64; BLOCK], &mut [f64; 4])>,
) {
    let len = mass.len();
    if let Some((tangent, k_w, c2_lanes)) = stiffness {
        // The nodal stiffness of the new state (eq 56) from the same stencils: the
        // particles' weights first (a loop without stores to shared slots, and `c²_ref`
        // as lane maxima by compare-and-select, exact in any order and equal to
        // `f64::max` without NaN; a NaN weight is ignored by both), then both deposits
        // in one loop, so the two chains of read-modify-write adds on neighbouring slots
        // overlap.
        stiffness_weights(tangent, (f1, vol0, mass), &mut k_w[..len], c2_lanes);
        for i in 0..len {
            let base = base_slot(stencils.first[i] as i64, max_base);
            let m = mass[i];
            let sfv = s1[i] * f1[i] * vol0[i];
            let d = stencils.d(i);
            deposit(
                acc_window.at(acc, base),
                &stencils.s(i),
                &d,
                m,
                m * v1[i],
                sfv,
            );
            deposit_band(band_slots(band, base), &d, k_w[i]);
        }
    } else {
        // The same deposit without the band, as a loop of its own: one loop with an
        // `if stiffness` inside measured slower on the bare step (min of 300 steps at
        // 10⁵ particles, best of ten interleaved runs on a loaded machine: 1.40 against
        // 1.31 ms).
        for i in 0..len {
            let base = base_slot(stencils.first[i] as i64, max_base);
            let m = mass[i];
            let sfv = s1[i] * f1[i] * vol0[i];
            let slots = acc_window.at(acc, base);
            deposit(slots, &stencils.s(i), &stencils.d(i), m, m * v1[i], sfv);
        }
    }
}

/// The pass's flags: the first offending particles located in the trial's `x`, `F`, and
/// the lanes folded.
#[inline(always)]
fn finish(
    flags: Flags,
    span: Span,
    (x1, f1): (&[f64], &[f64]),
    c2_lanes: [f64; 4],
    summary: Option<SummaryLanes>,
    element_bound: Option<f64>,
) -> PassFlags {
    let Span { origin, upper, .. } = span;
    let first_inverted = if flags.any_inverted {
        f1.iter().position(|&f| f <= 0.0)
    } else {
        None
    };
    let first_out = if flags.any_out {
        x1.iter().position(|&x| !(x >= origin && x <= upper))
    } else {
        None
    };
    let c2_ref = c2_lanes.iter().fold(0.0_f64, |acc, &c| acc.max(c));
    PassFlags {
        maybe_non_finite: flags.maybe_non_finite,
        first_inverted,
        first_out,
        c2_ref,
        summary: summary.map(SummaryLanes::finish),
        element_bound,
    }
}
