//! The kernels of the d-dimensional USL step: weights at the particle positions,
//! particle → grid, grid update and grid → particle. Written once for any `D` over the
//! tensor-product stencil (`nodes_per_axis^D` entries per particle).

use super::factor_metric::ParticleBounds;
use super::factors::{form_row, AxisFactors};
use super::shape::{AxisShape, BSplineAxis, GimpAxis, LinearAxis};
use super::{GridNd, MaterialNd, ShapeNd, SummaryNd, Tensor, Vector, ViewWeightsNd, WeightsNd};
use crate::grid::Boundary;
use crate::reduce::Reduce;

/// Fills `weights` with `S_ip`, `∇S_ip` at positions `x` as stored rows formed from the
/// per-axis factors ([`super::factors`]). Returns the first particle whose stencil leaves
/// the stored nodes (a fixed axis), if any.
pub(super) fn compute_weights<const D: usize>(
    grid: &GridNd<D>,
    shape: ShapeNd,
    x: &[Vector<D>],
    domain: &[Vector<D>],
    weights: &mut WeightsNd<D>,
) -> Result<(), usize> {
    let n_axis = shape.nodes_per_axis();
    let width = shape.width(D);
    if weights.width() != width || weights.n_nodes() != grid.n_nodes() {
        *weights = WeightsNd::new(grid.n_nodes(), width);
    }
    let strides: [usize; D] = std::array::from_fn(|a| grid.stride(a));
    let (nodes, s, grad) = weights.storage_mut(x.len());
    for p in 0..x.len() {
        let f = axis_factors(grid, shape, &strides, &x[p], &domain[p]).ok_or(p)?;
        let r = p * width..(p + 1) * width;
        form_row(
            &f,
            n_axis,
            &mut nodes[r.clone()],
            &mut s[r.clone()],
            &mut grad[r],
        );
    }
    Ok(())
}

/// The per-axis factors of a particle at `x` with GIMP domain `l`; `None` if its stencil
/// leaves the stored nodes.
#[inline]
pub(super) fn axis_factors<const D: usize>(
    grid: &GridNd<D>,
    shape: ShapeNd,
    strides: &[usize; D],
    x: &Vector<D>,
    l: &Vector<D>,
) -> Option<[AxisFactors; D]> {
    match shape {
        ShapeNd::Gimp => axis_factors_as::<D, GimpAxis>(grid, strides, x, l),
        ShapeNd::Linear => axis_factors_as::<D, LinearAxis>(grid, strides, x, l),
        ShapeNd::BSpline2 => axis_factors_as::<D, BSplineAxis>(grid, strides, x, l),
    }
}

/// [`axis_factors`] of shape `S`, inlined into a pass compiled for it.
#[inline(always)]
pub(super) fn axis_factors_as<const D: usize, S: AxisShape>(
    grid: &GridNd<D>,
    strides: &[usize; D],
    x: &Vector<D>,
    l: &Vector<D>,
) -> Option<[AxisFactors; D]> {
    let n_axis = S::NODES;
    let mut out = [AxisFactors::default(); D];
    for (a, f) in out.iter_mut().enumerate() {
        let st = S::stencil(x[a] - grid.origin[a], l[a], grid.h[a]);
        f.s = st.s;
        f.d = st.d;
        if grid.boundary[a] == Boundary::Periodic {
            // One wrap for the first node; the next ones wrap by a comparison (a loop: an
            // axis of fewer cells than the stencil's nodes wraps more than once).
            let n = grid.cells[a];
            // Inside the box already for all but the particles near its upper end: no
            // integer division there.
            let first = match usize::try_from(st.first) {
                Ok(i) if i < n => i,
                _ => st.first.rem_euclid(n as i64) as usize,
            };
            for k in 0..n_axis {
                let mut i = first + k;
                while i >= n {
                    i -= n;
                }
                f.offset[k] = (i * strides[a]) as u32;
            }
            continue;
        }
        for k in 0..n_axis {
            f.offset[k] = match grid.storage_along(a, st.first + k as i64) {
                Some(i) => (i * strides[a]) as u32,
                // A padding slot (weight and derivative zero) past the ghost node: any
                // stored node will do.
                None if st.s[k] == 0.0 && st.d[k] == 0.0 => 0,
                None => return None,
            };
        }
    }
    Some(out)
}

/// Completes the nodal sums `(Σ S m, Σ S m v, −Σ V σ ∇S)` over the processes of a split
/// run (nothing on one process).
pub(super) type NodalCompletion<'a, const D: usize> =
    dyn Fn(&mut Vec<f64>, &mut Vec<Vector<D>>, &mut Vec<Vector<D>>) + 'a;

