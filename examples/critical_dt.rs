//! Critical time steps of one scenario, every way this crate knows (docs/design.md contract).
//!
//! ```sh
//! cargo run --release --example critical_dt -- --scenario FILE [--json] [--amplitude A]
//! ```
//!
//! Prints (as one JSON document with `--json`, logs on stderr):
//!
//! * `h`; `dt_eq49 = h/c` (eq 49 as printed, `c = max √(E/ρ)` at rest);
//! * `lambda_max` — `λmax(D*F)` in the paper's normalisation (4 on uniform GIMP), from the
//!   Lanczos tracker (cold start), `lambda_max_dense` when the problem is small, and
//!   `lambda_max_gershgorin`, the rigorous `O(nnz)` upper bound;
//! * `dt_eq56 = h √(2/(c² λmax))`;
//! * `dt_full_map` — the exact frozen-particle critical step of the linearised USL map,
//!   reduced to the nodes (one symmetric eigenvalue, matrix-free Lanczos:
//!   `stability::nodal_full_map`), `full_map_products` its Lanczos products; and
//!   `dt_full_map_dense`, the same from the dense map, its cross-check (`null` above 120
//!   particles);
//! * `dt_controller` — the smaller of what the `Stability` and `SoundSpeed` limits of
//!   `Controller::standard` (the `ControllerConfig` defaults, or the scenario's `controller`)
//!   propose for the initial state: the controller's first step before a temporal-error
//!   limit has an opinion;
//! * `bound58` — `[{dt, dt_over_eq56, value, value_consistent, value_energy, norm_2, rho}]`:
//!   the eq 58 ratio in the paper's reading (`value`, Euclidean norm) and in the consistent
//!   reading (Euclidean and strain-energy norms) against the spectral norm `norm_2 = ‖A‖₂`
//!   and the spectral radius `rho = ρ(A)` (dense; `null` above 120 particles), evaluated on the
//!   state a quarter period into a run of the protocol at `0.5·dt_eq56` (the initial state has
//!   `σ = 0`, where eq 58 has no information);
//! * `dt_empirical` — bisection on real runs (initial `v = A c sin(2πx/L)` + noise
//!   `10⁻⁶ A c`, `σ = 0`, `F = 1`, 4000 steps, unstable when the energy exceeds 10× its start,
//!   a value is not finite or some `F ≤ 0`), `A = --amplitude` (default `10⁻⁴`);
//! * `dt_empirical_scan` — `{tried: [[dt, stable], …], unstable_below_stable: [dt, …]}`:
//!   33 more runs at equally spaced steps in `[0.7, 1.3]·dt_empirical`, and the steps that
//!   blew up below a larger step that did not (empty where stability is monotone in `dt`;
//!   where it is not, the bisection's answer depends on its bracket).
//!
//! Above 10 000 particles `bound58` and `dt_empirical` are `null` and `skipped` says why:
//! their runs cost particles × steps (the bisection and the scan about 45 runs of 4000
//! steps: seconds on small layouts, a minute or two near the limit);
//! above the dense limit `skipped` also names the dense columns left `null`. In
//! 2D and 3D the dense check, the full map and the bisection have size limits of their own
//! (`limits_nd::critical`, `limits_nd::full_map`), and `skipped` names each of those three
//! columns left `null`, with its size and limit (or "no result" when the tool ran and
//! failed).

mod common;
#[path = "critical_dt/full_map_1d.rs"]
mod full_map_1d;

use full_map_1d::full_map_1d;
use mpm_dt::limits_nd::critical;
use mpm_dt::limits_nd::full_map::FULL_MAP_LIMIT;
use mpm_dt::scenario::Scenario;
use mpm_dt::stability::operator::spectral_norm;
use mpm_dt::stability::{
    bound58, Bound58Reading, EmpiricalConfig, EmpiricalCritical, Eq56Operator, LambdaMaxTracker,
    LanczosConfig, MonotoneScan, Protocol, SoundSpeed, Stability,
};
use mpm_dt::{StepLimit, Stepper};
use serde_json::{json, Value};
use std::process::ExitCode;

