//! A plain 2D MPM solver of the kind users write: quadratic B-spline weights, FLIP
//! velocity transfer, a compressible neo-Hookean material, gravity and slip walls,
//! written against mpm-dt's public [`Stepper`] trait only.
//!
//! One step from a state whose grid fields are known (update stress last):
//!
//! 1. grid update: `v_i' = v_i + dt a_i`, then the walls (a node within [`BOUND`] cells of
//!    a wall loses the velocity component pointing into it);
//! 2. grid → particle (FLIP): `v_p += Σ S_ip (v_i' − v_i)`, `x_p += dt Σ S_ip v_i'`,
//!    `F_p ← (I + dt Σ v_i' ⊗ ∇S_ip) F_p`;
//! 3. particle → grid at the new positions (the new state's grid fields):
//!    `m_i = Σ S m_p`, `v_i = Σ S m_p v_p / m_i`,
//!    `a_i = −Σ V_p σ_p ∇S_ip / m_i + g`, `V_p = J_p V⁰_p`, with the neo-Hookean Cauchy
//!    stress `σ = (μ(F Fᵀ − I) + λ ln J I)/J`.
//!
//! The view reports the material's spatial tangent about the current state, isotropic:
//! `λ_t = λ/J`, `μ_t = (μ − λ ln J)/J`. A solver that opts in
//! ([`FlipSolver::with_summary`]) also hands over, from pass 3, its energies, whether its
//! fields are finite, the speed-of-sound step and the element bound on `λmax`
//! (`mpm_dt::limits_nd::element_bound`), from the particle's own B-spline gradients.

use mpm_dt::limits_nd::element_bound::from_metric;
use mpm_dt::nd::{GridNd, SummaryNd, Tensor, Vector, ViewNd, WeightsNd};
use mpm_dt::{Boundary, StepError, Stepper};
use nalgebra::{Matrix2, Vector2};

/// Cells next to each wall where the wall condition acts.
pub const BOUND: i64 = 3;

/// One state: particle fields and the grid fields computed from them.
#[derive(Clone)]
struct State {
    t: f64,
    step: u64,
    x: Vec<Vector2<f64>>,
    v: Vec<Vector2<f64>>,
    f: Vec<Matrix2<f64>>,
    sigma: Vec<Matrix2<f64>>,
    density: Vec<f64>,
    lame_lambda: Vec<f64>,
    lame_mu: Vec<f64>,
    weights: WeightsNd<2>,
    node_mass: Vec<f64>,
    node_v: Vec<Vector2<f64>>,
    node_a: Vec<Vector2<f64>>,
    active: Vec<bool>,
    summary: Option<SummaryNd<2>>,
}

/// The material and the forces: what pass 3 needs besides the particles.
#[derive(Clone, Copy)]
struct Physics {
    lambda: f64,
    mu: f64,
    gravity: Vector2<f64>,
}

/// The user's solver.
pub struct FlipSolver {
    grid: GridNd<2>,
    physics: Physics,
    mass: Vec<f64>,
    volume0: Vec<f64>,
    committed: State,
    trial: Option<State>,
    spare: Option<State>,
    opt_in: bool,
}