/// Particle → grid at one state (docs/design.md, "USL step in d dimensions"):
/// `m_i = Σ S m_p`, `v_i = Σ S m_p v_p / m_i`,
/// `a_i = (−Σ V_p σ_p ∇S_ip)/m_i + g` with `V_p = det(F_p) V⁰_p`; nodes that are
/// constrained or have `m_i ≤ threshold` are inactive, with `v_i = a_i = 0`.
/// Returns the first particle whose row could not be formed (its stencil leaves the
/// stored nodes past a fixed wall; formed weights only), which then added nothing: the
/// check costs no pass of its own.
#[allow(clippy::too_many_arguments)]
pub(super) fn particle_to_grid<const D: usize>(
    weights: &ViewWeightsNd<'_, D>,
    mass: &[f64],
    volume0: &[f64],
    v: &[Vector<D>],
    sigma: &[Tensor<D>],
    f: &[Tensor<D>],
    gravity: &Vector<D>,
    constrained: &[bool],
    threshold: f64,
    node_mass: &mut Vec<f64>,
    node_v: &mut Vec<Vector<D>>,
    node_a: &mut Vec<Vector<D>>,
    active: &mut Vec<bool>,
    complete: &NodalCompletion<'_, D>,
    mut bounds: Option<&mut ParticleBounds<'_, D>>,
) -> Option<usize> {
    let nn = weights.n_nodes();
    let formed = weights.is_formed();
    let mut unformed = None;
    node_mass.clear();
    node_mass.resize(nn, 0.0);
    node_v.clear();
    node_v.resize(nn, Vector::<D>::zeros());
    node_a.clear();
    node_a.resize(nn, Vector::<D>::zeros());
    for p in 0..v.len() {
        let mp = mass[p];
        let mv = v[p] * mp;
        let vol = super::det(&f[p]) * volume0[p];
        let vs = sigma[p] * (-vol);
        // The row formed on the stack first (as in the gather): a visitor closure is not
        // inlined into the unrolled stencil loop once the row is formed in the pass.
        weights.with_row_and_factors(p, |factors, nodes, s, grad| {
            if formed && factors.is_none() && unformed.is_none() {
                unformed = Some(p);
            }
            if let Some(b) = bounds.as_deref_mut() {
                b.add(p, &v[p], vol / mp, factors);
            }
            for ((&i, &w), g) in nodes.iter().zip(s).zip(grad) {
                let i = i as usize;
                node_mass[i] += w * mp;
                node_v[i] += mv * w;
                node_a[i] += vs * g;
            }
        });
    }
    finish_nodal(
        (node_mass, node_v, node_a, active),
        gravity,
        constrained,
        threshold,
        complete,
    );
    unformed
}

/// The nodal fields from the sums of a particle → grid pass: the sums completed over the
/// processes of a split run, then `v_i = Σ S m v / m_i`, `a_i = (−Σ V σ ∇S)/m_i + g` on
/// active nodes, zero on the others ([`particle_to_grid`]'s docs).
pub(super) fn finish_nodal<const D: usize>(
    (node_mass, node_v, node_a, active): (
        &mut Vec<f64>,
        &mut Vec<Vector<D>>,
        &mut Vec<Vector<D>>,
        &mut Vec<bool>,
    ),
    gravity: &Vector<D>,
    constrained: &[bool],
    threshold: f64,
    complete: &NodalCompletion<'_, D>,
) {
    finish_nodal_on(
        None,
        (node_mass, node_v, node_a, active),
        gravity,
        constrained,
        threshold,
        complete,
    );
}

