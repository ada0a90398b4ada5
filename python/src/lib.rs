//! `mpm_dt._native`: the Python bindings of mpm-dt (the package `mpm_dt` re-exports them).
//!
//! * [`controller::PyController`] — `mpm_dt.Controller`, the adaptive controller driving a
//!   Python stepper through [`stepper::PyStepper`];
//! * [`critical_dt`], [`max_stable_modulus`] — the critical steps of one state.

mod arrays;
mod controller;
mod convert;
mod errors;
mod moduli;
mod state;
mod stepper;
mod summary;

use arrays::{item, shape_of};
use errors::state_error;
use mpm_dt::limits_nd::nodal_full_map::critical_dt_nodal;
use mpm_dt::limits_nd::stiffness::dense_lambda_max;
use mpm_dt::limits_nd::stiffness::lambda_max;
use mpm_dt::nd::{Vector, ViewNd};
use mpm_dt::stability::nodal_full_map::NODAL_FULL_MAP_LIMIT;
use mpm_dt::{Dim, Dimension};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use state::StateNd;

/// Above this many nodal unknowns `critical_dt` skips the dense eigenvalue check.
const DENSE_LIMIT: usize = 1000;

/// The spatial dimension of a state dict: the second axis of `"x"`.
fn dimension(state: &Bound<'_, PyDict>) -> PyResult<usize> {
    let shape = shape_of(&item(state, "x")?, "x")?;
    match shape[..] {
        [_, d @ (2 | 3)] => Ok(d),
        _ => Err(state_error(
            state.py(),
            format!("state[\"x\"] must have shape (n, 2) or (n, 3), got {shape:?}"),
        )),
    }
}

/// A state of dimension `D` read from `state` (a `StateError` if invalid).
fn read<const D: usize>(state: &Bound<'_, PyDict>) -> PyResult<Box<StateNd<D>>> {
    let mut s = Box::<StateNd<D>>::default();
    s.read(state, &Vector::<D>::zeros(), 0.0, 0)
        .map_err(|f| f.into_pyerr(state.py(), "state"))?;
    Ok(s)
}

/// The frozen-particle full map's critical step, reduced to the nodes
/// (`mpm_dt::stability::nodal_full_map`; `None` above `NODAL_FULL_MAP_LIMIT` nodal
/// unknowns, or when its Lanczos iteration does not settle).
fn full_map_dt<const D: usize>(view: &ViewNd<'_, D>) -> Option<f64> {
    critical_dt_nodal(view)
        .filter(|c| c.converged)
        .map(|c| c.dt)
}

/// `(c_p, λmax, λmax dense)` of a view: the largest P-wave speed, `λmax(M⁻¹K)` by Lanczos,
/// and the dense check on small layouts.
fn critical_of<const D: usize>(view: &ViewNd<'_, D>) -> (f64, f64, Option<f64>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let c_p = (0..view.n_particles())
        .map(|p| view.p_wave_speed(p))
        .fold(0.0, f64::max);
    let dense = (view.n_nodes() * D <= DENSE_LIMIT)
        .then(|| dense_lambda_max(view))
        .flatten();
    (c_p, lambda_max(view), dense)
}

fn critical_dict<'py, const D: usize>(
    state: &Bound<'py, PyDict>,
    full: bool,
) -> PyResult<Bound<'py, PyDict>>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let s = read::<D>(state)?;
    let view = s.view();
    let (c_p, lambda, dense) = critical_of(&view);
    let d = PyDict::new(state.py());
    d.set_item("cell_size", view.grid.h.to_vec())?;
    d.set_item("c_p", c_p)?;
    d.set_item("dt_sound", view.grid.h_min() / c_p)?;
    d.set_item("lambda_max", lambda)?;
    d.set_item("lambda_max_dense", dense)?;
    d.set_item("dt_eq56", (2.0 / lambda).sqrt())?;
    d.set_item("dt_full_map", full.then(|| full_map_dt(&view)).flatten())?;
    Ok(d)
}

