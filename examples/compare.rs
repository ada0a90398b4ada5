//! mpm-dt against the rules of thumb: one scenario, the same reference stepper, every policy
//! in one run.
//!
//! ```text
//! cargo run --release --example compare -- --scenario FILE [--json]
//! ```
//!
//! Policies:
//! - `alpha=0.3`, `alpha=0.4`, `alpha=0.5`, `alpha=0.9`: a fixed multiplier `α` of the
//!   sound-speed step `α h/(c_max + ‖v‖_∞)` (eq 49 generalised, [`SoundSpeed::dt`]),
//!   re-evaluated on every committed state, the last step clamped to `t_end`. This is what
//!   Uintah (0.3–0.4), NairnMPM (0.5), sparkl (0.5–0.9) and Karamelo (0.9) ship.
//!   `--alpha A,B,...` replaces the four multipliers (e.g. to add one that takes as many
//!   steps as mpm-dt); the step and error ratios are printed against 0.3 and 0.4 when
//!   they are in the list.
//! - `matched alpha=A`: the fixed multiplier that takes as many steps as mpm-dt (`run_matched`:
//!   a first guess from mpm-dt's mean step and the sound-speed step at `t = 0`, proportional
//!   corrections and bisection on the step count; a run that blows up bounds α from above).
//!   A whole interval of α gives the same count, with errors that differ by a few tenths of
//!   a percent, so once a multiplier hits the count `N`, 24 more around it (`α (1 + k/8N)`,
//!   `k = ±1 … ±12`) are run and the row is the most accurate with that count; their errors are printed as a
//!   range (`matched_same_step_count` in the JSON). When no multiplier lands on the count,
//!   the row is the closest stable run with *more* steps; with none stable at or above it,
//!   the first run that blew up. It asks whether the controller places its steps better
//!   than a fixed rule with as many steps (not the same cost: a controlled step costs more
//!   than a bare one, README "Controller overhead"). `--no-matched` skips it; without an
//!   mpm-dt run to match, or when the search fails, a warning is logged and the row is
//!   absent.
//! - `mpm-dt`: the standard controller, [`Controller::standard`] with the scenario's
//!   `controller` configuration (else the defaults): the `SoundSpeed` cap with `α = 1`
//!   (never binding on GIMP layouts at rest; it protects against particles crossing cells
//!   when `‖v‖_∞` is large), the `Stability` limit (eq 56 tracked λmax, the config's safety,
//!   0.95 by default), the temporal error limit and the growth monitor.
//!   `--tracking MODE` chooses how the stability limit follows λmax: `certified` (default,
//!   [`Tracking::Certified`]: a rigorous upper bound at every step, re-anchored by Lanczos
//!   when it drifts), `lanczos` (the Lanczos Ritz value recomputed at every step,
//!   `Refresh::every_step`) or `lanczos-cached` (`Refresh::cached`).
//!
//! A run *blows up* when the stepper returns an error, any particle value is not finite, the
//! total energy exceeds 10× its initial value, or a deformation gradient `F ≤ 0` — the
//! criteria of the stability module's empirical protocol ([`mpm_dt::stability::Protocol`]).
//! For `mpm-dt` a controller error (e.g. too many rejections) also counts as a blow-up.
//!
//! Reported per policy: `policy, steps, rejected, blew_up, t_final, velocity_error_linf,
//! velocity_error_linf_raw, closing_half_step, energy_drift, wall_s, wall_s_runs,
//! dt_mean`:
//! - `velocity_error_linf = max_p |v_sync,p − v_exact(X_p, t_final)|` (the ∞-norm over
//!   particles, `X_p` the particle's initial position) against the scenario's standing-wave
//!   solution, for the **synchronised velocity** `v_sync,p = v_p + ℓ Σ_i S_ip a_i`
//!   ([`mpm_dt::View::synchronized_velocity`]): the USL step's particle velocity lags the
//!   exact one by half a step (symplectic Euler, an error `(dt/2)|a|` of first order in dt),
//!   and the closing half kick removes that lag. `ℓ` (`closing_half_step`) is half the last
//!   step that was not shortened to land on `t_end`: for a fixed α the last unclamped step,
//!   for mpm-dt the last accepted step not bound by `t_end`
//!   ([`mpm_dt::closing_half_step`]). `null` for the neo-Hookean material or a scenario at
//!   rest. The exact solution is that of linear elasticity at small amplitude: for a large
//!   amplitude (particles crossing cells) it is only a reference, not the truth.
//! - `velocity_error_linf_raw`: the same norm for the particle velocity `v_p` itself, with
//!   its half-step lag (what `velocity_error_linf` was before the synchronisation).
//! - `energy_drift = (E_final − E_0)/E_0`, `E = kinetic + strain energy` (relative).
//! - `dt_mean = t_final / steps` (accepted steps).
//!
//! `--repeat N` times every policy's run `N` times (default 1), interleaved (mpm-dt first in
//! every other repeat); `wall_s` is then the median of `wall_s_runs`, and the
//! JSON's `wall_ratio_of_pairs` (a list of `{against, range}`; in 2D/3D a
//! `wall_ratio_of_pairs` beside each `wall_ratio` entry, and `wall_s`/`wall_s_runs` per
//! policy) and a line per rule in the table give the range of the ratios within each
//! repeat. An mpm-dt run that blew up is not repeated and has no wall ratio. Single runs of a few seconds vary by several per cent on a
//! shared machine; the runs are deterministic, so only their times differ.
//!
//! Human table on stdout by default; `--json` prints one JSON document on stdout instead.
//! Logs go to stderr (`RUST_LOG` filters them, default `warn`).
//!
//! A 2D or 3D scenario (`"dim": 2` or `3`) is compared by `compare/nd.rs` on the
//! d-dimensional reference solver: the same fixed multipliers, mpm-dt, the wall-time
//! ratios and, on small layouts, the empirical critical step and mpm-dt's mean step as a
//! fraction of it (the matched-α search and `--tracking` are 1D only). Exit status 1 when
//! mpm-dt blew up there.

