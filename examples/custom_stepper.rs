//! A stepper written outside the library, driven by the library's controller.
//!
//! ```text
//! cargo run --release --example custom_stepper [-- --json]
//! ```
//!
//! `UserMpm` below is a user's own small 1D MPM code (update-stress-last, linear-hat
//! weights, periodic bar, double-buffered state). To be driven by
//! [`mpm_dt::controller::Controller`] it implements only the [`Stepper`] trait: trial step,
//! accept, reject, and a read-only [`View`] of its fields. The user also adds a limit of
//! their own (a sound-speed CFL step `α h/(c + |v|max)` written here as a [`StepLimit`]);
//! the controller adds its temporal error limit and growth monitor. Nothing else of the
//! library is needed: no reference solver, no scenario file.

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::limit::{LimitError, Metrics, Proposal, StepLimit};
use mpm_dt::{Boundary, Grid, Shape, StepError, Stepper, View, WeightKind, Weights};
use std::process::ExitCode;

/// One state of the user's solver: particle fields plus the nodal fields the next step
/// starts from.
#[derive(Clone)]
struct UserState {
    t: f64,
    step: u64,
    x: Vec<f64>,
    v: Vec<f64>,
    sigma: Vec<f64>,
    f: Vec<f64>,
    weights: Weights,
    node_mass: Vec<f64>,
    node_v: Vec<f64>,
    node_a: Vec<f64>,
    active: Vec<bool>,
    density: Vec<f64>,
}

/// The user's solver.
struct UserMpm {
    grid: Grid,
    youngs: f64,
    mass: Vec<f64>,
    volume0: Vec<f64>,
    tangent: Vec<f64>,
    committed: UserState,
    trial: Option<UserState>,
}

impl UserMpm {
    /// A periodic bar of unit length and density, `cells` cells, `ppc` particles per cell,
    /// released from `v = A c sin(2πx)`.
    fn new(cells: usize, ppc: usize, youngs: f64, amplitude: f64) -> Self {
        let grid = Grid::new(Boundary::Periodic, cells, 1.0);
        let n = cells * ppc;
        let vol = 1.0 / n as f64;
        let c = youngs.sqrt();
        let x: Vec<f64> = (0..n).map(|p| (p as f64 + 0.5) * vol).collect();
        let v = x
            .iter()
            .map(|x| amplitude * c * (std::f64::consts::TAU * x).sin())
            .collect();
        let mass = vec![vol; n];
        let volume0 = vec![vol; n];
        let committed = Self::nodal(
            &grid,
            &mass,
            &volume0,
            0.0,
            0,
            x,
            v,
            vec![0.0; n],
            vec![1.0; n],
        );
        Self {
            grid,
            youngs,
            mass,
            volume0,
            tangent: vec![youngs; n],
            committed,
            trial: None,
        }
    }

    /// Weights at `x` and the nodal mass, velocity and acceleration (the usual P2G).
    #[allow(clippy::too_many_arguments)]
    fn nodal(
        grid: &Grid,
        mass: &[f64],
        volume0: &[f64],
        t: f64,
        step: u64,
        x: Vec<f64>,
        v: Vec<f64>,
        sigma: Vec<f64>,
        f: Vec<f64>,
    ) -> UserState {
        let n = x.len();
        let nn = grid.n_nodes();
        let weights = Weights::compute(grid, Shape::Linear, &x, volume0);
        let mut node_mass = vec![0.0; nn];
        weights.scatter(WeightKind::S, mass, &mut node_mass);
        let mom: Vec<f64> = (0..n).map(|p| mass[p] * v[p]).collect();
        let mut node_mom = vec![0.0; nn];
        weights.scatter(WeightKind::S, &mom, &mut node_mom);
        let inner: Vec<f64> = (0..n).map(|p| sigma[p] * f[p] * volume0[p]).collect();
        let mut node_force = vec![0.0; nn];
        weights.scatter(WeightKind::D, &inner, &mut node_force);
        let active: Vec<bool> = node_mass.iter().map(|&m| m > 1e-12).collect();
        let node_v = (0..nn)
            .map(|i| {
                if active[i] {
                    node_mom[i] / node_mass[i]
                } else {
                    0.0
                }
            })
            .collect();
        let node_a = (0..nn)
            .map(|i| {
                if active[i] {
                    -node_force[i] / node_mass[i]
                } else {
                    0.0
                }
            })
            .collect();
        let density = (0..n).map(|p| mass[p] / (f[p] * volume0[p])).collect();
        UserState {
            t,
            step,
            x,
            v,
            sigma,
            f,
            weights,
            node_mass,
            node_v,
            node_a,
            active,
            density,
        }
    }

