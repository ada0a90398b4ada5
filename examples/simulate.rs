//! Runs a scenario of any dimension under mpm-dt's controller.
//!
//! ```text
//! cargo run --release --example simulate -- --scenario FILE [--json] [--fixed-dt DT --steps K] [--compare [--repeat N]] [--threads N]
//! ```
//!
//! * `--threads N` (2D/3D): the solver steps on N threads (`SolverNd::set_threads`; the
//!   fixed rules of `--compare` too) and the limits' passes over the particles run on N
//!   threads of their own (`Controller::with_threads`).
//!
//! * default: the controller (1D: `Controller::standard`; 2D/3D: the standard limits of
//!   `mpm_dt::limits_nd`) runs the scenario to its `t_end`; a summary is printed (one JSON
//!   document on stdout with `--json`: `t_final`, `steps_accepted`, `steps_rejected`,
//!   `blew_up`, `dt_min`, `dt_min_chosen` (without the step cut to land on `t_end`),
//!   `dt_mean`, `dt_max`, `binding`, `velocity_error_linf` (null without an exact
//!   solution), `energy_initial`, `energy_final`, `wall_s`);
//! * `--fixed-dt DT --steps K`: K plain steps of DT without the controller; the summary
//!   adds `state` (`x`, `v` as lists of d-vectors, `sigma`, `F` as d×d nested row lists);
//! * `--compare` (2D/3D): the same solver also runs to `t_end` with the fixed rules
//!   `dt = α · min_a h_a/(c_p + |v_a|)` for α = 0.4 and 0.5, side by side in this process,
//!   and prints each run's steps, wall time and final error, and `wall_ratio` (controlled
//!   wall time over each fixed rule's). The timed runs are repeated `--repeat N` times
//!   (default 3), interleaved, the rules going first in every other repeat; each `wall_s`
//!   is then the median of a policy's runs (`wall_s_runs`), `wall_ratio` the ratio of the
//!   medians and `wall_ratio_of_pairs` the range of the ratios within each repeat. A
//!   controlled run that does not reach `t_end` is not repeated, the rules run once, and
//!   both ratios are `null`.
//!
//!
//! Built with the `mpi` feature it also runs 2D and 3D scenarios across MPI ranks, the
//! grid cut into slabs along its last axis (`SolverNd::new_slab`); rank 0 prints the
//! summary (energies and errors of the whole run) and the progress lines, with `ranks`
//! and `reduce_s` (time in the reductions and neighbour exchanges) added:
//!
//! ```text
//! cargo build --release --features mpi --example simulate
//! mpirun -np 4 target/release/examples/simulate --scenario scenarios/nd/colliding_disks_1e5.json
//! ```
//!
//! (`--fixed-dt` and `--compare` run on one process.)
//!
//! Errors (a bad scenario, a failed run) print a message on stderr and exit with status 1;
//! usage errors exit with 2.

mod common;
#[path = "simulate/side_by_side.rs"]
mod side_by_side;
#[path = "simulate/state_stream.rs"]
mod state_stream;
#[path = "simulate/summaries.rs"]
mod summaries;

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::nd::problems::PlaneWave;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::SolverNd;
use mpm_dt::reduce::Reduce;
use mpm_dt::scenario::Scenario;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use serde_json::{json, Value};
use std::process::ExitCode;
use std::rc::Rc;
use std::time::Instant;
use summaries::{bound_ratio_summary, failure_message, stats_summary};

const USAGE: &str =
    "usage: simulate --scenario FILE [--json] [--fixed-dt DT --steps K] [--compare [--repeat N]] [--threads N]";

struct Args {
    scenario: String,
    json: bool,
    fixed: Option<(f64, u64)>,
    compare: bool,
    repeat: usize,
    threads: Option<usize>,
}

