//! `compare` for 2D and 3D scenarios: the fixed rules `dt = α·min_a h_a/(c_p + |v_a|)` and
//! mpm-dt's controller on the same reference solver (`SolverNd`), in one run.
//!
//! Per policy: steps, rejections, whether it blew up (a failed trial, a non-finite energy
//! or the energy above 10× its start; the fixed rules check the energy every 50 steps and
//! at the end, so that their wall time is the rule's), the velocity error against the
//! scenario's plane wave (`max_p |v_p − v(x_p, t)|∞/(A c)`), the energy drift, the wall
//! time (the median of `--repeat` interleaved runs, `wall_s_runs`), the mean step; for the
//! controller also `wall_ratio` against each fixed rule (with `wall_ratio_of_pairs`, the
//! range within each repeat, when repeated).
//! For layouts small enough (`limits_nd::critical::EMPIRICAL_LIMIT`) the empirical
//! critical step of the layout at `t = 0` (bisection on fixed-step runs from a wave of
//! amplitude `A = 10⁻²`, 4000 steps, `limits_nd::critical`) and the controller's mean step
//! as a fraction of it.

use crate::common::fixed_rule_nd::{energy_grew, run_alpha};
use crate::common::repeats::{median, more_rounds, ratio_range};
use mpm_dt::limits_nd::critical::critical_table;
use mpm_dt::nd::problems::PlaneWave;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::SolverNd;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use serde_json::{json, Value};
use std::time::Instant;

/// One policy's run.
struct Run {
    policy: String,
    steps: u64,
    rejected: u64,
    blew_up: Option<String>,
    t_final: f64,
    error: Option<f64>,
    energy_drift: f64,
    /// The median of `wall_s_runs`.
    wall_s: f64,
    /// Every timed run of the policy (`--repeat`).
    wall_s_runs: Vec<f64>,
}

impl Run {
    fn json(&self) -> Value {
        json!({
            "policy": self.policy, "steps": self.steps, "rejected": self.rejected,
            "blew_up": self.blew_up.is_some(), "failure": self.blew_up, "t_final": self.t_final,
            "velocity_error_linf": self.error, "energy_drift": self.energy_drift,
            "wall_s": self.wall_s, "wall_s_runs": self.wall_s_runs,
            "dt_mean": (self.steps > 0).then(|| self.t_final / self.steps as f64),
        })
    }
}

fn finish<const D: usize>(
    policy: String,
    s: &SolverNd<D>,
    e0: f64,
    wave: Option<&PlaneWave<D>>,
    mut blew_up: Option<String>,
    rejected: u64,
    wall_s: f64,
) -> Run
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let e = s.total_energy();
    if blew_up.is_none() && energy_grew(e, e0) {
        blew_up = Some(format!("energy {e:.3e} from {e0:.3e}"));
    }
    Run {
        policy,
        steps: s.step_count(),
        rejected,
        t_final: s.time(),
        error: wave
            .filter(|_| blew_up.is_none())
            .map(|w| w.velocity_error(&s.view())),
        energy_drift: (e - e0) / e0,
        blew_up,
        wall_s,
        wall_s_runs: vec![wall_s],
    }
}

fn fixed<const D: usize>(s: SolverNd<D>, alpha: f64, t_end: f64, wave: Option<&PlaneWave<D>>) -> Run
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let e0 = s.total_energy();
    let run = run_alpha(s, alpha, t_end);
    finish(
        format!("alpha={alpha}"),
        &run.solver,
        e0,
        wave,
        run.blew_up,
        0,
        run.wall_s,
    )
}

fn controlled<const D: usize>(
    mut s: SolverNd<D>,
    scenario: &ScenarioNd,
    wave: Option<&PlaneWave<D>>,
) -> Result<Run, String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let e0 = s.total_energy();
    let config = scenario.controller_config().map_err(|e| e.to_string())?;
    let mut controller = crate::common::controller_nd::controller_for::<D>(scenario, config, None)?;
    let start = Instant::now();
    let why = controller
        .run_until(&mut s, scenario.t_end, &mut |_| {})
        .err()
        .map(|e| e.to_string());
    let wall = start.elapsed().as_secs_f64();
    let rejected = controller.stats().rejected;
    Ok(finish("mpm-dt".into(), &s, e0, wave, why, rejected, wall))
}

