//! Hand-built states (Views) for the stability tests: layouts of particles on a grid with
//! nodal masses by eq 7, independent of any solver.
#![allow(dead_code)]

use mpm_dt::stability::{Eq56Operator, NodalOperator};
use mpm_dt::{Boundary, Grid, NodalStiffness, Shape, View, WeightKind, Weights};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The eq 56 critical step of a view from the dense eigenvalue: the reference the tracked
/// proposals are checked against.
pub fn dense_dt56(view: &View<'_>) -> f64 {
    let op = Eq56Operator::new(view).expect("valid view");
    Eq56Operator::critical_dt(op.dense_lambda_max().expect("dense eigenvalue"))
}

/// An owned state that lends a [`View`].
#[derive(Clone)]
pub struct Fixture {
    pub grid: Grid,
    pub shape: Shape,
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub sigma: Vec<f64>,
    pub f: Vec<f64>,
    pub volume0: Vec<f64>,
    pub mass: Vec<f64>,
    pub modulus: Vec<f64>,
    pub density: Vec<f64>,
    pub weights: Weights,
    pub node_mass: Vec<f64>,
    pub node_velocity: Vec<f64>,
    pub node_acceleration: Vec<f64>,
    pub node_active: Vec<bool>,
    /// `K_N` handed to the view as a stepper would (`None`: the library assembles it).
    pub stiffness: Option<NodalStiffness>,
}

impl Fixture {
    /// Particles at `x` on `grid` with density `rho`, modulus `e`, volumes `L/n` (GIMP width
    /// = volume), σ = 0, v = 0, F = 1.
    pub fn new(grid: Grid, shape: Shape, x: Vec<f64>, rho: f64, e: f64) -> Self {
        let n = x.len();
        let vol = grid.length() / n as f64;
        let mut fx = Self {
            grid,
            shape,
            v: vec![0.0; n],
            sigma: vec![0.0; n],
            f: vec![1.0; n],
            volume0: vec![vol; n],
            mass: vec![rho * vol; n],
            modulus: vec![e; n],
            density: vec![rho; n],
            x,
            weights: Weights::default(),
            node_mass: Vec::new(),
            node_velocity: Vec::new(),
            node_acceleration: Vec::new(),
            node_active: Vec::new(),
            stiffness: None,
        };
        fx.refresh();
        fx
    }

    /// Recomputes weights and nodal masses after changing `x`, `mass`, `volume0`.
    pub fn refresh(&mut self) {
        let widths = self.volume0.clone();
        self.weights = Weights::compute(&self.grid, self.shape, &self.x, &widths);
        let nn = self.grid.n_nodes();
        self.node_mass = vec![0.0; nn];
        self.weights
            .scatter(WeightKind::S, &self.mass, &mut self.node_mass);
        let mmax = self.node_mass.iter().cloned().fold(0.0, f64::max);
        self.node_active = (0..nn)
            .map(|i| !self.grid.is_constrained(i) && self.node_mass[i] > 1e-12 * mmax)
            .collect();
        self.node_velocity = vec![0.0; nn];
        self.node_acceleration = vec![0.0; nn];
        if self.stiffness.is_some() {
            self.provide_stiffness();
        }
    }

    /// [`Self::provide_stiffness`] when `provide`.
    pub fn with_stiffness(mut self, provide: bool) -> Self {
        if provide {
            self.provide_stiffness();
        }
        self
    }

    /// From now on the view carries `K_N` (assembled from the weights, as
    /// [`NodalOperator`] does for a view without it), so the trackers take the path they
    /// take under a stepper that accumulates it.
    pub fn provide_stiffness(&mut self) {
        self.stiffness = None;
        let op = NodalOperator::new(&self.view()).expect("valid fixture");
        self.stiffness = Some(op.stiffness().clone());
    }

    pub fn view(&self) -> View<'_> {
        View {
            t: 0.0,
            step: 0,
            grid: &self.grid,
            x: &self.x,
            v: &self.v,
            sigma: &self.sigma,
            f: &self.f,
            volume0: &self.volume0,
            mass: &self.mass,
            tangent_modulus: &self.modulus,
            density: &self.density,
            weights: (&self.weights).into(),
            node_mass: &self.node_mass,
            node_velocity: &self.node_velocity,
            node_acceleration: &self.node_acceleration,
            node_active: &self.node_active,
            nodal_stiffness: self.stiffness.as_ref(),
            summary: None,
        }
    }
}

/// The linear-hat collapse of the stability tests: two particles per cell on `cells` cells,
/// and the layout they slide into, where node 11's mass is 1.5 % of a typical node's.
pub fn collapse_layouts(cells: usize) -> (Vec<f64>, Vec<f64>) {
    (uniform(cells, 1.0, 2), small_mass(cells, 1.0, 11))
}

/// `ppc` evenly spaced particles per cell (at the centres of `ppc` sub-cells).
pub fn uniform(cells: usize, length: f64, ppc: usize) -> Vec<f64> {
    let h = length / cells as f64;
    (0..cells * ppc)
        .map(|k| (k as f64 + 0.5) * h / ppc as f64)
        .collect()
}

/// Uniform positions moved by up to `amp` of the sub-cell spacing, seeded.
pub fn jittered(cells: usize, length: f64, ppc: usize, amp: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d = length / (cells * ppc) as f64;
    uniform(cells, length, ppc)
        .into_iter()
        .map(|x| x + amp * d * (rng.random::<f64>() - 0.5))
        .collect()
}

/// Two particles per cell, with the four particles around node `k` pushed away from it so that
/// its linear-hat mass is 1.5 % of a typical node's.
pub fn small_mass(cells: usize, length: f64, k: usize) -> Vec<f64> {
    let h = length / cells as f64;
    let mut x = uniform(cells, length, 2);
    let xk = k as f64 * h;
    x[2 * (k - 1)] = xk - h + 0.005 * h;
    x[2 * (k - 1) + 1] = xk - h + 0.01 * h;
    x[2 * k] = xk + h - 0.01 * h;
    x[2 * k + 1] = xk + h - 0.005 * h;
    x
}

pub fn periodic(cells: usize, length: f64) -> Grid {
    Grid::new(Boundary::Periodic, cells, length)
}

pub fn fixed(cells: usize, length: f64) -> Grid {
    Grid::new(Boundary::Fixed, cells, length)
}

/// The layout a fraction `a ∈ [0, 1]` of the way from `start` to `end`, particle by particle
/// (the collapsing linear-hat layouts of the tracking tests).
pub fn interpolate(start: &[f64], end: &[f64], a: f64) -> Vec<f64> {
    start
        .iter()
        .zip(end)
        .map(|(x0, x1)| x0 + a * (x1 - x0))
        .collect()
}
