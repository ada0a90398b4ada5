//! [`SolverNd`]: the reference d-dimensional update-stress-last solver (D = 2, 3).
//!
//! One step from a committed state whose weights and nodal fields are known (docs/design.md, "The
//! USL step in d dimensions"): `v_iⁿ⁺¹ = v_i + dt a_i`; grid → particle
//! ([`super::kernels`]); then, at the new positions, the weights and the particle → grid
//! pass that the *next* step starts from. A step therefore costs one particle → grid and
//! one grid → particle pass, and every state — committed or trial — carries the weights
//! and nodal fields of its own particle positions, as the [`ViewNd`] promises.
//!
//! The trial is written into a second buffer; [`Stepper::accept`] swaps the buffers and
//! [`Stepper::reject`] drops the trial, so the committed state is never written by a trial
//! and a rejection restores it bit for bit.

use super::kernels::{self, Committed, ParticleFault, Written};
use super::particles::{ParticlesNd, SetupNdError};
use super::{GridNd, MaterialNd, ShapeNd, SummaryNd, Tensor, Vector, ViewNd, WeightsNd};
use crate::dimension::{Dim, Dimension, StateView};
use crate::reduce::Reduce;
use crate::stepper::{StepError, Stepper};
use std::rc::Rc;

/// Relative nodal-mass threshold: nodes with `m_i ≤ 1e-14 · min_p m_p` are inactive.
pub const INACTIVE_MASS_RATIO: f64 = 1e-14;

/// One state of the solver.
#[derive(Clone, Debug, Default)]
struct StateNd<const D: usize> {
    t: f64,
    step: u64,
    x: Vec<Vector<D>>,
    v: Vec<Vector<D>>,
    sigma: Vec<Tensor<D>>,
    f: Vec<Tensor<D>>,
    density: Vec<f64>,
    lame_lambda: Vec<f64>,
    lame_mu: Vec<f64>,
    weights: WeightsNd<D>,
    node_mass: Vec<f64>,
    node_v: Vec<Vector<D>>,
    node_a: Vec<Vector<D>>,
    active: Vec<bool>,
    /// Totals over the particles ([`SummaryNd`]), written with them.
    summary: Option<SummaryNd<D>>,
}

/// The reference d-dimensional MPM solver.
#[derive(Clone, Debug)]
pub struct SolverNd<const D: usize> {
    grid: GridNd<D>,
    shape: ShapeNd,
    gravity: Vector<D>,
    mass: Vec<f64>,
    volume0: Vec<f64>,
    domain: Vec<Vector<D>>,
    material: Vec<MaterialNd>,
    constrained: Vec<bool>,
    threshold: f64,
    committed: StateNd<D>,
    trial: StateNd<D>,
    has_trial: bool,
    node_v1: Vec<Vector<D>>,
    /// The run's reductions when it is split over processes by particle
    /// ([`SolverNd::new_distributed`]).
    reduce: Option<Rc<dyn Reduce>>,
    /// Whether the trials carry their [`SummaryNd`] ([`Stepper::provide_summary`]).
    summarize: bool,
}

impl<const D: usize> SolverNd<D> {
    /// A solver on `grid` with `shape` weights, starting at `t = 0` from `particles` with
    /// zero stress and `F = I`, under the body force `gravity` (an acceleration).
    pub fn new(
        grid: GridNd<D>,
        shape: ShapeNd,
        particles: ParticlesNd<D>,
        gravity: Vector<D>,
    ) -> Result<Self, SetupNdError> {
        particles.validate(&grid, shape)?;
        let min_mass = particles.mass.iter().copied().fold(f64::INFINITY, f64::min);
        Self::build(grid, shape, particles, gravity, min_mass, None)
    }

