//! The main job: run a scenario of the reference solver (the vibrating bar by default) under
//! the adaptive controller.
//!
//! ```text
//! cargo run --release --example vibrating_bar -- [--scenario FILE] [--json] [--log-json]
//!     [--plot FILE.svg] [--fixed-dt DT --steps K]
//! ```
//!
//! Without `--fixed-dt` the scenario runs to `t_end` under [`Controller::standard`]: the
//! sound-speed cap (eq 49 with `|v|`, α = 1), the stability limit (tracked eq 56 step at
//! safety 0.95, eq 58 check; the growth monitor lowers the safety when it sees growth), the
//! temporal error limit (eqs 20–30) and the growth monitor; the scenario's `controller` field,
//! if present, is the [`mpm_dt::controller::ControllerConfig`]. Logs go to stderr: human-readable by default, one JSON object per
//! event with `--log-json` (an INFO event per attempted step with its decision; `RUST_LOG`
//! filters, default `info`; `RUST_LOG=debug` adds each limit's proposal and the full
//! decision). `--json` prints one summary document on stdout (docs/design.md keys plus
//! `rejected_by_cause`, `growth_events`, `safety_scale`, `velocity_error_linf_raw`,
//! `closing_half_step`). `--plot FILE.svg` draws dt against t with each limit's proposal and
//! the rejected attempts marked.
//!
//! `velocity_error_linf = max_p |v_sync,p − v_exact(X_p, t_final)|` (`X_p` the initial
//! position; `null` for the neo-Hookean material, which has no exact solution here) is the
//! error of the **synchronised velocity** `v_sync,p = v_p + ℓ Σ_i S_ip a_i`
//! ([`mpm_dt::View::synchronized_velocity`]): the USL step's particle velocity lags the exact
//! one by half a step (symplectic Euler, an error `(dt/2)|a|` of first order in dt), and the
//! closing half kick removes the lag. `ℓ` (`closing_half_step`) is half the last accepted
//! step not shortened to land on `t_end` ([`mpm_dt::closing_half_step`]; 0 if there is
//! none), or `DT/2` with `--fixed-dt`. `velocity_error_linf_raw` is the same norm for the
//! particle velocity `v_p` itself.
//!
//! With `--fixed-dt DT --steps K` it runs exactly K plain steps of DT without the controller
//! and also prints the particle state.

mod common;

use common::history::DtHistory;
use mpm_dt::controller::{Controller, Outcome, Stats};
use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::Scenario;
use mpm_dt::Stepper;
use serde_json::json;
use std::collections::BTreeMap;
use std::process::ExitCode;

/// Command-line options.
struct Args {
    scenario: Option<String>,
    fixed_dt: Option<f64>,
    steps: Option<u64>,
    json: bool,
    log_json: bool,
    plot: Option<String>,
}

const USAGE: &str = "usage: vibrating_bar [--scenario FILE] [--json] [--log-json] [--plot FILE.svg] [--fixed-dt DT --steps K]";

/// `parse_args`' answer to `--help` (printed on stdout, exit status 0).
const HELP: &str = "help";

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        scenario: None,
        fixed_dt: None,
        steps: None,
        json: false,
        log_json: false,
        plot: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--scenario" => args.scenario = Some(value("--scenario")?),
            "--fixed-dt" => {
                let v = value("--fixed-dt")?;
                let dt: f64 = v
                    .parse()
                    .map_err(|_| format!("--fixed-dt: not a number: {v}"))?;
                if !(dt.is_finite() && dt > 0.0) {
                    return Err(format!("--fixed-dt must be positive and finite, got {v}"));
                }
                args.fixed_dt = Some(dt);
            }
            "--steps" => {
                let v = value("--steps")?;
                let k: u64 = v
                    .parse()
                    .map_err(|_| format!("--steps: not a positive integer: {v}"))?;
                if k == 0 {
                    return Err("--steps must be at least 1".into());
                }
                args.steps = Some(k);
            }
            "--json" => args.json = true,
            "--log-json" => args.log_json = true,
            "--plot" => args.plot = Some(value("--plot")?),
            "-h" | "--help" => return Err(HELP.into()),
            other => return Err(format!("unknown argument {other}\n{USAGE}")),
        }
    }
    match (args.fixed_dt, args.steps) {
        (Some(_), None) => Err("--fixed-dt needs --steps".into()),
        (None, Some(_)) => Err("--steps needs --fixed-dt".into()),
        _ => Ok(args),
    }
}

