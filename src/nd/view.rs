//! A read-only view of one state of a d-dimensional MPM solver: what the limits, the
//! estimators and the controller read. The d-dimensional counterpart of [`crate::View`].

use super::{GridNd, Tensor, Vector, ViewWeightsNd};

/// A read-only view of one state of a `D`-dimensional solver. Particle slices all have the
/// number of particles as length, nodal slices `grid.n_nodes()`.
///
/// The material enters through each particle's *tangent* Lamé moduli: for a small
/// perturbation of the velocity gradient `δL` about the current state the stress changes
/// by `dt (λ_t tr(δε̇) I + 2 μ_t δε̇)`, `δε̇ = sym(δL)`. For hypoelastic linear elasticity
/// they are the material's `λ`, `μ`; a solver whose tangent is anisotropic reports an
/// isotropic pair that bounds its P-wave modulus `λ_t + 2μ_t` from above.
///
/// For hyperelastic models [`crate::tangent`] computes the pair from `F`: exact for
/// neo-Hookean, a guaranteed bound for fixed corotated (Stomakhin et al. 2012):
///
/// ```
/// use mpm_dt::nd::Tensor;
/// let (lambda, mu) = (10.0, 1.0); // the material's small-strain Lamé parameters
/// let f = [Tensor::<2>::identity(), Tensor::<2>::new(1.2, 0.1, 0.0, 0.9)];
/// let (lame_lambda, lame_mu): (Vec<f64>, Vec<f64>) = f
///     .iter()
///     .map(|f| mpm_dt::tangent::fixed_corotated(lambda, mu, f))
///     .unzip();
/// assert_eq!((lame_lambda[0], lame_mu[0]), (lambda, mu)); // at rest, the material's pair
/// assert!(lame_lambda[1] + 2.0 * lame_mu[1] > lambda + 2.0 * mu);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct ViewNd<'a, const D: usize> {
    /// Time `t` of this state.
    pub t: f64,
    /// Number of accepted steps that led to this state.
    pub step: u64,
    /// The background grid.
    pub grid: &'a GridNd<D>,
    /// Particle positions `x_p`.
    pub x: &'a [Vector<D>],
    /// Particle velocities `v_p`.
    pub v: &'a [Vector<D>],
    /// Particle Cauchy stresses `σ_p`.
    pub sigma: &'a [Tensor<D>],
    /// Deformation gradients `F_p`.
    pub f: &'a [Tensor<D>],
    /// Initial particle volumes `V⁰_p` (current volume `det(F_p) V⁰_p`).
    pub volume0: &'a [f64],
    /// Particle masses `m_p`.
    pub mass: &'a [f64],
    /// Tangent Lamé modulus `λ_t` per particle (for hyperelastic models see
    /// [`crate::tangent`]).
    pub lame_lambda: &'a [f64],
    /// Tangent shear modulus `μ_t` per particle.
    pub lame_mu: &'a [f64],
    /// Current density `ρ_p = m_p / (det(F_p) V⁰_p)`.
    pub density: &'a [f64],
    /// `S_ip` and `∇S_ip` at this state's particle positions: stored by the stepper
    /// (`(&weights).into()`), or formed when a pass reads a row ([`ViewWeightsNd`]).
    pub weights: ViewWeightsNd<'a, D>,
    /// Nodal masses `m_i = Σ_p S_ip m_p`.
    pub node_mass: &'a [f64],
    /// Nodal velocities `v_i` (zero at inactive and constrained nodes).
    pub node_velocity: &'a [Vector<D>],
    /// Nodal accelerations `a_i` (zero at inactive and constrained nodes).
    pub node_acceleration: &'a [Vector<D>],
    /// Whether a node is active: not constrained and with mass above the solver's threshold.
    pub node_active: &'a [bool],
    /// Totals the stepper computed in its own pass over the particles, if it offers them
    /// (optional: `None` makes the limits compute what they need from the slices).
    pub summary: Option<SummaryNd<D>>,
    /// For a stepper whose grid is decomposed over processes: how this process's nodes and
    /// particles relate to the whole run (`None` for an undivided grid).
    pub split: Option<SplitNd<'a, D>>,
}

