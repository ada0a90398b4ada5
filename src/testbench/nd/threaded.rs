//! The reference solver's step on several threads ([`super::SolverNd::set_threads`]), with
//! a result that does not depend on how many.
//!
//! 1. **Grid → particle**, in fixed chunks of [`CHUNK`] particles run in parallel: every
//!    particle's update is its own. Each chunk sums its particles' energies and first
//!    moment and notes the slab its particle landed in; the chunks' sums are added in
//!    chunk order, and the first failed particle is the lowest-numbered one, as on one
//!    thread.
//! 2. **Particles by slab**: a counting sort of the particle indices by the slab of
//!    their new position (slabs of at least [`MIN_SLAB_CELLS`] cells across the last
//!    axis), stable, so each slab lists its particles in index order.
//! 3. **Particle → grid** in [`COLOURS`] colours, slab `s` of colour `s mod 4`: the slabs
//!    of one colour in parallel, colour after colour. A particle in cell `c` (along the
//!    last axis) touches node rows `c − 1 … c + 2` (GIMP, B-spline; `c … c + 1` for hats),
//!    one more each way allowing for `⌊·⌋` rounding differently from the stencil's own:
//!    `c − 2 … c + 3`. Two slabs of one colour have three slabs, at least six cells,
//!    between them (around a periodic axis too: the number of slabs is a multiple of
//!    four), so they never add to the same node. Each node's sum is then made in an
//!    order fixed by the grid and the particle numbering alone. Narrow slabs in four
//!    colours rather than wide ones in two give each colour many slabs, so that the
//!    threads share a colour's work evenly.
//!
//! Chunks and slabs depend on the particle count and the grid only, never on the number of
//! threads: one thread and many give the same state bit for bit. The order of the sums is
//! not the single-threaded solver's (particle by particle over the whole grid), so a
//! threaded run differs from an unthreaded one by round-off. Cost: 8 bytes per particle
//! (its slab and its place in the sorted order).

use super::fused::{FusedInputs, FusedOutcome, NodalSums};
use super::material::LameCache;
use super::prefetch;
use super::row_sums::Gather;
use super::update::{update_particle, Committed, ParticleFault, Written};
use crate::nd::factor_metric::ParticleBounds;
use crate::nd::factors::{visit_row_with, AxisFactors, RowVisitor};
use crate::nd::kernels::axis_factors_into;
use crate::nd::shape::AxisShape;
use crate::nd::{SummaryNd, Tensor, Vector};
use rayon::prelude::*;
use slabs::Slabs;
use sort::sort_by_slab;

mod slabs;
mod sort;

/// Particles per chunk of the grid → particle phase.
pub(super) const CHUNK: usize = 4096;
/// Narrowest slab, in cells (module docs).
pub(super) const MIN_SLAB_CELLS: usize = 2;
/// Colours of the particle → grid phase (module docs).
pub(super) const COLOURS: usize = 4;
/// Most slabs a grid is cut into.
const MAX_SLABS: usize = 256;

/// What a threaded step keeps between steps (8 bytes per particle).
#[derive(Clone, Debug, Default)]
pub(super) struct ThreadScratch {
    /// Each particle's slab.
    slab_of: Vec<u32>,
    /// Particle indices sorted by slab (stable).
    order: Vec<u32>,
    /// Where each slab's particles start in `order` (and where the last ends).
    starts: Vec<usize>,
}

impl ThreadScratch {
    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        4 * (self.slab_of.capacity() + self.order.capacity())
            + std::mem::size_of::<usize>() * self.starts.capacity()
    }
}

/// A chunk of the trial's particle fields, written by one task.
struct ChunkMut<'a, const D: usize> {
    start: usize,
    x: &'a mut [Vector<D>],
    v: &'a mut [Vector<D>],
    f: &'a mut [Tensor<D>],
    sigma: &'a mut [Tensor<D>],
    density: &'a mut [f64],
    moduli: Option<(&'a mut [f64], &'a mut [f64])>,
    slab_of: &'a mut [u32],
}

/// What a chunk of phase 1 found.
struct ChunkTotals<const D: usize> {
    kinetic: f64,
    strain: f64,
    first_moment: Vector<D>,
    fault: Option<ParticleFault>,
}

