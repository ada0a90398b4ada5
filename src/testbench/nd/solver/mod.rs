//! [`SolverNd`]: the reference d-dimensional update-stress-last solver (D = 2, 3).
//!
//! One step from a committed state whose nodal fields are known (docs/design.md, "The
//! USL step in d dimensions"): `v_iⁿ⁺¹ = v_i + dt a_i`; grid → particle
//! ([`crate::nd::kernels`]); then, at the new positions, the particle → grid pass that the
//! *next* step starts from. A step therefore costs one particle → grid and one grid →
//! particle pass, and every state — committed or trial — carries the nodal fields of its
//! own particle positions, as the [`ViewNd`] promises. No state stores its weights: every
//! pass forms a particle's row from its position, GIMP domain, the grid and the shape
//! ([`ViewWeightsNd`]), bit for bit the row a stored form would hold. The two passes are
//! made in one sweep over the particles (each particle's update, then at once its share of
//! the particle → grid sums at its new position), bit for bit the two passes apart; a grid
//! split into slabs over processes makes them apart, particles moving between processes in
//! between.
//!
//! # Threads
//!
//! [`SolverNd::set_threads`] runs a step on a pool of threads: the updates in fixed chunks
//! of particles, then the particle → grid sums slab by slab across the last axis, the
//! slabs in four colours so that those run at once never add to the same node. Chunks and
//! slabs depend on the particle count and the grid only, so the state after a step is the
//! same, bit for bit, on any number of threads; it differs from the unthreaded step's by
//! round-off (the sums are made in another order).
//!
//! The trial is written into a second buffer; [`Stepper::accept`] swaps the buffers and
//! [`Stepper::reject`] drops the trial, so the committed state is never written by a trial
//! and a rejection restores it bit for bit.
//!
//! # Memory
//!
//! Per particle (O(particles)), in bytes for `D = 3` (`D = 2`): the committed state and
//! the trial each hold `x`, `v` (48; 32), `σ`, `F` (144; 64) and the density (8); the
//! fields a step does not change — mass, `V⁰`, GIMP domain, material, run-wide id
//! ([`CarriedNd`], 72; 64) — are held once and shared, and so are the two tangent moduli
//! (16) where every material is linear-elastic ([`ModuliNd`]; else each state holds its
//! own). In all `2·200 + 72 + 16 = 488` bytes (`2·104 + 64 + 16 = 288` in 2D). Per node (O(nodes)), per state:
//! mass, velocity, acceleration, activity (`8 + 16D + 1` bytes), plus the solver's
//! `v_iⁿ⁺¹` and constraint flags. [`SolverNd::memory_bytes`] sums what is held.

mod memory;
mod own_bounds;
mod setup;
mod threads;
mod trial;

pub use threads::ThreadsError;

use super::particles::SetupError;
use super::slab::SlabNd;
use super::MaterialNd;
use crate::dimension::{Dim, Dimension, StateView};
use crate::nd::kernels;
use crate::nd::{GridNd, ShapeNd, SplitNd, SummaryNd, Tensor, Vector, ViewNd, ViewWeightsNd};
use crate::reduce::Reduce;
use crate::stepper::{StepError, Stepper};
use crate::testbench::nd::threaded::ThreadScratch;
use std::rc::Rc;
use std::sync::Arc;

pub use crate::nd::fields::INACTIVE_MASS_RATIO;

/// The fields of the particles that a step does not change. They travel with the
/// particles between processes ([`SolverNd::new_slab`]); a state shares them with the
/// state it came from unless particles moved between processes.
#[derive(Clone, Debug, Default)]
pub(super) struct CarriedNd<const D: usize> {
    pub mass: Vec<f64>,
    pub volume0: Vec<f64>,
    pub domain: Vec<Vector<D>>,
    pub material: Vec<MaterialNd>,
    /// Each particle's index in the whole run.
    pub id: Vec<u64>,
}

