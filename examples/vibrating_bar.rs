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
//! decision). `--json` prints one summary document on stdout (DESIGN.md keys plus
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

use mpm_dt::controller::{Controller, Decision, Outcome, Stats};
use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::Scenario;
use mpm_dt::{closing_half_step, Stepper};
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
                args.steps = Some(
                    v.parse()
                        .map_err(|_| format!("--steps: not a non-negative integer: {v}"))?,
                );
            }
            "--json" => args.json = true,
            "--log-json" => args.log_json = true,
            "--plot" => args.plot = Some(value("--plot")?),
            "-h" | "--help" => return Err(USAGE.into()),
            other => return Err(format!("unknown argument {other}\n{USAGE}")),
        }
    }
    match (args.fixed_dt, args.steps) {
        (Some(_), None) => Err("--fixed-dt needs --steps".into()),
        (None, Some(_)) => Err("--steps needs --fixed-dt".into()),
        _ => Ok(args),
    }
}

/// What a run produced.
struct Run {
    dts: Vec<f64>,
    failure: Option<String>,
}

/// Takes `dt`-steps from `next_dt` until it returns `None` or a step fails.
fn drive(
    stepper: &mut ReferenceStepper,
    mut next_dt: impl FnMut(&ReferenceStepper) -> Option<f64>,
) -> Run {
    let mut dts = Vec::new();
    while let Some(dt) = next_dt(stepper) {
        if let Err(e) = stepper.try_step(dt) {
            tracing::error!(error = %e, "step failed");
            return Run {
                dts,
                failure: Some(e.to_string()),
            };
        }
        if let Err(e) = stepper.accept() {
            return Run {
                dts,
                failure: Some(e.to_string()),
            };
        }
        dts.push(dt);
    }
    Run { dts, failure: None }
}

/// The controller run: stability + temporal error + growth monitor, config from the
/// scenario's `controller` field.
fn run_controller(
    stepper: &mut ReferenceStepper,
    scenario: &Scenario,
    decisions: &mut Vec<Decision>,
) -> Result<(Run, Stats, f64), String> {
    let config = scenario.controller_config().map_err(|e| e.to_string())?;
    // The standard set: sound-speed cap, stability (eq 56 at safety 0.95, eq 58 check),
    // temporal error, growth monitor (which lowers the stability safety when it sees growth).
    let mut controller = Controller::standard(config).map_err(|e| e.to_string())?;
    tracing::info!(
        t_end = scenario.t_end,
        limits = ?controller.limit_names(),
        "adaptive controller run"
    );
    let result = controller
        .run_until(stepper, scenario.t_end, &mut |d| decisions.push(d.clone()))
        .map(|_| ());
    let dts = decisions
        .iter()
        .filter(|d| d.outcome == Outcome::Accepted)
        .map(|d| d.dt)
        .collect();
    let failure = result.err().map(|e| {
        tracing::error!(error = %e, "controller stopped");
        e.to_string()
    });
    Ok((
        Run { dts, failure },
        controller.stats().clone(),
        controller.state().safety_scale,
    ))
}

