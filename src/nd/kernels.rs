//! The library's kernels of the d-dimensional USL step: weights at the particle positions
//! and particle → grid with the nodal finish (for the views of a solver that keeps only
//! particles, [`super::fields`], and for the reference solver). Written once for any `D`
//! over the tensor-product stencil (`nodes_per_axis^D` entries per particle). The
//! reference solver's grid → particle update is in the test bench (`testbench::nd::update`).

use super::factor_metric::ParticleBounds;
use super::factors::{form_row, AxisFactors};
use super::shape::{AxisShape, BSplineAxis, GimpAxis, LinearAxis};
use super::{GridNd, ShapeNd, Tensor, Vector, ViewWeightsNd, WeightsNd};
use crate::grid::Boundary;

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
pub(crate) fn axis_factors<const D: usize>(
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
pub(crate) fn axis_factors_as<const D: usize, S: AxisShape>(
    grid: &GridNd<D>,
    strides: &[usize; D],
    x: &Vector<D>,
    l: &Vector<D>,
) -> Option<[AxisFactors; D]> {
    let inv_h: [f64; D] = std::array::from_fn(|a| 1.0 / grid.h[a]);
    let inv_l: [f64; D] = std::array::from_fn(|a| 1.0 / l[a]);
    axis_factors_inv::<D, S>(grid, strides, &inv_h, x, l, &inv_l)
}

/// [`axis_factors_as`] with the reciprocals of the spacings `inv_h[a] = 1/h_a` and of the
/// GIMP domain `inv_l[a] = 1/l_a` given ([`AxisShape::stencil_inv`]): a pass forms `1/h`
/// once and a particle's `1/l` once for its gather and its scatter. The same factors, bit
/// for bit.
#[inline(always)]
pub(crate) fn axis_factors_inv<const D: usize, S: AxisShape>(
    grid: &GridNd<D>,
    strides: &[usize; D],
    inv_h: &[f64; D],
    x: &Vector<D>,
    l: &Vector<D>,
    inv_l: &[f64; D],
) -> Option<[AxisFactors; D]> {
    let mut out = [AxisFactors::default(); D];
    axis_factors_into::<D, S>(grid, strides, (inv_h, inv_l), x, l, &mut out).then_some(out)
}

/// [`axis_factors_inv`] written into `out`, a pass's own buffer (`false`: the stencil
/// leaves the stored nodes, `out` then partly written). Returned in an `Option` the
/// factors would be copied once more on the stack, and in 3D that copy reads back as wide
/// loads the narrow stores of the offsets just made: a stall per stencil.
#[inline(always)]
pub(crate) fn axis_factors_into<const D: usize, S: AxisShape>(
    grid: &GridNd<D>,
    strides: &[usize; D],
    (inv_h, inv_l): (&[f64; D], &[f64; D]),
    x: &Vector<D>,
    l: &Vector<D>,
    out: &mut [AxisFactors; D],
) -> bool {
    let axis = |a: usize, f: &mut AxisFactors| {
        axis_factor_into::<D, S>(grid, strides, (inv_h[a], inv_l[a]), x, l, a, f)
    };
    // The axes one by one with constant indices (a loop over them is not unrolled): the
    // factors can then stay in registers for the row that reads them.
    match out.as_mut_slice() {
        [f0, f1] => axis(0, f0) && axis(1, f1),
        [f0, f1, f2] => axis(0, f0) && axis(1, f1) && axis(2, f2),
        rest => rest.iter_mut().enumerate().all(|(a, f)| axis(a, f)),
    }
}

/// Axis `a` of [`axis_factors_into`], into `f`.
#[inline(always)]
fn axis_factor_into<const D: usize, S: AxisShape>(
    grid: &GridNd<D>,
    strides: &[usize; D],
    (inv_h, inv_l): (f64, f64),
    x: &Vector<D>,
    l: &Vector<D>,
    a: usize,
    f: &mut AxisFactors,
) -> bool {
    let n_axis = S::NODES;
    let st = S::stencil_inv(x[a] - grid.origin[a], l[a], grid.h[a], inv_l, inv_h);
    f.s = st.s;
    f.d = st.d;
    if grid.boundary[a] == Boundary::Periodic {
        // One wrap for the first node; the next ones wrap by a comparison (a loop only on
        // an axis of fewer cells than the stencil's nodes, which wraps more than once).
        let n = grid.cells[a];
        // Inside the box already for all but the particles near its upper end: no integer
        // division there.
        let first = match usize::try_from(st.first) {
            Ok(i) if i < n => i,
            _ => st.first.rem_euclid(n as i64) as usize,
        };
        for k in 0..n_axis {
            let mut i = first + k;
            if n >= n_axis {
                // `first + k < n + n_axis ≤ 2n`: at most one wrap.
                i -= if i >= n { n } else { 0 };
            } else {
                while i >= n {
                    i -= n;
                }
            }
            f.offset[k] = (i * strides[a]) as u32;
        }
        return true;
    }
    for k in 0..n_axis {
        f.offset[k] = match grid.storage_along(a, st.first + k as i64) {
            Some(i) => (i * strides[a]) as u32,
            // A padding slot (weight and derivative zero) past the ghost node: any stored
            // node will do.
            None if st.s[k] == 0.0 && st.d[k] == 0.0 => 0,
            None => return false,
        };
    }
    true
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
pub(crate) fn particle_to_grid<const D: usize>(
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
pub(crate) fn finish_nodal_on<const D: usize>(
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
