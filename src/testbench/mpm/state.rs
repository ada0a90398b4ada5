//! One state buffer of the reference solver (double buffering: committed and trial).
//!
//! A state at `tⁿ` holds the particle fields `xⁿ, vⁿ, σⁿ, Fⁿ` *and* the nodal sums that the
//! next step starts from, computed at `xⁿ`: `m_i` (eq 7), `v_i` (eq 17) and `a_i` (eq 18).
//! Quantities only observers need — the weight matrices `S`, `D`, per-particle tangent
//! modulus and density, and the node activity flags — are computed lazily on first use
//! through [`Recycled`] cells, cleared (their storage kept) whenever the buffer is
//! overwritten, so the hot step never builds them.

use super::material::Material;
use crate::grid::Grid;
use crate::nodal_stiffness::NodalStiffness;
use crate::pass_summary::PassSummary;
use crate::recycled::{refill, Recycled};
use crate::view_weights::WeightsCache;

/// Particle and nodal fields of one state, plus lazily computed observer data.
#[derive(Clone, Debug, Default)]
pub(crate) struct State {
    pub t: f64,
    pub step: u64,
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub sigma: Vec<f64>,
    pub f: Vec<f64>,
    pub node_mass: Vec<f64>,
    pub node_velocity: Vec<f64>,
    pub node_acceleration: Vec<f64>,
    /// `S`, `D` at `x`, computed when a view's weights are first read.
    pub weights: WeightsCache,
    /// The nodal stiffness `K_N` at `x`, valid when the pass that wrote this state
    /// accumulated it.
    pub stiffness: NodalStiffness,
    pub stiffness_valid: bool,
    /// The pass's [`PassSummary`] of this state, when the pass that wrote it took one.
    pub summary: Option<PassSummary>,
    tangent_modulus: Recycled<Vec<f64>>,
    density: Recycled<Vec<f64>>,
    node_active: Recycled<Vec<bool>>,
}

impl State {
    /// A state with the given particle fields and zeroed nodal arrays of `n_nodes`.
    pub fn new(x: Vec<f64>, v: Vec<f64>, sigma: Vec<f64>, f: Vec<f64>, n_nodes: usize) -> Self {
        Self {
            x,
            v,
            sigma,
            f,
            node_mass: vec![0.0; n_nodes],
            node_velocity: vec![0.0; n_nodes],
            node_acceleration: vec![0.0; n_nodes],
            ..Self::default()
        }
    }

    /// Drops the lazily computed data (call before overwriting the fields).
    pub fn invalidate(&mut self) {
        self.summary = None;
        self.weights.invalidate();
        self.tangent_modulus.invalidate();
        self.density.invalidate();
        self.node_active.invalidate();
    }

    /// Installs the per-particle tangent moduli, densities and node flags that the pass
    /// computed for this state (freshly invalidated), and returns the spare storage of each
    /// for the next pass, and whether all three were installed. A cell that is already
    /// computed (not reached: `try_step` invalidates the trial first) keeps its value, its
    /// buffer is handed back, and the caller must not vouch for the state.
    pub fn install_observed(&mut self, observed: Observed) -> (Observed, bool) {
        /// The spare storage, or the refused buffer (clearing `all`).
        fn back<T>(r: Result<Option<Vec<T>>, Vec<T>>, all: &mut bool) -> Vec<T> {
            r.unwrap_or_else(|unused| {
                *all = false;
                Some(unused)
            })
            .unwrap_or_default()
        }
        let mut all = true;
        let spare = Observed {
            tangent_modulus: back(
                self.tangent_modulus.install(observed.tangent_modulus),
                &mut all,
            ),
            density: back(self.density.install(observed.density), &mut all),
            node_active: back(self.node_active.install(observed.node_active), &mut all),
        };
        (spare, all)
    }

    /// `E_t(F_p)` per particle.
    pub fn tangent_modulus(&self, material: &Material) -> &[f64] {
        self.tangent_modulus.get_or_init_with(|spare| {
            refill(spare, self.f.iter().map(|&f| material.tangent_modulus(f)))
        })
    }

    /// `ρ_p = m_p / (F_p V_p⁰)` per particle.
    pub fn density(&self, mass: &[f64], volume0: &[f64]) -> &[f64] {
        self.density.get_or_init_with(|spare| {
            let rho = self
                .f
                .iter()
                .zip(mass.iter().zip(volume0))
                .map(|(&f, (&m, &v0))| m / (f * v0));
            refill(spare, rho)
        })
    }

    /// Node activity flags: not constrained and `m_i` above `threshold`.
    pub fn node_active(&self, grid: &Grid, threshold: f64) -> &[bool] {
        self.node_active.get_or_init_with(|spare| {
            let active = self
                .node_mass
                .iter()
                .enumerate()
                .map(|(i, &m)| is_active(grid, i, m, threshold));
            refill(spare, active)
        })
    }
}

/// Whether node `i` with mass `m` takes part in the solve (see the module docs of
/// [`crate::mpm`] for the threshold).
#[inline]
pub(crate) fn is_active(grid: &Grid, i: usize, m: f64, threshold: f64) -> bool {
    m > threshold && !grid.is_constrained(i)
}

/// Per-particle and per-node data that observers read and a pass with a summary fills
/// directly (the same values the lazy cells of [`State`] compute), or the buffers to fill.
#[derive(Clone, Debug, Default)]
pub(crate) struct Observed {
    /// `E_t(F_p)`, as [`State::tangent_modulus`].
    pub tangent_modulus: Vec<f64>,
    /// `m_p/(F_p V_p⁰)`, as [`State::density`].
    pub density: Vec<f64>,
    /// As [`State::node_active`].
    pub node_active: Vec<bool>,
}