/// [`super::fused::fused_step`] on the threads of `pool` (module docs), for shape `S`.
pub(super) fn threaded_step<const D: usize, S: AxisShape>(
    pool: &rayon::ThreadPool,
    scratch: &mut ThreadScratch,
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    into: &mut Written<'_, D>,
    sums: NodalSums<'_, D>,
    bounds: Option<&mut ParticleBounds<'_, D>>,
) -> Result<FusedOutcome<D>, ParticleFault> {
    let (n, summarize) = (from.x.len(), bounds.is_some());
    let slabs = Slabs::of(inputs.grid);
    scratch.slab_of.resize(n, 0);
    let summary = pool.install(|| {
        grid_to_particle::<D, S>(inputs, from, into, &slabs, &mut scratch.slab_of, summarize)
    })?;
    pool.install(|| sort_by_slab(scratch, slabs.count()));
    let sums = sums.zeroed_on(pool, inputs.grid.n_nodes());
    let (unformed, found) = pool.install(|| {
        particle_to_grid::<D, S>(inputs, into, &slabs, scratch, sums, bounds.is_some())
    });
    if let (Some(b), Some(found)) = (bounds, found) {
        b.merge(&found);
    }
    Ok(FusedOutcome { summary, unformed })
}

/// Phase 1 (module docs): every particle's update, chunk by chunk in parallel.
fn grid_to_particle<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    into: &mut Written<'_, D>,
    slabs: &Slabs,
    slab_of: &mut [u32],
    summarize: bool,
) -> Result<SummaryNd<D>, ParticleFault> {
    let moduli: Vec<Option<(&mut [f64], &mut [f64])>> = match into.moduli.as_mut() {
        Some((l, m)) => l
            .chunks_mut(CHUNK)
            .zip(m.chunks_mut(CHUNK))
            .map(Some)
            .collect(),
        None => (0..from.x.len().div_ceil(CHUNK)).map(|_| None).collect(),
    };
    let chunks: Vec<ChunkMut<'_, D>> = into
        .x
        .chunks_mut(CHUNK)
        .zip(into.v.chunks_mut(CHUNK))
        .zip(into.f.chunks_mut(CHUNK))
        .zip(into.sigma.chunks_mut(CHUNK))
        .zip(into.density.chunks_mut(CHUNK))
        .zip(slab_of.chunks_mut(CHUNK))
        .zip(moduli)
        .enumerate()
        .map(
            |(k, ((((((x, v), f), sigma), density), slab_of), moduli))| ChunkMut {
                start: k * CHUNK,
                x,
                v,
                f,
                sigma,
                density,
                moduli,
                slab_of,
            },
        )
        .collect();
    let totals: Vec<ChunkTotals<D>> = chunks
        .into_par_iter()
        .map(|chunk| update_chunk_dispatch::<D, S>(inputs, from, chunk, slabs, summarize))
        .collect();
    let mut summary = SummaryNd::zero(true);
    for t in totals {
        if let Some(fault) = t.fault {
            return Err(fault);
        }
        summary.kinetic += t.kinetic;
        summary.strain += t.strain;
        summary.first_moment += t.first_moment;
    }
    Ok(summary)
}

/// [`update_chunk`] in the AVX2 build where the CPU has it, else in the baseline build.
fn update_chunk_dispatch<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    chunk: ChunkMut<'_, D>,
    slabs: &Slabs,
    summarize: bool,
) -> ChunkTotals<D> {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        // SAFETY: `update_chunk_avx2` only requires AVX2, which `has_avx2` detected.
        return unsafe { update_chunk_avx2::<D, S>(inputs, from, chunk, slabs, summarize) };
    }
    update_chunk::<D, S>(inputs, from, chunk, slabs, summarize)
}

/// [`update_chunk`] compiled for AVX2 ([`crate::cpu`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn update_chunk_avx2<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    chunk: ChunkMut<'_, D>,
    slabs: &Slabs,
    summarize: bool,
) -> ChunkTotals<D> {
    update_chunk::<D, S>(inputs, from, chunk, slabs, summarize)
}

