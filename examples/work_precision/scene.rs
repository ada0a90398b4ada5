//! A scene of the diagram: a 1D scenario on the 1D reference solver, a 2D/3D one on the
//! d-dimensional solver, or taichi's mpm88 jelly or fluid on the MLS-MPM solver of
//! `mls_mpm` (`mpm88-jelly`, `mpm88-fluid`: 8 192 particles, 128² cells, to t = 0.5, its
//! controller told the APIC transfer, the total energy kinetic + elastic + potential above
//! the floor), with what the error measures need (its particles, its initial energy and
//! mass, its end time) and, for mpm88, its shipped step `2·10⁻⁴`.

use super::measure::Scales;
use super::mpm88::{self, MPM88_DT};
use super::runs::{run_1d, run_nd, EndState, Policy};
use super::solver::MlsMpm;
use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::SolverNd;
use mpm_dt::scenario::Scenario;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};

#[path = "../common/controller_nd.rs"]
mod controller_nd;

/// A scene, its controller config and its scales.
pub struct Scene {
    kind: Kind,
    /// The scenario's controller config (the defaults when it has none).
    pub config: ControllerConfig,
    /// Particles.
    pub particles: usize,
    /// The error measures' scales.
    pub scales: Scales,
    /// End time.
    pub t_end: f64,
    /// The scene's shipped fixed step, if it has one.
    pub shipped_dt: Option<f64>,
    /// Whether the 1D reference solver runs with the staggered kick
    /// (`ReferenceStepper::set_staggered_kick`; `--staggered-kick`).
    pub staggered_kick: bool,
}

enum Kind {
    One(Box<Scenario>),
    Two(Box<ScenarioNd>),
    Three(Box<ScenarioNd>),
    Mpm88(mpm88::Scene),
}

impl Scene {
    /// Whether the scene runs the 1D reference solver (the only one with a staggered kick).
    pub fn is_one_d(&self) -> bool {
        matches!(self.kind, Kind::One(_))
    }
}

fn mpm88_energy(s: &MlsMpm) -> f64 {
    let (k, e, p) = s.energies();
    k + e + p
}

fn nd_totals<const D: usize>(s: &SolverNd<D>) -> (usize, f64, f64)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let mass = s.view().mass.iter().sum();
    (s.n_particles(), s.total_energy(), mass)
}

impl Scene {
    /// Reads the scenario file at `path` (any dimension), or sets up `mpm88-jelly` /
    /// `mpm88-fluid`.
    pub fn open(path: &str) -> Result<Self, String> {
        if let Some(kind) = path.strip_prefix("mpm88-") {
            return Ok(Self::mpm88(kind == "fluid"));
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
        let dim = ScenarioNd::dim_of(&text).map_err(|e| e.to_string())?;
        let (kind, config, (n, e0, mass), t_end) = if dim == 1 {
            let s = Scenario::from_json(&text).map_err(|e| e.to_string())?;
            let solver = s.build().map_err(|e| e.to_string())?;
            let totals = (
                solver.n_particles(),
                solver.total_energy(),
                solver.total_mass(),
            );
            let config = s.controller_config().map_err(|e| e.to_string())?;
            let t_end = s.t_end;
            (Kind::One(Box::new(s)), config, totals, t_end)
        } else {
            let s = ScenarioNd::from_json(&text).map_err(|e| e.to_string())?;
            let config = s.controller_config().map_err(|e| e.to_string())?;
            let totals = match dim {
                2 => nd_totals(&s.build::<2>().map_err(|e| e.to_string())?.0),
                _ => nd_totals(&s.build::<3>().map_err(|e| e.to_string())?.0),
            };
            let t_end = s.t_end;
            let kind = if dim == 2 {
                Kind::Two(Box::new(s))
            } else {
                Kind::Three(Box::new(s))
            };
            (kind, config, totals, t_end)
        };
        if !(e0 > 0.0 && mass > 0.0) {
            return Err(format!(
                "the scene has no motion to measure (energy {e0:e}, mass {mass:e})"
            ));
        }
        Ok(Self {
            kind,
            config,
            particles: n,
            scales: Scales::new(e0, mass, t_end),
            t_end,
            shipped_dt: None,
            staggered_kick: false,
        })
    }

    /// mpm88's scene (module docs).
    fn mpm88(fluid: bool) -> Self {
        let scene = mpm88::Scene {
            n_grid: 128,
            t_end: 0.5,
            fluid,
            apic: true,
            summary: true,
        };
        let s = mpm88::build(scene);
        let mass: f64 = mpm_dt::Stepper::view(&s).mass.iter().sum();
        Self {
            kind: Kind::Mpm88(scene),
            config: ControllerConfig::default(),
            particles: mpm_dt::Stepper::view(&s).x.len(),
            scales: Scales::new(mpm88_energy(&s), mass, scene.t_end),
            t_end: scene.t_end,
            shipped_dt: Some(MPM88_DT),
            staggered_kick: false,
        }
    }

    /// The same scene run to `t_end` instead of its own end time (the length scale
    /// `U·t_end` follows).
    pub fn until(mut self, t_end: f64) -> Self {
        self.scales.length = self.scales.velocity * t_end;
        self.t_end = t_end;
        self
    }

    /// Runs the scene under `policy` to its end.
    pub fn run(&self, policy: Policy) -> Result<EndState, String> {
        match &self.kind {
            Kind::One(s) => run_1d(s, policy, &self.config, self.staggered_kick),
            Kind::Two(s) => self.run_nd::<2>(s, policy),
            Kind::Three(s) => self.run_nd::<3>(s, policy),
            Kind::Mpm88(scene) => {
                // Fixed-step runs compute neither the pass totals nor the tangent moduli
                // (as in `mls_mpm`).
                let controlled = matches!(policy, Policy::Controller(_));
                let solver = mpm88::build(mpm88::Scene {
                    summary: controlled,
                    ..*scene
                });
                let solver = if controlled {
                    solver
                } else {
                    solver.without_views()
                };
                let controller = |c: ControllerConfig| {
                    Controller::<2>::standard(mpm88::controller_config(*scene, &c))
                        .map_err(|e| e.to_string())
                };
                run_nd(
                    solver,
                    policy,
                    self.t_end,
                    &self.config,
                    &controller,
                    &mpm88_energy,
                )
            }
        }
    }

    fn run_nd<const D: usize>(&self, s: &ScenarioNd, policy: Policy) -> Result<EndState, String>
    where
        Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
        SolverNd<D>: Stepper<D>,
    {
        let (solver, _) = s.build::<D>().map_err(|e| e.to_string())?;
        let controller = |c| controller_nd::controller_for::<D>(s, c, None);
        run_nd(
            solver,
            policy,
            self.t_end,
            &self.config,
            &controller,
            &|s: &SolverNd<D>| s.total_energy(),
        )
    }
}