/// [`finish_nodal`], on `pool` in ranges of nodes where given (each node's values are its
/// own: the same bits on any number of threads).
pub(super) fn finish_nodal_on<const D: usize>(
    pool: Option<&rayon::ThreadPool>,
    (node_mass, node_v, node_a, active): (
        &mut Vec<f64>,
        &mut Vec<Vector<D>>,
        &mut Vec<Vector<D>>,
        &mut Vec<bool>,
    ),
    gravity: &Vector<D>,
    constrained: &[bool],
    threshold: f64,
    complete: &NodalCompletion<'_, D>,
) {
    use rayon::prelude::*;
    let nn = node_mass.len();
    // The other processes' sums, in a split run.
    complete(node_mass, node_v, node_a);
    active.clear();
    active.resize(nn, false);
    let finish =
        |start: usize, m: &[f64], v: &mut [Vector<D>], a: &mut [Vector<D>], act: &mut [bool]| {
            for k in 0..m.len() {
                if m[k] > threshold && !constrained[start + k] {
                    act[k] = true;
                    v[k] /= m[k];
                    a[k] = a[k] / m[k] + gravity;
                } else {
                    v[k] = Vector::<D>::zeros();
                    a[k] = Vector::<D>::zeros();
                }
            }
        };
    match pool {
        Some(pool) => pool.install(|| {
            const NODES: usize = 8192;
            node_mass
                .par_chunks(NODES)
                .zip(node_v.par_chunks_mut(NODES))
                .zip(node_a.par_chunks_mut(NODES))
                .zip(active.par_chunks_mut(NODES))
                .enumerate()
                .for_each(|(k, (((m, v), a), act))| finish(k * NODES, m, v, a, act));
        }),
        None => finish(0, node_mass, node_v, node_a, active),
    }
}

/// Completes the nodal sums `Σ_p S m`, `Σ_p S m v`, `−Σ_p V σ ∇S` over the processes of a
/// split run (one reduction of `(1 + 2D)·n_nodes` numbers). A process whose own pass
/// failed calls it with zeros, so that every process takes part.
pub(super) fn sum_nodal<const D: usize>(
    reduce: &dyn Reduce,
    node_mass: &mut [f64],
    node_v: &mut [Vector<D>],
    node_a: &mut [Vector<D>],
) {
    let nn = node_mass.len();
    let mut buf = Vec::with_capacity(nn * (1 + 2 * D));
    buf.extend_from_slice(node_mass);
    buf.extend(node_v.iter().flat_map(|v| v.iter().copied()));
    buf.extend(node_a.iter().flat_map(|v| v.iter().copied()));
    reduce.sum(&mut buf);
    node_mass.copy_from_slice(&buf[..nn]);
    for (i, v) in node_v.iter_mut().enumerate() {
        *v = Vector::<D>::from_fn(|a, _| buf[nn + i * D + a]);
    }
    for (i, v) in node_a.iter_mut().enumerate() {
        *v = Vector::<D>::from_fn(|a, _| buf[nn * (1 + D) + i * D + a]);
    }
}

/// Where a particle's update failed.
pub(super) enum ParticleFault {
    /// A non-finite value in this field.
    NonFinite(&'static str, usize),
    /// Left a fixed box (particle, axis, coordinate along it).
    OutOfDomain(usize, usize, f64),
    /// `det F ≤ 0` (particle, det F).
    Inverted(usize, f64),
}

/// The committed state a step starts from.
pub(super) struct Committed<'a, const D: usize> {
    pub x: &'a [Vector<D>],
    pub v: &'a [Vector<D>],
    pub sigma: &'a [Tensor<D>],
    pub f: &'a [Tensor<D>],
    pub weights: ViewWeightsNd<'a, D>,
    pub node_a: &'a [Vector<D>],
}

/// The particle fields a step writes.
pub(super) struct Written<'a, const D: usize> {
    pub x: &'a mut [Vector<D>],
    pub v: &'a mut [Vector<D>],
    pub sigma: &'a mut [Tensor<D>],
    pub f: &'a mut [Tensor<D>],
    pub density: &'a mut [f64],
    /// The tangent moduli `(λ_t, μ_t)`; `None` where they are constant (not written).
    pub moduli: Option<(&'a mut [f64], &'a mut [f64])>,
}