/// Most particles for the dense tools (full map, spectral norms): their cost grows as n³
/// per bisection step, and 120 particles keep `critical_dt` within a few seconds.
const DENSE_LIMIT: usize = 120;

/// Most particles for which the real runs (eq 58's state, the empirical bisection) are made.
const RUN_LIMIT: usize = 10_000;

/// Why `dt_controller` is `null` (JSON has no infinity): the scenario's configuration has
/// no limit that proposes a step for the initial state.
const NO_PROPOSAL: &str = "dt_controller: no limit of the configuration proposes a step";

const USAGE: &str = "usage: critical_dt --scenario FILE [--json] [--amplitude A]";

/// `parse_args`' answer to `--help`.
const HELP: &str = "help";

struct Args {
    scenario: String,
    json: bool,
    amplitude: f64,
}

fn parse_args() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let (mut scenario, mut json, mut amplitude) = (None, false, 1e-4);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--scenario" => scenario = Some(it.next().ok_or("--scenario needs a file")?),
            "--json" => json = true,
            "--amplitude" => {
                let v = it.next().ok_or("--amplitude needs a value")?;
                amplitude = v
                    .parse::<f64>()
                    .map_err(|e| format!("--amplitude {v}: {e}"))?;
            }
            "-h" | "--help" => return Err(HELP.into()),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    Ok(Args {
        scenario: scenario.ok_or("--scenario FILE is required")?,
        json,
        amplitude,
    })
}

/// The table of a 2D or 3D scenario (`mpm_dt::limits_nd::critical`): `cell_size`, `c_p`,
/// `dt_sound`, `lambda_max_nodal`, `dt_eq56`, `dt_full_map` (from the nodes, `null` above
/// `limits_nd::critical::NODAL_FULL_MAP_LIMIT` active nodal unknowns), `dt_full_map_dense` (`null`
/// above `limits_nd::full_map::FULL_MAP_LIMIT` particle unknowns), `dt_controller` (the smallest proposal
/// of the standard d-dimensional limits for the initial state), `dt_empirical` (bisection,
/// 4000 steps, amplitude `A`), and `dt_sound_over_critical`: `dt_sound` over the best
/// critical step known (empirical, else full map, else eq 56) — above 1 the speed-of-sound
/// step `h/c_p` is unsafe by that factor (`sound_unsafe_by = ratio − 1`, else 0). A column
/// beyond its tool's size limit is `null`, and `skipped` says which and why.
fn run_nd<const D: usize>(
    scenario: &mpm_dt::nd::scenario::ScenarioNd,
    amplitude: f64,
) -> Result<Value, Box<dyn std::error::Error>>
where
    mpm_dt::Dim<D>: for<'a> mpm_dt::Dimension<View<'a> = mpm_dt::ViewNd<'a, D>>,
{
    let (solver, _) = scenario.build::<D>()?;
    let mut table = critical::critical_table(&solver, Some((amplitude, 4000)));
    table.dt_empirical_scan = table
        .dt_empirical
        .map(|dt| critical::empirical_scan(&solver, amplitude, 4000, dt));
    let config = scenario.controller_config()?;
    let gravity = mpm_dt::nd::Vector::<D>::zeros();
    let view = solver.view();
    let mut dt_controller = f64::INFINITY;
    for mut limit in mpm_dt::controller::standard_limits::<D>(&config, gravity) {
        dt_controller = dt_controller.min(limit.propose(&view)?.dt);
    }
    let best_known = table
        .dt_empirical
        .or(table.dt_full_map)
        .unwrap_or(table.dt_eq56);
    let ratio = table.dt_sound / best_known;
    let mut out = serde_json::to_value(&table)?;
    // Why a column is `null`: the size limit of its tool, or the tool gave no result (the
    // dense eigensolver or the dense map's search failed, or the full map's Lanczos
    // iteration did not settle; the error is not kept).
    let unknowns = view.n_nodes() * D;
    let particle_unknowns = view.n_particles() * (D + D * (D + 1) / 2);
    let pairs = view.n_particles() * view.weights.width();
    let reason = |column: &str, count: usize, what: &str, limit: usize| {
        if count > limit {
            format!("{column}: {count} {what}, above {limit}")
        } else {
            format!("{column}: no result ({count} {what}, within the limit of {limit})")
        }
    };
    // (left null, column, size, what is counted, the tool's limit)
    let columns = [
        (
            table.lambda_max_dense.is_none(),
            "lambda_max_dense",
            unknowns,
            "nodal unknowns",
            critical::DENSE_LIMIT,
        ),
        (
            table.dt_full_map.is_none(),
            "dt_full_map",
            mpm_dt::limits_nd::nodal_full_map::active_unknowns(&view),
            "active nodal unknowns",
            critical::NODAL_FULL_MAP_LIMIT,
        ),
        (
            table.dt_full_map_dense.is_none(),
            "dt_full_map_dense",
            particle_unknowns,
            "particle unknowns",
            FULL_MAP_LIMIT,
        ),
        (
            table.dt_empirical.is_none(),
            "dt_empirical",
            pairs,
            "particle-node pairs",
            critical::EMPIRICAL_LIMIT,
        ),
    ];
    let mut skipped: Vec<String> = columns
        .into_iter()
        .filter(|column| column.0)
        .map(|(_, column, count, what, limit)| reason(column, count, what, limit))
        .collect();
    if !dt_controller.is_finite() {
        skipped.push(NO_PROPOSAL.to_string());
    }
    if !skipped.is_empty() {
        out["skipped"] = json!(skipped.join("; "));
    }
    out["dt_controller"] = json!(dt_controller);
    out["dt_sound_over_critical"] = json!(ratio);
    out["sound_unsafe_by"] = json!((ratio - 1.0).max(0.0));
    out["dim"] = json!(D);
    Ok(out)
}