    /// This process's part of a run split over the processes of `reduce` by particle
    /// ([`crate::reduce`]): every process passes the *whole* set of particles and keeps the
    /// block `[r·n/size, (r+1)·n/size)` ([`ParticlesNd::block`]). Every process holds the
    /// whole grid; after each particle → grid pass the nodal sums are completed with one
    /// reduction, so the nodal fields — and the grid → particle update of every particle —
    /// are those of the undivided run up to the order of the floating-point sums. The
    /// view holds this process's particles and the global nodal fields. Every process must
    /// make the same calls (steps, [`Self::set_velocity_and_stress`]) together.
    ///
    /// This is a particle decomposition with a replicated grid: memory for the grid and
    /// the reduction grow with the grid, not with the share of it a process works on (a
    /// decomposition of the grid itself is not implemented).
    pub fn new_distributed(
        grid: GridNd<D>,
        shape: ShapeNd,
        particles: ParticlesNd<D>,
        gravity: Vector<D>,
        reduce: Rc<dyn Reduce>,
    ) -> Result<Self, SetupNdError> {
        particles.validate(&grid, shape)?;
        let min_mass = particles.mass.iter().copied().fold(f64::INFINITY, f64::min);
        let block = particles.block(reduce.rank(), reduce.size());
        Self::build(grid, shape, block, gravity, min_mass, Some(reduce))
    }

    fn build(
        grid: GridNd<D>,
        shape: ShapeNd,
        particles: ParticlesNd<D>,
        gravity: Vector<D>,
        min_mass: f64,
        reduce: Option<Rc<dyn Reduce>>,
    ) -> Result<Self, SetupNdError> {
        if gravity.iter().any(|g| !g.is_finite()) {
            return Err(SetupNdError::Gravity);
        }
        let n = particles.len();
        let constrained = (0..grid.n_nodes())
            .map(|i| grid.is_constrained(i))
            .collect();
        let (lame_lambda, lame_mu): (Vec<f64>, Vec<f64>) =
            particles.material.iter().map(|m| m.tangent(1.0)).unzip();
        let committed = StateNd {
            t: 0.0,
            step: 0,
            density: (0..n)
                .map(|p| particles.mass[p] / particles.volume[p])
                .collect(),
            x: particles.x,
            v: particles.v,
            sigma: vec![Tensor::<D>::zeros(); n],
            f: vec![Tensor::<D>::identity(); n],
            lame_lambda,
            lame_mu,
            weights: WeightsNd::new(grid.n_nodes(), shape.width(D)),
            ..StateNd::default()
        };
        let mut solver = Self {
            grid,
            shape,
            gravity,
            mass: particles.mass,
            volume0: particles.volume,
            domain: particles.domain,
            material: particles.material,
            constrained,
            threshold: INACTIVE_MASS_RATIO * min_mass,
            committed,
            trial: StateNd::default(),
            has_trial: false,
            node_v1: Vec::new(),
            reduce,
            summarize: false,
        };
        let mut c = std::mem::take(&mut solver.committed);
        solver
            .derive_state(&mut c)
            .map_err(|index| SetupNdError::OutsideBox {
                index,
                axis: 0,
                x: c.x[index][0],
            })?;
        solver.committed = c;
        Ok(solver)
    }

    /// Weights and nodal fields of a state from its particle fields.
    fn derive_state(&self, s: &mut StateNd<D>) -> Result<(), usize> {
        if let Err(index) =
            kernels::compute_weights(&self.grid, self.shape, &s.x, &self.domain, &mut s.weights)
        {
            self.take_part_after_failure();
            return Err(index);
        }
        kernels::particle_to_grid(
            &s.weights,
            &self.mass,
            &self.volume0,
            &s.v,
            &s.sigma,
            &s.f,
            &self.gravity,
            &self.constrained,
            self.threshold,
            &mut s.node_mass,
            &mut s.node_v,
            &mut s.node_a,
            &mut s.active,
            self.reduce.as_deref(),
        );
        Ok(())
    }