/// The tangent moduli `(λ_t, μ_t)` of a state's particles ([`ViewNd`]). Where every
/// material's tangent is constant (linear elasticity) a step does not change them: the
/// committed state and the trial then share one copy.
#[derive(Clone, Debug, Default)]
pub(super) struct ModuliNd {
    pub lambda: Vec<f64>,
    pub mu: Vec<f64>,
}

/// One state of the solver.
#[derive(Clone, Debug, Default)]
pub(super) struct StateNd<const D: usize> {
    t: f64,
    step: u64,
    pub x: Vec<Vector<D>>,
    pub v: Vec<Vector<D>>,
    pub sigma: Vec<Tensor<D>>,
    pub f: Vec<Tensor<D>>,
    pub density: Vec<f64>,
    /// Shared with the other state where the moduli are constant ([`ModuliNd`]).
    pub moduli: Rc<ModuliNd>,
    node_mass: Vec<f64>,
    node_v: Vec<Vector<D>>,
    node_a: Vec<Vector<D>>,
    active: Vec<bool>,
    /// Totals over the particles ([`SummaryNd`]), written with them.
    summary: Option<SummaryNd<D>>,
    /// The fields a step does not change.
    pub carried: Rc<CarriedNd<D>>,
}

/// How a run is split over processes.
#[derive(Clone, Debug)]
enum Split<const D: usize> {
    /// One process.
    Alone,
    /// By particle, the whole grid on every process ([`SolverNd::new_distributed`]).
    Particles(Rc<dyn Reduce>),
    /// By grid, a slab per process ([`SolverNd::new_slab`]).
    Slab(SlabNd<D>),
}

impl<const D: usize> Split<D> {
    /// This process's slab of a decomposed grid.
    fn slab(&self) -> Option<&SlabNd<D>> {
        match self {
            Split::Slab(s) => Some(s),
            _ => None,
        }
    }

    /// Completes the nodal sums `Σ S m`, `Σ S m v`, `−Σ V σ ∇S` of a particle → grid pass
    /// over the processes (nothing on one process).
    fn complete_nodal(&self, m: &mut [f64], v: &mut [Vector<D>], a: &mut [Vector<D>]) {
        match self {
            Split::Alone => {}
            Split::Particles(r) => super::update::sum_nodal(&**r, m, v, a),
            Split::Slab(s) => s.complete_nodal(m, v, a),
        }
    }
}

/// The reference d-dimensional MPM solver.
#[derive(Clone, Debug)]
pub struct SolverNd<const D: usize> {
    /// The grid whose nodes the nodal fields hold: the whole grid, or this process's
    /// window of it ([`Self::new_slab`]).
    grid: GridNd<D>,
    shape: ShapeNd,
    gravity: Vector<D>,
    constrained: Vec<bool>,
    threshold: f64,
    committed: StateNd<D>,
    trial: StateNd<D>,
    has_trial: bool,
    node_v1: Vec<Vector<D>>,
    /// How the run is split over processes.
    split: Split<D>,
    /// Number of particles over all processes.
    n_total: usize,
    /// Whether the trials carry their [`SummaryNd`] ([`Stepper::provide_summary`]).
    summarize: bool,
    /// Every material's tangent moduli are constant: the states share them.
    constant_moduli: bool,
    /// The threads a step runs on ([`SolverNd::set_threads`]); `None`: this thread.
    threads: Option<Arc<rayon::ThreadPool>>,
    /// The particles' order by slab, kept between threaded steps.
    scratch: ThreadScratch,
}

impl<const D: usize> SolverNd<D> {
    /// The whole grid: boundaries, walls and periodic wraps.
    fn whole(&self) -> &GridNd<D> {
        self.split.slab().map_or(&self.grid, |s| s.whole())
    }

