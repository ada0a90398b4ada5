//! [`ReferenceStepper`]: the reference 1D USL solver behind the [`Stepper`] trait.

use super::material::Material;
use super::setup::{ParticleInit, SetupError};
use super::state::State;
use super::step::{advance, deposit_state, Ctx, Failure, Workspace};
use crate::grid::Grid;
use crate::shape::Shape;
use crate::stepper::{StepError, Stepper, View};
use crate::view_weights::ViewWeights;
use serde::{Deserialize, Serialize};

/// Nodes whose mass is at most this fraction of the mean nodal mass `M/N` (total particle
/// mass over number of cells) are *inactive*: their velocity and acceleration are set to
/// zero instead of dividing by a vanishing mass (eqs 17, 18). The fraction is tiny on
/// purpose: only nodes that particles barely touch are dropped, so the collapse of the
/// critical step with linear-hat weights and small nodal masses (docs/design.md) stays visible.
pub const INACTIVE_MASS_FRACTION: f64 = 1e-12;

/// Everything needed to continue a run of the [`ReferenceStepper`] bit for bit: the
/// committed state's time, step count and particle fields, and the run's constants (serde;
/// serialize it with `serde_json`, whose `float_roundtrip` feature keeps every `f64` exact).
/// The nodal arrays are not stored: [`ReferenceStepper::from_checkpoint`] recomputes them
/// from the particles with the same arithmetic, in the same order, as the step does.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SolverCheckpoint {
    /// Time of the committed state.
    pub t: f64,
    /// Accepted steps so far.
    pub step: u64,
    /// The grid.
    pub grid: Grid,
    /// The weights.
    pub shape: Shape,
    /// The material.
    pub material: Material,
    /// Particle fields of the committed state (`x, v, σ, F`) and constants (`V⁰, m, l`).
    pub particles: ParticleInit,
    /// Whether the run kicks staggered ([`ReferenceStepper::set_staggered_kick`]; absent in
    /// older checkpoints: off).
    #[serde(default)]
    pub staggered_kick: bool,
    /// The last accepted step, which the next staggered kick spans with its own.
    #[serde(default)]
    pub last_dt: Option<f64>,
}

/// The reference 1D update-stress-last MPM solver (eqs 17–29; see [`crate::mpm`]).
///
/// Holds a committed and a trial state (double buffering): [`Stepper::try_step`] writes only
/// the trial, [`Stepper::accept`] swaps the two, [`Stepper::reject`] drops the trial flag, so
/// rollback is exact bit for bit and costs nothing.
#[derive(Clone, Debug)]
pub struct ReferenceStepper {
    grid: Grid,
    shape: Shape,
    material: Material,
    mass: Vec<f64>,
    volume0: Vec<f64>,
    width: Vec<f64>,
    threshold: f64,
    committed: State,
    trial: State,
    trial_pending: bool,
    workspace: Workspace,
    /// Whether the particle pass accumulates the nodal stiffness
    /// ([`Stepper::provide_nodal_stiffness`]).
    stiffness: bool,
    /// Whether the particle pass takes the states' summaries ([`Stepper::provide_summary`]).
    summary: bool,
    /// Whether the summaries carry the element bound ([`Stepper::provide_element_bound`]).
    bound: bool,
    /// Whether a step after a change of step kicks over `(dt₋ + dt)/2`
    /// ([`ReferenceStepper::set_staggered_kick`]).
    staggered_kick: bool,
    /// The last accepted step (`None` before the first; a checkpoint carries it).
    last_dt: Option<f64>,
    /// The step of the pending trial.
    trial_dt: f64,
}