fn parse_args() -> Result<Option<Args>, String> {
    let mut scenario = None;
    let (mut json, mut compare) = (false, false);
    let (mut dt, mut steps) = (None, None);
    let mut repeat = None;
    let mut threads = None;
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--help" | "-h" => return Ok(None),
            "--json" => json = true,
            "--compare" => compare = true,
            "--repeat" => repeat = Some(common::repeats::parse_repeat(it.next())?),
            "--scenario" => scenario = Some(it.next().ok_or("--scenario needs a file")?),
            "--threads" => {
                let v = it.next().ok_or("--threads needs a count")?;
                threads = Some(
                    v.parse::<usize>()
                        .ok()
                        .filter(|&n| n > 0)
                        .ok_or(format!("--threads: not a positive count: {v}"))?,
                );
            }
            "--fixed-dt" => {
                let v = it.next().ok_or("--fixed-dt needs a value")?;
                let v: f64 = v
                    .parse()
                    .map_err(|_| format!("--fixed-dt: not a number: {v}"))?;
                if !(v.is_finite() && v > 0.0) {
                    return Err("--fixed-dt must be a positive number".into());
                }
                dt = Some(v);
            }
            "--steps" => {
                let v = it.next().ok_or("--steps needs a value")?;
                let v: u64 = v
                    .parse()
                    .map_err(|_| format!("--steps: not a count: {v}"))?;
                if v == 0 {
                    return Err("--steps must be at least 1".into());
                }
                steps = Some(v);
            }
            other => return Err(format!("unknown argument {other}")),
        }
    }
    let fixed = match (dt, steps) {
        (Some(dt), Some(k)) => Some((dt, k)),
        (None, None) => None,
        _ => return Err("--fixed-dt and --steps go together".into()),
    };
    let scenario = scenario.ok_or("--scenario FILE is required")?;
    if repeat.is_some() && !compare {
        return Err("--repeat goes with --compare".into());
    }
    Ok(Some(Args {
        scenario,
        json,
        fixed,
        compare,
        repeat: repeat.unwrap_or(3),
        threads,
    }))
}

/// `k` plain steps of `dt` (no controller); the first failure's message, if any.
fn fixed_steps<const D: usize>(s: &mut dyn Stepper<D>, dt: f64, k: u64) -> Option<String>
where
    Dim<D>: Dimension,
{
    for _ in 0..k {
        if let Err(e) = s.try_step(dt).and_then(|_| s.accept()) {
            return Some(e.to_string());
        }
    }
    None
}

/// The processes of a run: one, or the ranks of `mpirun` (feature `mpi`).
struct Ranks {
    reduce: Option<Rc<dyn Reduce>>,
    /// Time spent in reductions and exchanges, when measured.
    spent: Box<dyn Fn() -> f64>,
}

impl Ranks {
    fn single() -> Self {
        Self {
            reduce: None,
            spent: Box::new(|| 0.0),
        }
    }
    fn size(&self) -> usize {
        self.reduce.as_ref().map_or(1, |r| r.size())
    }
    fn lead(&self) -> bool {
        self.reduce.as_ref().is_none_or(|r| r.rank() == 0)
    }
    fn sum(&self, v: f64) -> f64 {
        let mut b = [v];
        if let Some(r) = &self.reduce {
            r.sum(&mut b);
        }
        b[0]
    }
    fn max(&self, v: Option<f64>) -> Option<f64> {
        let r = self.reduce.as_ref()?;
        let v = v?;
        // A NaN travels as the flag (the minimum must not see one).
        let (m, nan) = r.min_and_any(if v.is_nan() { 0.0 } else { -v }, v.is_nan());
        Some(if nan { f64::NAN } else { -m })
    }
}

/// `--fixed-dt DT --steps K` in 2D/3D: K plain steps of DT from `s` (whose energy is
/// `e0`), the summary and the state to stream with it.
fn fixed_nd<const D: usize>(
    mut s: SolverNd<D>,
    wave: Option<&PlaneWave<D>>,
    (dt, k): (f64, u64),
    e0: f64,
) -> (Value, Option<state_stream::StateWriter>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let error = fixed_steps(&mut s, dt, k);
    let e = s.total_energy();
    let blew_up = error.is_some() || !e.is_finite() || e > 10.0 * e0;
    let out = json!({
        "t_final": s.time(), "steps_accepted": s.step_count(), "steps_rejected": 0,
        "blew_up": blew_up, "dt_min": dt, "dt_min_chosen": dt, "dt_mean": dt, "dt_max": dt, "binding": {},
        "velocity_error_linf": wave.map(|w| w.velocity_error(&s.view())),
        "energy_initial": e0, "energy_final": e, "error": error,
    });
    // The state is streamed when the summary is printed, not built here.
    (out, Some(state_stream::writer(s)))
}

