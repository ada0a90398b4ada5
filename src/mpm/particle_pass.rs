//! The fused particle pass of the 1D reference step (step 2 of [`super::step`]'s module
//! docs, where its layout, its bit-for-bit guarantees and its measurements are described),
//! monomorphised over instruction set, shape, boundary and material.

use super::element_bound::{self, BoundInputs};
use super::material::Material;
use super::slot_window::SlotWindow;
use super::state::State;
use super::stencil;
use super::step::{
    band_slots, base_slot, deposit, deposit_band, stiffness_weights, Ctx, Workspace,
};
use super::summary_lanes::{Block, SummaryLanes, SummaryParts};
use crate::controller::ENERGY_LANES;
#[cfg(target_arch = "x86_64")]
use crate::cpu::has_avx2;
use crate::grid::Boundary;
use crate::shape::{Shape, MAX_NODES};

/// Step 2 in the best build the CPU supports (see the module docs of [`super::step`]).
pub(super) fn particle_pass_dispatch(
    ctx: &Ctx<'_>,
    ws: &mut Workspace,
    from: &State,
    to: &mut State,
    dt: f64,
) -> PassFlags {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: `particle_pass_avx2` only requires AVX2 (and the SSE4.1 it implies),
        // which `is_x86_feature_detected!` has just confirmed on this CPU.
        return unsafe { particle_pass_avx2(ctx, ws, from, to, dt) };
    }
    with_shape::<false>(ctx, ws, from, to, dt)
}

/// The particle pass compiled for AVX2: VEX-encoded arithmetic and `f64::floor` as one
/// `roundsd` (no FMA, so every result is bit for bit that of the baseline build).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn particle_pass_avx2(
    ctx: &Ctx<'_>,
    ws: &mut Workspace,
    from: &State,
    to: &mut State,
    dt: f64,
) -> PassFlags {
    with_shape::<true>(ctx, ws, from, to, dt)
}

/// Selects the shape and boundary at compile time; `ROUND` says whether the code is
/// compiled with a rounding instruction (SSE4.1).
#[inline(always)]
fn with_shape<const ROUND: bool>(
    ctx: &Ctx<'_>,
    ws: &mut Workspace,
    from: &State,
    to: &mut State,
    dt: f64,
) -> PassFlags {
    let inv_h = 1.0 / ctx.grid.h;
    match (ctx.shape, ctx.grid.boundary) {
        (Shape::Gimp, Boundary::Periodic) => {
            with_material::<_, true>(ctx, ws, from, to, dt, Fixed::<true, ROUND>(inv_h))
        }
        (Shape::Gimp, Boundary::Fixed) => {
            with_material::<_, false>(ctx, ws, from, to, dt, Fixed::<true, ROUND>(inv_h))
        }
        (Shape::Linear, Boundary::Periodic) => {
            with_material::<_, true>(ctx, ws, from, to, dt, Fixed::<false, ROUND>(inv_h))
        }
        (Shape::Linear, Boundary::Fixed) => {
            with_material::<_, false>(ctx, ws, from, to, dt, Fixed::<false, ROUND>(inv_h))
        }
    }
}

/// A stencil evaluator with the shape fixed at compile time, so that the particle pass
/// inlines it (a closure was not inlined, measured at 40 % of the step).
trait Stencil {
    fn at(&self, x: f64, width: f64) -> stencil::Parts;
}

/// `Fixed::<true, _>` evaluates GIMP, `Fixed::<false, _>` linear-hat weights, with
/// `f64::floor` if `ROUND`; `.0` is `1/h`.
struct Fixed<const GIMP: bool, const ROUND: bool>(f64);

impl<const GIMP: bool, const ROUND: bool> Stencil for Fixed<GIMP, ROUND> {
    #[inline(always)]
    fn at(&self, x: f64, width: f64) -> stencil::Parts {
        if GIMP {
            stencil::gimp_parts::<ROUND>(x, width, self.0)
        } else {
            stencil::linear_parts::<ROUND>(x, self.0)
        }
    }
}

/// Particles per block of the particle pass (see `particle_pass`).
pub(super) const BLOCK: usize = 256;
const _: () = assert!(
    BLOCK.is_multiple_of(ENERGY_LANES),
    "summary lanes must follow p mod 4"
);

