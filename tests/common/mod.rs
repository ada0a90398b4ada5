//! Mock steppers and limits shared by the controller tests.
//!
//! `MockStepper` is a small, self-contained 1D update-stress-last MPM solver (eqs 17–29)
//! on a periodic grid, written only against the public `Stepper`/`View`/`Weights` API, with
//! fault injection for the adversarial tests.
#![allow(dead_code)]

use mpm_dt::limit::{Judgement, LimitError, Metrics, Proposal, RejectCause, StepLimit, Verdict};
use mpm_dt::{Boundary, Grid, Shape, StepError, Stepper, View, WeightKind, Weights};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The primary fields of a state (what a checkpoint stores).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fields {
    pub t: f64,
    pub step: u64,
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub sigma: Vec<f64>,
    pub f: Vec<f64>,
}

/// A state with its derived nodal fields.
#[derive(Clone, Debug)]
pub struct State {
    pub fields: Fields,
    pub weights: Weights,
    pub tangent: Vec<f64>,
    pub density: Vec<f64>,
    pub node_mass: Vec<f64>,
    pub node_v: Vec<f64>,
    pub node_a: Vec<f64>,
    pub node_active: Vec<bool>,
}

/// Fault injection.
#[derive(Clone, Debug, Default)]
pub struct Faults {
    /// Every `try_step` fails.
    pub always_fail: bool,
    /// Trials with `dt` above this produce a NaN velocity (a crude instability).
    pub nan_above_dt: Option<f64>,
    /// Trials produce NaN with this probability (seeded).
    pub nan_probability: f64,
    /// Trials produce +∞ stress with this probability (seeded).
    pub inf_probability: f64,
}

pub struct MockStepper {
    pub grid: Grid,
    pub shape: Shape,
    pub youngs: f64,
    pub mass: Vec<f64>,
    pub volume0: Vec<f64>,
    pub width: Vec<f64>,
    pub committed: State,
    pub trial: Option<State>,
    pub faults: Faults,
    rng: ChaCha8Rng,
}

impl MockStepper {
    /// A periodic bar of length 1, `cells` cells, `ppc` particles per cell (jittered by
    /// `jitter` × spacing with a seeded RNG), density 1, standing wave `v = A sin(2πx)`.
    pub fn standing_wave(
        cells: usize,
        ppc: usize,
        youngs: f64,
        amplitude: f64,
        shape: Shape,
        jitter: f64,
        seed: u64,
    ) -> Self {
        let grid = Grid::new(Boundary::Periodic, cells, 1.0);
        let n = cells * ppc;
        let dx = 1.0 / n as f64;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x: Vec<f64> = (0..n)
            .map(|p| (p as f64 + 0.5) * dx + jitter * dx * (rng.random::<f64>() - 0.5))
            .collect();
        let c = youngs.sqrt();
        let v: Vec<f64> = x
            .iter()
            .map(|&x| amplitude * c * (2.0 * std::f64::consts::PI * x).sin())
            .collect();
        let fields = Fields {
            t: 0.0,
            step: 0,
            x,
            v,
            sigma: vec![0.0; n],
            f: vec![1.0; n],
        };
        Self::from_fields(grid, shape, youngs, fields, seed)
    }

    pub fn from_fields(grid: Grid, shape: Shape, youngs: f64, fields: Fields, seed: u64) -> Self {
        let n = fields.x.len();
        let vol = grid.length() / n as f64;
        let mass = vec![vol; n];
        let volume0 = vec![vol; n];
        let width = vec![vol; n];
        let committed = derive(&grid, shape, youngs, &mass, &volume0, &width, fields);
        Self {
            grid,
            shape,
            youngs,
            mass,
            volume0,
            width,
            committed,
            trial: None,
            faults: Faults::default(),
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x5eed),
        }
    }

    /// Changes the Young's modulus (a sudden stiffness jump) from the committed state on.
    pub fn set_youngs(&mut self, youngs: f64) {
        self.youngs = youngs;
        self.trial = None;
        let fields = self.committed.fields.clone();
        self.committed = derive(
            &self.grid,
            self.shape,
            youngs,
            &self.mass,
            &self.volume0,
            &self.width,
            fields,
        );
    }

    pub fn energy(&self) -> f64 {
        let s = &self.committed;
        (0..s.fields.x.len())
            .map(|p| {
                0.5 * self.mass[p] * s.fields.v[p].powi(2)
                    + 0.5 * s.fields.sigma[p].powi(2) * self.volume0[p] * s.fields.f[p]
                        / self.youngs
            })
            .sum()
    }
}

