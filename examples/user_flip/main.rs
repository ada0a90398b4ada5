//! A user's own 2D solver under mpm-dt: a plain quadratic B-spline FLIP solver with a
//! neo-Hookean material and gravity ([`solver`]), on two scenes users run, against the
//! rule of thumb `dt = 0.4·h/c_p` they would otherwise take.
//!
//! ```text
//! cargo run --release --example user_flip -- [--scene block|disks] [--generic] [--full-map] [--find-failure] [--repeat N]
//! ```
//!
//! * `block`: a 0.4 × 0.4 block (2×2 particles per cell, 128² cells, ~10⁴ particles)
//!   falling at 1 m/s under gravity onto the floor, to t = 0.6 s;
//! * `disks`: two disks of radius 0.17 meeting head-on at ±1.5 m/s, no gravity, to
//!   t = 0.3 s (~1.8·10⁴ particles);
//!
//! both E = 400, ν = 0.3, ρ = 1 in a box `[0, 1]²` with slip walls three cells thick.
//! The controller runs with its standard 2D limits and no tuning; the solver hands the
//! library its pass's totals (the opt-in contract) unless `--generic` is given, and then
//! the limits make their own passes. `--find-failure` bisects the fixed step at which the
//! scene blows up (non-finite values, a particle through a wall, `det F ≤ 0`, or energy
//! above 10× its start) and compares the controller's largest step with it. `--repeat N`
//! (default 3) times the rule and the controller `N` times, interleaved. `--full-map`
//! sets `stability_nd.full_map` (the limit on the whole linearised FLIP step).

#[path = "../common/repeats.rs"]
mod repeats;
mod solver;

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::Stepper;
use nalgebra::Vector2;
use solver::FlipSolver;
use std::process::ExitCode;

/// The scene and how the controlled run sees the solver.
#[derive(Clone, Copy)]
struct Scene {
    disks: bool,
    opt_in: bool,
    /// `stability_nd.full_map`: the limit on the whole linearised FLIP step.
    full_map: bool,
}

impl Scene {
    fn t_end(self) -> f64 {
        if self.disks {
            0.3
        } else {
            0.6
        }
    }

    fn gravity(self) -> Vector2<f64> {
        Vector2::new(0.0, if self.disks { 0.0 } else { -9.8 })
    }

    fn build(self, opt_in: bool) -> FlipSolver {
        let n_grid = 128;
        let h = 1.0 / n_grid as f64;
        let mut x = Vec::new();
        let mut v = Vec::new();
        // Particles at the cell-uniform points (2 per cell per axis) inside each body.
        for i in 0..2 * n_grid {
            for j in 0..2 * n_grid {
                let p = Vector2::new((i as f64 + 0.5) * h / 2.0, (j as f64 + 0.5) * h / 2.0);
                let velocity = if self.disks {
                    let (a, b) = (Vector2::new(0.3, 0.5), Vector2::new(0.7, 0.5));
                    if (p - a).norm() < 0.17 {
                        Some(Vector2::new(1.5, 0.0))
                    } else if (p - b).norm() < 0.17 {
                        Some(Vector2::new(-1.5, 0.0))
                    } else {
                        None
                    }
                } else {
                    let inside = (0.3..0.7).contains(&p[0]) && (0.35..0.75).contains(&p[1]);
                    inside.then(|| Vector2::new(0.0, -1.0))
                };
                if let Some(vel) = velocity {
                    x.push(p);
                    v.push(vel);
                }
            }
        }
        FlipSolver::new(n_grid, x, v, h * h / 4.0, 1.0, 400.0, 0.3, self.gravity())
            .with_summary(opt_in)
    }
}

/// How a run ended: steps, wall time of the stepping, largest step, failure if any.
struct Run {
    steps: u64,
    wall_s: f64,
    dt_max: f64,
    failure: Option<String>,
}

/// A fixed-step run (the stepper without summary), with the blow-up checks untimed.
fn run_fixed(scene: Scene, dt: f64) -> Run {
    let mut s = scene.build(false);
    let start_energy = s.total_energy();
    let mut wall = std::time::Duration::ZERO;
    let mut failure = None;
    while s.time() < scene.t_end() - 1e-12 {
        let started = std::time::Instant::now();
        let step = dt.min(scene.t_end() - s.time());
        let stepped = s.try_step(step).and_then(|_| s.accept());
        wall += started.elapsed();
        if let Err(e) = stepped {
            failure = Some(e.to_string());
            break;
        }
        let e = s.total_energy();
        if !e.is_finite() || e > 10.0 * start_energy.abs() || s.inverted() {
            failure = Some(format!("energy {e:.3e} at t = {:.4}", s.time()));
            break;
        }
    }
    Run {
        steps: s.step_count(),
        wall_s: wall.as_secs_f64(),
        dt_max: dt,
        failure,
    }
}