/// The table of the scenario in `args`, in its dimension.
fn run(args: &Args) -> Result<Value, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(&args.scenario)
        .map_err(|e| format!("cannot read {}: {e}", args.scenario))?;
    match mpm_dt::nd::scenario::ScenarioNd::dim_of(&text)? {
        1 => run_1d(args),
        d => {
            let scenario = mpm_dt::nd::scenario::ScenarioNd::from_json(&text)?;
            if d == 2 {
                run_nd::<2>(&scenario, args.amplitude)
            } else {
                run_nd::<3>(&scenario, args.amplitude)
            }
        }
    }
}

/// The table of a 1D scenario.
fn run_1d(args: &Args) -> Result<Value, Box<dyn std::error::Error>> {
    let scenario = Scenario::from_file(&args.scenario)?;
    let grid = scenario.grid()?;
    let layout = scenario.particle_init()?;
    let material = scenario.material();
    let config = EmpiricalConfig {
        amplitude: args.amplitude,
        ..EmpiricalConfig::default()
    };
    let protocol = Protocol::new(grid.clone(), scenario.shape, material, &layout, config)?;
    let stepper = mpm_dt::mpm::ReferenceStepper::new(
        grid.clone(),
        scenario.shape,
        material,
        protocol.initial().clone(),
    )?;
    let view = stepper.view();
    let n = view.n_particles();
    let h = grid.h;
    let dt_eq49 = SoundSpeed::dt_eq49(&view)?;
    let op = Eq56Operator::new(&view)?;
    let est = LambdaMaxTracker::new(LanczosConfig::default())?.update(&op)?;
    let small = n <= DENSE_LIMIT;
    let lambda_dense = if small {
        Some(op.normalised(op.dense_lambda_max()?))
    } else {
        None
    };
    let dt_eq56 = est.dt_eq56;
    tracing::info!(
        n,
        h,
        dt_eq49,
        lambda = est.lambda_hat,
        dt_eq56,
        "eq 49 and eq 56"
    );
    let (full, dt_full_dense, full_skipped) = full_map_1d(&view, dt_eq56, small)?;
    let dt_full = full.map(|c| c.dt);
    let (p_stab, p_sound) = controller_proposals(&scenario, &view)?;
    let dt_controller = p_stab.dt.min(p_sound.dt);

    // Real runs (eq 58's quarter period, the empirical bisection) cost in proportion to
    // particles × steps: above RUN_LIMIT particles they are skipped, so that the tool
    // answers in minutes at most on any scenario (the columns are `null`).
    // The columns every table has; the real runs add theirs below.
    let c = h / dt_eq49;
    let mut table = json!({
        "scenario": args.scenario,
        "shape": scenario.shape,
        "particles": n,
        "h": h,
        "wave_speed": c,
        "dt_eq49": dt_eq49,
        "lambda_max": est.lambda_hat,
        "lambda_max_dense": lambda_dense,
        "lambda_max_gershgorin": op.normalised(op.gershgorin_bound()),
        "lanczos_applications": est.applications,
        "dt_eq56": dt_eq56,
        "dt_full_map": dt_full,
        "full_map_products": full.map(|c| c.products),
        "dt_full_map_dense": dt_full_dense,
        "dt_controller": dt_controller,
        "dt_controller_stability": p_stab.dt,
        "dt_controller_sound_speed": p_sound.dt,
        "amplitude": args.amplitude,
    });
    let ratio_eq56 = dt_eq56 / dt_eq49;
    let ratio_full = dt_full.map(|d| d / dt_eq49);
    // Why columns are `null`: the dense tools' and the real runs' size limits.
    let mut skipped = skipped_columns(dt_controller, small);
    skipped.extend(full_skipped);
    let runs = real_runs_if_few(
        n,
        &grid,
        (scenario.shape, material),
        &protocol,
        (dt_eq49, dt_eq56, c),
        small,
        &mut skipped,
    )?;
    add_run_columns(
        &mut table,
        runs,
        (ratio_eq56, ratio_full, dt_eq49),
        &skipped,
    );
    Ok(table)
}