    /// Weights and nodal fields of a state from its particle fields. With `failed` (this
    /// process's trial failed before) it only takes part in the exchanges of a split run,
    /// with zeros, so that the other processes are not left waiting. While summaries are
    /// on it also returns this process's element bound and speed-of-sound unit step,
    /// accumulated in the same pass ([`own_bounds`]).
    fn derive_state(&self, s: &mut StateNd<D>, failed: bool) -> Result<Option<(f64, f64)>, usize> {
        if failed {
            self.take_part_after_failure();
            return Ok(None);
        }
        let complete = |m: &mut Vec<f64>, v: &mut Vec<Vector<D>>, a: &mut Vec<Vector<D>>| {
            self.split.complete_nodal(m, v, a)
        };
        let mut node_mass = std::mem::take(&mut s.node_mass);
        let mut node_v = std::mem::take(&mut s.node_v);
        let mut node_a = std::mem::take(&mut s.node_a);
        let mut active = std::mem::take(&mut s.active);
        let mut bounds = self.summarize.then(|| self.particle_bounds(s));
        // A stencil past a fixed wall is found by the pass itself (it adds nothing); the
        // nodal sums are then completed as after any failure, the state is not used.
        let unformed = kernels::particle_to_grid(
            &ViewWeightsNd::formed(&self.grid, self.shape, &s.x, &s.carried.domain),
            &s.carried.mass,
            &s.carried.volume0,
            &s.v,
            &s.sigma,
            &s.f,
            &self.gravity,
            &self.constrained,
            self.threshold,
            &mut node_mass,
            &mut node_v,
            &mut node_a,
            &mut active,
            &complete,
            bounds.as_mut(),
        );
        let local = bounds.map(|b| b.result());
        (s.node_mass, s.node_v, s.node_a, s.active) = (node_mass, node_v, node_a, active);
        match unformed {
            Some(p) => Err(p),
            None => Ok(local),
        }
    }

    /// The totals of a state's particles ([`SummaryNd`]), by a pass of their own (for the
    /// states the step did not write: the initial one, one set by the user).
    fn summary_of(&self, s: &StateNd<D>) -> SummaryNd<D> {
        // The view's own scan, not a summary the state may still carry.
        let view = ViewNd {
            summary: None,
            ..self.view_of(s)
        };
        let summary = SummaryNd {
            finite: view.first_nonfinite().is_none(),
            kinetic: self.kinetic_of(s),
            strain: self.strain_of(s),
            first_moment: s
                .x
                .iter()
                .zip(&s.carried.mass)
                .fold(Vector::<D>::zeros(), |acc, (x, &m)| acc + x * m),
            element_bound: None,
            sound_unit_step: None,
        };
        let (element_bound, sound_unit_step) = self.whole_run_bounds(Some(self.own_bounds_pass(s)));
        SummaryNd {
            element_bound,
            sound_unit_step,
            ..self.whole_run_summary(summary)
        }
    }

    /// In a grid-decomposed run the totals of every process (particles move between
    /// them): one reduction. Otherwise `summary` itself.
    fn whole_run_summary(&self, summary: SummaryNd<D>) -> SummaryNd<D> {
        let Some(slab) = self.split.slab() else {
            return summary;
        };
        let mut buf = vec![
            f64::from(u8::from(!summary.finite)),
            summary.kinetic,
            summary.strain,
        ];
        buf.extend(summary.first_moment.iter());
        slab.reduce().sum(&mut buf);
        SummaryNd {
            finite: buf[0] == 0.0,
            kinetic: buf[1],
            strain: buf[2],
            first_moment: Vector::<D>::from_fn(|a, _| buf[3 + a]),
            element_bound: None,
            sound_unit_step: None,
        }
    }

    /// In a split run, the nodal exchange of a pass this process could not make: zeros,
    /// so that the other processes are not left waiting (the step fails everywhere
    /// through the controller's agreement on the verdict).
    fn take_part_after_failure(&self) {
        if let Split::Alone = self.split {
            return;
        }
        let nn = self.grid.n_nodes();
        self.split.complete_nodal(
            &mut vec![0.0; nn],
            &mut vec![Vector::<D>::zeros(); nn],
            &mut vec![Vector::<D>::zeros(); nn],
        );
    }

    /// The (whole) grid.
    pub fn grid(&self) -> &GridNd<D> {
        self.whole()
    }

