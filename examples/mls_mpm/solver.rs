//! A compact 2D MLS-MPM / APIC solver (Hu et al. 2018, as taichi's `mpm88`/`mpm99` write
//! it), written against mpm-dt's public [`Stepper`] trait only.
//!
//! Quadratic B-spline weights `w_ip`, affine particle velocities `C_p` (APIC), a
//! fixed-corotated elastic jelly, gravity, and walls as boundary conditions on the grid
//! (a node within `BOUND` cells of a wall loses the velocity component pointing into the
//! wall, mpm88's rule). One step from a state whose grid fields are known:
//!
//! 1. grid update: `v_i ← v_i + dt a_i`, walls;
//! 2. grid → particle: `v_p = Σ w v_i`, `C_p = (4/h²) Σ w v_i (x_i − x_p)ᵀ`,
//!    `x_p ← x_p + dt v_p`, `F_p ← (I + dt C_p) F_p`;
//! 3. particle → grid at the new positions (the new state's grid fields): `m_i = Σ w m_p`,
//!    `m_i v_i = Σ w m_p (v_p + C_p (x_i − x_p))`,
//!    `f_i = −(4/h²) Σ w V⁰_p P(F_p) F_pᵀ (x_i − x_p)`, `a_i = f_i/m_i + g`.
//!
//! MLS-MPM's *effective* weight gradient is `∇w_ip = (4/h²) w_ip (x_i − x_p)` (the
//! quadratic B-spline's `D_p⁻¹ = 4/h² I`); the solver exposes exactly that through the
//! [`ViewNd`] it hands to the library, so the stability limit analyses this scheme's own
//! force operator, not the reference solver's.

pub use super::model::Model;
#[path = "kernels.rs"]
mod kernels;

use super::summary::{ParticleFields, PassTotals};
use kernels::{bspline, tensors, vectors};
use mpm_dt::nd::{GridNd, SummaryNd, ViewNd, WeightsNd};
use mpm_dt::{Boundary, StepError, Stepper};
use nalgebra::{Matrix2, Vector2};

/// Cells next to each wall where the wall condition acts (mpm88's `bound`).
pub const BOUND: i64 = 3;

/// One state: particle fields and the grid fields computed from them.
#[derive(Clone)]
struct State {
    t: f64,
    step: u64,
    x: Vec<Vector2<f64>>,
    v: Vec<Vector2<f64>>,
    affine: Vec<Matrix2<f64>>,
    f: Vec<Matrix2<f64>>,
    /// Volume ratio `J` (`det F` for the jelly, advected for the fluid).
    j: Vec<f64>,
    sigma: Vec<Matrix2<f64>>,
    density: Vec<f64>,
    /// The tangent pair per particle ([`Model::tangent`]).
    lame_lambda: Vec<f64>,
    lame_mu: Vec<f64>,
    weights: WeightsNd<2>,
    node_mass: Vec<f64>,
    node_v: Vec<Vector2<f64>>,
    node_a: Vec<Vector2<f64>>,
    active: Vec<bool>,
    /// The totals of the pass that wrote this state, when the solver opts in.
    summary: Option<SummaryNd<2>>,
}

impl State {
    /// `self` takes `n` particles, keeping its own allocations: a trial rewrites every
    /// particle field before reading it, and [`particle_to_grid`] rebuilds the weights and
    /// the grid fields.
    fn fit_particles(&mut self, n: usize) {
        self.x.resize(n, Vector2::zeros());
        self.v.resize(n, Vector2::zeros());
        self.affine.resize(n, Matrix2::zeros());
        self.f.resize(n, Matrix2::zeros());
        self.j.resize(n, 0.0);
        self.sigma.resize(n, Matrix2::zeros());
        self.density.resize(n, 0.0);
        self.lame_lambda.resize(n, 0.0);
        self.lame_mu.resize(n, 0.0);
    }
}

/// The MLS-MPM solver.
pub struct MlsMpm {
    grid: GridNd<2>,
    model: Model,
    density: f64,
    gravity: Vector2<f64>,
    mass: Vec<f64>,
    volume0: Vec<f64>,
    committed: State,
    trial: Option<State>,
    /// A state no longer needed (the last replaced or rejected one), whose arrays the next
    /// trial overwrites instead of cloning the committed state.
    spare: Option<State>,
    /// What the pass forms for the views beyond the step itself.
    handover: Handover,
}