/// [`real_runs`] on the `protocol`'s `n` particles (`(shape, material)` on `grid`) when
/// there are at most [`RUN_LIMIT`]; above, `None` and the reason in `skipped`.
fn real_runs_if_few(
    n: usize,
    grid: &mpm_dt::Grid,
    (shape, material): (mpm_dt::Shape, mpm_dt::mpm::Material),
    protocol: &Protocol,
    steps: (f64, f64, f64),
    small: bool,
    skipped: &mut Vec<String>,
) -> Result<Option<RealRuns>, Box<dyn std::error::Error>> {
    Ok(if n > RUN_LIMIT {
        tracing::info!(
            n,
            RUN_LIMIT,
            "too many particles for the real runs: skipped"
        );
        skipped.push(format!(
            "eq 58 and the empirical bisection above {RUN_LIMIT} particles"
        ));
        None
    } else {
        Some(real_runs(grid, shape, material, protocol, steps, small)?)
    })
}

/// The stability and the sound-speed limits' proposals on `view`, the limits as
/// `Controller::standard` builds them from the scenario's config.
fn controller_proposals(
    scenario: &Scenario,
    view: &mpm_dt::View<'_>,
) -> Result<(mpm_dt::Proposal, mpm_dt::Proposal), Box<dyn std::error::Error>> {
    // The limits as `Controller::standard` builds them from the scenario's config.
    let config = scenario.controller_config()?;
    let p_stab = match config.stability {
        Some(c) => Stability::new(c)?.propose(view)?,
        None => mpm_dt::Proposal::no_opinion(),
    };
    let p_sound = match config.sound_speed {
        Some(c) => StepLimit::<1>::propose(&mut SoundSpeed::new(c)?, view)?,
        None => mpm_dt::Proposal::no_opinion(),
    };
    Ok((p_stab, p_sound))
}

/// Why columns are `null` before the full map and the real runs add theirs: no limit
/// proposing a step, and the dense tools' size limit.
fn skipped_columns(dt_controller: f64, small: bool) -> Vec<String> {
    let mut skipped = Vec::new();
    if !dt_controller.is_finite() {
        skipped.push(NO_PROPOSAL.to_string());
    }
    if !small {
        skipped.push(format!(
            "lambda_max_dense, dt_full_map_dense and bound58's norm_2 and rho above {DENSE_LIMIT} \
             particles"
        ));
    }
    skipped
}