    /// The weight functions.
    pub fn shape(&self) -> ShapeNd {
        self.shape
    }

    /// Number of this process's particles (all of them in an undivided run).
    pub fn n_particles(&self) -> usize {
        self.committed.x.len()
    }

    /// Number of particles over all processes.
    pub fn n_particles_total(&self) -> usize {
        self.n_total
    }

    /// Particle materials.
    pub fn materials(&self) -> &[MaterialNd] {
        &self.committed.carried.material
    }

    /// Each particle's index in the whole run (the order of the particles the run was
    /// set up from): `0..n` in an undivided run.
    pub fn particle_ids(&self) -> &[u64] {
        &self.committed.carried.id
    }

    /// Total mass `Σ m_p`.
    pub fn total_mass(&self) -> f64 {
        self.committed.carried.mass.iter().sum()
    }

    /// Total momentum `Σ m_p v_p` of the committed state.
    pub fn momentum(&self) -> Vector<D> {
        self.committed
            .v
            .iter()
            .zip(&self.committed.carried.mass)
            .fold(Vector::<D>::zeros(), |acc, (v, &m)| acc + v * m)
    }

    /// Kinetic energy `Σ ½ m_p |v_p|²` of the committed state.
    pub fn kinetic_energy(&self) -> f64 {
        self.kinetic_of(&self.committed)
    }

    fn kinetic_of(&self, s: &StateNd<D>) -> f64 {
        s.v.iter()
            .zip(&s.carried.mass)
            .map(|(v, &m)| 0.5 * m * v.norm_squared())
            .sum()
    }

    /// Stored elastic energy of the committed state ([`MaterialNd::energy`]).
    pub fn strain_energy(&self) -> f64 {
        self.strain_of(&self.committed)
    }

    fn strain_of(&self, s: &StateNd<D>) -> f64 {
        let c = &s.carried;
        (0..s.x.len())
            .map(|p| c.material[p].energy(&s.sigma[p], &s.f[p], c.volume0[p]))
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
    ) -> Result<(), SetupError> {
        let n = self.n_particles();
        for (field, len) in [("v", v.len()), ("sigma", sigma.len())] {
            if len != n {
                // In a split run the others are making the nodal exchanges: take part.
                self.take_part_after_failure();
                // The same reductions as the summary of a state that was set (none when
                // summaries are off).
                let _ = self.trial_summary(None, None);
                return Err(SetupError::Length {
                    field,
                    len,
                    expected: n,
                });
            }
        }
        let mut c = std::mem::take(&mut self.committed);
        c.v.copy_from_slice(v);
        c.sigma.copy_from_slice(sigma);
        let r = self.derive_state(&mut c, false);
        c.summary = self.summarize.then(|| self.summary_of(&c));
        self.committed = c;
        self.has_trial = false;
        r.map(|_| ()).map_err(|index| SetupError::OutsideBox {
            index,
            axis: 0,
            x: self.committed.x[index][0],
        })
    }

    fn view_of<'a>(&'a self, s: &'a StateNd<D>) -> ViewNd<'a, D> {
        let split = self.split.slab().map(|slab| SplitNd {
            whole: slab.whole(),
            global_node: slab.global_node(),
            owned: slab.owned(),
            particle_id: &s.carried.id,
            n_particles_total: self.n_total,
            halo: slab,
        });
        ViewNd {
            t: s.t,
            step: s.step,
            grid: &self.grid,
            x: &s.x,
            v: &s.v,
            sigma: &s.sigma,
            f: &s.f,
            volume0: &s.carried.volume0,
            mass: &s.carried.mass,
            lame_lambda: &s.moduli.lambda,
            lame_mu: &s.moduli.mu,
            density: &s.density,
            weights: ViewWeightsNd::formed(&self.grid, self.shape, &s.x, &s.carried.domain),
            node_mass: &s.node_mass,
            node_velocity: &s.node_v,
            node_acceleration: &s.node_a,
            node_active: &s.active,
            summary: s.summary,
            split,
        }
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