/// What the particle → grid pass forms for the library beyond the step itself.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Handover {
    /// Nothing: a run with no controller (fixed steps, the rules of thumb), whose views
    /// keep the first state's rest moduli ([`MlsMpm::without_views`]).
    Nothing,
    /// The tangent pair per particle ([`Model::tangent`]): the generic path.
    Moduli,
    /// The moduli and the pass's totals ([`SummaryNd`]: energies, finiteness, the
    /// speed-of-sound step, the element bound) — the opt-in contract.
    Summary,
}

impl MlsMpm {
    /// A box `[0, 1]²` of `n_grid²` cells with walls, particles at `x` moving at `v`, each
    /// of volume `(h/2)²` (mpm88's `p_vol`) and mass `ρ·volume`.
    pub fn new(
        n_grid: usize,
        model: Model,
        density: f64,
        gravity: Vector2<f64>,
        x: Vec<Vector2<f64>>,
        v: Vec<Vector2<f64>>,
    ) -> Self {
        let grid = GridNd::new([Boundary::Fixed; 2], [n_grid; 2], [1.0; 2]);
        let h = grid.h[0];
        let n = x.len();
        let vol = (0.5 * h).powi(2);
        let mut committed = State {
            t: 0.0,
            step: 0,
            x,
            v,
            affine: vec![Matrix2::zeros(); n],
            f: vec![Matrix2::identity(); n],
            j: vec![1.0; n],
            sigma: vec![Matrix2::zeros(); n],
            density: vec![density; n],
            lame_lambda: vec![0.0; n],
            lame_mu: vec![0.0; n],
            weights: WeightsNd::new(grid.n_nodes(), 9),
            node_mass: Vec::new(),
            node_v: Vec::new(),
            node_a: Vec::new(),
            active: Vec::new(),
            summary: None,
        };
        let mass = vec![density * vol; n];
        let volume0 = vec![vol; n];
        particle_to_grid(
            &grid,
            &model,
            gravity,
            &mass,
            &volume0,
            &mut committed,
            Handover::Summary,
        );
        Self {
            grid,
            model,
            density,
            gravity,
            mass,
            volume0,
            committed,
            trial: None,
            spare: None,
            handover: Handover::Summary,
        }
    }

    /// Whether the solver hands the library its pass's totals ([`SummaryNd`]; default
    /// yes): `false` shows the generic path, where every limit makes its own passes.
    pub fn with_summary(mut self, opt_in: bool) -> Self {
        self.handover = if opt_in {
            Handover::Summary
        } else {
            Handover::Moduli
        };
        self
    }

    /// A solver for runs without the controller (fixed steps and the rules of thumb): its
    /// passes form neither the totals nor the tangent moduli. Its views keep the first
    /// state's moduli — the rest pair, which is what a rule of thumb `α·h/(c_p + |v|)`
    /// reads (`SoundSpeed::unit_step` in `main.rs` and `work_precision`): a user's rule
    /// takes the material's wave speed, not a tangent one.
    pub fn without_views(mut self) -> Self {
        self.handover = Handover::Nothing;
        self
    }

    /// The grid.
    pub fn grid(&self) -> &GridNd<2> {
        &self.grid
    }

    /// P-wave speed of the undeformed jelly, `√((λ + 2μ)/ρ)`.
    pub fn p_wave_speed(&self) -> f64 {
        let (lambda, mu) = self.model.lame();
        ((lambda + 2.0 * mu) / self.density).sqrt()
    }

    /// Kinetic, elastic and gravitational potential energy of the committed state.
    pub fn energies(&self) -> (f64, f64, f64) {
        let s = &self.committed;
        let kinetic: f64 = (0..s.x.len())
            .map(|p| 0.5 * self.mass[p] * s.v[p].norm_squared())
            .sum();
        let elastic: f64 = (0..s.x.len())
            .map(|p| self.volume0[p] * self.model.energy_density(&s.f[p], s.j[p]))
            .sum();
        let potential: f64 = (0..s.x.len())
            .map(|p| -self.mass[p] * self.gravity.dot(&s.x[p]))
            .sum();
        (kinetic, elastic, potential)
    }
}

