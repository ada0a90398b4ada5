//! A 2D stepper written outside the library, driven by the library's controller: the 2D
//! counterpart of `examples/custom_stepper.rs`.
//!
//! ```text
//! cargo run --release --example custom_stepper_2d [-- --json]
//! ```
//!
//! `UserMpm2d` below is a user's own small 2D MPM code: a periodic unit square of 16 × 16
//! cells with 2 × 2 particles per cell, a linear elastic (hypoelastic) solid, update stress
//! last with FLIP, quadratic B-spline weights written here, released from a small plane
//! P-wave `v = (A c sin(2πx), 0)`. To be driven by [`Controller`] it implements only
//! [`Stepper<2>`]: a trial step kept beside the committed state, accept, reject, and a
//! read-only [`ViewNd`] of both states. Its weights reach the library as stored rows
//! ([`WeightsNd`]); it offers no pass summary (`summary: None`), so the limits make their
//! own passes (the generic path). The user adds a limit of their own (`user_cfl`, the
//! sound-speed step `α h / max_p (c_p + |v_p|)` written here as a [`StepLimit<2>`]) to the
//! standard 2D limits ([`standard_limits`]: sound speed, stability, temporal error,
//! growth). Nothing else of the library is needed: no reference solver, no scenario file,
//! and it builds without the `reference` feature.

use mpm_dt::controller::{standard_limits, Controller, ControllerConfig};
use mpm_dt::limit::{LimitError, Metrics, Proposal, StepLimit};
use mpm_dt::nd::{det, GridNd, Tensor, Vector, ViewNd, WeightsNd};
use mpm_dt::{Boundary, StepError, Stepper};
use std::process::ExitCode;

/// Nodes per particle of the quadratic B-spline stencil in 2D (3 × 3).
const WIDTH: usize = 9;

/// One state of the user's solver: particle fields plus the nodal fields the next step
/// starts from (formed at this state's positions).
#[derive(Clone)]
struct UserState {
    t: f64,
    step: u64,
    x: Vec<Vector<2>>,
    v: Vec<Vector<2>>,
    sigma: Vec<Tensor<2>>,
    f: Vec<Tensor<2>>,
    density: Vec<f64>,
    weights: WeightsNd<2>,
    node_mass: Vec<f64>,
    node_v: Vec<Vector<2>>,
    node_a: Vec<Vector<2>>,
    active: Vec<bool>,
}

/// The user's solver.
struct UserMpm2d {
    grid: GridNd<2>,
    lambda: f64,
    mu: f64,
    mass: Vec<f64>,
    volume0: Vec<f64>,
    lame_lambda: Vec<f64>,
    lame_mu: Vec<f64>,
    committed: UserState,
    trial: Option<UserState>,
}

/// The quadratic B-spline along one axis at coordinate `x`: the first node's lattice
/// index, the three weights and their derivatives.
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

impl UserMpm2d {
    /// A periodic unit square of `cells²` cells, `ppc²` particles per cell, density 1,
    /// Young's modulus `youngs`, Poisson ratio `poisson`, released from
    /// `v = (A c sin(2πx), 0)`.
    fn new(cells: usize, ppc: usize, youngs: f64, poisson: f64, amplitude: f64) -> Self {
        let grid = GridNd::new([Boundary::Periodic; 2], [cells; 2], [1.0; 2]);
        let lambda = youngs * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
        let mu = youngs / (2.0 * (1.0 + poisson));
        let c = (lambda + 2.0 * mu).sqrt();
        let side = cells * ppc;
        let n = side * side;
        let vol = 1.0 / n as f64;
        let spacing = 1.0 / side as f64;
        let x: Vec<Vector<2>> = (0..n)
            .map(|p| {
                let (i, j) = (p % side, p / side);
                Vector::<2>::new((i as f64 + 0.5) * spacing, (j as f64 + 0.5) * spacing)
            })
            .collect();
        let nn = grid.n_nodes();
        let v = x
            .iter()
            .map(|x| Vector::<2>::new(amplitude * c * (std::f64::consts::TAU * x[0]).sin(), 0.0))
            .collect();
        let mut solver = Self {
            grid,
            lambda,
            mu,
            mass: vec![vol; n],
            volume0: vec![vol; n],
            lame_lambda: vec![lambda; n],
            lame_mu: vec![mu; n],
            committed: UserState {
                t: 0.0,
                step: 0,
                x,
                v,
                sigma: vec![Tensor::<2>::zeros(); n],
                f: vec![Tensor::<2>::identity(); n],
                density: Vec::new(),
                weights: WeightsNd::new(nn, WIDTH),
                node_mass: Vec::new(),
                node_v: Vec::new(),
                node_a: Vec::new(),
                active: Vec::new(),
            },
            trial: None,
        };
        let mut s = solver.committed.clone();
        solver.particle_to_grid(&mut s);
        solver.committed = s;
        solver
    }