/// Completes nodal sums across the processes of a grid-decomposed run ([`SplitNd`]).
pub trait NodalHalo: std::fmt::Debug {
    /// Adds the other processes' partial sums at the nodes this process shares with them
    /// into `values` (`width` numbers per local node, node-major), so that every copy of a
    /// node holds the same total, bit for bit. Collective: every process calls it together.
    fn complete(&self, values: &mut [f64], width: usize);
    /// The reductions over the processes of the run (sums over owned nodes, agreements):
    /// a limit reading a split view uses these, so that it cannot disagree with the
    /// stepper about who takes part.
    fn reduce(&self) -> &dyn crate::reduce::Reduce;
}

/// How the nodes and particles of a grid-decomposed view relate to the whole run
/// ([`crate::nd::SolverNd::new_slab`]).
///
/// The view's `grid` is this process's window of the whole grid: its own nodes plus
/// ghost copies of its neighbours' nodes that its particles' stencils reach. Its nodal
/// fields are complete at every copy (the stepper has added the other processes' sums);
/// its particles are the ones this process owns. A quantity summed over nodes is summed
/// over the *owned* nodes and then over the processes; a product with the stiffness is
/// this process's particles' part, completed with [`NodalHalo::complete`].
#[derive(Clone, Copy, Debug)]
pub struct SplitNd<'a, const D: usize> {
    /// The whole grid (boundaries, periodicity, lattice numbering).
    pub whole: &'a GridNd<D>,
    /// Index in the whole grid of each local node.
    pub global_node: &'a [u32],
    /// Whether this process owns a local node (every node has exactly one owner).
    pub owned: &'a [bool],
    /// A run-wide identity of each local particle, in `0..n_particles_total`; particles
    /// keep it when they move between processes.
    pub particle_id: &'a [u64],
    /// Number of particles over all processes.
    pub n_particles_total: usize,
    /// The exchange that completes nodal sums.
    pub halo: &'a dyn NodalHalo,
}

/// Totals over a state's particles that a stepper can compute while it writes them, so
/// that the controller and the limits need no pass of their own ([`ViewNd::summary`]).
/// In a run split over processes by particle ([`crate::reduce`]) they are this process's;
/// in a grid-decomposed run ([`ViewNd::split`]), where particles move between processes,
/// they are the whole run's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SummaryNd<const D: usize> {
    /// Every `x`, `v`, `σ`, `F` value of the state is finite (checked by the stepper).
    pub finite: bool,
    /// `Σ_p ½ m_p |v_p|²`.
    pub kinetic: f64,
    /// The stored elastic energy `Σ_p` of the material's energy density times volume.
    pub strain: f64,
    /// `Σ_p m_p x_p` (the gravitational potential is `−g · Σ m x`).
    pub first_moment: Vector<D>,
    /// `max_p λ_p`, the element bound on `λmax(M⁻¹K)`
    /// ([`crate::limits_nd::element_bound`]), if the stepper computed it in its pass:
    /// each particle's `λ_p = (V_p/m_p) min(λ̄(H_p) max(Dλ_t + 2μ_t, 2μ_t),
    /// tr(H_p) max(λ_t + 2μ_t, 2μ_t))` with `H_p = Σ_i ∇S_ip ∇S_ipᵀ/S_ip`, `λ̄` its largest
    /// Gershgorin row sum (for MLS-MPM's gradients `H_p = (4/h²) I`, so
    /// `λ_p = (4/h²)(V_p/m_p) min(max(Dλ_t + 2μ_t, 2μ_t), D max(λ_t + 2μ_t, 2μ_t))`, which is
    /// `(4/h²)(V_p/m_p)(Dλ_t + 2μ_t)` when `λ_t ≥ 0`; O(1) per particle). It must be an upper
    /// bound of what the library would compute; `None` makes the stability limit compute
    /// it with a pass over the weights when it needs it.
    pub element_bound: Option<f64>,
    /// `min_p min_a h_a/(c_p + |v_{p,a}|)`, the speed-of-sound step at α = 1
    /// ([`crate::limits_nd::sound_speed::pass_unit_step`]), if the stepper computed it in its
    /// pass; `None` makes the sound-speed limit make a pass of its own.
    pub sound_unit_step: Option<f64>,
}