/// The new state's weights and grid fields from its particle fields (step 3 of the module
/// docs); also its Cauchy stress and density for the view.
fn particle_to_grid(
    grid: &GridNd<2>,
    model: &Model,
    gravity: Vector2<f64>,
    mass: &[f64],
    volume0: &[f64],
    s: &mut State,
    handover: Handover,
) {
    let h = grid.h[0];
    let mut totals = (handover == Handover::Summary).then(|| PassTotals::new(h, model));
    let moduli = handover != Handover::Nothing;
    let inv = 4.0 / (h * h);
    let nn = grid.n_nodes();
    s.node_mass.clear();
    s.node_mass.resize(nn, 0.0);
    s.node_v.clear();
    s.node_v.resize(nn, Vector2::zeros());
    s.node_a.clear();
    s.node_a.resize(nn, Vector2::zeros());
    let n = s.x.len();
    if moduli {
        model.tangents(&s.f, &mut s.lame_lambda, &mut s.lame_mu);
    }
    let (nodes, ws, grads) = s.weights.storage_mut(n);
    for p in 0..n {
        let (bx, wx, dx) = bspline(s.x[p][0], h);
        let (by, wy, dy) = bspline(s.x[p][1], h);
        let f = s.f[p];
        let j = s.j[p];
        let tau = model.kirchhoff(&f, j);
        s.sigma[p] = tau / j;
        s.density[p] = mass[p] / (volume0[p] * j);
        // −V⁰ τ (4/h²): the force on node i is stress_term · (x_i − x_p).
        let stress_term = -volume0[p] * inv * tau;
        let affine = mass[p] * s.affine[p];
        if let Some(t) = totals.as_mut() {
            t.add(&ParticleFields {
                mass: mass[p],
                volume0: volume0[p],
                x: &s.x[p],
                v: &s.v[p],
                f: &f,
                sigma: &s.sigma[p],
                density: s.density[p],
                lame: (s.lame_lambda[p], s.lame_mu[p]),
            });
        }
        for a in 0..3 {
            for b in 0..3 {
                let k = p * 9 + a * 3 + b;
                let node = grid.flat_index([bx + a as i64, by + b as i64]).unwrap_or(0);
                let w = wx[a] * wy[b];
                let dpos = Vector2::new(dx[a], dy[b]) * h;
                nodes[k] = node as u32;
                ws[k] = w;
                grads[k] = inv * w * dpos;
                s.node_mass[node] += w * mass[p];
                s.node_v[node] += w * (mass[p] * s.v[p] + affine * dpos);
                s.node_a[node] += w * (stress_term * dpos);
            }
        }
    }
    s.active.clear();
    s.active.resize(nn, false);
    for i in 0..nn {
        let m = s.node_mass[i];
        if m > 0.0 {
            s.active[i] = true;
            s.node_v[i] /= m;
            s.node_a[i] = s.node_a[i] / m + gravity;
        }
    }
    s.summary = totals.map(PassTotals::finish);
}

impl MlsMpm {
    /// One trial step of `dt` from the committed state (steps 1–3 of the module docs), in
    /// `spare`'s arrays when there is one.
    fn trial_from(&self, dt: f64, spare: Option<State>) -> Result<State, StepError> {
        let c = &self.committed;
        // The trial, in the spare state's arrays when there is one.
        let mut s = match spare {
            Some(mut s) => {
                s.fit_particles(c.x.len());
                s
            }
            None => c.clone(),
        };
        // 1. Grid update with mpm88's walls, in the trial's nodal-velocity array (which
        // `particle_to_grid` rebuilds at the end).
        let mut vi = std::mem::take(&mut s.node_v);
        vi.clone_from(&c.node_v);
        self.grid_update(dt, &mut vi);
        // 2. Grid to particle.
        s.t = c.t + dt;
        s.step = c.step + 1;
        self.grid_to_particle(dt, &vi, &mut s)?;
        // 3. The new state's grid fields.
        s.node_v = vi;
        particle_to_grid(
            &self.grid,
            &self.model,
            self.gravity,
            &self.mass,
            &self.volume0,
            &mut s,
            self.handover,
        );
        Ok(s)
    }

    /// Step 1: the committed nodal velocities `vi` advanced by `dt`, with mpm88's walls.
    fn grid_update(&self, dt: f64, vi: &mut [Vector2<f64>]) {
        let c = &self.committed;
        let grid = &self.grid;
        let n_cells = grid.cells[0] as i64;
        for (i, v) in vi.iter_mut().enumerate() {
            if !c.active[i] {
                *v = Vector2::zeros();
                continue;
            }
            *v += dt * c.node_a[i];
            let lat = grid.lattice_of(i);
            for a in 0..2 {
                if (lat[a] < BOUND && v[a] < 0.0) || (lat[a] > n_cells - BOUND && v[a] > 0.0) {
                    v[a] = 0.0;
                }
            }
        }
    }

