//! Critical steps of a d-dimensional layout, for verification (docs/design.md, "Contracts for any
//! dimension", `critical_dt`).
//!
//! * `dt_sound = min_a h_a / max_p c_p` — the speed-of-sound step at rest;
//! * `lambda_max_nodal = λmax(M⁻¹K)` by Lanczos run to a relative residual of `1e-10`
//!   ([`crate::limits_nd::stiffness`]) and, on small problems, checked against the dense symmetric
//!   eigenvalues; `dt_eq56 = √(2/λmax)`;
//! * `dt_empirical` — bisection on real runs of the reference solver: from
//!   `v = A c_p sin(2π x_0/L_0) e_0` plus seeded noise `10⁻⁶ A` on every component of `v`
//!   and `σ`, `F = I`, `steps` steps (4000 in the contract), unstable when the energy exceeds
//!   10× its start, a value is not finite, or some `det F ≤ 0` (up to
//!   [`EMPIRICAL_LIMIT`] particle–node pairs).
//!
//! * `dt_full_map` — the frozen-particle critical step of the whole linearised step,
//!   velocity and stress, reduced to the nodes ([`crate::limits_nd::nodal_full_map`],
//!   [`crate::stability::nodal_full_map`]): one symmetric eigenvalue found by Lanczos, on
//!   layouts of up to [`NODAL_FULL_MAP_LIMIT`] nodal unknowns;
//! * `dt_full_map_dense` — the same from the dense map ([`crate::limits_nd::full_map`]), its
//!   cross-check, on layouts of at most [`crate::limits_nd::full_map::FULL_MAP_LIMIT`] particle
//!   unknowns (`None` above, or when its search brackets no critical step).

use crate::dimension::{Dim, Dimension};
use crate::limits_nd::stiffness::dense_lambda_max;
pub use crate::limits_nd::stiffness::lambda_max;
use crate::nd::{SolverNd, Tensor, Vector, ViewNd};
use crate::stepper::Stepper;
use serde::Serialize;

/// Above this many nodal unknowns the dense check is skipped.
pub const DENSE_LIMIT: usize = 1000;

pub use crate::stability::nodal_full_map::NODAL_FULL_MAP_LIMIT;

/// Above this many particle–node pairs (particles × stencil width) the empirical bisection
/// is skipped (`dt_empirical = None`): it takes about ten runs of `steps` steps (and the
/// scan around its answer, [`empirical_scan`], 33 more).
pub const EMPIRICAL_LIMIT: usize = 20_000;

/// The verification table of one layout.
#[derive(Clone, Debug, Serialize)]
pub struct CriticalTable {
    /// Cell size per axis.
    pub cell_size: Vec<f64>,
    /// Largest P-wave speed over the particles.
    pub c_p: f64,
    /// `min_a h_a / c_p`.
    pub dt_sound: f64,
    /// `λmax(M⁻¹K)` (1/s²), Lanczos.
    pub lambda_max_nodal: f64,
    /// The same from the dense matrix, on small problems.
    pub lambda_max_dense: Option<f64>,
    /// `√(2/λmax)`.
    pub dt_eq56: f64,
    /// The frozen-particle full map's critical step from the nodes (module docs).
    pub dt_full_map: Option<f64>,
    /// The same from the dense map, on small layouts (module docs).
    pub dt_full_map_dense: Option<f64>,
    /// Bisection on real runs, if asked for.
    pub dt_empirical: Option<f64>,
    /// Real runs at steps around `dt_empirical` ([`empirical_scan`], filled in by the
    /// caller who wants them: 33 runs more): where stability is not monotone in `dt`, one
    /// bisection's answer depends on its bracket, and this says where.
    pub dt_empirical_scan: Option<crate::stability::MonotoneScan>,
}