/// The critical time steps of one state (a dict as ``state(trial)`` returns).
///
/// Returns a dict:
///
/// * ``dt_sound`` -- ``min_a h_a / max_p c_p``, the speed-of-sound step at rest, with the
///   P-wave speed ``c_p = sqrt((lambda + 2 mu) / rho)`` (eq 49 with ``alpha = 1``);
/// * ``lambda_max`` -- ``lambda_max(M^-1 K)``, the largest eigenvalue of the nodal
///   stiffness ``K = sum_p V_p B_p^T C_p B_p`` over the lumped masses (eq 56 in d
///   dimensions), by Lanczos to a relative residual of 1e-10;
/// * ``dt_eq56`` -- ``sqrt(2 / lambda_max)``: a fixed step above it amplifies the top
///   mode of the explicit step (no safety factor);
/// * ``dt_full_map`` -- the critical step of the whole linearised USL/FLIP step
///   (velocity and stress) with the particles frozen, with ``full_map=True``: what a
///   fixed-step run of the paper's scheme tolerates, 6-10 % above ``dt_eq56`` on typical
///   layouts. Reduced exactly to one symmetric eigenvalue on the nodes and found by
///   Lanczos, on layouts of up to 20 000 active nodal unknowns (``d`` per active node; else ``None``),
///   in milliseconds to about a second;
/// * ``c_p``, ``cell_size``, and ``lambda_max_dense`` (the dense eigenvalue, on layouts of
///   at most 1000 nodal unknowns; else ``None``).
///
/// The state dict holds ``"x"`` (n, d), ``"v"`` (n, d), ``"mass"`` (n,), ``"volume0"``
/// (n,), ``"F"`` (n, d, d), ``"stress"`` (n, d, d) Cauchy, the moduli as ``"lame"`` (n, 2)
/// or the scalars ``"youngs_modulus"`` and ``"poisson_ratio"`` (with an optional
/// ``"material"``, ``"neo_hookean"`` or ``"fixed_corotated"``, they are the small-strain
/// moduli and each particle's tangent pair at its ``F`` is used), the grid as ``"cells"``
/// (d,), ``"length"`` (d,), ``"boundary"`` (``"periodic"``, ``"fixed"`` or one per
/// axis), optional ``"origin"`` (d,), ``"shape"`` (``"bspline2"``, ``"gimp"``,
/// ``"linear"``), optional ``"transfer"`` (``"flip"``, ``"apic"``: the APIC limit
/// ``sqrt(2 (1 + p) / lambda_max)`` of the controller, ``bspline2`` only), optional
/// ``"gradient"`` (``"exact"``, or ``"mls"``: MLS-MPM's ``(4/h^2) S_ip (x_i - x_p)``,
/// ``bspline2`` only), optional
/// ``"domain"`` (n, d) GIMP particle lengths (default: the cube root of ``volume0``) and
/// an optional ``"summary"``: a dict of totals the solver computes in its own pass over the
/// particles -- ``"kinetic"`` (sum of 1/2 m v^2), ``"strain"`` (the stored energy the
/// growth monitor watches; the library's own is sum of 1/2 sigma : C^-1 : sigma V),
/// ``"first_moment"`` (d,) (sum of m x), optionally ``"element_bound"`` (an upper bound on
/// ``lambda_max``, the largest over the particles of
/// ``(4/h^2)(V/m) min(max(d lambda + 2 mu, 2 mu), d max(lambda + 2 mu, 2 mu))`` for MLS-MPM's
/// gradients; a value below the library's own lets the stability limit propose steps that
/// are too large) and ``"sound_unit_step"`` (min of ``h_a / (c_p + |v_a|)``) -- so that the
/// controller's limits make no passes of their own for them. A NaN in a trial's summary is
/// a blow-up (the trial is retried with a smaller step); a missing or unknown key, a
/// negative bound or a step that is not positive is a ``StateError``.
#[pyfunction]
#[pyo3(signature = (state, full_map = false))]
fn critical_dt<'py>(state: Bound<'py, PyDict>, full_map: bool) -> PyResult<Bound<'py, PyDict>> {
    match dimension(&state)? {
        2 => critical_dict::<2>(&state, full_map),
        _ => critical_dict::<3>(&state, full_map),
    }
}

fn max_modulus<const D: usize>(state: &Bound<'_, PyDict>, dt: f64, full: bool) -> PyResult<f64>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let py = state.py();
    let s = read::<D>(state)?;
    let e = if state.contains("youngs_modulus")? {
        arrays::scalar(state, "youngs_modulus")?
    } else if state.contains("material")? {
        // The rows are then the tangent pairs, not the material's: its E is not theirs.
        return Err(state_error(py, "max_stable_modulus with \"material\" needs the scalars \"youngs_modulus\" and \"poisson_ratio\" (the tangent pairs scale with E)".into()));
    } else {
        // Per-particle moduli: they must be one material, E = μ(3λ + 2μ)/(λ + μ).
        let (l, m) = (s.lame_lambda[0], s.lame_mu[0]);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        let uniform = s
            .lame_lambda
            .iter()
            .zip(&s.lame_mu)
            .all(|(&a, &b)| close(a, l) && close(b, m));
        if !uniform || l + m <= 0.0 {
            return Err(state_error(py, "max_stable_modulus needs one material: give \"youngs_modulus\" and \"poisson_ratio\", or equal \"lame\" rows".into()));
        }
        m * (3.0 * l + 2.0 * m) / (l + m)
    };
    let view = s.view();
    let lambda = lambda_max(&view);
    if !full {
        return Ok(e * 2.0 / (dt * dt * lambda));
    }
    // The full map depends on dt and E only through dt·√E (module docs of the function).
    match full_map_dt(&view) {
        Some(dt_c) => Ok(e * (dt_c / dt).powi(2)),
        None => Err(state_error(py, format!("method=\"full_map\" needs a layout of at most {NODAL_FULL_MAP_LIMIT} active nodal unknowns (d per active node) on which its Lanczos iteration settles"))),
    }
}