fn run_nd<const D: usize>(
    scenario: &ScenarioNd,
    args: &Args,
    ranks: &Ranks,
) -> Result<(Value, Option<state_stream::StateWriter>), String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let (mut s, wave) = match &ranks.reduce {
        Some(r) => scenario.build_slab::<D>(Rc::clone(r)),
        None => scenario.build::<D>(),
    }
    .map_err(|e| e.to_string())?;
    s.set_threads(args.threads).map_err(|e| e.to_string())?;
    // The initial state for the side-by-side runs; no copy otherwise.
    let template = args.compare.then(|| s.clone());
    let e0 = ranks.sum(s.total_energy());
    let describe = format!(
        "{D}D, {} particles, cells {:?}, shape {:?}, {} process(es)",
        s.n_particles_total(),
        s.grid().cells,
        s.shape(),
        ranks.size()
    );
    if ranks.lead() {
        eprintln!("simulate: {describe}, t_end = {}", scenario.t_end);
    }
    if let Some((dt, k)) = args.fixed {
        return Ok(fixed_nd(s, wave.as_ref(), (dt, k), e0));
    }
    let config: ControllerConfig = scenario.controller_config().map_err(|e| e.to_string())?;
    let mut controller =
        common::controller_nd::controller_for(scenario, config.clone(), ranks.reduce.as_ref())?
            .with_threads(args.threads)
            .map_err(|e| e.to_string())?;
    let start = Instant::now();
    let mut last_rejection = None;
    let mut refreshes = (0.0, 0.0);
    let mut bound_ratios = Vec::new();
    let run = controller.run_until(&mut s, scenario.t_end, &mut |d| {
        if d.outcome == mpm_dt::controller::Outcome::Rejected {
            last_rejection = Some(d.clone());
        }
        for l in &d.limits {
            if let (Some(&r), Some(&a)) = (
                l.metrics.get("refreshes"),
                l.metrics.get("lanczos_applications"),
            ) {
                refreshes = (r, a);
                bound_ratios.extend(l.metrics.get("bound_ratio"));
            }
        }
    });
    let wall = start.elapsed().as_secs_f64();
    let error = run
        .err()
        .map(|e| failure_message(e, last_rejection.as_ref()));
    let mut out = stats_summary(controller.stats());
    let e = ranks.sum(s.total_energy());
    let velocity_error = wave.as_ref().map(|w| w.velocity_error(&s.view()));
    let velocity_error = ranks.max(velocity_error).or(velocity_error);
    out["t_final"] = json!(s.time());
    out["blew_up"] = json!(error.is_some() || !e.is_finite() || e > 10.0 * e0);
    out["velocity_error_linf"] = json!(velocity_error);
    out["energy_initial"] = json!(e0);
    out["energy_final"] = json!(e);
    out["wall_s"] = json!(wall);
    out["error"] = json!(error);
    out["stability_refreshes"] = json!(refreshes.0);
    out["lanczos_applications"] = json!(refreshes.1);
    // The element bound over the Lanczos value at the refreshes (min, median, max).
    out["bound_ratio"] = bound_ratio_summary(&bound_ratios);
    if ranks.reduce.is_some() {
        out["ranks"] = json!(ranks.size());
        out["reduce_s"] = json!((ranks.spent)());
    }
    if let Some(template) = &template {
        let reached = error.is_none();
        let timed = side_by_side::fixed_rules(
            template,
            scenario,
            &config,
            wave.as_ref(),
            (wall, reached),
            args.repeat,
        )?;
        out["wall_s"] = json!(timed.ours_median);
        out["wall_s_runs"] = json!(timed.ours_runs);
        out["fixed_rules"] = timed.rules;
    }
    Ok((out, None))
}