/// Draws dt against t: accepted steps, each limit's proposal, rejected attempts.
fn plot(path: &str, decisions: &[Decision]) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let accepted: Vec<(f64, f64)> = decisions
        .iter()
        .filter(|d| d.outcome == Outcome::Accepted)
        .map(|d| (d.t, d.dt))
        .collect();
    let rejected: Vec<(f64, f64)> = decisions
        .iter()
        .filter(|d| d.outcome == Outcome::Rejected)
        .map(|d| (d.t, d.dt))
        .collect();
    let mut names: Vec<String> = Vec::new();
    for d in decisions {
        for l in &d.limits {
            if l.proposal.is_some() && !names.contains(&l.name) {
                names.push(l.name.clone());
            }
        }
    }
    let proposals: Vec<Vec<(f64, f64)>> = names
        .iter()
        .map(|n| {
            decisions
                .iter()
                .filter(|d| d.attempt == 1)
                .filter_map(|d| {
                    d.limits
                        .iter()
                        .find(|l| &l.name == n)
                        .and_then(|l| l.proposal)
                        .map(|p| (d.t, p))
                })
                .collect()
        })
        .collect();
    let filter: Vec<(f64, f64)> = decisions
        .iter()
        .filter(|d| d.attempt == 1)
        .filter_map(|d| d.filter_dt.map(|f| (d.t, f)))
        .collect();
    let all = accepted
        .iter()
        .chain(&rejected)
        .chain(proposals.iter().flatten())
        .chain(&filter);
    let (mut t1, mut lo, mut hi) = (0.0_f64, f64::INFINITY, 0.0_f64);
    for &(t, dt) in all {
        t1 = t1.max(t);
        lo = lo.min(dt);
        hi = hi.max(dt);
    }
    if !(lo.is_finite() && hi > 0.0) {
        return Err("nothing to plot".into());
    }
    let root = SVGBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("time step against time", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            0.0..t1.max(1e-300) * 1.02,
            (lo * 0.8..hi * 1.25).log_scale(),
        )?;
    chart.configure_mesh().x_desc("t").y_desc("dt").draw()?;
    chart
        .draw_series(LineSeries::new(
            accepted.iter().copied(),
            BLACK.stroke_width(2),
        ))?
        .label("accepted dt")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    for (i, (name, pts)) in names.iter().zip(&proposals).enumerate() {
        let color = Palette99::pick(i + 1).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color))?
            .label(format!("{name} proposal"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
    }
    if !filter.is_empty() {
        let color = Palette99::pick(names.len() + 2).to_rgba();
        chart
            .draw_series(LineSeries::new(filter.iter().copied(), color))?
            .label("filter proposal")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
    }
    chart
        .draw_series(
            rejected
                .iter()
                .map(|&p| Cross::new(p, 5, RED.stroke_width(2))),
        )?
        .label("rejected attempt")
        .legend(|(x, y)| Cross::new((x + 10, y), 5, RED.stroke_width(2)));
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    root.present()?;
    Ok(())
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(msg) => {
            eprintln!("{msg}");
            return ExitCode::from(2);
        }
    };
    common::init_logs("info", args.log_json);
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
    let h = stepper.grid().h;
    let c = scenario.wave_speed();

    let mut decisions: Vec<Decision> = Vec::new();
    let mut controller_stats: Option<(Stats, f64)> = None;
    let (run, mode) = match (args.fixed_dt, args.steps) {
        (Some(dt), Some(k)) => {
            tracing::info!(dt, steps = k, "fixed-dt run (no controller)");
            let run = drive(&mut stepper, |s| (s.step_count() < k).then_some(dt));
            (run, "fixed_dt")
        }
        _ => match run_controller(&mut stepper, &scenario, &mut decisions) {
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
        if let Err(e) = plot(path, &decisions) {
            eprintln!("error: cannot draw {path}: {e}");
            return ExitCode::from(1);
        }
    }

    let view = stepper.view();
    let energy_final = stepper.total_energy();
    let blew_up = run.failure.is_some()
        || !energy_final.is_finite()
        || (energy_initial > 0.0 && energy_final > 10.0 * energy_initial);
    // ℓ of the synchronised velocity (module docs).
    let half_step = match args.fixed_dt {
        Some(dt) if !run.dts.is_empty() => 0.5 * dt,
        Some(_) => 0.0,
        None => closing_half_step(&decisions).unwrap_or(0.0),
    };
    let (velocity_error_linf, velocity_error_linf_raw) =
        common::velocity_errors(&scenario, &x0, &view, half_step);
    let n = run.dts.len();
    let dt_min = run.dts.iter().copied().fold(f64::INFINITY, f64::min);
    let dt_max = run.dts.iter().copied().fold(0.0, f64::max);
    let dt_mean = if n > 0 {
        run.dts.iter().sum::<f64>() / n as f64
    } else {
        f64::NAN
    };
    let mut binding: BTreeMap<String, u64> = BTreeMap::new();
    let mut steps_rejected = 0;
    match &controller_stats {
        Some((stats, _)) => {
            binding.clone_from(&stats.binding);
            steps_rejected = stats.rejected;
        }
        None => {
            binding.insert(mode.to_string(), n as u64);
        }
    }
    let finite = |x: f64| x.is_finite().then_some(x);

    let mut out = json!({
        "t_final": view.t,
        "steps_accepted": n,
        "steps_rejected": steps_rejected,
        "blew_up": blew_up,
        "failure": run.failure,
        "dt_min": finite(dt_min),
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
    } else {
        println!(
            "t = {:.6}  steps = {} ({} rejected)  mean dt = {:.3e}  blew up: {}  energy {:.6e} -> {:.6e}  |v_sync - v_exact|_inf = {} (raw {})  binding {:?}",
            view.t,
            n,
            steps_rejected,
            dt_mean,
            blew_up,
            energy_initial,
            energy_final,
            velocity_error_linf.map_or("n/a".to_string(), |e| format!("{e:.3e}")),
            velocity_error_linf_raw.map_or("n/a".to_string(), |e| format!("{e:.3e}")),
            binding,
        );
    }
    // A blow-up is a result (`blew_up`), not a failure of the program.
    ExitCode::SUCCESS
}