/// What a run produced: running statistics of the accepted steps (constant memory).
#[derive(Default)]
struct Run {
    n: u64,
    dt_sum: f64,
    dt_min: f64,
    dt_max: f64,
    failure: Option<String>,
}

impl Run {
    /// The mean accepted step; NaN without a step.
    fn dt_mean(&self) -> f64 {
        if self.n > 0 {
            self.dt_sum / self.n as f64
        } else {
            f64::NAN
        }
    }

    fn push(&mut self, dt: f64) {
        if self.n == 0 {
            self.dt_min = dt;
            self.dt_max = dt;
        }
        self.n += 1;
        self.dt_sum += dt;
        self.dt_min = self.dt_min.min(dt);
        self.dt_max = self.dt_max.max(dt);
    }
}

/// Takes `dt`-steps from `next_dt` until it returns `None` or a step fails.
fn drive(
    stepper: &mut ReferenceStepper,
    mut next_dt: impl FnMut(&ReferenceStepper) -> Option<f64>,
) -> Run {
    let mut run = Run::default();
    while let Some(dt) = next_dt(stepper) {
        if let Err(e) = stepper.try_step(dt).and_then(|_| stepper.accept()) {
            tracing::error!(error = %e, "step failed");
            run.failure = Some(e.to_string());
            return run;
        }
        run.push(dt);
    }
    run
}

/// The controller run: the standard limits, config from the scenario's `controller` field.
/// Every decision goes to the bounded `history`; a progress line reaches stderr every 2 s.
fn run_controller(
    stepper: &mut ReferenceStepper,
    scenario: &Scenario,
    history: &mut DtHistory,
    unit: f64,
) -> Result<(Run, Stats, f64), String> {
    let config = scenario.controller_config().map_err(|e| e.to_string())?;
    let mut controller = Controller::standard(config).map_err(|e| e.to_string())?;
    tracing::info!(
        t_end = scenario.t_end,
        limits = serde_json::to_string(&controller.limit_names())
            .unwrap_or_default()
            .as_str(),
        "adaptive controller run"
    );
    let started = std::time::Instant::now();
    let mut last_report = started;
    let mut run = Run::default();
    let result = controller
        .run_until(stepper, scenario.t_end, &mut |d| {
            history.record(d);
            if d.outcome == Outcome::Accepted {
                run.push(d.dt);
            }
            if last_report.elapsed().as_secs_f64() >= 2.0 {
                last_report = std::time::Instant::now();
                eprintln!(
                    "  t = {:.4e} of {:.4e}  step {}  dt = {:.3} h/c  ({:.0} s)",
                    d.t,
                    scenario.t_end,
                    d.step,
                    d.dt / unit,
                    started.elapsed().as_secs_f64()
                );
            }
        })
        .map(|_| ());
    run.failure = result.err().map(|e| e.to_string());
    Ok((
        run,
        controller.stats().clone(),
        controller.state().safety_scale,
    ))
}

