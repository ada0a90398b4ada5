//! One state of a Python solver, read from its state dict into the package's own storage,
//! with the weights and nodal fields the library's view needs.
//!
//! From the dict's particle fields the package computes, with the library's kernels
//! (`mpm_dt::nd::fields`):
//!
//! * the weights `S_ip = Π_a s_a` and gradients `∂_a S_ip = s'_a Π_{b≠a} s_b` of the
//!   `"shape"` at the particle positions;
//! * `m_i = Σ_p S_ip m_p` (eq 7), `v_i = Σ_p S_ip m_p v_p / m_i` (eq 17) and
//!   `a_i = (−Σ_p V_p σ_p ∇S_ip)/m_i + g` (eq 18), `V_p = det(F_p) V⁰_p`;
//! * the density `ρ_p = m_p/(det(F_p) V⁰_p)` and the tangent Lamé moduli from `"lame"` or
//!   from `"youngs_modulus"`, `"poisson_ratio"`: `λ = Eν/((1 + ν)(1 − 2ν))`,
//!   `μ = E/(2(1 + ν))`; with `"material"` (`"neo_hookean"`, `"fixed_corotated"`) those are
//!   the small-strain pair and each particle's tangent at its `F` is reported
//!   (`mpm_dt::tangent`).

use crate::arrays::{item, read_into, shape_of, with_values};
use crate::errors::state_error;
use mpm_dt::limits_nd::TransferNd;
use mpm_dt::nd::fields::{compute_weights, NodalFieldsNd, ParticleFieldsNd};
use mpm_dt::nd::{
    det, GridNd, ShapeNd, SummaryNd, Tensor, Vector, ViewNd, WeightsNd, INACTIVE_MASS_RATIO,
};
use mpm_dt::Boundary;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Why a state could not be read.
pub enum Fault {
    /// A non-finite value (field, particle): a blow-up, retryable in a trial.
    NonFinite(&'static str, usize),
    /// A non-finite total in the state's `"summary"` (which one): a blow-up, retryable in a
    /// trial.
    NonFiniteSummary(&'static str),
    /// `det F ≤ 0` (particle, det F): retryable in a trial.
    Inverted(usize, f64),
    /// A particle whose stencil leaves the grid (particle, the axis along which it lies
    /// outside the grid's box — 0 if it does not —, its coordinate there): retryable in a
    /// trial.
    OutOfGrid(usize, usize, f64),
    /// An invalid dict (or a Python error while reading it): never retried.
    Invalid(PyErr),
}

impl From<PyErr> for Fault {
    fn from(e: PyErr) -> Self {
        Fault::Invalid(e)
    }
}

impl Fault {
    /// The fault as a Python `StateError` (for a committed state, where nothing retries).
    pub fn into_pyerr(self, py: Python<'_>, what: &str) -> PyErr {
        let msg = match self {
            Fault::Invalid(e) => return e,
            Fault::NonFinite(field, p) => format!("non-finite {field} at particle {p}"),
            Fault::NonFiniteSummary(what) => format!("non-finite {what}"),
            Fault::Inverted(p, j) => format!("det F = {j} <= 0 at particle {p}"),
            Fault::OutOfGrid(p, a, x) => {
                format!("particle {p} (x[{a}] = {x}) has nodes outside the grid")
            }
        };
        state_error(py, format!("{what}: {msg}"))
    }
}

/// One state in the package's storage (module docs).
#[derive(Clone, Debug)]
pub struct StateNd<const D: usize> {
    pub t: f64,
    pub step: u64,
    pub grid: GridNd<D>,
    pub shape: ShapeNd,
    pub transfer: TransferNd,
    /// MLS-MPM's effective gradients `∇S_ip = D_p⁻¹ S_ip (X_i − x_p)` in place of the
    /// B-spline's own (`"gradient": "mls"`).
    mls: bool,
    pub x: Vec<Vector<D>>,
    pub v: Vec<Vector<D>>,
    pub sigma: Vec<Tensor<D>>,
    pub f: Vec<Tensor<D>>,
    pub volume0: Vec<f64>,
    pub mass: Vec<f64>,
    pub lame_lambda: Vec<f64>,
    pub lame_mu: Vec<f64>,
    pub density: Vec<f64>,
    domain: Vec<Vector<D>>,
    pub weights: WeightsNd<D>,
    pub nodal: NodalFieldsNd<D>,
    /// The solver's own totals (`"summary"`, [`crate::summary`]), if it gave them.
    pub summary: Option<SummaryNd<D>>,
}

impl<const D: usize> Default for StateNd<D> {
    fn default() -> Self {
        Self {
            t: 0.0,
            step: 0,
            grid: GridNd::new([Boundary::Periodic; D], [1; D], [1.0; D]),
            shape: ShapeNd::Linear,
            transfer: TransferNd::Flip,
            mls: false,
            x: Vec::new(),
            v: Vec::new(),
            sigma: Vec::new(),
            f: Vec::new(),
            volume0: Vec::new(),
            mass: Vec::new(),
            lame_lambda: Vec::new(),
            lame_mu: Vec::new(),
            density: Vec::new(),
            domain: Vec::new(),
            weights: WeightsNd::default(),
            nodal: NodalFieldsNd::default(),
            summary: None,
        }
    }
}

/// Reads `key` as `n` d-vectors (`(n, D)`), checking that every value is finite.
fn vectors<const D: usize>(
    dict: &Bound<'_, PyDict>,
    key: &'static str,
    n: usize,
    out: &mut Vec<Vector<D>>,
) -> Result<(), Fault> {
    let obj = item(dict, key)?;
    let bad = with_values(&obj, key, &[n, D], |s| {
        out.clear();
        out.extend(s.chunks_exact(D).map(Vector::<D>::from_column_slice));
        s.iter().position(|v| !v.is_finite()).map(|k| k / D)
    })?;
    bad.map_or(Ok(()), |p| Err(Fault::NonFinite(key, p)))
}

/// Reads `key` as `n` d×d tensors (`(n, D, D)`, row `i` of particle `p` at `[p, i, :]`).
fn tensors<const D: usize>(
    dict: &Bound<'_, PyDict>,
    key: &'static str,
    n: usize,
    out: &mut Vec<Tensor<D>>,
) -> Result<(), Fault> {
    let obj = item(dict, key)?;
    let bad = with_values(&obj, key, &[n, D, D], |s| {
        out.clear();
        out.extend(s.chunks_exact(D * D).map(Tensor::<D>::from_row_slice));
        s.iter().position(|v| !v.is_finite()).map(|k| k / (D * D))
    })?;
    bad.map_or(Ok(()), |p| Err(Fault::NonFinite(key, p)))
}

/// Reads `key` as `n` positive finite numbers.
fn positive(dict: &Bound<'_, PyDict>, key: &str, n: usize, out: &mut Vec<f64>) -> PyResult<()> {
    read_into(dict, key, &[n], out)?;
    match out.iter().position(|&m| !(m.is_finite() && m > 0.0)) {
        Some(p) => Err(state_error(
            dict.py(),
            format!("state[{key:?}][{p}] = {} is not a positive number", out[p]),
        )),
        None => Ok(()),
    }
}

/// The grid of a state dict: `"cells"` (d ints), `"length"` (d floats), `"boundary"`
/// (`"periodic"`, `"fixed"`, or one per axis), optional `"origin"` (d floats).
pub fn read_grid<const D: usize>(dict: &Bound<'_, PyDict>) -> PyResult<GridNd<D>> {
    let py = dict.py();
    let cells: Vec<usize> = item(dict, "cells")?.extract().map_err(|_| {
        state_error(
            py,
            format!("state[\"cells\"] must be {D} positive integers"),
        )
    })?;
    let mut length = Vec::new();
    read_into(dict, "length", &[D], &mut length)?;
    if cells.len() != D || cells.contains(&0) {
        return Err(state_error(
            py,
            format!("state[\"cells\"] must be {D} positive integers, got {cells:?}"),
        ));
    }
    if length.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
        return Err(state_error(
            py,
            format!("state[\"length\"] must be {D} positive numbers, got {length:?}"),
        ));
    }
    let parse = |s: &str| match s {
        "periodic" => Ok(Boundary::Periodic),
        "fixed" => Ok(Boundary::Fixed),
        _ => Err(state_error(
            py,
            format!("boundary {s:?}: expected \"periodic\" or \"fixed\""),
        )),
    };
    let b = item(dict, "boundary")?;
    let boundary: Vec<Boundary> = match b.extract::<String>() {
        Ok(s) => vec![parse(&s)?; D],
        Err(_) => {
            let names: Vec<String> = b.extract().map_err(|_| {
                state_error(
                    py,
                    "state[\"boundary\"] must be a string or a list of strings".into(),
                )
            })?;
            names.iter().map(|s| parse(s)).collect::<PyResult<_>>()?
        }
    };
    if boundary.len() != D {
        return Err(state_error(
            py,
            format!("state[\"boundary\"] must name {D} axes"),
        ));
    }
    let mut grid = GridNd::new(
        std::array::from_fn(|a| boundary[a]),
        std::array::from_fn(|a| cells[a]),
        std::array::from_fn(|a| length[a]),
    );
    if dict.contains("origin")? {
        let mut origin = Vec::new();
        read_into(dict, "origin", &[D], &mut origin)?;
        grid.origin = std::array::from_fn(|a| origin[a]);
    }
    Ok(grid)
}

/// `"shape"`, `"transfer"` and `"gradient"` of a state dict.
fn read_scheme(dict: &Bound<'_, PyDict>) -> PyResult<(ShapeNd, TransferNd, bool)> {
    let py = dict.py();
    let shape: String = item(dict, "shape")?.extract()?;
    let shape = match shape.as_str() {
        "bspline2" => ShapeNd::BSpline2,
        "gimp" => ShapeNd::Gimp,
        "linear" => ShapeNd::Linear,
        s => {
            return Err(state_error(
                py,
                format!("shape {s:?}: expected \"bspline2\", \"gimp\" or \"linear\""),
            ))
        }
    };
    let transfer = match dict.get_item("transfer")? {
        None => TransferNd::Flip,
        Some(t) => match t.extract::<String>()?.as_str() {
            "flip" => TransferNd::Flip,
            // APIC's inertia D_p = h²/4 per axis is that of quadratic B-splines.
            "apic" if shape == ShapeNd::BSpline2 => TransferNd::Apic { inertia: 0.25 },
            "apic" => {
                return Err(state_error(
                    py,
                    "transfer \"apic\" is analysed for shape \"bspline2\" only".into(),
                ))
            }
            s => {
                return Err(state_error(
                    py,
                    format!("transfer {s:?}: expected \"flip\" or \"apic\""),
                ))
            }
        },
    };
    let mls = match dict.get_item("gradient")? {
        None => false,
        Some(g) => match g.extract::<String>()?.as_str() {
            "exact" => false,
            "mls" if shape == ShapeNd::BSpline2 => true,
            "mls" => {
                return Err(state_error(
                    py,
                    "gradient \"mls\" needs shape \"bspline2\"".into(),
                ))
            }
            s => {
                return Err(state_error(
                    py,
                    format!("gradient {s:?}: expected \"exact\" or \"mls\""),
                ))
            }
        },
    };
    Ok((shape, transfer, mls))
}

/// Replaces the gradients by MLS-MPM's effective ones, `∇S_ip = (4/h_a²) S_ip (X_i − x_p)`
/// per axis (quadratic B-splines: `D_p = h_a²/4`). `X_i` is the unwrapped lattice node
/// `first_a + k_a` of the stencil, walked in the order of `compute_weights` (axis 0
/// fastest), so that periodic images need no care.
fn mls_gradients<const D: usize>(grid: &GridNd<D>, x: &[Vector<D>], weights: &mut WeightsNd<D>) {
    let n = x.len();
    let width = weights.width();
    let inv_h: [f64; D] = std::array::from_fn(|a| 1.0 / grid.h[a]);
    let (_, s, grad) = weights.storage_mut(n);
    for (p, xp) in x.iter().enumerate() {
        // Per axis and stencil node: (4/h²)(X_i − x_p) = (4/h)(first + k − x/h).
        let rel: [[f64; 3]; D] = std::array::from_fn(|a| {
            let q = (xp[a] - grid.origin[a]) * inv_h[a];
            let first = (q - 0.5).floor() - q;
            std::array::from_fn(|k| 4.0 * inv_h[a] * (first + k as f64))
        });
        let mut ks = [0usize; D];
        for m in 0..width {
            let k = p * width + m;
            grad[k] = Vector::<D>::from_fn(|a, _| rel[a][ks[a]] * s[k]);
            for kk in ks.iter_mut() {
                *kk += 1;
                if *kk < 3 {
                    break;
                }
                *kk = 0;
            }
        }
    }
}

impl<const D: usize> StateNd<D> {
    /// Overwrites this state with the dict's, at time `t` after `step` accepted steps, and
    /// computes its weights and nodal fields under body force `gravity` (module docs).
    pub fn read(
        &mut self,
        dict: &Bound<'_, PyDict>,
        gravity: &Vector<D>,
        t: f64,
        step: u64,
    ) -> Result<(), Fault> {
        self.read_particles(dict, t, step)?;
        self.form_nodal(gravity)?;
        self.summary = crate::summary::read_summary(dict)?;
        Ok(())
    }