/// The table for the committed state of `solver`; `empirical` = `Some((A, steps))` runs
/// the bisection. On a solver split over processes every process must call it together,
/// and only `lambda_max_nodal` and `dt_eq56` are computed (the other checks are
/// single-process tools).
pub fn critical_table<const D: usize>(
    solver: &SolverNd<D>,
    empirical: Option<(f64, usize)>,
) -> CriticalTable
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let view = solver.view();
    let c_p = (0..view.n_particles())
        .map(|p| view.p_wave_speed(p))
        .fold(0.0, f64::max);
    let lambda = lambda_max(&view);
    // The dense check, the full map and the bisection are single-process tools: on a
    // split solver each process would analyse or run its own part alone.
    let alone = view.split.is_none();
    let dense = (alone && view.n_nodes() * D <= DENSE_LIMIT)
        .then(|| dense_lambda_max(&view))
        .flatten();
    let runs =
        empirical.filter(|_| alone && view.n_particles() * view.weights.width() <= EMPIRICAL_LIMIT);
    // The true limit is a few per cent above dt_eq56 on GIMP and linear layouts
    // (docs/design.md); the bracket widens itself when it is not.
    let guess = (2.0 / lambda).sqrt();
    let dt_empirical =
        runs.map(|(a, steps)| empirical_critical(solver, a, steps, 0.95 * guess, 1.25 * guess, 9));
    CriticalTable {
        cell_size: view.grid.h.to_vec(),
        c_p,
        dt_sound: view.grid.h_min() / c_p,
        lambda_max_nodal: lambda,
        lambda_max_dense: dense,
        dt_eq56: (2.0 / lambda).sqrt(),
        dt_full_map: alone
            .then(|| crate::limits_nd::nodal_full_map::critical_dt_nodal(&view))
            .flatten()
            .filter(|c| c.converged)
            .map(|c| c.dt),
        dt_full_map_dense: alone
            .then(|| crate::limits_nd::full_map::critical_dt(&view, (2.0 / lambda).sqrt()))
            .flatten()
            .and_then(Result::ok),
        dt_empirical,
        dt_empirical_scan: None,
    }
}

/// [`crate::stability::scan_monotone`] with real runs of `steps` steps at amplitude
/// `amplitude` ([`blows_up`]) around `center`.
pub fn empirical_scan<const D: usize>(
    template: &SolverNd<D>,
    amplitude: f64,
    steps: usize,
    center: f64,
) -> crate::stability::MonotoneScan
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let stable =
        |dt: f64| Ok::<bool, std::convert::Infallible>(!blows_up(template, amplitude, steps, dt));
    match crate::stability::scan_monotone(center, stable) {
        Ok(scan) => scan,
        Err(never) => match never {},
    }
}

/// Whether a run of `steps` fixed steps `dt` from the perturbed state blows up
/// (module docs). For an undivided solver: the processes of a split one would not agree
/// on when to stop.
pub fn blows_up<const D: usize>(
    template: &SolverNd<D>,
    amplitude: f64,
    steps: usize,
    dt: f64,
) -> bool
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut s = template.clone();
    let view = s.view();
    let l0 = view.grid.length(0);
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let n = view.n_particles();
    let mut v = Vec::with_capacity(n);
    let mut sigma = Vec::with_capacity(n);
    for p in 0..n {
        let c = view.p_wave_speed(p);
        let mut vp = Vector::<D>::zeros();
        vp[0] = amplitude * c * (2.0 * std::f64::consts::PI * view.x[p][0] / l0).sin();
        for a in 0..D {
            vp[a] += 1e-6 * amplitude * c * noise();
        }
        v.push(vp);
        let scale = 1e-6 * amplitude * (view.lame_lambda[p] + 2.0 * view.lame_mu[p]);
        sigma.push(Tensor::<D>::from_fn(|_, _| scale * noise()));
    }
    for t in sigma.iter_mut() {
        *t = (*t + t.transpose()) * 0.5;
    }
    if s.set_velocity_and_stress(&v, &sigma).is_err() {
        return true;
    }
    let e0 = s.total_energy();
    for _ in 0..steps {
        if s.try_step(dt).and_then(|_| s.accept()).is_err() {
            return true;
        }
        let e = s.total_energy();
        if !e.is_finite() || e > 10.0 * e0 {
            return true;
        }
    }
    false
}

/// Bisection of the blow-up step between `lo` (assumed stable) and `hi` (assumed
/// unstable; both are checked and widened by factors of 2 if not) in `iterations` halvings;
/// returns the largest stable step found.
pub fn empirical_critical<const D: usize>(
    template: &SolverNd<D>,
    amplitude: f64,
    steps: usize,
    mut lo: f64,
    mut hi: f64,
    iterations: usize,
) -> f64
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    for _ in 0..8 {
        if blows_up(template, amplitude, steps, hi) {
            break;
        }
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..8 {
        if !blows_up(template, amplitude, steps, lo) {
            break;
        }
        hi = lo;
        lo *= 0.5;
    }
    for _ in 0..iterations {
        let mid = 0.5 * (lo + hi);
        if blows_up(template, amplitude, steps, mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    lo
}