    /// Step 2: the trial's particle fields from the updated nodal velocities `vi`; an error
    /// at the first particle that inverts, turns non-finite or leaves the domain.
    fn grid_to_particle(
        &self,
        dt: f64,
        vi: &[Vector2<f64>],
        s: &mut State,
    ) -> Result<(), StepError> {
        let c = &self.committed;
        let grid = &self.grid;
        let h = grid.h[0];
        let inv = 4.0 / (h * h);
        for p in 0..c.x.len() {
            let nodes = c.weights.nodes_of(p);
            let ws = c.weights.s_of(p);
            let mut v = Vector2::zeros();
            let mut b = Matrix2::zeros();
            for k in 0..9 {
                let i = nodes[k] as usize;
                let dpos = grid.node_position(i) - c.x[p];
                v += ws[k] * vi[i];
                b += ws[k] * vi[i] * dpos.transpose();
            }
            let cp = inv * b;
            s.v[p] = v;
            s.affine[p] = cp;
            s.x[p] = c.x[p] + dt * v;
            match self.model {
                Model::Jelly { .. } => {
                    s.f[p] = (Matrix2::identity() + dt * cp) * c.f[p];
                    s.j[p] = s.f[p].determinant();
                }
                Model::Fluid { .. } => {
                    // mpm88: J ← (1 + dt tr C) J; a fluid keeps no shape, F = √J I.
                    s.j[p] = (1.0 + dt * cp.trace()) * c.j[p];
                    s.f[p] = Matrix2::identity() * s.j[p].max(0.0).sqrt();
                }
            }
            if s.j[p] <= 0.0 {
                return Err(StepError::Inverted {
                    index: p,
                    det_f: s.j[p],
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
            if !(s.x[p].iter().all(|x| x.is_finite()) && s.f[p].iter().all(|x| x.is_finite())) {
                return Err(StepError::NonFinite {
                    field: "x",
                    index: p,
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
            let lo = h;
            let hi = 1.0 - h;
            if let Some(axis) = (0..2).find(|&a| !(lo..=hi).contains(&s.x[p][a])) {
                return Err(StepError::OutOfDomain {
                    index: p,
                    axis,
                    x: s.x[p][axis],
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
        }
        Ok(())
    }

    fn view_of<'a>(&'a self, s: &'a State) -> ViewNd<'a, 2> {
        ViewNd {
            t: s.t,
            step: s.step,
            grid: &self.grid,
            x: vectors(&s.x),
            v: vectors(&s.v),
            sigma: tensors(&s.sigma),
            f: tensors(&s.f),
            volume0: &self.volume0,
            mass: &self.mass,
            lame_lambda: &s.lame_lambda,
            lame_mu: &s.lame_mu,
            density: &s.density,
            weights: (&s.weights).into(),
            node_mass: &s.node_mass,
            node_velocity: vectors(&s.node_v),
            node_acceleration: vectors(&s.node_a),
            node_active: &s.active,
            summary: if self.handover == Handover::Summary {
                s.summary
            } else {
                None
            },
            split: None,
        }
    }
}

impl Stepper<2> for MlsMpm {
    fn time(&self) -> f64 {
        self.committed.t
    }

    fn step_count(&self) -> u64 {
        self.committed.step
    }

    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        if let Some(old) = self.trial.take() {
            self.spare = Some(old);
        }
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidDt {
                dt,
                t: self.committed.t,
            });
        }
        let spare = self.spare.take();
        self.trial = Some(self.trial_from(dt, spare)?);
        Ok(())
    }

    fn accept(&mut self) -> Result<(), StepError> {
        let trial = self.trial.take().ok_or(StepError::NoTrial)?;
        self.spare = Some(std::mem::replace(&mut self.committed, trial));
        Ok(())
    }

    fn reject(&mut self) {
        if let Some(old) = self.trial.take() {
            self.spare = Some(old);
        }
    }

    fn view(&self) -> ViewNd<'_, 2> {
        self.view_of(&self.committed)
    }

    fn trial_view(&self) -> Option<ViewNd<'_, 2>> {
        self.trial.as_ref().map(|s| self.view_of(s))
    }
}