    /// The particle half of [`Self::read`]: the arrays, moduli and densities (a view of
    /// them alone is [`mpm_dt::nd::ViewNd::without_nodal`]; its summary is not read).
    pub fn read_particles(
        &mut self,
        dict: &Bound<'_, PyDict>,
        t: f64,
        step: u64,
    ) -> Result<(), Fault> {
        let py = dict.py();
        self.t = t;
        self.step = step;
        let x_shape = shape_of(&item(dict, "x")?, "x")?;
        if x_shape.len() != 2 || x_shape[1] != D {
            let msg =
                format!("state[\"x\"] has shape {x_shape:?}: expected (n, {D}) for dimension {D}");
            return Err(state_error(py, msg).into());
        }
        self.grid = read_grid(dict)?;
        (self.shape, self.transfer, self.mls) = read_scheme(dict)?;
        let mass_shape = shape_of(&item(dict, "mass")?, "mass")?;
        let [n] = mass_shape[..] else {
            return Err(state_error(
                py,
                format!("state[\"mass\"] must have shape (n,), got {mass_shape:?}"),
            )
            .into());
        };
        positive(dict, "mass", n, &mut self.mass)?;
        positive(dict, "volume0", n, &mut self.volume0)?;
        vectors(dict, "x", n, &mut self.x)?;
        vectors(dict, "v", n, &mut self.v)?;
        tensors(dict, "F", n, &mut self.f)?;
        tensors(dict, "stress", n, &mut self.sigma)?;
        self.read_moduli(dict, n)?;
        self.summary = None;
        self.density.clear();
        for p in 0..n {
            let j = det(&self.f[p]);
            if j <= 0.0 {
                return Err(Fault::Inverted(p, j));
            }
            self.density.push(self.mass[p] / (j * self.volume0[p]));
        }
        self.apply_material(dict)?;
        if dict.contains("domain")? {
            vectors(dict, "domain", n, &mut self.domain)?;
        } else if self.shape == ShapeNd::Gimp {
            // The GIMP particle domain: a cube of the initial volume.
            self.domain.clear();
            let d = D as f64;
            self.domain.extend(
                self.volume0
                    .iter()
                    .map(|v| Vector::<D>::repeat(v.powf(1.0 / d))),
            );
        } else {
            // Read by GIMP only.
            self.domain.resize(n, Vector::<D>::zeros());
        }
        Ok(())
    }