impl ReferenceStepper {
    /// Builds the solver at `t = 0` from validated particle data (see
    /// [`ParticleInit::validate`]) and computes the nodal mass, velocity (eq 17) and
    /// acceleration (eq 18) of the initial state.
    pub fn new(
        grid: Grid,
        shape: Shape,
        material: Material,
        particles: ParticleInit,
    ) -> Result<Self, SetupError> {
        let e = material.youngs_modulus();
        if !(e.is_finite() && e > 0.0) {
            return Err(SetupError::Material { value: e });
        }
        particles.validate(&grid)?;
        let ParticleInit {
            x,
            v,
            sigma,
            f,
            volume0,
            mass,
            width,
        } = particles;
        let total_mass: f64 = mass.iter().sum();
        let threshold = INACTIVE_MASS_FRACTION * total_mass / grid.cells as f64;
        let n_nodes = grid.n_nodes();
        let mut committed = State::new(x, v, sigma, f, n_nodes);
        let mut workspace = Workspace::new(&grid);
        {
            let ctx = Ctx {
                grid: &grid,
                shape,
                material,
                mass: &mass,
                volume0: &volume0,
                width: &width,
                threshold,
                stiffness: false,
                summary: false,
                bound: false,
                kick: None,
            };
            deposit_state(&ctx, &mut workspace, &mut committed);
        }
        let trial = committed.clone();
        tracing::debug!(
            particles = committed.x.len(),
            cells = grid.cells,
            ?shape,
            ?material,
            "reference MPM solver built"
        );
        Ok(Self {
            grid,
            shape,
            material,
            mass,
            volume0,
            width,
            threshold,
            committed,
            trial,
            trial_pending: false,
            workspace,
            stiffness: false,
            summary: false,
            bound: false,
            staggered_kick: false,
            last_dt: None,
            trial_dt: 0.0,
        })
    }

    /// The committed state and the run's constants, to restart later
    /// ([`ReferenceStepper::from_checkpoint`]). A pending trial is not saved.
    pub fn checkpoint(&self) -> SolverCheckpoint {
        let c = &self.committed;
        SolverCheckpoint {
            t: c.t,
            step: c.step,
            grid: self.grid.clone(),
            shape: self.shape,
            material: self.material,
            particles: ParticleInit {
                x: c.x.clone(),
                v: c.v.clone(),
                sigma: c.sigma.clone(),
                f: c.f.clone(),
                volume0: self.volume0.clone(),
                mass: self.mass.clone(),
                width: self.width.clone(),
            },
            staggered_kick: self.staggered_kick,
            last_dt: self.last_dt,
        }
    }

    /// A solver continuing from `checkpoint`: the same states, bit for bit, as the run that
    /// wrote it. Validates like [`ReferenceStepper::new`]; a non-finite or negative time is
    /// an error too.
    pub fn from_checkpoint(checkpoint: SolverCheckpoint) -> Result<Self, SetupError> {
        let SolverCheckpoint {
            t,
            step,
            grid,
            shape,
            material,
            particles,
            staggered_kick,
            last_dt,
        } = checkpoint;
        if !(t.is_finite() && t >= 0.0) {
            return Err(SetupError::Time { value: t });
        }
        if let Some(dt) = last_dt.filter(|dt| !(dt.is_finite() && *dt > 0.0)) {
            return Err(SetupError::LastStep { value: dt });
        }
        let mut s = Self::new(grid, shape, material, particles)?;
        (s.staggered_kick, s.last_dt) = (staggered_kick, last_dt);
        for state in [&mut s.committed, &mut s.trial] {
            state.t = t;
            state.step = step;
        }
        Ok(s)
    }

    /// The background grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The particle–node weights in use.
    pub fn shape(&self) -> Shape {
        self.shape
    }