pub fn derive(
    grid: &Grid,
    shape: Shape,
    youngs: f64,
    mass: &[f64],
    volume0: &[f64],
    width: &[f64],
    fields: Fields,
) -> State {
    let n = fields.x.len();
    let nn = grid.n_nodes();
    let finite = fields
        .x
        .iter()
        .chain(&fields.v)
        .chain(&fields.sigma)
        .chain(&fields.f)
        .all(|v| v.is_finite());
    let xs: Vec<f64> = if finite {
        fields.x.iter().map(|&x| grid.wrap(x)).collect()
    } else {
        vec![0.5; n]
    };
    let weights = Weights::compute(grid, shape, &xs, width);
    let mut node_mass = vec![0.0; nn];
    weights.scatter(WeightKind::S, mass, &mut node_mass);
    let mom: Vec<f64> = (0..n).map(|p| mass[p] * fields.v[p]).collect();
    let mut node_mom = vec![0.0; nn];
    weights.scatter(WeightKind::S, &mom, &mut node_mom);
    let inner: Vec<f64> = (0..n)
        .map(|p| fields.sigma[p] * fields.f[p] * volume0[p])
        .collect();
    let mut node_f = vec![0.0; nn];
    weights.scatter(WeightKind::D, &inner, &mut node_f);
    let mmax = node_mass.iter().cloned().fold(0.0, f64::max);
    let node_active: Vec<bool> = node_mass.iter().map(|&m| m > 1e-12 * mmax).collect();
    let node_v: Vec<f64> = (0..nn)
        .map(|i| {
            if node_active[i] {
                node_mom[i] / node_mass[i]
            } else {
                0.0
            }
        })
        .collect();
    let node_a: Vec<f64> = (0..nn)
        .map(|i| {
            if node_active[i] {
                -node_f[i] / node_mass[i]
            } else {
                0.0
            }
        })
        .collect();
    let density: Vec<f64> = (0..n)
        .map(|p| mass[p] / (fields.f[p] * volume0[p]))
        .collect();
    State {
        fields,
        weights,
        tangent: vec![youngs; n],
        density,
        node_mass,
        node_v,
        node_a,
        node_active,
    }
}

fn view_of<'a>(s: &'a State, grid: &'a Grid, m: &'a MockStepper) -> View<'a> {
    View {
        t: s.fields.t,
        step: s.fields.step,
        grid,
        x: &s.fields.x,
        v: &s.fields.v,
        sigma: &s.fields.sigma,
        f: &s.fields.f,
        volume0: &m.volume0,
        mass: &m.mass,
        tangent_modulus: &s.tangent,
        density: &s.density,
        weights: (&s.weights).into(),
        node_mass: &s.node_mass,
        node_velocity: &s.node_v,
        node_acceleration: &s.node_a,
        node_active: &s.node_active,
        nodal_stiffness: None,
        summary: None,
    }
}

impl Stepper for MockStepper {
    fn time(&self) -> f64 {
        self.committed.fields.t
    }
    fn step_count(&self) -> u64 {
        self.committed.fields.step
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.trial = None;
        let c = &self.committed;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidDt { dt, t: c.fields.t });
        }
        if self.faults.always_fail {
            return Err(StepError::Other("mock stepper always fails".into()));
        }
        let n = c.fields.x.len();
        let nn = self.grid.n_nodes();
        let node_v1: Vec<f64> = (0..nn).map(|i| c.node_v[i] + dt * c.node_a[i]).collect();
        let mut ap = vec![0.0; n];
        c.weights.gather(WeightKind::S, &c.node_a, &mut ap);
        let mut l = vec![0.0; n];
        c.weights.gather(WeightKind::D, &node_v1, &mut l);
        let mut f = c.fields.clone();
        f.t = c.fields.t + dt;
        f.step += 1;
        for p in 0..n {
            f.v[p] += dt * ap[p];
            f.f[p] += dt * l[p] * c.fields.f[p];
            f.sigma[p] += dt * self.youngs * l[p];
            f.x[p] = self.grid.wrap(f.x[p] + dt * f.v[p]);
        }
        if self.faults.nan_above_dt.is_some_and(|lim| dt > lim)
            || (self.faults.nan_probability > 0.0
                && self.rng.random::<f64>() < self.faults.nan_probability)
        {
            f.v[n / 2] = f64::NAN;
        }
        if self.faults.inf_probability > 0.0
            && self.rng.random::<f64>() < self.faults.inf_probability
        {
            f.sigma[0] = f64::INFINITY;
        }
        self.trial = Some(derive(
            &self.grid,
            self.shape,
            self.youngs,
            &self.mass,
            &self.volume0,
            &self.width,
            f,
        ));
        Ok(())
    }
    fn accept(&mut self) -> Result<(), StepError> {
        match self.trial.take() {
            Some(t) => {
                self.committed = t;
                Ok(())
            }
            None => Err(StepError::NoTrial),
        }
    }
    fn reject(&mut self) {
        self.trial = None;
    }
    fn view(&self) -> View<'_> {
        view_of(&self.committed, &self.grid, self)
    }
    fn trial_view(&self) -> Option<View<'_>> {
        self.trial.as_ref().map(|s| view_of(s, &self.grid, self))
    }
}