/// One chunk of phase 1: [`super::fused`]'s grid → particle half, particle by particle
/// (inlined into each instruction-set build, [`crate::cpu`]).
#[inline(always)]
fn update_chunk<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    from: &Committed<'_, D>,
    chunk: ChunkMut<'_, D>,
    slabs: &Slabs,
    summarize: bool,
) -> ChunkTotals<D> {
    let grid = inputs.grid;
    let strides: [usize; D] = std::array::from_fn(|a| grid.stride(a));
    let mut totals = ChunkTotals {
        kinetic: 0.0,
        strain: 0.0,
        first_moment: Vector::<D>::zeros(),
        fault: None,
    };
    let ChunkMut {
        start,
        x,
        v,
        f,
        sigma,
        density,
        mut moduli,
        slab_of,
    } = chunk;
    let inv_h: [f64; D] = std::array::from_fn(|a| 1.0 / grid.h[a]);
    let mut lame = LameCache::default();
    // One particle's factors at a time, in one buffer, and the chunk's lines prefetched
    // ahead of their stores, as in [`super::fused`].
    let mut factors = [AxisFactors::default(); D];
    for k in 0..x.len() {
        let p = start + k;
        let ahead = k + prefetch::AHEAD;
        prefetch::line_of(x, ahead);
        prefetch::line_of(v, ahead);
        prefetch::line_of(f, ahead);
        prefetch::line_of(sigma, ahead);
        prefetch::line_of(density, ahead);
        let mut gather = Gather::new(from.node_a, inputs.node_v1);
        let domain = &inputs.domain[p];
        let inv_l: [f64; D] = std::array::from_fn(|a| 1.0 / domain[a]);
        let inv = (&inv_h, &inv_l);
        if axis_factors_into::<D, S>(grid, &strides, inv, &from.x[p], domain, &mut factors) {
            gather.add_row(&factors, S::NODES);
        }
        let material = &inputs.material[p];
        let old = (&from.x[p], &from.v[p], &from.f[p], &from.sigma[p]);
        let lame_p = lame.get(material);
        let gathered = (&gather.acc, &gather.l);
        let u = match update_particle(grid, (material, lame_p), p, old, gathered, inputs.dt) {
            Ok(u) => u,
            Err(fault) => {
                totals.fault = Some(fault);
                return totals;
            }
        };
        let (mp, vol0) = (inputs.mass[p], inputs.volume0[p]);
        if summarize {
            totals.kinetic += 0.5 * mp * u.v.norm_squared();
            totals.strain += material.energy(&u.sigma, &u.f, vol0);
            totals.first_moment += u.x * mp;
        }
        if let Some((lambda, mu)) = moduli.as_mut() {
            (lambda[k], mu[k]) = material.tangent_with(lame_p, u.det_f);
        }
        slab_of[k] = slabs.slab_of(u.x[D - 1]);
        density[k] = mp / (u.det_f * vol0);
        (x[k], v[k], f[k], sigma[k]) = (u.x, u.v, u.f, u.sigma);
    }
    totals
}

/// Phase 3: every slab's particles added to the nodes, the slabs of one colour in
/// parallel, colour after colour. Returns the first particle whose stencil could not be formed and, with
/// `with_bounds`, the element bound and sound-speed step of the particles.
fn particle_to_grid<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    into: &Written<'_, D>,
    slabs: &Slabs,
    scratch: &ThreadScratch,
    sums: NodalSums<'_, D>,
    with_bounds: bool,
) -> (Option<usize>, Option<ParticleBounds<'static, D>>) {
    let nodes = SharedNodes {
        mass: sums.mass.as_mut_ptr(),
        momentum: sums.momentum.as_mut_ptr(),
        force: sums.force.as_mut_ptr(),
        len: sums.mass.len(),
    };
    // Each slab's range of `order`.
    let ranges: Vec<_> = (0..slabs.count())
        .map(|s| scratch.starts[s]..scratch.starts[s + 1])
        .collect();
    let h: [f64; D] = std::array::from_fn(|a| inputs.grid.h[a]);
    let mut unformed: Option<usize> = None;
    let mut bounds = with_bounds.then(|| ParticleBounds::detached(h));
    for colour in 0..COLOURS {
        let found: Vec<(Option<usize>, Option<ParticleBounds<'static, D>>)> = ranges
            .iter()
            .enumerate()
            .filter(|(s, _)| s % COLOURS == colour)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|(_, r)| {
                // SAFETY: the slabs of one colour add to disjoint nodes (module docs), and
                // the tasks of one colour are all that touch the nodal arrays meanwhile.
                unsafe {
                    scatter_slab_dispatch::<D, S>(
                        inputs,
                        into,
                        &scratch.order[r.clone()],
                        nodes,
                        with_bounds,
                    )
                }
            })
            .collect();
        for (u, b) in found {
            unformed = match (unformed, u) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            };
            if let (Some(acc), Some(b)) = (bounds.as_mut(), b) {
                acc.merge(&b);
            }
        }
    }
    (unformed, bounds)
}

/// The nodal arrays of phase 3, shared by the tasks of one colour.
#[derive(Clone, Copy)]
struct SharedNodes<const D: usize> {
    mass: *mut f64,
    momentum: *mut Vector<D>,
    force: *mut Vector<D>,
    len: usize,
}

// SAFETY: the tasks that share it write disjoint nodes (module docs).
unsafe impl<const D: usize> Send for SharedNodes<D> {}
unsafe impl<const D: usize> Sync for SharedNodes<D> {}

