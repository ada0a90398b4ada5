//! The 1D state view, [`View`]: what a 1D solver hands the library of one state
//! (the [`crate::Stepper`] contract's read-only side; [`crate::ViewNd`] is its 2D/3D
//! counterpart).
//!
//! A view describes one state: particle fields at the particle positions, the weights `S`,
//! `D` evaluated *at those positions* ([`ViewWeights`]: ready or computed on first use), and
//! the nodal fields obtained from them by eq 7 (mass), eq 17 (velocity) and eq 18
//! (acceleration); optionally the nodal stiffness `K_N` of eq 56 from the solver's own pass
//! ([`NodalStiffness`]) and the pass's totals ([`PassSummary`]).

pub mod pass_summary;

use crate::grid::Grid;
use crate::nodal_stiffness::NodalStiffness;
use crate::view_weights::ViewWeights;
use pass_summary::PassSummary;

/// A read-only view of one state of a 1D MPM solver. All slices of particle fields have
/// the same length (number of particles), all nodal slices `grid.n_nodes()`.
#[derive(Clone, Copy, Debug)]
pub struct View<'a> {
    /// Time `t` of this state.
    pub t: f64,
    /// Number of accepted steps that led to this state (`n` in `tⁿ`).
    pub step: u64,
    /// The background grid (spacing `h`, boundary, node positions).
    pub grid: &'a Grid,
    /// Particle positions `x_p`.
    pub x: &'a [f64],
    /// Particle velocities `v_p`.
    pub v: &'a [f64],
    /// Particle (Cauchy) stresses `σ_p`.
    pub sigma: &'a [f64],
    /// Deformation gradients `F_p` (eq 8).
    pub f: &'a [f64],
    /// Initial particle volumes `V_p⁰` (eq 8; current volume is `F_p V_p⁰`).
    pub volume0: &'a [f64],
    /// Particle masses `m_p`.
    pub mass: &'a [f64],
    /// Material tangent modulus `E_t = ∂σ/∂(ln F)` per particle: the `E` of eqs 16, 27 and
    /// 56 for this particle (equal to `E` for linear elasticity).
    pub tangent_modulus: &'a [f64],
    /// Current density `ρ_p = m_p/(F_p V_p⁰)`.
    pub density: &'a [f64],
    /// `S_ip` and `D_ip` at the particle positions of this state, ready or computed on first
    /// use ([`ViewWeights`]; dereferences to [`crate::Weights`]).
    pub weights: ViewWeights<'a>,
    /// Nodal masses `m_i` (eq 7).
    pub node_mass: &'a [f64],
    /// Nodal velocities `v_i` (eq 17); zero at inactive and constrained nodes.
    pub node_velocity: &'a [f64],
    /// Nodal accelerations `a_i` (eq 18); zero at inactive and constrained nodes.
    pub node_acceleration: &'a [f64],
    /// Whether a node is active: not constrained, and mass above the solver's threshold.
    pub node_active: &'a [bool],
    /// The nodal stiffness `K_N = Σ_p E_p V_p d_p d_pᵀ` of this state, if the stepper
    /// accumulated it in its particle pass ([`NodalStiffness`]; see
    /// [`crate::Stepper::provide_nodal_stiffness`]); `None` makes the stability limit assemble it
    /// from [`View::weights`].
    pub nodal_stiffness: Option<&'a NodalStiffness>,
    /// Reductions the stepper took in the pass that wrote this state, and its guarantee
    /// that the state passes the library's checks ([`PassSummary`], asked for through
    /// [`crate::Stepper::provide_summary`]); `None` makes the limits scan the fields themselves.
    /// The library reads it through [`View::trusted_summary`], which ignores it on a view
    /// whose arrays are not the ones it was stamped for (a view rebuilt with a field
    /// replaced, `View { sigma, ..*view }`).
    pub summary: Option<PassSummary>,
}

impl View<'_> {
    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.x.len()
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.node_mass.len()
    }

    /// [`View::summary`] if it was stamped for this view's arrays
    /// ([`PassSummary::describes`]): what the library trusts.
    pub fn trusted_summary(&self) -> Option<PassSummary> {
        self.summary.filter(|s| s.describes(self))
    }

    /// Longitudinal wave speed of particle `p`, `c_p = √(E_t/ρ)`.
    pub fn wave_speed(&self, p: usize) -> f64 {
        (self.tangent_modulus[p] / self.density[p]).sqrt()
    }
}