/// Eq 49 generalised: `dt ≤ α h / (c + |v|max)` (a test stand-in for the real sound-speed
/// limit).
pub struct SoundSpeedMock {
    pub alpha: f64,
    pub safety_scale: f64,
}

impl StepLimit for SoundSpeedMock {
    fn name(&self) -> &str {
        "sound_speed_mock"
    }
    fn propose(&mut self, s: &View<'_>) -> Result<Proposal, LimitError> {
        let c = (0..s.n_particles())
            .map(|p| s.wave_speed(p))
            .fold(0.0, f64::max);
        let vmax = s.v.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        Ok(Proposal {
            dt: self.safety_scale * self.alpha * s.grid.h / (c + vmax),
            metrics: Metrics::new(),
        })
    }
    fn scale_safety(&mut self, factor: f64) {
        self.safety_scale *= factor;
    }
}

/// Proposes a fixed sequence of steps (cycled), for property tests.
pub struct ScriptedLimit {
    pub name: String,
    pub proposals: Vec<f64>,
    pub k: usize,
}

impl StepLimit for ScriptedLimit {
    fn name(&self) -> &str {
        &self.name
    }
    fn propose(&mut self, _s: &View<'_>) -> Result<Proposal, LimitError> {
        let dt = self.proposals[self.k % self.proposals.len()];
        self.k += 1;
        Ok(Proposal {
            dt,
            metrics: Metrics::new(),
        })
    }
}

/// Reports random error estimates `dsm ∈ [0, max)` (seeded) and rejects when `dsm > 1`.
pub struct RandomError {
    pub rng: ChaCha8Rng,
    pub max: f64,
}

impl StepLimit for RandomError {
    fn name(&self) -> &str {
        "random_error"
    }
    fn propose(&mut self, _s: &View<'_>) -> Result<Proposal, LimitError> {
        Ok(Proposal::no_opinion())
    }
    fn judge(&mut self, _b: &View<'_>, _a: &View<'_>, _dt: f64) -> Result<Judgement, LimitError> {
        let dsm = self.rng.random::<f64>() * self.max;
        let mut metrics = Metrics::new();
        metrics.insert("dsm".into(), dsm);
        let verdict = if dsm <= 1.0 {
            Verdict::Accept
        } else {
            Verdict::Reject {
                cause: RejectCause::Error,
                suggested_dt: None,
            }
        };
        Ok(Judgement { verdict, metrics })
    }
}

/// Vetoes every trial.
pub struct AlwaysVeto;

impl StepLimit for AlwaysVeto {
    fn name(&self) -> &str {
        "veto"
    }
    fn propose(&mut self, _s: &View<'_>) -> Result<Proposal, LimitError> {
        Ok(Proposal::no_opinion())
    }
    fn judge(&mut self, _b: &View<'_>, _a: &View<'_>, _dt: f64) -> Result<Judgement, LimitError> {
        Ok(Judgement {
            verdict: Verdict::Reject {
                cause: RejectCause::UserVeto,
                suggested_dt: None,
            },
            metrics: Metrics::new(),
        })
    }
}

pub fn all_finite(m: &MockStepper) -> bool {
    let f = &m.committed.fields;
    f.x.iter()
        .chain(&f.v)
        .chain(&f.sigma)
        .chain(&f.f)
        .all(|v| v.is_finite())
}