/// The real runs' columns (`null` when they were skipped), the ratios to `h/c` (`ratios`
/// are eq 56's, the full map's and `dt_eq49`) and the `skipped` note.
fn add_run_columns(
    table: &mut Value,
    runs: Option<RealRuns>,
    (ratio_eq56, ratio_full, dt_eq49): (f64, Option<f64>, f64),
    skipped: &[String],
) {
    let (bound, emp_scan) = runs.unzip();
    let (emp, scan) = emp_scan.unzip();
    table["bound58"] = json!(bound);
    table["dt_empirical"] = json!(emp.map(|e| e.dt()));
    table["dt_empirical_bracket"] = json!(emp.map(|e| [e.dt_stable, e.dt_unstable]));
    table["empirical_runs"] = json!(emp.map_or(0, |e| e.runs));
    table["dt_empirical_scan"] = json!(scan);
    table["ratios_to_h_over_c"] = json!({
        "eq56": ratio_eq56,
        "full_map": ratio_full,
        "empirical": emp.map(|e| e.dt() / dt_eq49),
    });
    if !skipped.is_empty() {
        table["skipped"] = json!(skipped.join("; "));
    }
}

/// The nodal full map, the dense one and why the former is `null` ([`full_map_1d`]).
/// The eq 58 rows, the bisection and the monotonicity scan around its answer.
type RealRuns = (Vec<Value>, (EmpiricalCritical, MonotoneScan));

/// The real runs of a 1D table: eq 58 (both readings, and the dense `‖A‖₂` and `ρ(A)` on
/// small layouts) on the state a quarter period into a stable run, at multiples of
/// `dt_eq56`, and the empirical bisection. `steps` are `(dt_eq49, dt_eq56, c)`, `c` the wave speed.
fn real_runs(
    grid: &mpm_dt::Grid,
    shape: mpm_dt::Shape,
    material: mpm_dt::mpm::Material,
    protocol: &Protocol,
    (dt_eq49, dt_eq56, c): (f64, f64, f64),
    small: bool,
) -> Result<RealRuns, Box<dyn std::error::Error>> {
    // eq 58 on the state a quarter period into a stable run.
    let mut s = mpm_dt::mpm::ReferenceStepper::new(
        grid.clone(),
        shape,
        material,
        protocol.initial().clone(),
    )?;
    let dt_run = 0.5 * dt_eq56;
    let quarter = grid.length() / (4.0 * c);
    let steps = (quarter / dt_run).ceil() as usize;
    for _ in 0..steps {
        s.try_step(dt_run)?;
        s.accept()?;
    }
    let sv = s.view();
    let op_s = Eq56Operator::new(&sv)?;
    let lam_s = if small {
        op_s.dense_lambda_max().ok()
    } else {
        None
    };
    let mut bound = Vec::new();
    for f in [0.5, 0.9, 1.0, 1.1, 1.5, 2.0] {
        let dt = f * dt_eq56;
        let paper = bound58(&sv, dt, Bound58Reading::Paper)?;
        let cons = bound58(&sv, dt, Bound58Reading::Consistent)?;
        let norm_2 = if small {
            Some(spectral_norm(&op_s.dense_amplification(dt))?)
        } else {
            None
        };
        let rho = lam_s.map(|l| (1.0 - dt * dt * l).abs().max(1.0));
        bound.push(json!({
            "dt": dt,
            "dt_over_eq56": f,
            "value": paper.map(|b| b.value),
            "value_consistent": cons.map(|b| b.value),
            "value_energy": cons.map(|b| b.value_energy),
            "norm_2": norm_2,
            "rho": rho,
        }));
    }

    let emp = protocol.critical_dt(0.5 * dt_eq49, 1.5 * dt_eq49)?;
    tracing::info!(?emp, "empirical");
    let scan = protocol.scan(emp.dt())?;
    Ok((bound, (emp, scan)))
}

fn main() -> ExitCode {
    common::init_logs("info", false);
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) if e == HELP => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("error: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(v) => {
            if args.json {
                println!("{v}");
            } else {
                println!("{}", serde_json::to_string_pretty(&v).unwrap_or_default());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