#[path = "compare/args.rs"]
mod args;
mod common;
#[path = "compare/matched.rs"]
mod matched;
#[path = "compare/nd.rs"]
mod nd;
#[path = "compare/report.rs"]
mod report;

use mpm_dt::controller::Controller;
use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::Scenario;
use mpm_dt::stability::{SoundSpeed, SoundSpeedConfig, Tracking};
use mpm_dt::{closing_half_step, Stepper};
use serde::Serialize;
use std::process::ExitCode;
use std::time::Instant;

use args::{parse_args, Args};
use matched::run_matched;
use report::print_results;

/// Energy growth factor that counts as a blow-up (the empirical protocol's default).
const ENERGY_GROWTH: f64 = 10.0;

/// One policy's result.
#[derive(Debug, Serialize)]
struct PolicyResult {
    policy: String,
    steps: u64,
    rejected: u64,
    blew_up: bool,
    /// Why the run blew up, if it did.
    failure: Option<String>,
    t_final: f64,
    /// Error of the synchronised velocity (module docs).
    velocity_error_linf: Option<f64>,
    /// Error of the raw particle velocity.
    velocity_error_linf_raw: Option<f64>,
    /// The closing half step `ℓ` of the synchronisation.
    closing_half_step: f64,
    energy_drift: Option<f64>,
    /// Wall time to the end: the median of `wall_s_runs`.
    wall_s: f64,
    /// Every timed run of this policy (`--repeat`; one without it).
    wall_s_runs: Vec<f64>,
    dt_mean: Option<f64>,
}

/// The blow-up test on a committed state (see the module docs). Non-finite values and
/// `F ≤ 0` need no scan here: `ReferenceStepper::try_step` already fails such a trial with
/// `StepError::NonFinite` / `StepError::Inverted`, which the policies count as a blow-up, so
/// only the energy criterion is left to check.
///
/// Reads the energy from the pass summary both runs ask for (the solver's own pass
/// computes it), so the check costs no pass of its own: a per-step energy pass here would
/// add the same time to every step of every policy and flatter the run with fewer steps.
fn blow_up(stepper: &ReferenceStepper, e0: f64) -> Option<String> {
    let e = stepper
        .view()
        .trusted_summary()
        .map_or_else(|| stepper.total_energy(), |s| s.total_energy);
    if !e.is_finite() || e > ENERGY_GROWTH * e0 {
        return Some(format!(
            "energy {e:.3e} exceeds {ENERGY_GROWTH}× its start {e0:.3e}"
        ));
    }
    None
}

/// Fills the error columns from the final state.
struct Reference<'a> {
    scenario: &'a Scenario,
    x0: Vec<f64>,
    e0: f64,
}