/// Outcome flags of a particle pass.
pub(super) struct PassFlags {
    /// Some particle's `|x| + |v| + |σ| + |F|` of the trial is not finite: some value is
    /// NaN or infinite, or (harmless, found out when locating) the sum overflowed.
    pub(super) maybe_non_finite: bool,
    pub(super) first_inverted: Option<usize>,
    pub(super) first_out: Option<usize>,
    /// `max_p E_t,p/ρ_p` of the trial when the stiffness is accumulated (else 0).
    pub(super) c2_ref: f64,
    /// The trial's summary when [`Ctx::summary`] is set.
    pub(super) summary: Option<SummaryParts>,
    /// The trial's element bound (`element_bound.rs`) when the summary and the bound are
    /// taken on GIMP weights.
    pub(super) element_bound: Option<f64>,
}

/// The stencils of one block in structure-of-arrays form, so that evaluating them is a
/// loop the compiler vectorises.
struct BlockStencils {
    first: [f64; BLOCK],
    s: [[f64; BLOCK]; MAX_NODES],
    d: [[f64; BLOCK]; MAX_NODES],
}

impl BlockStencils {
    fn new() -> Self {
        Self {
            first: [0.0; BLOCK],
            s: [[0.0; BLOCK]; MAX_NODES],
            d: [[0.0; BLOCK]; MAX_NODES],
        }
    }

    /// Stencils of the particles at `x` (at most `BLOCK`) with widths `width`.
    #[inline(always)]
    fn fill<St: Stencil>(&mut self, stencil: &St, x: &[f64], width: &[f64], origin: f64) {
        let n = x.len().min(width.len()).min(BLOCK);
        for i in 0..n {
            let st = stencil.at(x[i] - origin, width[i]);
            self.first[i] = st.first;
            for k in 0..MAX_NODES {
                self.s[k][i] = st.s[k];
                self.d[k][i] = st.d[k];
            }
        }
    }

    #[inline(always)]
    fn s(&self, i: usize) -> [f64; MAX_NODES] {
        [self.s[0][i], self.s[1][i], self.s[2][i]]
    }

    #[inline(always)]
    fn d(&self, i: usize) -> [f64; MAX_NODES] {
        [self.d[0][i], self.d[1][i], self.d[2][i]]
    }
}

#[inline(always)]
fn with_material<St, const PERIODIC: bool>(
    ctx: &Ctx<'_>,
    ws: &mut Workspace,
    from: &State,
    to: &mut State,
    dt: f64,
    stencil: St,
) -> PassFlags
where
    St: Stencil,
{
    // The tangent modulus is `Material::tangent_modulus` of a material rebuilt in each arm
    // with its variant known, so that its `match` folds away and the loops stay vector code
    // (the `match` on `ctx.material` inside the loops kept them scalar).
    match ctx.material {
        Material::LinearElastic { youngs_modulus } => {
            let known = Material::LinearElastic { youngs_modulus };
            particle_pass::<_, _, _, PERIODIC>(
                ctx,
                ws,
                from,
                to,
                dt,
                stencil,
                |s, _f, dt_l| s + youngs_modulus * dt_l,
                move |f| known.tangent_modulus(f),
            )
        }
        Material::NeoHookean { youngs_modulus } => {
            let known = Material::NeoHookean { youngs_modulus };
            let half_e = 0.5 * youngs_modulus;
            particle_pass::<_, _, _, PERIODIC>(
                ctx,
                ws,
                from,
                to,
                dt,
                stencil,
                |_s, f, _dt_l| half_e * (f - 1.0 / f),
                move |f| known.tangent_modulus(f),
            )
        }
    }
}

/// [`crate::grid::Grid::wrap`] of a periodic grid for `y = x − origin`, with origin and length
/// hoisted: the same arithmetic, so the same bits.
#[inline(always)]
fn wrap_periodic(mut y: f64, origin: f64, length: f64) -> f64 {
    if !(0.0..length).contains(&y) {
        y = y.rem_euclid(length);
        if y >= length {
            y = 0.0;
        }
    }
    origin + y
}