impl FlipSolver {
    /// A box `[0, 1]²` of `n_grid²` cells with walls; particles at `x` moving at `v`, each
    /// of volume `volume` and density `density`; Young's modulus `e`, Poisson's ratio `nu`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        n_grid: usize,
        x: Vec<Vector2<f64>>,
        v: Vec<Vector2<f64>>,
        volume: f64,
        density: f64,
        e: f64,
        nu: f64,
        gravity: Vector2<f64>,
    ) -> Self {
        let grid = GridNd::new([Boundary::Fixed; 2], [n_grid; 2], [1.0; 2]);
        let n = x.len();
        let physics = Physics {
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            mu: e / (2.0 * (1.0 + nu)),
            gravity,
        };
        let mut committed = State {
            t: 0.0,
            step: 0,
            x,
            v,
            f: vec![Matrix2::identity(); n],
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
        let mass = vec![density * volume; n];
        let volume0 = vec![volume; n];
        particle_to_grid(&grid, physics, &mass, &volume0, &mut committed, true);
        Self {
            grid,
            physics,
            mass,
            volume0,
            committed,
            trial: None,
            spare: None,
            opt_in: true,
        }
    }

    /// Whether the views carry the pass's totals (the opt-in contract; default yes).
    pub fn with_summary(mut self, opt_in: bool) -> Self {
        self.opt_in = opt_in;
        self
    }

    /// The grid.
    pub fn grid(&self) -> &GridNd<2> {
        &self.grid
    }

    /// P-wave speed of the undeformed material, `√((λ + 2μ)/ρ)`.
    pub fn p_wave_speed(&self) -> f64 {
        ((self.physics.lambda + 2.0 * self.physics.mu) / self.committed.density[0]).sqrt()
    }

    /// Kinetic plus stored energy plus the potential above `y = 0`.
    pub fn total_energy(&self) -> f64 {
        let s = &self.committed;
        (0..s.x.len())
            .map(|p| {
                let m = self.mass[p];
                0.5 * m * s.v[p].norm_squared() - m * self.physics.gravity.dot(&s.x[p])
                    + self.volume0[p]
                        * energy_density(self.physics, &s.f[p], s.f[p].determinant().ln())
            })
            .sum()
    }

    /// Whether some particle's `det F` is not positive.
    pub fn inverted(&self) -> bool {
        self.committed.f.iter().any(|f| f.determinant() <= 0.0)
    }

    fn trial_from(&self, dt: f64, spare: Option<State>) -> Result<State, StepError> {
        let c = &self.committed;
        let grid = &self.grid;
        let n_cells = grid.cells[0] as i64;
        let mut s = spare.unwrap_or_else(|| c.clone());
        // 1. Grid update and walls, into the trial's nodal-velocity array.
        let mut vi = std::mem::take(&mut s.node_v);
        vi.clone_from(&c.node_v);
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
        // 2. Grid to particle (FLIP).
        s.t = c.t + dt;
        s.step = c.step + 1;
        let n = c.x.len();
        for vec in [&mut s.x, &mut s.v] {
            vec.resize(n, Vector2::zeros());
        }
        s.f.resize(n, Matrix2::zeros());
        let (lo, hi) = (grid.h[0], 1.0 - grid.h[0]);
        for p in 0..n {
            let (nodes, ws, gs) = (
                c.weights.nodes_of(p),
                c.weights.s_of(p),
                c.weights.grad_of(p),
            );
            let mut dv = Vector2::zeros();
            let mut vg = Vector2::zeros();
            let mut l = Matrix2::zeros();
            for k in 0..9 {
                let i = nodes[k] as usize;
                dv += ws[k] * (vi[i] - c.node_v[i]);
                vg += ws[k] * vi[i];
                l += vi[i] * gs[k].transpose();
            }
            s.v[p] = c.v[p] + dv;
            s.x[p] = c.x[p] + dt * vg;
            s.f[p] = (Matrix2::identity() + dt * l) * c.f[p];
            let j = s.f[p].determinant();
            if j.is_nan() || j <= 0.0 {
                return Err(StepError::Inverted {
                    index: p,
                    det_f: j,
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
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
        // 3. The new state's grid fields.
        s.node_v = vi;
        particle_to_grid(
            grid,
            self.physics,
            &self.mass,
            &self.volume0,
            &mut s,
            self.opt_in,
        );
        Ok(s)
    }

    fn view_of<'a>(&'a self, s: &'a State) -> ViewNd<'a, 2> {
        ViewNd {
            t: s.t,
            step: s.step,
            grid: &self.grid,
            x: &s.x,
            v: &s.v,
            sigma: tensors(&s.sigma),
            f: tensors(&s.f),
            volume0: &self.volume0,
            mass: &self.mass,
            lame_lambda: &s.lame_lambda,
            lame_mu: &s.lame_mu,
            density: &s.density,
            weights: (&s.weights).into(),
            node_mass: &s.node_mass,
            node_velocity: &s.node_v,
            node_acceleration: &s.node_a,
            node_active: &s.active,
            summary: if self.opt_in { s.summary } else { None },
            split: None,
        }
    }
}

/// `Matrix2<f64>` is `nd::Tensor<2>`.
fn tensors(v: &[Matrix2<f64>]) -> &[Tensor<2>] {
    v
}

/// Stored energy per reference volume: `μ/2 (tr(FᵀF) − 2) − μ ln J + λ/2 (ln J)²`.
fn energy_density(ph: Physics, f: &Matrix2<f64>, ln_j: f64) -> f64 {
    0.5 * ph.mu * (f.norm_squared() - 2.0) - ph.mu * ln_j + 0.5 * ph.lambda * ln_j * ln_j
}

/// Quadratic B-spline weights and derivatives on one axis: base node, weights, and
/// derivatives (1/length).
fn bspline(x: f64, h: f64) -> (i64, [f64; 3], [f64; 3]) {
    let xi = x / h;
    let base = (xi - 0.5).floor();
    let fx = xi - base;
    let w = [
        0.5 * (1.5 - fx).powi(2),
        0.75 - (fx - 1.0).powi(2),
        0.5 * (fx - 0.5).powi(2),
    ];
    let d = [(fx - 1.5) / h, -2.0 * (fx - 1.0) / h, (fx - 0.5) / h];
    (base as i64, w, d)
}

/// The new state's stress, tangent, weights and grid fields from its particle fields
/// (step 3 of the module docs); with `summarize`, also its [`SummaryNd`].
fn particle_to_grid(
    grid: &GridNd<2>,
    ph: Physics,
    mass: &[f64],
    volume0: &[f64],
    s: &mut State,
    summarize: bool,
) {
    let h = grid.h[0];
    let nn = grid.n_nodes();
    for (v, len) in [(&mut s.node_v, nn), (&mut s.node_a, nn)] {
        v.clear();
        v.resize(len, Vector2::zeros());
    }
    s.node_mass.clear();
    s.node_mass.resize(nn, 0.0);
    let n = s.x.len();
    for v in [&mut s.density, &mut s.lame_lambda, &mut s.lame_mu] {
        v.resize(n, 0.0);
    }
    s.sigma.resize(n, Matrix2::zeros());
    let mut totals = summarize.then(Totals::default);
    let (nodes, ws, grads) = s.weights.storage_mut(n);
    for p in 0..n {
        let (bx, wx, dx) = bspline(s.x[p][0], h);
        let (by, wy, dy) = bspline(s.x[p][1], h);
        let f = s.f[p];
        let j = f.determinant();
        let ln_j = j.ln();
        let sigma = (ph.mu * (f * f.transpose() - Matrix2::identity())
            + Matrix2::identity() * (ph.lambda * ln_j))
            / j;
        s.sigma[p] = sigma;
        s.density[p] = mass[p] / (volume0[p] * j);
        s.lame_lambda[p] = ph.lambda / j;
        s.lame_mu[p] = (ph.mu - ph.lambda * ln_j) / j;
        let vol = j * volume0[p];
        for a in 0..3 {
            for b in 0..3 {
                let k = p * 9 + a * 3 + b;
                let node = grid.flat_index([bx + a as i64, by + b as i64]).unwrap_or(0);
                let w = wx[a] * wy[b];
                let g = Vector2::new(dx[a] * wy[b], wx[a] * dy[b]);
                nodes[k] = node as u32;
                ws[k] = w;
                grads[k] = g;
                s.node_mass[node] += w * mass[p];
                s.node_v[node] += w * mass[p] * s.v[p];
                s.node_a[node] -= vol * (sigma * g);
            }
        }
        if let Some(t) = totals.as_mut() {
            let (l, m) = (s.lame_lambda[p], s.lame_mu[p]);
            let metric = [metric_of(&wx, &dx), metric_of(&wy, &dy)];
            t.add(
                0.5 * mass[p] * s.v[p].norm_squared(),
                mass[p] * s.x[p],
                volume0[p] * energy_density(ph, &f, ln_j),
                from_metric::<2>(
                    metric[0].max(metric[1]),
                    metric[0] + metric[1],
                    vol / mass[p],
                    l,
                    m,
                ),
                h / (((l + 2.0 * m) / s.density[p]).sqrt() + s.v[p].amax()),
                // One non-finite entry makes the sum non-finite.
                (s.x[p].sum() + s.v[p].sum() + f.sum()).is_finite(),
            );
        }
    }
    s.active.clear();
    s.active.resize(nn, false);
    for i in 0..nn {
        let m = s.node_mass[i];
        if m > 0.0 {
            s.active[i] = true;
            s.node_v[i] /= m;
            s.node_a[i] = s.node_a[i] / m + ph.gravity;
        }
    }
    s.summary = totals.map(Totals::finish);
}

/// One axis's share of the gradient metric `H_p = Σ_i ∇S_ip ∇S_ipᵀ/S_ip`: for tensor-product
/// weights `S = s_x s_y` (each axis summing to one, its derivatives to zero) `H_p` is
/// diagonal with `H_aa = Σ_k s'_k²/s_k` over the axis's three weights.
fn metric_of(w: &[f64; 3], d: &[f64; 3]) -> f64 {
    (0..3).map(|k| d[k] * d[k] / w[k]).sum()
}

/// The totals of a pass (the opt-in contract).
#[derive(Default)]
struct Totals {
    kinetic: f64,
    first_moment: Vector2<f64>,
    strain: f64,
    bound: f64,
    unit_step: Option<f64>,
    not_finite: bool,
}

impl Totals {
    fn add(
        &mut self,
        kinetic: f64,
        moment: Vector2<f64>,
        strain: f64,
        bound: f64,
        unit: f64,
        finite: bool,
    ) {
        self.kinetic += kinetic;
        self.first_moment += moment;
        self.strain += strain;
        if bound.is_nan() || bound > self.bound {
            self.bound = bound;
        }
        self.unit_step = Some(self.unit_step.map_or(unit, |u| u.min(unit)));
        self.not_finite |= !finite || !unit.is_finite();
    }

    fn finish(self) -> SummaryNd<2> {
        SummaryNd {
            finite: !self.not_finite && self.bound.is_finite(),
            kinetic: self.kinetic,
            strain: self.strain,
            first_moment: Vector::<2>::new(self.first_moment[0], self.first_moment[1]),
            element_bound: Some(self.bound),
            sound_unit_step: self.unit_step,
        }
    }
}

impl Stepper<2> for FlipSolver {
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
