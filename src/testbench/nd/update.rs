//! The reference solver's own kernels in d dimensions: the grid → particle update (each
//! particle's new velocity, deformation gradient, stress and position from the grid's
//! updated fields) and the nodal sums of a run split over processes (the library's own
//! kernels — weights, particle → grid — are in [`crate::nd::kernels`]).

use super::material::LameCache;
use super::MaterialNd;
use crate::grid::Boundary;
use crate::nd::{GridNd, SummaryNd, Tensor, Vector, ViewWeightsNd};
use crate::reduce::Reduce;

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
    let mut lame = LameCache::default();
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
        let lame_p = lame.get(&material[p]);
        let u = update_particle(
            grid,
            (&material[p], lame_p),
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
            (lambda[p], mu[p]) = material[p].tangent_with(lame_p, j);
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

/// Particle `p`'s update (of `material` with its Lamé pair [`MaterialNd::lame`]) from its
/// committed `(x, v, F, σ)` = `old` and the grid's
/// `(Σ S a_i, Σ v_iⁿ⁺¹ ⊗ ∇S)` = `gathered` ([`grid_to_particle`]'s docs): the new
/// velocity, `F`, stress and position (wrapped or put back on a wall), every value checked.
#[inline(always)]
pub(super) fn update_particle<const D: usize>(
    grid: &GridNd<D>,
    (material, lame): (&MaterialNd, (f64, f64)),
    p: usize,
    old: (&Vector<D>, &Vector<D>, &Tensor<D>, &Tensor<D>),
    (acc, l): (&Vector<D>, &Tensor<D>),
    dt: f64,
) -> Result<Updated<D>, ParticleFault> {
    let (x_old, v_old, f_old, sigma_old) = old;
    let mut v = *v_old + acc * dt;
    let f = *f_old + l * *f_old * dt;
    let sigma = material.update_with(lame, sigma_old, l, &f, dt);
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
    // `c · 0` is `±0` for a finite `c` and NaN otherwise: one branch-free sum tells whether
    // every value is finite, and the field is named only on the rare failure.
    let probe = (x * 0.0 + v * 0.0).sum() + (sigma * 0.0 + f * 0.0).sum();
    if probe != 0.0 {
        non_finite(p, (&x, &v, &sigma, &f))?;
    }
    let j = crate::nd::det(&f);
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

/// The first non-finite field of a particle's update, in the order x, v, σ, F.
#[cold]
fn non_finite<const D: usize>(
    p: usize,
    (x, v, sigma, f): (&Vector<D>, &Vector<D>, &Tensor<D>, &Tensor<D>),
) -> Result<(), ParticleFault> {
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
    Ok(())
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