/// The fused particle pass (step 2 of the module docs of [`super::step`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn particle_pass<St, Up, Tg, const PERIODIC: bool>(
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
    let grid = ctx.grid;
    let origin = grid.origin;
    let length = grid.length();
    let upper = origin + length;
    let gather = ws.gather.as_slice();
    let acc = ws.acc.as_mut_slice();
    let band = ws.band.as_mut_slice();
    let stiffness = ctx.stiffness;
    let n = from.x.len();
    // The trial's tangent moduli and densities, written here when a summary is asked for.
    let (et_out, rho_out) = if ctx.summary {
        let o = &mut ws.observed;
        o.tangent_modulus.resize(n, 0.0);
        o.density.resize(n, 0.0);
        (&mut o.tangent_modulus[..n], &mut o.density[..n])
    } else {
        (&mut [][..], &mut [][..])
    };
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

    // Branch-free flags: the first offending particle is located afterwards, only when a
    // flag is raised.
    let mut maybe_non_finite = false;
    let mut any_inverted = false;
    let mut any_out = false;
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
        let (x0, v0, s0, f0) = (
            &x0[start..end],
            &v0[start..end],
            &s0[start..end],
            &f0[start..end],
        );
        let (x1, v1, s1, f1) = (
            &mut x1[start..end],
            &mut v1[start..end],
            &mut s1[start..end],
            &mut f1[start..end],
        );
        let (mass, vol0, width) = (&mass[start..end], &vol0[start..end], &width[start..end]);

        // Gather at xⁿ (eqs 21, 24): stencils (vectorised), then the indexed sums.
        stencils.fill(&stencil, x0, width, origin);
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

        // Particle update (eqs 22, 25, 27, 29), vectorised.
        let mut wrap = false;
        for i in 0..len {
            let v_new = v0[i] + dt * a_p[i];
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
        if PERIODIC && wrap {
            for (x, &y) in x1.iter_mut().zip(&y[..len]) {
                *x = wrap_periodic(y, origin, length);
            }
        }

        // The summary (pass_summary.rs), vectorised: `E_t` and `ρ` as the state's lazy cells
        // compute them, particle `start + i` in lane `i mod 4` (`BLOCK` is a multiple of 4).
        if let Some(lanes) = summary.as_mut() {
            lanes.add(
                ctx.material,
                tangent,
                Block {
                    mass: &mass[..len],
                    vol0: &vol0[..len],
                    v: &v1[..len],
                    s: &s1[..len],
                    f: &f1[..len],
                    et_out: &mut et_out[start..end],
                    rho_out: &mut rho_out[start..end],
                },
            );
        }

        // Deposit at xⁿ⁺¹ (eqs 6, 7, 17) from the just-written, cache-hot trial fields.
        // Out-of-domain or non-finite particles deposit on clamped slots: harmless,
        // because such a trial is refused before finalizing.
        stencils.fill(&stencil, x1, width, origin);
        if take_bound {
            let inputs = BoundInputs {
                s: &stencils.s,
                d: &stencils.d,
                tangent: &et_out[start..end],
                f: &f1[..len],
                volume0: &vol0[..len],
                mass: &mass[..len],
            };
            element_bound::add_block(&inputs, &mut bound_lanes);
        }
        if stiffness {
            // The nodal stiffness of the new state (eq 56) from the same stencils: the
            // particles' weights first (a loop without stores to shared slots, and `c²_ref`
            // as lane maxima by compare-and-select, exact in any order and equal to
            // `f64::max` without NaN; a NaN weight is ignored by both), then both deposits
            // in one loop, so the two chains of read-modify-write adds on neighbouring slots
            // overlap.
            stiffness_weights(
                tangent,
                (&f1[..len], &vol0[..len], &mass[..len]),
                &mut k_w[..len],
                &mut c2_lanes,
            );
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
        start = end;
    }
    let first_inverted = if any_inverted {
        f1.iter().position(|&f| f <= 0.0)
    } else {
        None
    };
    let first_out = if any_out {
        x1.iter().position(|&x| !(x >= origin && x <= upper))
    } else {
        None
    };
    acc_window.flush(acc);
    let c2_ref = c2_lanes.iter().fold(0.0_f64, |acc, &c| acc.max(c));
    PassFlags {
        maybe_non_finite,
        first_inverted,
        first_out,
        c2_ref,
        summary: summary.map(SummaryLanes::finish),
        element_bound: take_bound.then(|| bound_lanes.iter().fold(0.0_f64, |a, &b| a.max(b))),
    }
}
