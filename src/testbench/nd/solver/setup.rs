//! Setting a [`SolverNd`] up: undivided, split by particle, or on a slab of a decomposed
//! grid.

use super::{CarriedNd, ModuliNd, SolverNd, Split, StateNd, INACTIVE_MASS_RATIO};
use crate::nd::{GridNd, MaterialNd, ShapeNd, Tensor, Vector};
use crate::reduce::Reduce;
use crate::testbench::nd::particles::{ParticlesNd, SetupError};
use crate::testbench::nd::slab::SlabNd;
use crate::testbench::nd::threaded::ThreadScratch;
use std::rc::Rc;

impl<const D: usize> SolverNd<D> {
    /// A solver on `grid` with `shape` weights, starting at `t = 0` from `particles` with
    /// zero stress and `F = I`, under the body force `gravity` (an acceleration).
    pub fn new(
        grid: GridNd<D>,
        shape: ShapeNd,
        particles: ParticlesNd<D>,
        gravity: Vector<D>,
    ) -> Result<Self, SetupError> {
        let (min_mass, n) = checked(&particles, &grid, shape)?;
        let ids = (0..n as u64).collect();
        Self::build(
            grid,
            shape,
            particles,
            ids,
            gravity,
            min_mass,
            Split::Alone,
            n,
        )
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
    /// the reduction grow with the grid, not with the share of it a process works on
    /// ([`Self::new_slab`] decomposes the grid).
    pub fn new_distributed(
        grid: GridNd<D>,
        shape: ShapeNd,
        particles: ParticlesNd<D>,
        gravity: Vector<D>,
        reduce: Rc<dyn Reduce>,
    ) -> Result<Self, SetupError> {
        let (min_mass, n) = checked(&particles, &grid, shape)?;
        let block: Vec<usize> =
            ParticlesNd::<D>::block_range(n, reduce.rank(), reduce.size()).collect();
        let mine = particles.select(&block);
        let ids = block.iter().map(|&p| p as u64).collect();
        let split = Split::Particles(reduce);
        Self::build(grid, shape, mine, ids, gravity, min_mass, split, n)
    }

    /// This process's part of a run whose grid is decomposed into slabs along its last
    /// axis over the processes of `reduce` (docs/design.md, "Grid decomposition"): every process
    /// passes the *whole* set of particles and keeps those in its slab; it holds its own
    /// node planes plus two ghost planes each side, completes the nodal sums with its
    /// neighbours after each particle → grid pass, and hands particles that leave its slab
    /// to the neighbour that owns them. Memory and work per process scale with its slab;
    /// the communication per step is two shifts of four node planes and of the moving
    /// particles (plus the controller's reductions). The view ([`crate::nd::ViewNd::split`]) holds
    /// this process's particles and window of nodes; its [`crate::nd::SummaryNd`] is the whole
    /// run's. Every process must make the same calls together. The last axis needs at
    /// least [`MIN_SLAB_CELLS`](crate::nd::MIN_SLAB_CELLS) cells per process.
    pub fn new_slab(
        grid: GridNd<D>,
        shape: ShapeNd,
        particles: ParticlesNd<D>,
        gravity: Vector<D>,
        reduce: Rc<dyn Reduce>,
    ) -> Result<Self, SetupError> {
        let (min_mass, n) = checked(&particles, &grid, shape)?;
        let slab = SlabNd::new(grid, Rc::clone(&reduce))?;
        let mine: Vec<usize> = (0..n)
            .filter(|&p| slab.owns(particles.x[p][D - 1]))
            .collect();
        let own = particles.select(&mine);
        let ids = mine.iter().map(|&p| p as u64).collect();
        let local = slab.local().clone();
        Self::build(
            local,
            shape,
            own,
            ids,
            gravity,
            min_mass,
            Split::Slab(slab),
            n,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        grid: GridNd<D>,
        shape: ShapeNd,
        particles: ParticlesNd<D>,
        ids: Vec<u64>,
        gravity: Vector<D>,
        min_mass: f64,
        split: Split<D>,
        n_total: usize,
    ) -> Result<Self, SetupError> {
        if gravity.iter().any(|g| !g.is_finite()) {
            return Err(SetupError::Gravity);
        }
        let n = particles.len();
        let constrained = match split.slab() {
            Some(s) => s
                .global_node()
                .iter()
                .map(|&g| s.whole().is_constrained(g as usize))
                .collect(),
            None => (0..grid.n_nodes())
                .map(|i| grid.is_constrained(i))
                .collect(),
        };
        let constant_moduli = particles
            .material
            .iter()
            .all(|m| matches!(m, MaterialNd::LinearElastic { .. }));
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
            moduli: Rc::new(ModuliNd {
                lambda: lame_lambda,
                mu: lame_mu,
            }),
            carried: Rc::new(CarriedNd {
                mass: particles.mass,
                volume0: particles.volume,
                domain: particles.domain,
                material: particles.material,
                id: ids,
            }),
            ..StateNd::default()
        };
        let mut solver = Self {
            grid,
            shape,
            gravity,
            constrained,
            threshold: INACTIVE_MASS_RATIO * min_mass,
            committed,
            trial: StateNd::default(),
            has_trial: false,
            node_v1: Vec::new(),
            split,
            n_total,
            summarize: false,
            constant_moduli,
            threads: None,
            scratch: ThreadScratch::default(),
        };
        let mut c = std::mem::take(&mut solver.committed);
        solver
            .derive_state(&mut c, false)
            .map_err(|index| SetupError::OutsideBox {
                index,
                axis: 0,
                x: c.x[index][0],
            })?;
        solver.committed = c;
        Ok(solver)
    }
}

/// Checks the whole set of particles against the grid: their smallest mass (the inactive
/// node threshold is relative to it, the same on every process) and their number.
fn checked<const D: usize>(
    particles: &ParticlesNd<D>,
    grid: &GridNd<D>,
    shape: ShapeNd,
) -> Result<(f64, usize), SetupError> {
    particles.validate(grid, shape)?;
    let min_mass = particles.mass.iter().copied().fold(f64::INFINITY, f64::min);
    Ok((min_mass, particles.len()))
}