fn run_1d(text: &str, args: &Args) -> Result<Value, String> {
    if args.threads.is_some() {
        return Err("--threads runs 2D/3D scenarios (the 1D solver steps on one thread)".into());
    }
    if args.compare {
        return Err(
            "--compare runs 2D/3D scenarios; for a 1D scenario use the compare example \
             (`compare --scenario FILE --repeat N`)"
                .into(),
        );
    }
    // The 1D format has no `dim`; drop an explicit `"dim": 1`.
    let mut value: Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    if let Some(o) = value.as_object_mut() {
        o.remove("dim");
    }
    let scenario = Scenario::from_json(&value.to_string()).map_err(|e| e.to_string())?;
    let mut s = scenario.build().map_err(|e| e.to_string())?;
    let e0 = s.total_energy();
    if let Some((dt, k)) = args.fixed {
        let error = fixed_steps(&mut s, dt, k);
        let view = s.view();
        let e = s.total_energy();
        let one = |v: &[f64]| -> Value { v.iter().map(|x| json!([x])).collect() };
        let two = |v: &[f64]| -> Value { v.iter().map(|x| json!([[x]])).collect() };
        return Ok(json!({
            "t_final": s.time(), "steps_accepted": s.step_count(), "steps_rejected": 0,
            "blew_up": error.is_some() || !e.is_finite() || e > 10.0 * e0,
            "dt_min": dt, "dt_min_chosen": dt, "dt_mean": dt, "dt_max": dt, "binding": {},
            "velocity_error_linf": null, "energy_initial": e0, "energy_final": e, "error": error,
            "state": {"x": one(view.x), "v": one(view.v), "sigma": two(view.sigma), "F": two(view.f)},
        }));
    }
    let config = scenario.controller_config().map_err(|e| e.to_string())?;
    let mut controller = Controller::standard(config).map_err(|e| e.to_string())?;
    let start = Instant::now();
    let error = controller
        .run_until(&mut s, scenario.t_end, &mut |_| {})
        .err()
        .map(|e| e.to_string());
    let mut out = stats_summary(controller.stats());
    let e = s.total_energy();
    out["t_final"] = json!(s.time());
    out["blew_up"] = json!(error.is_some() || !e.is_finite() || e > 10.0 * e0);
    out["velocity_error_linf"] = Value::Null;
    out["energy_initial"] = json!(e0);
    out["energy_final"] = json!(e);
    out["wall_s"] = json!(start.elapsed().as_secs_f64());
    out["error"] = json!(error);
    Ok(out)
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(Some(a)) => a,
        Ok(None) => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("error: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    #[cfg(feature = "mpi")]
    let Some(universe) = mpi::initialize() else {
        eprintln!("error: MPI could not be initialised");
        return ExitCode::FAILURE;
    };
    #[cfg(feature = "mpi")]
    let ranks = {
        use mpi::topology::Communicator;
        let world = universe.world();
        if world.size() > 1 {
            let timed = Rc::new(mpm_dt::reduce::Timed::new(mpm_dt::reduce::MpiReduce::new(
                world,
            )));
            let clock = Rc::clone(&timed);
            Ranks {
                reduce: Some(timed),
                spent: Box::new(move || clock.spent().as_secs_f64()),
            }
        } else {
            Ranks::single()
        }
    };
    #[cfg(not(feature = "mpi"))]
    let ranks = Ranks::single();
    if ranks.size() > 1 && (args.fixed.is_some() || args.compare) {
        if ranks.lead() {
            eprintln!("error: --fixed-dt and --compare run on one process\n{USAGE}");
        }
        return ExitCode::from(2);
    }
    let result = run_file(&args, &ranks);
    if !ranks.lead() {
        // Rank 0 reports; the others only say why they failed, if they did.
        return match result {
            Ok((summary, _)) if !summary["blew_up"].as_bool().unwrap_or(false) => ExitCode::SUCCESS,
            Ok(_) => ExitCode::FAILURE,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        };
    }
    report(result, args.json)
}

/// Reads the scenario file and runs it in its dimension: the summary, and the state to
/// stream with it after `--fixed-dt`.
fn run_file(
    args: &Args,
    ranks: &Ranks,
) -> Result<(Value, Option<state_stream::StateWriter>), String> {
    std::fs::read_to_string(&args.scenario)
        .map_err(|e| format!("cannot read {}: {e}", args.scenario))
        .and_then(|text| {
            let dim = ScenarioNd::dim_of(&text).map_err(|e| e.to_string())?;
            match dim {
                1 if ranks.size() > 1 => Err("1D scenarios run on one process".into()),
                1 => run_1d(&text, args).map(|v| (v, None)),
                d => {
                    let scenario = ScenarioNd::from_json(&text).map_err(|e| e.to_string())?;
                    if d == 2 {
                        run_nd::<2>(&scenario, args, ranks)
                    } else {
                        run_nd::<3>(&scenario, args, ranks)
                    }
                }
            }
        })
}

/// Prints a run's summary (one JSON document with `json`, with the state when there is
/// one) or its error, and the exit code it ends with.
fn report(
    result: Result<(Value, Option<state_stream::StateWriter>), String>,
    json: bool,
) -> ExitCode {
    match result {
        Ok((summary, state)) => {
            let failed = summary["blew_up"].as_bool().unwrap_or(false);
            match state {
                Some(state) if json => {
                    if let Err(e) = state_stream::print_with_state(&summary, state) {
                        eprintln!("error: writing the state: {e}");
                        return ExitCode::FAILURE;
                    }
                }
                _ if json => println!("{summary}"),
                _ => println!(
                    "{}",
                    serde_json::to_string_pretty(&summary).unwrap_or_default()
                ),
            }
            if failed {
                eprintln!(
                    "error: the run blew up or stopped: {}",
                    summary["error"]
                        .as_str()
                        .unwrap_or("energy grew above 10x its start")
                );
                return ExitCode::FAILURE;
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