/// The controlled run: standard limits, default config.
fn run_controlled(scene: Scene) -> (Run, String) {
    let mut s = scene.build(scene.opt_in);
    let mut config = ControllerConfig::default();
    config.stability_nd.full_map = scene.full_map;
    config.gravity = Some(scene.gravity().as_slice().to_vec());
    let started = std::time::Instant::now();
    let mut tracking = String::new();
    let result = Controller::<2>::standard(config)
        .map_err(|e| e.to_string())
        .and_then(|mut c| {
            let mut last = (0.0, 0.0, 0.0);
            let mut ratios = Vec::new();
            let r = c
                .run_until(&mut s, scene.t_end(), &mut |d| {
                    for l in d.limits.iter().filter(|l| l.name == "stability") {
                        let get = |k: &str| l.metrics.get(k).copied();
                        if let (Some(r), Some(a)) = (get("refreshes"), get("lanczos_applications"))
                        {
                            (last.0, last.1) = (r, a);
                        }
                        last.2 = get("bound_proposals").unwrap_or(last.2);
                        ratios.extend(get("bound_ratio").filter(|_| get("refreshes").is_some()));
                    }
                })
                .map(|_| ())
                .map_err(|e| e.to_string());
            let [lo, hi] = ratios
                .iter()
                .fold([f64::INFINITY, 0.0f64], |[lo, hi], &r| [lo.min(r), hi.max(r)]);
            tracking = format!(
                "{} refreshes, {} Lanczos products, {} steps on the bound, bound/λmax at the refreshes {lo:.2} … {:.2} … {hi:.2}; bound by {:?}",
                last.0,
                last.1,
                last.2,
                if ratios.is_empty() { f64::NAN } else { repeats::median(&ratios) },
                c.stats().binding
            );
            r.map(|_| c.stats().clone())
        });
    let wall_s = started.elapsed().as_secs_f64();
    let run = match result {
        Ok(stats) => Run {
            steps: stats.accepted,
            wall_s,
            dt_max: stats.dt_max.unwrap_or(f64::NAN),
            failure: None,
        },
        Err(e) => Run {
            steps: s.step_count(),
            wall_s,
            dt_max: f64::NAN,
            failure: Some(e),
        },
    };
    (run, tracking)
}

/// Bisection of the fixed step between a stable and an unstable run (12 halvings).
fn find_failure(scene: Scene, unit: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (0.2 * unit, 4.0 * unit);
    for _ in 0..12 {
        let mid = 0.5 * (lo + hi);
        if run_fixed(scene, mid).failure.is_some() {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (lo, hi)
}

fn parse() -> Result<(Scene, bool, usize), String> {
    let mut scene = Scene {
        disks: false,
        opt_in: true,
        full_map: false,
    };
    let (mut failure, mut repeat) = (false, 3);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--scene" => match args.next().as_deref() {
                Some("block") => scene.disks = false,
                Some("disks") => scene.disks = true,
                other => return Err(format!("--scene: block or disks, not {other:?}")),
            },
            "--generic" => scene.opt_in = false,
            "--full-map" => scene.full_map = true,
            "--find-failure" => failure = true,
            "--repeat" => repeat = repeats::parse_repeat(args.next())?,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    Ok((scene, failure, repeat))
}

fn main() -> ExitCode {
    let (scene, failure, repeat) = match parse() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}\nusage: user_flip [--scene block|disks] [--generic] [--full-map] [--find-failure] [--repeat N]");
            return ExitCode::from(2);
        }
    };
    let probe = scene.build(false);
    let unit = probe.grid().h[0] / probe.p_wave_speed();
    let rule = 0.4 * unit;
    println!(
        "user FLIP solver, {}: {} particles, h/c_p = {unit:.4e} s, rule 0.4·h/c_p = {rule:.4e} s, {} path",
        if scene.disks { "two disks head-on" } else { "falling block" },
        probe.view().n_particles(),
        if scene.opt_in { "opt-in" } else { "generic" }
    );
    let (mut controlled, tracking) = run_controlled(scene);
    let mut fixed = run_fixed(scene, rule);
    let mut walls = vec![vec![controlled.wall_s], vec![fixed.wall_s]];
    let more = repeats::more_rounds(&mut walls, repeat, |k| -> Result<f64, ()> {
        Ok(if k == 0 {
            run_controlled(scene).0.wall_s
        } else {
            run_fixed(scene, rule).wall_s
        })
    });
    if more.is_err() {
        return ExitCode::FAILURE;
    }
    controlled.wall_s = repeats::median(&walls[0]);
    fixed.wall_s = repeats::median(&walls[1]);
    let [lo, hi] = repeats::ratio_range(&walls[0], &walls[1]);
    println!(
        "rule 0.4·h/c_p: {} steps, {:.3} s, {}",
        fixed.steps,
        fixed.wall_s,
        fixed.failure.as_deref().unwrap_or("stable")
    );
    println!(
        "mpm-dt: {} steps, {:.3} s, largest step {:.4e} s ({tracking}); {}",
        controlled.steps,
        controlled.wall_s,
        controlled.dt_max,
        controlled.failure.as_deref().unwrap_or("reached t_end")
    );
    println!(
        "wall time against the rule, medians of {repeat} interleaved runs: {:.3} (within a round {lo:.3} … {hi:.3})",
        controlled.wall_s / fixed.wall_s
    );
    if failure {
        let (stable, fails) = find_failure(scene, unit);
        println!(
            "failure step: stable at {stable:.4e} s, blows up at {fails:.4e} s; the controller's largest step is {:.3} of it",
            controlled.dt_max / fails
        );
    }
    if controlled.failure.is_some() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