/// What the scenario is, in one line.
fn describe(scenario: &Scenario, stepper: &ReferenceStepper) -> String {
    let amplitude = match &scenario.initial {
        mpm_dt::scenario::Initial::StandingWave { amplitude, mode } => {
            format!("standing wave, amplitude {amplitude}, mode {mode}")
        }
        other => format!("{other:?}").to_lowercase(),
    };
    format!(
        "{} cells, {} particles ({:?} weights), {:?} ends, {:?}, E = {}, rho = {}, {amplitude}, to t = {}",
        stepper.grid().cells,
        stepper.n_particles(),
        stepper.shape(),
        stepper.grid().boundary,
        stepper.material(),
        scenario.youngs_modulus,
        scenario.density,
        scenario.t_end
    )
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(msg) if msg == HELP => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(msg) => {
            eprintln!("error: {msg}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    // Each attempt is an INFO event of the library: shown with RUST_LOG=info (or debug for
    // every limit's proposal); by default only warnings, with a progress line every 2 s.
    common::init_logs("warn", args.log_json);
    let scenario = match &args.scenario {
        Some(path) => match Scenario::from_file(path) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        },
        None => Scenario::default(),
    };
    let mut stepper = match scenario.build() {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let x0 = stepper.view().x.to_vec();
    let energy_initial = stepper.total_energy();
    let unit = stepper.grid().h / scenario.wave_speed();
    eprintln!("vibrating_bar: {}", describe(&scenario, &stepper));
    let mut history = DtHistory::new();
    let mut controller_stats: Option<(Stats, f64)> = None;
    let (run, mode) = match (args.fixed_dt, args.steps) {
        (Some(dt), Some(k)) => {
            tracing::info!(dt, steps = k, "fixed-dt run (no controller)");
            let run = drive(&mut stepper, |s| (s.step_count() < k).then_some(dt));
            (run, "fixed_dt")
        }
        _ => match run_controller(&mut stepper, &scenario, &mut history, unit) {
            Ok((run, stats, safety_scale)) => {
                controller_stats = Some((stats, safety_scale));
                (run, "controller")
            }
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        },
    };
    if let Some(path) = &args.plot {
        let title = plot_title(&scenario, &stepper);
        if let Err(e) = common::plot::plot_dt(path, &history, unit, &title) {
            eprintln!("error: cannot draw {path}: {e}");
            return ExitCode::from(1);
        }
    }

    let finished = Finished {
        run,
        mode,
        controller_stats,
        closing_half_step: history.closing_half_step,
        x0,
        energy_initial,
        unit,
    };
    report(&args, &scenario, &stepper, finished)
}

/// The run and what the summary compares it with, from `main` to [`report`].
struct Finished {
    run: Run,
    /// `"fixed_dt"` or `"controller"`.
    mode: &'static str,
    /// The controller's statistics and final safety scale (`None` with `--fixed-dt`).
    controller_stats: Option<(Stats, f64)>,
    /// The controlled run's closing half step ([`DtHistory`]).
    closing_half_step: Option<f64>,
    /// The initial particle positions.
    x0: Vec<f64>,
    energy_initial: f64,
    /// `h/c`.
    unit: f64,
}

/// The plot's title: the layout and the scenario.
fn plot_title(scenario: &Scenario, stepper: &ReferenceStepper) -> String {
    format!(
        "mpm-dt: {} cells, {:?}, {} to t = {}",
        stepper.grid().cells,
        stepper.shape(),
        match scenario.initial {
            mpm_dt::scenario::Initial::StandingWave { .. } => "standing wave",
            _ => "at rest",
        },
        scenario.t_end
    )
}

/// The steps per binding limit and the rejected steps: the controller's, or all `n` steps
/// under `mode` without a controller.
fn binding_and_rejected(
    controller_stats: Option<&(Stats, f64)>,
    mode: &str,
    n: u64,
) -> (BTreeMap<String, u64>, u64) {
    let mut binding: BTreeMap<String, u64> = BTreeMap::new();
    let mut steps_rejected = 0;
    match controller_stats {
        Some((stats, _)) => {
            binding.clone_from(&stats.binding);
            steps_rejected = stats.rejected;
        }
        None => {
            binding.insert(mode.to_string(), n);
        }
    }
    (binding, steps_rejected)
}

/// `ℓ` of the synchronised velocity (module docs): half the fixed step `fixed_dt` when `n`
/// steps were taken, else the controlled run's closing half step (0 without one).
fn half_step(fixed_dt: Option<f64>, n: u64, closing_half_step: Option<f64>) -> f64 {
    match fixed_dt {
        Some(dt) if n > 0 => 0.5 * dt,
        Some(_) => 0.0,
        None => closing_half_step.unwrap_or(0.0),
    }
}

/// Prints the summary of the finished run (JSON with `--json`, else one line) and the exit
/// code: failure when it blew up.
fn report(
    args: &Args,
    scenario: &Scenario,
    stepper: &ReferenceStepper,
    finished: Finished,
) -> ExitCode {
    let Finished {
        run,
        mode,
        controller_stats,
        closing_half_step,
        x0,
        energy_initial,
        unit,
    } = finished;
    let h = stepper.grid().h;
    let c = scenario.wave_speed();
    let view = stepper.view();
    let energy_final = stepper.total_energy();
    let blew_up = run.failure.is_some()
        || !energy_final.is_finite()
        || (energy_initial > 0.0 && energy_final > 10.0 * energy_initial);
    // ℓ of the synchronised velocity (module docs).
    let half_step = half_step(args.fixed_dt, run.n, closing_half_step);
    let (velocity_error_linf, velocity_error_linf_raw) =
        common::velocity_errors(scenario, &x0, &view, half_step);
    let n = run.n;
    let (dt_min, dt_max) = (run.dt_min, run.dt_max);
    let dt_mean = run.dt_mean();
    let (binding, steps_rejected) = binding_and_rejected(controller_stats.as_ref(), mode, n);
    let finite = |x: f64| x.is_finite().then_some(x);

    let mut out = json!({
        "t_final": view.t,
        "steps_accepted": n,
        "steps_rejected": steps_rejected,
        "blew_up": blew_up,
        "failure": run.failure,
        "dt_min": if n > 0 { Some(dt_min) } else { None },
        "dt_mean": finite(dt_mean),
        "dt_max": if n > 0 { Some(dt_max) } else { None },
        "binding": binding,
        "mode": mode,
        "velocity_error_linf": velocity_error_linf,
        "velocity_error_linf_raw": velocity_error_linf_raw,
        "closing_half_step": half_step,
        "energy_initial": energy_initial,
        "energy_final": finite(energy_final),
        "momentum_final": stepper.total_momentum(),
        "particles": view.n_particles(),
        "cells": view.grid.cells,
        "h": h,
        "wave_speed": c,
    });
    if let Some((stats, safety_scale)) = &controller_stats {
        out["rejected_by_cause"] = json!(stats.rejected_by_cause);
        out["growth_events"] = json!(stats.growth_events);
        out["safety_scale"] = json!(safety_scale);
    }
    if args.fixed_dt.is_some() {
        out["state"] = json!({ "x": view.x, "v": view.v, "sigma": view.sigma, "F": view.f });
    }
    if args.json {
        println!("{out}");
    } else if n == 0 {
        println!("no step was taken (t = {:.6})", view.t);
    } else {
        println!(
            "t = {:.6}  steps = {} ({} rejected)  dt mean {:.3e} s = {:.3} h/c (min {:.3}, max {:.3} h/c)  blew up: {}  energy {:.6e} -> {:.6e}  |v_sync - v_exact|_inf = {}  binding {:?}",
            view.t,
            n,
            steps_rejected,
            dt_mean,
            dt_mean / unit,
            dt_min / unit,
            dt_max / unit,
            blew_up,
            energy_initial,
            energy_final,
            velocity_error_linf.map_or("n/a".to_string(), |e| format!("{e:.3e}")),
            binding,
        );
    }
    if blew_up {
        eprintln!(
            "error: the run failed: {}",
            run.failure
                .as_deref()
                .unwrap_or("the energy grew above 10x its start or became non-finite")
        );
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
