//! A scene of the diagram: a 1D scenario on the 1D reference solver, or a 2D/3D one on the
//! d-dimensional solver, with what the error measures need (its particles, its initial
//! energy and mass, its end time).

use super::measure::Scales;
use super::runs::{run_1d, run_nd, EndState, Policy};
use mpm_dt::controller::ControllerConfig;
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
}

enum Kind {
    One(Box<Scenario>),
    Two(Box<ScenarioNd>),
    Three(Box<ScenarioNd>),
}

fn nd_totals<const D: usize>(s: &SolverNd<D>) -> (usize, f64, f64)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mass = s.view().mass.iter().sum();
    (s.n_particles(), s.total_energy(), mass)
}

impl Scene {
    /// Reads the scenario file at `path` (any dimension).
    pub fn open(path: &str) -> Result<Self, String> {
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
        })
    }

    /// Runs the scene under `policy` to its end.
    pub fn run(&self, policy: Policy) -> Result<EndState, String> {
        match &self.kind {
            Kind::One(s) => run_1d(s, policy, &self.config),
            Kind::Two(s) => self.run_nd::<2>(s, policy),
            Kind::Three(s) => self.run_nd::<3>(s, policy),
        }
    }

    fn run_nd<const D: usize>(&self, s: &ScenarioNd, policy: Policy) -> Result<EndState, String>
    where
        Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
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