    /// The rest of [`Self::read`]: the weights (a particle whose stencil leaves the grid
    /// is refused) and the nodal fields under body force `gravity`.
    pub fn form_nodal(&mut self, gravity: &Vector<D>) -> Result<(), Fault> {
        compute_weights(
            &self.grid,
            self.shape,
            &self.x,
            &self.domain,
            &mut self.weights,
        )
        .map_err(|p| {
            let axis = self.grid.axis_outside(&self.x[p]).unwrap_or(0);
            Fault::OutOfGrid(p, axis, self.x[p][axis])
        })?;
        if self.mls {
            mls_gradients(&self.grid, &self.x, &mut self.weights);
        }
        let min_mass = self.mass.iter().copied().fold(f64::INFINITY, f64::min);
        let particles = ParticleFieldsNd {
            mass: &self.mass,
            volume0: &self.volume0,
            v: &self.v,
            sigma: &self.sigma,
            f: &self.f,
        };
        self.nodal.compute(
            &self.grid,
            &self.weights,
            particles,
            gravity,
            INACTIVE_MASS_RATIO * min_mass,
        );
        Ok(())
    }

    /// The library's view of this state.
    pub fn view(&self) -> ViewNd<'_, D> {
        ViewNd {
            t: self.t,
            step: self.step,
            grid: &self.grid,
            x: &self.x,
            v: &self.v,
            sigma: &self.sigma,
            f: &self.f,
            volume0: &self.volume0,
            mass: &self.mass,
            lame_lambda: &self.lame_lambda,
            lame_mu: &self.lame_mu,
            density: &self.density,
            weights: (&self.weights).into(),
            node_mass: &self.nodal.mass,
            node_velocity: &self.nodal.velocity,
            node_acceleration: &self.nodal.acceleration,
            node_active: &self.nodal.active,
            summary: self.summary,
            split: None,
        }
    }
}

/// Lamé parameters `(λ, μ)` of Young's modulus `e` and Poisson's ratio `nu`.
pub fn lame(e: f64, nu: f64) -> (f64, f64) {
    (
        e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        e / (2.0 * (1.0 + nu)),
    )
}