    fn view_of<'a>(&'a self, s: &'a UserState) -> View<'a> {
        View {
            t: s.t,
            step: s.step,
            grid: &self.grid,
            x: &s.x,
            v: &s.v,
            sigma: &s.sigma,
            f: &s.f,
            volume0: &self.volume0,
            mass: &self.mass,
            tangent_modulus: &self.tangent,
            density: &s.density,
            weights: (&s.weights).into(),
            node_mass: &s.node_mass,
            node_velocity: &s.node_v,
            node_acceleration: &s.node_a,
            node_active: &s.active,
            nodal_stiffness: None,
            summary: None,
        }
    }
}

impl Stepper for UserMpm {
    fn time(&self) -> f64 {
        self.committed.t
    }

    fn step_count(&self) -> u64 {
        self.committed.step
    }

    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.trial = None;
        let c = &self.committed;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidDt { dt, t: c.t });
        }
        let n = c.x.len();
        let v_new: Vec<f64> = c
            .node_v
            .iter()
            .zip(&c.node_a)
            .map(|(v, a)| v + dt * a)
            .collect();
        let mut a_p = vec![0.0; n];
        c.weights.gather(WeightKind::S, &c.node_a, &mut a_p);
        let mut grad = vec![0.0; n];
        c.weights.gather(WeightKind::D, &v_new, &mut grad);
        let (mut x, mut v, mut sigma, mut f) =
            (c.x.clone(), c.v.clone(), c.sigma.clone(), c.f.clone());
        for p in 0..n {
            v[p] += dt * a_p[p];
            f[p] *= 1.0 + dt * grad[p];
            sigma[p] += dt * self.youngs * grad[p];
            x[p] = self.grid.wrap(x[p] + dt * v[p]);
            if !(v[p].is_finite() && sigma[p].is_finite() && x[p].is_finite()) {
                return Err(StepError::NonFinite {
                    field: "v",
                    index: p,
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
            if f[p] <= 0.0 {
                return Err(StepError::Inverted {
                    index: p,
                    det_f: f[p],
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
        }
        self.trial = Some(Self::nodal(
            &self.grid,
            &self.mass,
            &self.volume0,
            c.t + dt,
            c.step + 1,
            x,
            v,
            sigma,
            f,
        ));
        Ok(())
    }

    fn accept(&mut self) -> Result<(), StepError> {
        self.committed = self.trial.take().ok_or(StepError::NoTrial)?;
        Ok(())
    }

    fn reject(&mut self) {
        self.trial = None;
    }

    fn view(&self) -> View<'_> {
        self.view_of(&self.committed)
    }

    fn trial_view(&self) -> Option<View<'_>> {
        self.trial.as_ref().map(|s| self.view_of(s))
    }
}

/// The user's own limit: a CFL step `α h / (c + |v|max)` from the view.
struct UserCfl {
    alpha: f64,
}

impl StepLimit for UserCfl {
    fn name(&self) -> &str {
        "user_cfl"
    }

    fn propose(&mut self, s: &View<'_>) -> Result<Proposal, LimitError> {
        let c = (0..s.n_particles())
            .map(|p| s.wave_speed(p))
            .fold(0.0, f64::max);
        let vmax = s.v.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let mut metrics = Metrics::new();
        metrics.insert("wave_speed".into(), c);
        Ok(Proposal {
            dt: self.alpha * s.grid.h / (c + vmax),
            metrics,
        })
    }
}

fn main() -> ExitCode {
    // Decisions to stderr, `RUST_LOG` to see more (the library never installs a subscriber).
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_env_filter(filter)
        .init();
    let json = std::env::args().any(|a| a == "--json");
    let mut solver = UserMpm::new(32, 2, 1.0, 1e-2);
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(UserCfl { alpha: 0.5 })];
    let mut controller = match Controller::with_default_limits(ControllerConfig::default(), limits)
    {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let result = controller
        .run_until(&mut solver, 1.0, &mut |_| {})
        .map(|_| ());
    let stats = controller.stats();
    let summary = serde_json::json!({
        "t_final": solver.time(),
        "ok": result.is_ok(),
        "error": result.as_ref().err().map(|e| e.to_string()),
        "steps_accepted": stats.accepted,
        "steps_rejected": stats.rejected,
        "binding": stats.binding,
        "dt_min": stats.dt_min,
        "dt_min_chosen": stats.dt_min_chosen,
        "dt_mean": stats.dt_mean(),
        "dt_max": stats.dt_max,
    });
    if json {
        println!("{summary}");
    } else {
        println!(
            "user solver reached t = {:.4} in {} steps ({} rejected); dt in [{:.3e}, {:.3e}]; binding {:?}",
            solver.time(),
            stats.accepted,
            stats.rejected,
            stats.dt_min.unwrap_or(0.0),
            stats.dt_max.unwrap_or(0.0),
            stats.binding
        );
    }
    if result.is_ok() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
