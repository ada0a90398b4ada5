//! The fused particle pass of the 1D reference step (step 2 of [`super::step`]'s module
//! docs, where its layout, its bit-for-bit guarantees and its measurements are described),
//! monomorphised over instruction set, shape, boundary and material.

use super::material::Material;
use super::state::State;
use super::stencil;
use super::step::{Ctx, Workspace};
use super::summary_lanes::SummaryParts;
use crate::controller::ENERGY_LANES;
#[cfg(target_arch = "x86_64")]
use crate::cpu::has_avx2;
use crate::grid::Boundary;
use crate::shape::{Shape, MAX_NODES};
use fused::particle_pass;

mod fused;

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

/// Particles per block of the particle pass (see [`fused`]).
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