    /// The material.
    pub fn material(&self) -> &Material {
        &self.material
    }

    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.mass.len()
    }

    /// GIMP particle widths `l_p`.
    pub fn widths(&self) -> &[f64] {
        &self.width
    }

    /// Nodal mass at or below which a node is inactive
    /// ([`INACTIVE_MASS_FRACTION`] × total mass / cells).
    pub fn inactive_mass_threshold(&self) -> f64 {
        self.threshold
    }

    /// Total mass `Σ_p m_p`.
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// Kinetic energy of the committed state, `Σ_p ½ m_p v_p²` (particle velocities).
    pub fn kinetic_energy(&self) -> f64 {
        self.mass
            .iter()
            .zip(&self.committed.v)
            .map(|(&m, &v)| 0.5 * m * v * v)
            .sum()
    }

    /// Strain energy of the committed state, `Σ_p V_p⁰ W_p` with the stored energy per
    /// reference volume of [`Material::energy_density`].
    pub fn strain_energy(&self) -> f64 {
        self.volume0
            .iter()
            .zip(self.committed.sigma.iter().zip(&self.committed.f))
            .map(|(&v0, (&s, &f))| v0 * self.material.energy_density(s, f))
            .sum()
    }

    /// Kinetic plus strain energy of the committed state.
    pub fn total_energy(&self) -> f64 {
        self.kinetic_energy() + self.strain_energy()
    }

    /// Total momentum of the committed state, `Σ_p m_p v_p`.
    pub fn total_momentum(&self) -> f64 {
        self.mass
            .iter()
            .zip(&self.committed.v)
            .map(|(&m, &v)| m * v)
            .sum()
    }

    /// The kernel's view of the run's constants and of what the pass is asked to provide.
    fn ctx(&self) -> Ctx<'_> {
        Ctx {
            grid: &self.grid,
            shape: self.shape,
            material: self.material,
            mass: &self.mass,
            volume0: &self.volume0,
            width: &self.width,
            threshold: self.threshold,
            stiffness: self.stiffness,
            summary: self.summary,
            bound: self.bound,
            kick: None,
        }
    }

    /// Opt-in: the **staggered kick** (default off). The USL step (eqs 19, 22 then 24–29)
    /// is symplectic Euler: it kicks `vₚ` with `dt a_p`, then drifts `x` with the new
    /// velocity, so `vₚ` is the velocity half a step behind the state, at `tⁿ − dt₋/2`
    /// (leapfrog; [`crate::synchronized_velocity`]). After a change of step the kick that
    /// carries it from `tⁿ − dt₋/2` to `tⁿ + dt/2` spans `(dt₋ + dt)/2`, not `dt`: with
    /// `dt`, each change `dt − dt₋` leaves a velocity error `(dt − dt₋)/2·a_p` that the
    /// positions then integrate — the position drift of a controlled run on a smooth wave
    /// (docs/accuracy.md, "The velocity lag and the staggered kick"). On, the kicks of eqs 19 and 22 use
    /// `(dt₋ + dt)/2` (`dt₋` the last accepted step, which a [`SolverCheckpoint`] carries;
    /// the first step after construction kicks with `dt`); `F`, `σ` and `x` (eqs 25–29)
    /// still advance by `dt`. At a fixed step `(dt + dt)/2 == dt` in floating point: the
    /// run is the same bit for bit as with it off.
    ///
    /// Use it with the temporal error's velocity lag (`"temporal": {"lag": 1.0}`): the
    /// temporal error's rates `(vⁿ⁺¹ − vⁿ)/dt` (eqs 20, 23) and eq 44's `vᵢ + dt·aᵢ` still
    /// model a kick of `dt`, so after each change of step they carry the factor
    /// `(dt₋ + dt)/(2dt)`, which the second-order estimate alone reads as a second
    /// derivative (many rejections below tolerance 10⁻⁵ on the 1D wave); the lag part reads
    /// the nodal acceleration and does not depend on the kick.
    pub fn set_staggered_kick(&mut self, on: bool) {
        self.staggered_kick = on;
    }

    fn state_view<'a>(&'a self, s: &'a State) -> View<'a> {
        let view = View {
            t: s.t,
            step: s.step,
            grid: &self.grid,
            x: &s.x,
            v: &s.v,
            sigma: &s.sigma,
            f: &s.f,
            volume0: &self.volume0,
            mass: &self.mass,
            tangent_modulus: s.tangent_modulus(&self.material),
            density: s.density(&self.mass, &self.volume0),
            weights: ViewWeights::deferred(&s.weights, &self.grid, self.shape, &s.x, &self.width),
            node_mass: &s.node_mass,
            node_velocity: &s.node_velocity,
            node_acceleration: &s.node_acceleration,
            node_active: s.node_active(&self.grid, self.threshold),
            nodal_stiffness: s.stiffness_valid.then_some(&s.stiffness),
            summary: None,
        };
        // The pass's summary, stamped for this view's arrays (`crate::pass_summary`).
        View {
            summary: s.summary.map(|p| p.stamp(&view)),
            ..view
        }
    }
}

impl Stepper for ReferenceStepper {
    fn time(&self) -> f64 {
        self.committed.t
    }