/// [`scatter_slab`] in the AVX2 build where the CPU has it, else in the baseline build.
///
/// # Safety
/// As [`scatter_slab`].
unsafe fn scatter_slab_dispatch<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    into: &Written<'_, D>,
    particles: &[u32],
    nodes: SharedNodes<D>,
    with_bounds: bool,
) -> (Option<usize>, Option<ParticleBounds<'static, D>>) {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        // SAFETY: AVX2 detected by `has_avx2`; the caller keeps `scatter_slab`'s contract.
        return unsafe { scatter_slab_avx2::<D, S>(inputs, into, particles, nodes, with_bounds) };
    }
    // SAFETY: the caller keeps `scatter_slab`'s contract.
    unsafe { scatter_slab::<D, S>(inputs, into, particles, nodes, with_bounds) }
}

/// [`scatter_slab`] compiled for AVX2 ([`crate::cpu`]).
///
/// # Safety
/// As [`scatter_slab`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn scatter_slab_avx2<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    into: &Written<'_, D>,
    particles: &[u32],
    nodes: SharedNodes<D>,
    with_bounds: bool,
) -> (Option<usize>, Option<ParticleBounds<'static, D>>) {
    // SAFETY: the caller keeps `scatter_slab`'s contract.
    unsafe { scatter_slab::<D, S>(inputs, into, particles, nodes, with_bounds) }
}

/// One slab's particles added to the nodes, in the order of `particles` (inlined into
/// each instruction-set build, [`crate::cpu`]).
///
/// # Safety
/// No other thread may read or write the nodes these particles touch meanwhile.
#[inline(always)]
unsafe fn scatter_slab<const D: usize, S: AxisShape>(
    inputs: &FusedInputs<'_, D>,
    into: &Written<'_, D>,
    particles: &[u32],
    nodes: SharedNodes<D>,
    with_bounds: bool,
) -> (Option<usize>, Option<ParticleBounds<'static, D>>) {
    let grid = inputs.grid;
    let strides: [usize; D] = std::array::from_fn(|a| grid.stride(a));
    let h: [f64; D] = std::array::from_fn(|a| grid.h[a]);
    let mut bounds = with_bounds.then(|| ParticleBounds::detached(h));
    let mut unformed = None;
    let inv_h: [f64; D] = std::array::from_fn(|a| 1.0 / grid.h[a]);
    let mut factors = [AxisFactors::default(); D];
    for &p in particles {
        let p = p as usize;
        let (mp, vol0) = (inputs.mass[p], inputs.volume0[p]);
        let (x, v, f, sigma) = (&into.x[p], &into.v[p], &into.f[p], &into.sigma[p]);
        let l = &inputs.domain[p];
        let inv_l: [f64; D] = std::array::from_fn(|a| 1.0 / l[a]);
        let inv = (&inv_h, &inv_l);
        let formed = axis_factors_into::<D, S>(grid, &strides, inv, x, l, &mut factors);
        let vol = crate::nd::det(f) * vol0;
        if let Some(b) = bounds.as_mut() {
            let moduli = match (&into.moduli, inputs.constant_moduli) {
                (Some((lambda, mu)), _) => (lambda[p], mu[p]),
                (None, Some((lambda, mu))) => (lambda[p], mu[p]),
                (None, None) => (f64::NAN, f64::NAN),
            };
            let per_mass = vol / mp;
            b.add_values(
                moduli,
                into.density[p],
                v,
                per_mass,
                formed.then_some((&factors, S::NODES)),
            );
        }
        if !formed {
            unformed.get_or_insert(p);
            continue;
        }
        let mut scatter = RawScatter {
            nodes,
            mp,
            mv: v * mp,
            vs: sigma * (-vol),
        };
        visit_row_with(&factors, S::NODES, &mut scatter);
    }
    (unformed, bounds)
}

/// [`super::fused`]'s scatter through [`SharedNodes`].
struct RawScatter<const D: usize> {
    nodes: SharedNodes<D>,
    mp: f64,
    mv: Vector<D>,
    vs: Tensor<D>,
}

impl<const D: usize> RowVisitor<D> for RawScatter<D> {
    #[inline(always)]
    fn visit(&mut self, _: usize, i: usize, w: f64, g: Vector<D>) {
        assert!(i < self.nodes.len, "node {i} outside the grid");
        // SAFETY: `i` is in bounds (checked); no other thread touches node `i` meanwhile
        // (`scatter_slab`'s contract).
        unsafe {
            *self.nodes.mass.add(i) += w * self.mp;
            *self.nodes.momentum.add(i) += self.mv * w;
            *self.nodes.force.add(i) += self.vs * g;
        }
    }
}
