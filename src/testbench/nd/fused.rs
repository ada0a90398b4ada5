//! The reference solver's step in one pass over the particles: each particle's grid →
//! particle update ([`update::update_particle`]) followed at once by its share of the
//! particle → grid pass at its new position, so that a step reads and writes each
//! particle's fields once instead of twice.
//!
//! The nodal sums are made in the same order as by the two passes apart (particle by
//! particle, in index order, into the trial's own nodal arrays, while the gather reads the
//! committed state's), and every value is formed by the same functions: a fused step is
//! the same, bit for bit, as [`update::grid_to_particle`] followed by
//! [`kernels::particle_to_grid`]. A run whose particles move between processes between the
//! two passes (a grid split into slabs) cannot fuse them and takes the two passes.

use super::material::LameCache;
use super::prefetch;
use super::row_sums::{Gather, Scatter};
use super::threaded::{threaded_step, ThreadScratch};
use super::update::{self, Committed, ParticleFault, Written};
use super::MaterialNd;
use crate::nd::factor_metric::ParticleBounds;
use crate::nd::factors::AxisFactors;
use crate::nd::kernels::axis_factors_into;
use crate::nd::shape::{AxisShape, BSplineAxis, GimpAxis, LinearAxis};
use crate::nd::{GridNd, ShapeNd, SummaryNd, Vector};

/// What a fused step reads besides the committed particles.
pub(super) struct FusedInputs<'a, const D: usize> {
    /// The step.
    pub dt: f64,
    /// The grid (whole: wraps and walls).
    pub grid: &'a GridNd<D>,
    pub shape: ShapeNd,
    pub material: &'a [MaterialNd],
    pub mass: &'a [f64],
    pub volume0: &'a [f64],
    /// GIMP domains (the same for the committed state and the trial).
    pub domain: &'a [Vector<D>],
    /// `v_iⁿ⁺¹ = v_i + dt a_i`.
    pub node_v1: &'a [Vector<D>],
    /// The moduli where they are constant (shared by both states).
    pub constant_moduli: Option<(&'a [f64], &'a [f64])>,
}

/// The trial's nodal sums `Σ S m`, `Σ S m v`, `−Σ V σ ∇S`, written by a fused step
/// (cleared first).
pub(super) struct NodalSums<'a, const D: usize> {
    pub mass: &'a mut Vec<f64>,
    pub momentum: &'a mut Vec<Vector<D>>,
    pub force: &'a mut Vec<Vector<D>>,
}

impl<'a, const D: usize> NodalSums<'a, D> {
    /// [`Self::zeroed`] on the threads of `pool`, where the arrays already have their
    /// length (a run's steps after the first).
    pub fn zeroed_on(self, pool: &rayon::ThreadPool, n_nodes: usize) -> Self {
        use rayon::prelude::*;
        if self.mass.len() != n_nodes
            || self.momentum.len() != n_nodes
            || self.force.len() != n_nodes
        {
            return self.zeroed(n_nodes);
        }
        pool.install(|| {
            self.mass.par_iter_mut().for_each(|m| *m = 0.0);
            for v in [&mut *self.momentum, &mut *self.force] {
                v.par_iter_mut().for_each(|x| *x = Vector::<D>::zeros());
            }
        });
        self
    }

    /// The sums set to zero on `n_nodes` nodes (their storage reused).
    pub fn zeroed(self, n_nodes: usize) -> Self {
        self.mass.clear();
        self.mass.resize(n_nodes, 0.0);
        for v in [&mut *self.momentum, &mut *self.force] {
            v.clear();
            v.resize(n_nodes, Vector::<D>::zeros());
        }
        self
    }
}

/// What a fused step found: the trial's summary (energies and first moment with
/// `summarize`, else zeros) and the first particle whose new stencil could not be formed.
pub(super) struct FusedOutcome<const D: usize> {
    pub summary: SummaryNd<D>,
    pub unformed: Option<usize>,
}

/// One step of `dt` for every particle (module docs): the committed state `from` (its
/// weights formed from `from.x`), the trial written `into`, its nodal sums into `sums`
/// (to be completed and normalised by [`kernels::finish_nodal`]). With `bounds` (summaries
/// on) it also sums the trial's totals and accumulates its element bound and sound-speed
/// step there. Stops at the first particle whose update fails, as
/// [`update::grid_to_particle`] does.
pub(super) fn fused_step<const D: usize>(
    threads: Option<(&rayon::ThreadPool, &mut ThreadScratch)>,
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    into: &mut Written<'_, D>,
    sums: NodalSums<'_, D>,
    bounds: Option<&mut ParticleBounds<'_, D>>,
) -> Result<FusedOutcome<D>, ParticleFault> {
    // Compiled once per shape: the 1D weights inlined into the pass; on one thread or on
    // a pool ([`super::threaded`]).
    macro_rules! for_shape {
        ($shape:ty) => {
            match threads {
                Some((pool, scratch)) => {
                    threaded_step::<D, $shape>(pool, scratch, inputs, from, into, sums, bounds)
                }
                None => fused_step_dispatch::<D, $shape>(inputs, from, into, sums, bounds),
            }
        };
    }
    match inputs.shape {
        ShapeNd::Gimp => for_shape!(GimpAxis),
        ShapeNd::Linear => for_shape!(LinearAxis),
        ShapeNd::BSpline2 => for_shape!(BSplineAxis),
    }
}