impl<const D: usize> SummaryNd<D> {
    /// Zero totals, no bounds, with the given finiteness: where a pass starts summing
    /// (`true`), or what a failed pass hands over (`false`).
    pub fn zero(finite: bool) -> Self {
        Self {
            finite,
            kinetic: 0.0,
            strain: 0.0,
            first_moment: Vector::<D>::zeros(),
            element_bound: None,
            sound_unit_step: None,
        }
    }
}

impl<'a, const D: usize> ViewNd<'a, D> {
    /// A view that holds the state's [`SummaryNd`] and no particle or nodal arrays (all
    /// empty): what a stepper handing over its arrays on demand
    /// ([`crate::Stepper::provide_arrays_on_demand`]) shows until the controller asks for
    /// them ([`crate::Stepper::load_arrays`]). The controller passes such a view only to
    /// limits that declare they read none of its arrays ([`crate::StepLimit::reads_arrays`]).
    pub fn summary_only(t: f64, step: u64, grid: &'a GridNd<D>, summary: SummaryNd<D>) -> Self {
        Self {
            t,
            step,
            grid,
            x: &[],
            v: &[],
            sigma: &[],
            f: &[],
            volume0: &[],
            mass: &[],
            lame_lambda: &[],
            lame_mu: &[],
            density: &[],
            weights: ViewWeightsNd::formed(grid, super::ShapeNd::Linear, &[], &[]),
            node_mass: &[],
            node_velocity: &[],
            node_acceleration: &[],
            node_active: &[],
            summary: Some(summary),
            split: None,
        }
    }

    /// This view without its weights and nodal fields (all empty), its particle arrays and
    /// summary kept: what a stepper handing over on demand shows after
    /// [`crate::Stepper::load_particles`]. It needs a summary ([`Self::summary`]) and a
    /// grid with nodes: then, for the library, it is summary-only ([`Self::holds_arrays`]
    /// is `false`) except to a limit that declares that its call reads the particle arrays
    /// alone ([`crate::StepLimit::reads_nodal`]); without a summary it is a view with empty
    /// nodal arrays, which the door check refuses.
    pub fn without_nodal(self) -> Self {
        Self {
            weights: ViewWeightsNd::formed(self.grid, super::ShapeNd::Linear, &[], &[]),
            node_mass: &[],
            node_velocity: &[],
            node_acceleration: &[],
            node_active: &[],
            ..self
        }
    }

    /// Whether the view holds its arrays: `false` for a [`Self::summary_only`] view (a
    /// summary, no particle and no nodal arrays, on a grid with nodes) and for one
    /// [`Self::without_nodal`] (a summary and the particle arrays only).
    pub fn holds_arrays(&self) -> bool {
        !(self.summary.is_some() && self.node_mass.is_empty() && self.grid.n_nodes() > 0)
    }

    /// Whether the view holds its particle arrays: [`Self::holds_arrays`], or a view
    /// [`Self::without_nodal`] of at least one particle.
    pub fn holds_particles(&self) -> bool {
        self.holds_arrays() || !self.x.is_empty()
    }
}

impl<const D: usize> ViewNd<'_, D> {
    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.x.len()
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.node_mass.len()
    }

    /// Current volume of particle `p`, `V_p = det(F_p) V⁰_p`.
    #[inline]
    pub fn volume(&self, p: usize) -> f64 {
        super::det(&self.f[p]) * self.volume0[p]
    }

    /// P-wave speed of particle `p`, `c_p = √((λ_t + 2μ_t)/ρ)`.
    pub fn p_wave_speed(&self, p: usize) -> f64 {
        ((self.lame_lambda[p] + 2.0 * self.lame_mu[p]) / self.density[p]).sqrt()
    }

    /// S-wave speed of particle `p`, `c_s = √(μ_t/ρ)`.
    pub fn s_wave_speed(&self, p: usize) -> f64 {
        (self.lame_mu[p] / self.density[p]).sqrt()
    }
}