impl Reference<'_> {
    /// `half_step`: the closing half step `ℓ` of the synchronised velocity (module docs).
    fn finish(
        &self,
        policy: String,
        stepper: &ReferenceStepper,
        half_step: f64,
        rejected: u64,
        failure: Option<String>,
        wall_s: f64,
    ) -> PolicyResult {
        let t = stepper.time();
        let steps = stepper.step_count();
        let view = stepper.view();
        let (synchronised, raw) =
            common::velocity_errors(self.scenario, &self.x0, &view, half_step);
        let finite = |e: f64| e.is_finite().then_some(e);
        let velocity_error_linf = synchronised.and_then(finite);
        let velocity_error_linf_raw = raw.and_then(finite);
        let drift = (stepper.total_energy() - self.e0) / self.e0;
        PolicyResult {
            policy,
            steps,
            rejected,
            blew_up: failure.is_some(),
            failure,
            t_final: t,
            velocity_error_linf,
            velocity_error_linf_raw,
            closing_half_step: half_step,
            energy_drift: drift.is_finite().then_some(drift),
            wall_s,
            wall_s_runs: vec![wall_s],
            dt_mean: (steps > 0).then(|| t / steps as f64),
        }
    }
}

/// Fixed multiplier `α` of the sound-speed step, re-evaluated every step.
fn run_fixed(
    scenario: &Scenario,
    reference: &Reference<'_>,
    alpha: f64,
) -> Result<PolicyResult, String> {
    let limit = SoundSpeed::new(SoundSpeedConfig { alpha }).map_err(|e| e.to_string())?;
    let mut stepper = scenario.build().map_err(|e| e.to_string())?;
    // The pass summary saves the limit its validation scan (the same steps, bit for bit:
    // `tests/solver_summary.rs`), as in the controller's run.
    stepper.provide_summary(true);
    let t_end = scenario.t_end;
    let start = Instant::now();
    let mut failure = None;
    // Half the last step not clamped to land on t_end.
    let mut half_step = 0.0;
    while stepper.time() < t_end {
        let dt = match limit.dt(&stepper.view()) {
            Ok(dt) => dt,
            Err(e) => {
                failure = Some(e.to_string());
                break;
            }
        };
        let remaining = t_end - stepper.time();
        // Clamp the last step; a remainder below 1e-12 of t_end is round-off, not a step.
        if remaining <= 1e-12 * t_end {
            break;
        }
        let regular = dt <= remaining;
        let dt = dt.min(remaining);
        if let Err(e) = stepper.try_step(dt).and_then(|()| stepper.accept()) {
            failure = Some(e.to_string());
            break;
        }
        if regular {
            half_step = 0.5 * dt;
        }
        if let Some(why) = blow_up(&stepper, reference.e0) {
            failure = Some(why);
            break;
        }
    }
    let wall = start.elapsed().as_secs_f64();
    Ok(reference.finish(
        format!("alpha={alpha}"),
        &stepper,
        half_step,
        0,
        failure,
        wall,
    ))
}