/// Grid → particle: `v_p += dt Σ S a_i`, `L_p = Σ v_iⁿ⁺¹ ⊗ ∇S_ip`, `F ← F + dt L F`, the
/// stress update, `x += dt v_pⁿ⁺¹` (periodic axes wrap into `[origin, origin + L)`; on a
/// fixed axis a particle that crossed a wall by less than half a cell is put back on it
/// with its normal velocity removed, further is an `OutOfDomain` error).
/// `node_v1` holds `v_iⁿ⁺¹ = v_i + dt a_i`. Returns the trial's [`SummaryNd`]: `finite`
/// always (every written value is checked), the energies and first moment only with
/// `summarize` (else zeros).
#[allow(clippy::too_many_arguments)]
pub(super) fn grid_to_particle<const D: usize>(
    grid: &GridNd<D>,
    material: &[MaterialNd],
    mass: &[f64],
    volume0: &[f64],
    node_v1: &[Vector<D>],
    dt: f64,
    from: Committed<'_, D>,
    mut into: Written<'_, D>,
    summarize: bool,
) -> Result<SummaryNd<D>, ParticleFault> {
    let mut summary = SummaryNd::zero(true);
    for p in 0..from.x.len() {
        // The row formed on the stack first: a visitor's closure this large is not
        // inlined into the unrolled stencil loop.
        let (acc, l) = from.weights.with_row(p, |nodes, s, grad| {
            let mut acc = Vector::<D>::zeros();
            let mut l = Tensor::<D>::zeros();
            for ((&i, &w), g) in nodes.iter().zip(s).zip(grad) {
                let i = i as usize;
                acc += from.node_a[i] * w;
                l += node_v1[i] * g.transpose();
            }
            (acc, l)
        });
        let u = update_particle(
            grid,
            &material[p],
            p,
            (&from.x[p], &from.v[p], &from.f[p], &from.sigma[p]),
            (&acc, &l),
            dt,
        )?;
        let (x, v, f, sigma, j) = (u.x, u.v, u.f, u.sigma, u.det_f);
        if summarize {
            summary.kinetic += 0.5 * mass[p] * v.norm_squared();
            summary.strain += material[p].energy(&sigma, &f, volume0[p]);
            summary.first_moment += x * mass[p];
        }
        into.x[p] = x;
        into.v[p] = v;
        into.f[p] = f;
        into.sigma[p] = sigma;
        into.density[p] = mass[p] / (j * volume0[p]);
        if let Some((lambda, mu)) = into.moduli.as_mut() {
            (lambda[p], mu[p]) = material[p].tangent(j);
        }
    }
    Ok(summary)
}

/// A particle's fields after its grid → particle update.
pub(super) struct Updated<const D: usize> {
    pub x: Vector<D>,
    pub v: Vector<D>,
    pub f: Tensor<D>,
    pub sigma: Tensor<D>,
    /// `det F` of the new `F` (positive).
    pub det_f: f64,
}

/// Particle `p`'s update from its committed `(x, v, F, σ)` = `old` and the grid's
/// `(Σ S a_i, Σ v_iⁿ⁺¹ ⊗ ∇S)` = `gathered` ([`grid_to_particle`]'s docs): the new
/// velocity, `F`, stress and position (wrapped or put back on a wall), every value checked.
#[inline(always)]
pub(super) fn update_particle<const D: usize>(
    grid: &GridNd<D>,
    material: &MaterialNd,
    p: usize,
    old: (&Vector<D>, &Vector<D>, &Tensor<D>, &Tensor<D>),
    (acc, l): (&Vector<D>, &Tensor<D>),
    dt: f64,
) -> Result<Updated<D>, ParticleFault> {
    let (x_old, v_old, f_old, sigma_old) = old;
    let mut v = *v_old + acc * dt;
    let f = *f_old + l * *f_old * dt;
    let sigma = material.update(sigma_old, l, &f, dt);
    let mut x = *x_old + v * dt;
    for a in 0..D {
        let (lo, len) = (grid.origin[a], grid.length(a));
        match grid.boundary[a] {
            Boundary::Periodic => {
                if x[a] < lo || x[a] >= lo + len {
                    x[a] = lo + (x[a] - lo).rem_euclid(len);
                    if x[a] >= lo + len {
                        x[a] = lo;
                    }
                }
            }
            Boundary::Fixed => {
                // A particle that crosses a wall by less than half a cell is put back on
                // the wall with its velocity component across it removed (the walls hold
                // their nodes at rest: an inelastic, sticking wall); further is an
                // error (a blow-up, not contact).
                let slack = 0.5 * grid.h[a];
                if x[a] < lo || x[a] > lo + len {
                    if !(lo - slack..=lo + len + slack).contains(&x[a]) && x[a].is_finite() {
                        return Err(ParticleFault::OutOfDomain(p, a, x[a]));
                    }
                    x[a] = x[a].clamp(lo, lo + len);
                    v[a] = 0.0;
                }
            }
        }
    }
    for (name, ok) in [
        ("x", x.iter().all(|c| c.is_finite())),
        ("v", v.iter().all(|c| c.is_finite())),
        ("sigma", sigma.iter().all(|c| c.is_finite())),
        ("F", f.iter().all(|c| c.is_finite())),
    ] {
        if !ok {
            return Err(ParticleFault::NonFinite(name, p));
        }
    }
    let j = super::det(&f);
    if j <= 0.0 {
        return Err(ParticleFault::Inverted(p, j));
    }
    Ok(Updated {
        x,
        v,
        f,
        sigma,
        det_f: j,
    })
}