/// [`fused_step_as`] in the AVX2 build where the CPU has it, else in the baseline build
/// ([`crate::cpu`]).
fn fused_step_dispatch<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    into: &mut Written<'_, D>,
    sums: NodalSums<'_, D>,
    bounds: Option<&mut ParticleBounds<'_, D>>,
) -> Result<FusedOutcome<D>, ParticleFault> {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        // SAFETY: `fused_step_avx2` only requires AVX2, which `has_avx2` detected on this CPU.
        return unsafe { fused_step_avx2::<D, S>(inputs, from, into, sums, bounds) };
    }
    fused_step_as::<D, S>(inputs, from, into, sums, bounds)
}

/// [`fused_step_as`] compiled for AVX2 ([`crate::cpu`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn fused_step_avx2<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    into: &mut Written<'_, D>,
    sums: NodalSums<'_, D>,
    bounds: Option<&mut ParticleBounds<'_, D>>,
) -> Result<FusedOutcome<D>, ParticleFault> {
    fused_step_as::<D, S>(inputs, from, into, sums, bounds)
}

/// [`fused_step`] for shape `S`, inlined into each instruction-set build.
#[inline(always)]
fn fused_step_as<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    into: &mut Written<'_, D>,
    sums: NodalSums<'_, D>,
    mut bounds: Option<&mut ParticleBounds<'_, D>>,
) -> Result<FusedOutcome<D>, ParticleFault> {
    let (grid, dt, summarize) = (inputs.grid, inputs.dt, bounds.is_some());
    let n_axis = S::NODES;
    let strides: [usize; D] = std::array::from_fn(|a| grid.stride(a));
    let sums = sums.zeroed(grid.n_nodes());
    let mut scatter = Scatter::new(sums.mass, sums.momentum, sums.force);
    let mut outcome = FusedOutcome {
        summary: SummaryNd::zero(true),
        unformed: None,
    };
    // `1/h` once for the pass, `1/l` once for a particle's two stencils, the Lamé pair
    // once per run of one material: the same quotients as formed where they are used.
    let inv_h: [f64; D] = std::array::from_fn(|a| 1.0 / grid.h[a]);
    let mut lame = LameCache::default();
    // One particle's factors at a time, in one buffer ([`axis_factors_into`]).
    let mut factors = [AxisFactors::default(); D];
    for p in 0..from.x.len() {
        // The trial's lines a few particles on, to be in the cache when written.
        let ahead = p + prefetch::AHEAD;
        prefetch::line_of(into.x, ahead);
        prefetch::line_of(into.v, ahead);
        prefetch::line_of(into.f, ahead);
        prefetch::line_of(into.sigma, ahead);
        prefetch::line_of(into.density, ahead);
        let domain = &inputs.domain[p];
        let inv_l: [f64; D] = std::array::from_fn(|a| 1.0 / domain[a]);
        // Grid → particle from the committed position's stencil.
        let mut gather = Gather::new(from.node_a, inputs.node_v1);
        let x_old = &from.x[p];
        let inv = (&inv_h, &inv_l);
        if axis_factors_into::<D, S>(grid, &strides, inv, x_old, domain, &mut factors) {
            gather.add_row(&factors, n_axis);
        }
        let (material, old) = (
            &inputs.material[p],
            (x_old, &from.v[p], &from.f[p], &from.sigma[p]),
        );
        let lame_p = lame.get(material);
        let gathered = (&gather.acc, &gather.l);
        let u = update::update_particle(grid, (material, lame_p), p, old, gathered, dt)?;
        let (mp, vol0) = (inputs.mass[p], inputs.volume0[p]);
        if summarize {
            let s = &mut outcome.summary;
            s.kinetic += 0.5 * mp * u.v.norm_squared();
            s.strain += material.energy(&u.sigma, &u.f, vol0);
            s.first_moment += u.x * mp;
        }
        let density = mp / (u.det_f * vol0);
        let moduli = match (inputs.constant_moduli, into.moduli.as_mut()) {
            (_, Some((lambda, mu))) => {
                (lambda[p], mu[p]) = material.tangent_with(lame_p, u.det_f);
                (lambda[p], mu[p])
            }
            (Some((lambda, mu)), None) => (lambda[p], mu[p]),
            (None, None) => (f64::NAN, f64::NAN),
        };
        // Particle → grid at the new position, as `kernels::particle_to_grid` adds it.
        let formed = axis_factors_into::<D, S>(grid, &strides, inv, &u.x, domain, &mut factors);
        let mv = u.v * mp;
        let vol = u.det_f * vol0; // `det_f` is `det(F)` of the new `F`
        let vs = u.sigma * (-vol);
        if let Some(b) = bounds.as_deref_mut() {
            b.add_values(
                moduli,
                density,
                &u.v,
                vol / mp,
                formed.then_some((&factors, n_axis)),
            );
        }
        if formed {
            scatter.add_row(&factors, n_axis, mp, mv, vs);
        } else {
            outcome.unformed.get_or_insert(p);
        }
        into.x[p] = u.x;
        into.v[p] = u.v;
        into.f[p] = u.f;
        into.sigma[p] = u.sigma;
        into.density[p] = density;
    }
    Ok(outcome)
}