/// mpm-dt's controller.
fn run_controller(
    scenario: &Scenario,
    reference: &Reference<'_>,
    tracking: Option<Tracking>,
) -> Result<PolicyResult, String> {
    let mut config = scenario.controller_config().map_err(|e| e.to_string())?;
    if let Some(tracking) = tracking {
        if let Some(stability) = config.stability.as_mut() {
            stability.tracking = tracking;
        }
    }
    let mut controller = Controller::standard(config).map_err(|e| e.to_string())?;
    let mut stepper = scenario.build().map_err(|e| e.to_string())?;
    let t_end = scenario.t_end;
    let start = Instant::now();
    let mut failure = None;
    // Half the last accepted step not bound by t_end.
    let mut half_step = 0.0;
    while stepper.time() < t_end {
        match controller.step(&mut stepper, t_end) {
            Ok(decisions) => {
                if decisions.is_empty() {
                    break; // t_end reached within round-off
                }
                half_step = closing_half_step(&decisions).unwrap_or(half_step);
            }
            Err(e) => {
                failure = Some(e.to_string());
                break;
            }
        }
        if let Some(why) = blow_up(&stepper, reference.e0) {
            failure = Some(why);
            break;
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let stats = controller.stats();
    tracing::info!(binding = ?stats.binding, rejected = ?stats.rejected_by_cause,
        growth_events = stats.growth_events, "mpm-dt run");
    let rejected = stats.rejected;
    Ok(reference.finish(
        "mpm-dt".into(),
        &stepper,
        half_step,
        rejected,
        failure,
        wall,
    ))
}

fn main() -> ExitCode {
    common::init_logs("warn", false);
    let args = match parse_args() {
        Ok(a) => a,
        Err(msg) => {
            eprintln!("{msg}");
            return ExitCode::from(2);
        }
    };
    if let Some(code) = compare_nd(&args) {
        return code;
    }
    let scenario = match Scenario::from_file(&args.scenario) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let (x0, e0) = match scenario.build() {
        Ok(s) => (s.view().x.to_vec(), s.total_energy()),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let reference = Reference {
        scenario: &scenario,
        x0,
        e0,
    };
    let mut results = Vec::new();
    for &alpha in &args.alphas {
        match run_fixed(&scenario, &reference, alpha) {
            Ok(r) => results.push(r),
            Err(e) => {
                eprintln!("error: alpha={alpha}: {e}");
                return ExitCode::from(1);
            }
        }
    }
    match run_controller(&scenario, &reference, args.tracking.as_ref().map(|t| t.1)) {
        Ok(r) => results.push(r),
        Err(e) => {
            eprintln!("error: mpm-dt: {e}");
            return ExitCode::from(1);
        }
    }
    let (repeat, pair_ranges) = match repeat_timed_runs(&args, &scenario, &reference, &mut results)
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    // The fixed rule with mpm-dt's step count; a failure to find one is reported, not fatal.
    let mut same_count = Vec::new();
    if args.matched {
        if let Some(ours) = results.iter().find(|r| r.policy == "mpm-dt") {
            match run_matched(&scenario, &reference, ours) {
                Ok(Some(m)) => {
                    same_count = m.same_count;
                    results.push(m.result);
                }
                Ok(None) => tracing::warn!("no matched multiplier: mpm-dt blew up or took no step"),
                Err(e) => tracing::warn!(error = %e, "no matched multiplier"),
            }
        }
    }
    print_results(
        &args,
        &scenario,
        reference.x0.len(),
        &results,
        repeat,
        &pair_ranges,
        &same_count,
    );
    ExitCode::SUCCESS
}

/// A 2D or 3D scenario is compared by `nd::compare`: its exit code, or `None` for a 1D one.
fn compare_nd(args: &Args) -> Option<ExitCode> {
    if let Ok(text) = std::fs::read_to_string(&args.scenario) {
        if matches!(mpm_dt::nd::scenario::ScenarioNd::dim_of(&text), Ok(2 | 3)) {
            return Some(
                match nd::compare(&args.scenario, &text, &args.alphas, args.repeat, args.json) {
                    Ok(true) => ExitCode::SUCCESS,
                    Ok(false) => {
                        eprintln!("error: mpm-dt did not reach t_end");
                        ExitCode::from(1)
                    }
                    Err(e) => {
                        eprintln!("error: {e}");
                        ExitCode::from(1)
                    }
                },
            );
        }
    }
    None
}

/// mpm-dt's wall-ratio range within a repeat against each fixed rule, by the rule's name.
type PairRanges = Vec<(String, [f64; 2])>;

/// Repeats the timed runs (`--repeat`) and sets every result's `wall_s_runs` and median
/// `wall_s`: the number of repeats and mpm-dt's wall-ratio range within a repeat against
/// each fixed rule.
fn repeat_timed_runs(
    args: &Args,
    scenario: &Scenario,
    reference: &Reference<'_>,
    results: &mut [PolicyResult],
) -> Result<(usize, PairRanges), String> {
    // Interleaved repeats of the timed runs (`--repeat`): mpm-dt goes first in every other
    // repeat; every run is deterministic, so only the wall times are kept.
    let tracking = args.tracking.as_ref().map(|t| t.1);
    // An mpm-dt run that blew up is not repeated (and has no wall ratio, `report::ratios`).
    let reached = results.last().is_some_and(|r| !r.blew_up);
    let repeat = if reached { args.repeat } else { 1 };
    let mut walls: Vec<Vec<f64>> = results.iter().map(|r| vec![r.wall_s]).collect();
    let timed = common::repeats::more_rounds(&mut walls, repeat, |i| {
        match args.alphas.get(i) {
            Some(&alpha) => run_fixed(scenario, reference, alpha),
            None => run_controller(scenario, reference, tracking),
        }
        .map(|r| r.wall_s)
        .map_err(|e| format!("{}: {e}", results[i].policy))
    });
    timed?;
    for (r, w) in results.iter_mut().zip(walls) {
        r.wall_s_runs = w;
    }
    for r in results.iter_mut() {
        r.wall_s = common::repeats::median(&r.wall_s_runs);
    }
    let ours_runs = results
        .last()
        .map(|r| r.wall_s_runs.clone())
        .unwrap_or_default();
    let pair_ranges: PairRanges = results
        .iter()
        .filter(|r| r.policy != "mpm-dt" && !r.blew_up && reached && repeat > 1)
        .map(|r| {
            let range = common::repeats::ratio_range(&ours_runs, &r.wall_s_runs);
            (r.policy.clone(), range)
        })
        .collect();
    Ok((repeat, pair_ranges))
}