    /// The totals of a state's particles ([`SummaryNd`]), by a pass of their own (for the
    /// states the step did not write: the initial one, one set by the user).
    fn summary_of(&self, s: &StateNd<D>) -> SummaryNd<D> {
        // The view's own scan, not a summary the state may still carry.
        let view = ViewNd {
            summary: None,
            ..self.view_of(s)
        };
        SummaryNd {
            finite: view.first_nonfinite().is_none(),
            kinetic: self.kinetic_of(s),
            strain: self.strain_of(s),
            first_moment: s
                .x
                .iter()
                .zip(&self.mass)
                .fold(Vector::<D>::zeros(), |acc, (x, &m)| acc + x * m),
        }
    }

    /// In a split run, the nodal reduction of a pass this process could not make: zeros,
    /// so that the other processes are not left waiting (the step fails everywhere
    /// through the controller's agreement on the verdict).
    fn take_part_after_failure(&self) {
        if let Some(r) = &self.reduce {
            let nn = self.grid.n_nodes();
            kernels::sum_nodal(
                &**r,
                &mut vec![0.0; nn],
                &mut vec![Vector::<D>::zeros(); nn],
                &mut vec![Vector::<D>::zeros(); nn],
            );
        }
    }

    /// The grid.
    pub fn grid(&self) -> &GridNd<D> {
        &self.grid
    }