    /// The particle → grid pass at `s`'s positions: its weights, densities and nodal mass,
    /// velocity, acceleration and active flags.
    fn particle_to_grid(&self, s: &mut UserState) {
        let grid = &self.grid;
        let (nn, n) = (grid.n_nodes(), s.x.len());
        s.node_mass = vec![0.0; nn];
        s.node_v = vec![Vector::<2>::zeros(); nn];
        s.node_a = vec![Vector::<2>::zeros(); nn];
        s.density = vec![0.0; n];
        let (nodes, ws, grads) = s.weights.storage_mut(n);
        for p in 0..n {
            let (bx, wx, dx) = bspline(s.x[p][0], grid.h[0]);
            let (by, wy, dy) = bspline(s.x[p][1], grid.h[1]);
            let volume = det(&s.f[p]) * self.volume0[p];
            s.density[p] = self.mass[p] / volume;
            for a in 0..3 {
                for b in 0..3 {
                    let k = p * WIDTH + a * 3 + b;
                    let i = grid
                        .flat_index([bx + a as i64, by + b as i64])
                        .expect("periodic axes wrap every lattice index");
                    let w = wx[a] * wy[b];
                    let g = Vector::<2>::new(dx[a] * wy[b], wx[a] * dy[b]);
                    (nodes[k], ws[k], grads[k]) = (i as u32, w, g);
                    s.node_mass[i] += w * self.mass[p];
                    s.node_v[i] += w * self.mass[p] * s.v[p];
                    s.node_a[i] -= volume * (s.sigma[p] * g);
                }
            }
        }
        s.active = s.node_mass.iter().map(|&m| m > 1e-12).collect();
        for i in 0..nn {
            if s.active[i] {
                s.node_v[i] /= s.node_mass[i];
                s.node_a[i] /= s.node_mass[i];
            } else {
                s.node_v[i] = Vector::<2>::zeros();
                s.node_a[i] = Vector::<2>::zeros();
            }
        }
    }

    /// The trial of step `dt` from the committed state (USL, FLIP): grid update from the
    /// committed nodal fields, grid → particle, then particle → grid at the new positions.
    fn compute_trial(&self, dt: f64) -> Result<UserState, StepError> {
        let c = &self.committed;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidDt { dt, t: c.t });
        }
        let v_new: Vec<Vector<2>> = (0..c.node_v.len())
            .map(|i| c.node_v[i] + dt * c.node_a[i])
            .collect();
        let mut s = c.clone();
        (s.t, s.step) = (c.t + dt, c.step + 1);
        let id = Tensor::<2>::identity();
        for p in 0..c.x.len() {
            let (mut a_p, mut v_grid, mut l) = (
                Vector::<2>::zeros(),
                Vector::<2>::zeros(),
                Tensor::<2>::zeros(),
            );
            c.weights.for_each_in_row(p, |i, w, g| {
                a_p += w * c.node_a[i];
                v_grid += w * v_new[i];
                l += v_new[i] * g.transpose();
            });
            let d = 0.5 * (l + l.transpose());
            s.v[p] += dt * a_p;
            let y = c.x[p] + dt * v_grid;
            s.x[p] = Vector::<2>::from_fn(|a, _| y[a].rem_euclid(self.grid.length(a)));
            s.f[p] = (id + dt * l) * c.f[p];
            s.sigma[p] += dt * (self.lambda * d.trace() * id + 2.0 * self.mu * d);
            let finite = s.x[p]
                .iter()
                .chain(&s.v[p])
                .chain(&s.sigma[p])
                .all(|x| x.is_finite());
            if !finite {
                return Err(StepError::NonFinite {
                    field: "v",
                    index: p,
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
            let det_f = det(&s.f[p]);
            if det_f.is_nan() || det_f <= 0.0 {
                return Err(StepError::Inverted {
                    index: p,
                    det_f,
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
        }
        self.particle_to_grid(&mut s);
        Ok(s)
    }

    fn view_of<'a>(&'a self, s: &'a UserState) -> ViewNd<'a, 2> {
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
            lame_lambda: &self.lame_lambda,
            lame_mu: &self.lame_mu,
            density: &s.density,
            weights: (&s.weights).into(),
            node_mass: &s.node_mass,
            node_velocity: &s.node_v,
            node_acceleration: &s.node_a,
            node_active: &s.active,
            summary: None,
            split: None,
        }
    }
}

impl Stepper<2> for UserMpm2d {
    fn time(&self) -> f64 {
        self.committed.t
    }

    fn step_count(&self) -> u64 {
        self.committed.step
    }

    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        // Written into the trial only: the committed state is never touched here.
        self.trial = None;
        self.trial = Some(self.compute_trial(dt)?);
        Ok(())
    }

    fn accept(&mut self) -> Result<(), StepError> {
        self.committed = self.trial.take().ok_or(StepError::NoTrial)?;
        Ok(())
    }

    fn reject(&mut self) {
        self.trial = None;
    }

    fn view(&self) -> ViewNd<'_, 2> {
        self.view_of(&self.committed)
    }

    fn trial_view(&self) -> Option<ViewNd<'_, 2>> {
        self.trial.as_ref().map(|s| self.view_of(s))
    }
}

/// The user's own limit: a CFL step `α h / max_p (c_p + |v_p|)` from the view.
struct UserCfl {
    alpha: f64,
}

impl StepLimit<2> for UserCfl {
    fn name(&self) -> &str {
        "user_cfl"
    }

    fn propose(&mut self, s: &ViewNd<'_, 2>) -> Result<Proposal, LimitError> {
        let speed = (0..s.n_particles())
            .map(|p| s.p_wave_speed(p) + s.v[p].norm())
            .fold(0.0, f64::max);
        let mut metrics = Metrics::new();
        metrics.insert("signal_speed".into(), speed);
        Ok(Proposal {
            dt: self.alpha * s.grid.h_min() / speed,
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
    let t_end = 2.0;
    let mut solver = UserMpm2d::new(16, 2, 1.0, 0.25, 1e-2);
    // The standard 2D limits (no gravity here) plus the user's own.
    let config = ControllerConfig::default();
    let mut limits = standard_limits::<2>(&config, Vector::<2>::zeros());
    limits.push(Box::new(UserCfl { alpha: 0.5 }));
    let mut controller = match Controller::<2>::new(config, limits) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let result = controller
        .run_until(&mut solver, t_end, &mut |_| {})
        .map(|_| ());
    let stats = controller.stats();
    let summary = serde_json::json!({
        "dim": 2,
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