/// The largest Young's modulus for which the fixed step ``dt`` is stable on this layout.
///
/// The nodal stiffness ``K = sum_p V_p B_p^T C_p B_p`` is linear in the moduli, so scaling
/// every particle's ``(lambda, mu)`` by ``s`` (Poisson's ratio, masses and positions kept)
/// scales ``lambda_max(M^-1 K)`` by ``s``. The step is stable while
/// ``dt^2 s lambda_max <= 2`` (eq 56), hence
///
/// ``E_max = E * 2 / (dt^2 * lambda_max)``
///
/// with ``E`` the state's ``"youngs_modulus"`` (or, for ``"lame"`` rows all equal,
/// ``mu (3 lambda + 2 mu) / (lambda + mu)``) and ``lambda_max`` that of the state
/// (``critical_dt``). It is the eq 56 bound of the paper's USL/FLIP step, with no safety
/// factor, at this layout (positions, volumes, deformation): a solver whose step is
/// another scheme (APIC) or whose particles move far changes it.
///
/// ``method="full_map"`` instead uses the critical step ``dt_c`` of the whole
/// linearised step with frozen particles (``critical_dt``'s ``dt_full_map``, layouts of up
/// to 20 000 active nodal unknowns). Scaling the stress by ``sqrt(E)``, that map depends on ``dt`` and ``E`` only
/// through ``dt sqrt(E)``, so ``E_max = E (dt_c / dt)^2``: the value a bisection on real
/// runs finds, where eq 56 is 12-20 % lower (conservative).
#[pyfunction]
#[pyo3(signature = (state, dt, method = "eq56"))]
fn max_stable_modulus(state: Bound<'_, PyDict>, dt: f64, method: &str) -> PyResult<f64> {
    let full = match method {
        "eq56" => false,
        "full_map" => true,
        m => {
            return Err(state_error(
                state.py(),
                format!("method {m:?}: expected \"eq56\" or \"full_map\""),
            ))
        }
    };
    if !(dt.is_finite() && dt > 0.0) {
        return Err(state_error(
            state.py(),
            format!("dt = {dt} is not a positive number"),
        ));
    }
    match dimension(&state)? {
        2 => max_modulus::<2>(&state, dt, full),
        _ => max_modulus::<3>(&state, dt, full),
    }
}

thread_local! {
    /// `read_state`'s storage, reused from call to call as the controller reuses its own.
    static READ2: std::cell::RefCell<StateNd<2>> = std::cell::RefCell::new(StateNd::default());
    static READ3: std::cell::RefCell<StateNd<3>> = std::cell::RefCell::new(StateNd::default());
}

fn read_counts<const D: usize>(
    state: &Bound<'_, PyDict>,
    cell: &std::cell::RefCell<StateNd<D>>,
) -> PyResult<(usize, usize)> {
    let mut s = cell.borrow_mut();
    s.read(state, &Vector::<D>::zeros(), 0.0, 0)
        .map_err(|f| f.into_pyerr(state.py(), "state"))?;
    Ok((s.x.len(), s.nodal.active.iter().filter(|&&a| a).count()))
}

/// Reads a state dict as the controller reads every trial (the arrays into Rust memory,
/// the weights, the nodal mass, velocity and acceleration) and returns ``(particles,
/// active nodes)``: the package's part of the hand-over, for measuring it.
#[pyfunction]
fn read_state(state: Bound<'_, PyDict>) -> PyResult<(usize, usize)> {
    match dimension(&state)? {
        2 => READ2.with(|c| read_counts::<2>(&state, c)),
        _ => READ3.with(|c| read_counts::<3>(&state, c)),
    }
}

/// The native part of the `mpm_dt` package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<controller::PyController>()?;
    m.add_function(wrap_pyfunction!(critical_dt, m)?)?;
    m.add_function(wrap_pyfunction!(max_stable_modulus, m)?)?;
    m.add_function(wrap_pyfunction!(read_state, m)?)?;
    Ok(())
}