    /// The weight functions.
    pub fn shape(&self) -> ShapeNd {
        self.shape
    }

    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.mass.len()
    }

    /// Particle materials.
    pub fn materials(&self) -> &[MaterialNd] {
        &self.material
    }

    /// Total mass `Σ m_p`.
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// Total momentum `Σ m_p v_p` of the committed state.
    pub fn momentum(&self) -> Vector<D> {
        self.committed
            .v
            .iter()
            .zip(&self.mass)
            .fold(Vector::<D>::zeros(), |acc, (v, &m)| acc + v * m)
    }

    /// Kinetic energy `Σ ½ m_p |v_p|²` of the committed state.
    pub fn kinetic_energy(&self) -> f64 {
        self.kinetic_of(&self.committed)
    }

    fn kinetic_of(&self, s: &StateNd<D>) -> f64 {
        s.v.iter()
            .zip(&self.mass)
            .map(|(v, &m)| 0.5 * m * v.norm_squared())
            .sum()
    }

    /// Stored elastic energy of the committed state ([`MaterialNd::energy`]).
    pub fn strain_energy(&self) -> f64 {
        self.strain_of(&self.committed)
    }

    fn strain_of(&self, s: &StateNd<D>) -> f64 {
        (0..s.x.len())
            .map(|p| self.material[p].energy(&s.sigma[p], &s.f[p], self.volume0[p]))
            .sum()
    }

    /// Kinetic plus stored energy (no gravitational potential).
    pub fn total_energy(&self) -> f64 {
        self.kinetic_energy() + self.strain_energy()
    }

    /// Replaces the committed particle velocities and stresses (e.g. an initial condition)
    /// and recomputes the nodal fields. Lengths must match; values are not checked here
    /// (a non-finite value shows up in the first trial).
    pub fn set_velocity_and_stress(
        &mut self,
        v: &[Vector<D>],
        sigma: &[Tensor<D>],
    ) -> Result<(), SetupNdError> {
        let n = self.n_particles();
        for (field, len) in [("v", v.len()), ("sigma", sigma.len())] {
            if len != n {
                return Err(SetupNdError::Length {
                    field,
                    len,
                    expected: n,
                });
            }
        }
        let mut c = std::mem::take(&mut self.committed);
        c.v.copy_from_slice(v);
        c.sigma.copy_from_slice(sigma);
        let r = self.derive_state(&mut c);
        c.summary = self.summarize.then(|| self.summary_of(&c));
        self.committed = c;
        self.has_trial = false;
        r.map_err(|index| SetupNdError::OutsideBox {
            index,
            axis: 0,
            x: self.committed.x[index][0],
        })
    }

    fn view_of<'a>(&'a self, s: &'a StateNd<D>) -> ViewNd<'a, D> {
        ViewNd {
            t: s.t,
            step: s.step,
            grid: &self.grid,
            x: &s.x,
            v: &s.v,
            sigma: &s.sigma,
            f: &s.f,
            volume0: &self.volume0,
            mass: &self.mass,
            lame_lambda: &s.lame_lambda,
            lame_mu: &s.lame_mu,
            density: &s.density,
            weights: &s.weights,
            node_mass: &s.node_mass,
            node_velocity: &s.node_v,
            node_acceleration: &s.node_a,
            node_active: &s.active,
            summary: s.summary,
        }
    }

    /// Computes the trial state of step `dt` into the trial buffer.
    fn trial_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.has_trial = false;
        let c = &self.committed;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidDt { dt, t: c.t });
        }
        let n = c.x.len();
        self.node_v1.clear();
        self.node_v1
            .extend(c.node_v.iter().zip(&c.node_a).map(|(v, a)| v + a * dt));
        let mut trial = std::mem::take(&mut self.trial);
        trial.x.resize(n, Vector::<D>::zeros());
        trial.v.resize(n, Vector::<D>::zeros());
        trial.sigma.resize(n, Tensor::<D>::zeros());
        trial.f.resize(n, Tensor::<D>::zeros());
        trial.density.resize(n, 0.0);
        trial.lame_lambda.resize(n, 0.0);
        trial.lame_mu.resize(n, 0.0);
        let fault = kernels::grid_to_particle(
            &self.grid,
            &self.material,
            &self.mass,
            &self.volume0,
            &self.node_v1,
            dt,
            Committed {
                x: &c.x,
                v: &c.v,
                sigma: &c.sigma,
                f: &c.f,
                weights: &c.weights,
                node_a: &c.node_a,
            },
            Written {
                x: &mut trial.x,
                v: &mut trial.v,
                sigma: &mut trial.sigma,
                f: &mut trial.f,
                density: &mut trial.density,
                lame_lambda: &mut trial.lame_lambda,
                lame_mu: &mut trial.lame_mu,
            },
            self.summarize,
        );
        let (t, step) = (c.t, c.step);
        if fault.is_err() {
            self.take_part_after_failure();
        }
        let result = match fault {
            Err(ParticleFault::NonFinite(field, index)) => Err(StepError::NonFinite {
                field,
                index,
                t,
                step,
                dt,
            }),
            Err(ParticleFault::OutOfDomain(index, x)) => Err(StepError::OutOfDomain {
                index,
                x,
                t,
                step,
                dt,
            }),
            Err(ParticleFault::Inverted(index, f)) => Err(StepError::Inverted {
                index,
                f,
                t,
                step,
                dt,
            }),
            Ok(summary) => {
                trial.summary = self.summarize.then_some(summary);
                trial.t = t + dt;
                trial.step = step + 1;
                self.derive_state(&mut trial)
                    .map_err(|index| StepError::OutOfDomain {
                        index,
                        x: trial.x[index][0],
                        t,
                        step,
                        dt,
                    })
            }
        };
        self.trial = trial;
        self.has_trial = result.is_ok();
        result
    }
}

impl<const D: usize> Stepper<D> for SolverNd<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    fn time(&self) -> f64 {
        self.committed.t
    }

    fn step_count(&self) -> u64 {
        self.committed.step
    }

    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.trial_step(dt)
    }

    fn accept(&mut self) -> Result<(), StepError> {
        if !self.has_trial {
            return Err(StepError::NoTrial);
        }
        std::mem::swap(&mut self.committed, &mut self.trial);
        self.has_trial = false;
        Ok(())
    }

    fn reject(&mut self) {
        self.has_trial = false;
    }

    fn provide_summary(&mut self, on: bool) -> bool {
        if on && !self.summarize && self.committed.summary.is_none() {
            self.committed.summary = Some(self.summary_of(&self.committed));
        }
        self.summarize = on;
        if !on {
            self.committed.summary = None;
        }
        true
    }

    fn view(&self) -> ViewNd<'_, D> {
        self.view_of(&self.committed)
    }

    fn trial_view(&self) -> Option<ViewNd<'_, D>> {
        self.has_trial.then(|| self.view_of(&self.trial))
    }
}