    fn step_count(&self) -> u64 {
        self.committed.step
    }

    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.trial_pending = false;
        let (t, step) = (self.committed.t, self.committed.step);
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidDt { dt, t });
        }
        self.trial.invalidate();
        // The scratch and the trial are moved out so that the context can borrow `self`.
        let (mut workspace, mut trial) = (
            std::mem::take(&mut self.workspace),
            std::mem::take(&mut self.trial),
        );
        self.trial_dt = dt;
        let mut ctx = self.ctx();
        if self.staggered_kick {
            ctx.kick = self.last_dt.map(|prev| 0.5 * (prev + dt));
        }
        let result = advance(&ctx, &mut workspace, &self.committed, &mut trial, dt);
        (self.workspace, self.trial) = (workspace, trial);
        match result {
            Ok(()) => {
                self.trial.t = t + dt;
                self.trial.step = step + 1;
                self.trial_pending = true;
                tracing::trace!(t, step, dt, "trial step computed");
                Ok(())
            }
            Err(failure) => {
                let err = match failure {
                    Failure::NonFinite { field, index } => StepError::NonFinite {
                        field,
                        index,
                        t,
                        step,
                        dt,
                    },
                    Failure::Inverted { index, f } => StepError::Inverted {
                        index,
                        det_f: f,
                        t,
                        step,
                        dt,
                    },
                    Failure::OutOfDomain { index, x } => StepError::OutOfDomain {
                        index,
                        axis: 0,
                        x,
                        t,
                        step,
                        dt,
                    },
                };
                tracing::debug!(error = %err, "trial step failed");
                Err(err)
            }
        }
    }

    fn accept(&mut self) -> Result<(), StepError> {
        if !self.trial_pending {
            return Err(StepError::NoTrial);
        }
        std::mem::swap(&mut self.committed, &mut self.trial);
        self.trial_pending = false;
        self.last_dt = Some(self.trial_dt);
        Ok(())
    }

    fn reject(&mut self) {
        self.trial_pending = false;
    }

    fn view(&self) -> View<'_> {
        self.state_view(&self.committed)
    }

    fn trial_view(&self) -> Option<View<'_>> {
        self.trial_pending.then(|| self.state_view(&self.trial))
    }

    /// Takes the summary's reductions in the particle pass (a few vectorised operations per
    /// particle) and writes the trial's tangent moduli, densities and node flags there
    /// instead of in the lazy passes of its view. The reference pass refuses non-finite
    /// `x`, `v`, `σ`, `F` and `F ≤ 0`, and the set-up checked `V⁰` and `m_p`; the summary is
    /// attached only if every `E_t`, `ρ` is positive and finite and the nodes pass too.
    fn provide_summary(&mut self, on: bool) -> bool {
        self.summary = on;
        true
    }

    /// Takes the element bound ([`crate::PassSummary::element_bound`]) in the particle pass of
    /// GIMP runs, from the stencils the deposit evaluates anyway (one division per
    /// particle; `mpm/element_bound.rs`). Linear hats take none: their bound is infinite
    /// wherever a particle sits on a node.
    fn provide_element_bound(&mut self, on: bool) -> bool {
        self.bound = on;
        matches!(self.shape, Shape::Gimp)
    }

    /// The flag of [`Self::provide_nodal_stiffness`] without computing `K_N` for the
    /// committed state.
    fn provide_nodal_stiffness_on_trials(&mut self, on: bool) -> bool {
        self.stiffness = on;
        true
    }

    /// Accumulates `K_N` in the deposit of every step (six products per particle, from the
    /// stencils the deposit evaluates anyway). Switching it on also computes it for the
    /// committed state, by the set-up deposit, whose nodal sums are bit-identical to the
    /// step's (the checkpoint restart relies on the same fact).
    fn provide_nodal_stiffness(&mut self, on: bool) -> bool {
        self.stiffness = on;
        if on && !self.committed.stiffness_valid {
            let (mut workspace, mut committed) = (
                std::mem::take(&mut self.workspace),
                std::mem::take(&mut self.committed),
            );
            deposit_state(&self.ctx(), &mut workspace, &mut committed);
            (self.workspace, self.committed) = (workspace, committed);
        }
        true
    }
}