fn run<const D: usize>(
    scenario: &ScenarioNd,
    alphas: &[f64],
    repeat: usize,
) -> Result<Value, String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let (s, wave) = scenario.build::<D>().map_err(|e| e.to_string())?;
    eprintln!(
        "compare: {D}D, {} particles, cells {:?}, shape {:?}, to t = {}",
        s.n_particles(),
        s.grid().cells,
        s.shape(),
        scenario.t_end
    );
    let table = critical_table(&s, Some((1e-2, 4000)));
    let mut runs: Vec<Run> = alphas
        .iter()
        .map(|&a| fixed(s.clone(), a, scenario.t_end, wave.as_ref()))
        .collect();
    let mut ours = controlled(s.clone(), scenario, wave.as_ref())?;
    // Interleaved repeats (`--repeat`): mpm-dt first in every other repeat; the runs are
    // deterministic, only their wall times are kept.
    let mut walls: Vec<Vec<f64>> = runs
        .iter()
        .chain(std::iter::once(&ours))
        .map(|r| vec![r.wall_s])
        .collect();
    // A controlled run that blew up is not repeated, and has no wall ratio.
    let reached = ours.blew_up.is_none();
    let repeat = if reached { repeat } else { 1 };
    more_rounds(&mut walls, repeat, |i| match alphas.get(i) {
        Some(&a) => Ok(fixed(s.clone(), a, scenario.t_end, wave.as_ref()).wall_s),
        None => controlled(s.clone(), scenario, wave.as_ref()).map(|r| r.wall_s),
    })?;
    for (r, w) in runs.iter_mut().chain(std::iter::once(&mut ours)).zip(walls) {
        r.wall_s_runs = w;
    }
    for r in runs.iter_mut().chain(std::iter::once(&mut ours)) {
        r.wall_s = median(&r.wall_s_runs);
    }
    let dt_mean = (ours.steps > 0).then(|| ours.t_final / ours.steps as f64);
    // Against a rule that blew up there is no time to the end to compare with: `null`.
    let wall_ratio: Vec<Value> = runs
        .iter()
        .map(|r| {
            let ratio = (r.blew_up.is_none() && reached).then(|| ours.wall_s / r.wall_s);
            let pairs = (r.blew_up.is_none() && reached && repeat > 1)
                .then(|| ratio_range(&ours.wall_s_runs, &r.wall_s_runs));
            json!({"against": r.policy, "wall_ratio": ratio, "wall_ratio_of_pairs": pairs})
        })
        .collect();
    let doc = json!({
        "dim": D,
        "t_end": scenario.t_end,
        "repeats": repeat,
        "particles": s.n_particles(),
        "h_over_c": table.dt_sound,
        "dt_eq56": table.dt_eq56,
        "dt_empirical": table.dt_empirical,
        "mean_dt_over_empirical": dt_mean.zip(table.dt_empirical).map(|(m, e)| m / e),
        "wall_ratio": wall_ratio,
        "policies": runs.iter().chain(std::iter::once(&ours)).map(Run::json).collect::<Vec<_>>(),
    });
    Ok(doc)
}

/// Runs the comparison of the 2D/3D scenario in `text`; prints the JSON document or a
/// table. `Ok(true)` when mpm-dt reached `t_end` without blowing up.
pub fn compare(
    path: &str,
    text: &str,
    alphas: &[f64],
    repeat: usize,
    as_json: bool,
) -> Result<bool, String> {
    let scenario = ScenarioNd::from_json(text).map_err(|e| e.to_string())?;
    let doc = match scenario.dim {
        2 => run::<2>(&scenario, alphas, repeat)?,
        3 => run::<3>(&scenario, alphas, repeat)?,
        d => return Err(format!("not a 2D or 3D scenario ({d}D)")),
    };
    let policies = doc["policies"].as_array().cloned().unwrap_or_default();
    let ok = policies
        .last()
        .is_some_and(|p| p["blew_up"] == json!(false));
    if as_json {
        let mut doc = doc;
        doc["scenario"] = json!(path);
        println!("{doc}");
        return Ok(ok);
    }
    println!("{path}: {}D, {} particles", doc["dim"], doc["particles"]);
    let h_over_c = doc["h_over_c"].as_f64().unwrap_or(f64::NAN);
    println!(
        "  dt_eq56 = {:.4} h/c_p, dt_empirical = {} (mpm-dt's mean step: {})",
        doc["dt_eq56"].as_f64().unwrap_or(f64::NAN) / h_over_c,
        doc["dt_empirical"]
            .as_f64()
            .map_or("not run (layout too large)".into(), |e| format!(
                "{:.4} h/c_p",
                e / h_over_c
            )),
        doc["mean_dt_over_empirical"]
            .as_f64()
            .map_or("-".into(), |r| format!("{r:.3} of it")),
    );
    println!(
        "  {:<10} {:>7} {:>5} {:>8} {:>11} {:>10} {:>9} {:>10}",
        "policy", "steps", "rej", "blew_up", "error", "drift", "wall_s", "dt/(h/c)"
    );
    for p in &policies {
        println!(
            "  {:<10} {:>7} {:>5} {:>8} {:>11} {:>10} {:>9.4} {:>10}",
            p["policy"].as_str().unwrap_or("?"),
            p["steps"].to_string(),
            p["rejected"].to_string(),
            p["blew_up"].to_string(),
            p["velocity_error_linf"]
                .as_f64()
                .map_or("-".into(), |e| format!("{e:.4e}")),
            p["energy_drift"]
                .as_f64()
                .map_or("-".into(), |e| format!("{e:+.3e}")),
            p["wall_s"].as_f64().unwrap_or(f64::NAN),
            p["dt_mean"]
                .as_f64()
                .map_or("-".into(), |d| format!("{:.4}", d / h_over_c)),
        );
    }
    for w in doc["wall_ratio"].as_array().into_iter().flatten() {
        let ratio = w["wall_ratio"]
            .as_f64()
            .map_or("- (the rule blew up)".into(), |r| format!("{r:.3}"));
        let pairs = w["wall_ratio_of_pairs"]
            .as_array()
            .map(|r| {
                let at = |i: usize| r.get(i).and_then(Value::as_f64).unwrap_or(f64::NAN);
                format!(" (within a repeat {:.3} … {:.3})", at(0), at(1))
            })
            .unwrap_or_default();
        println!(
            "  wall_ratio mpm-dt / {} = {ratio}{pairs}",
            w["against"].as_str().unwrap_or("?"),
        );
    }
    Ok(ok)
}
