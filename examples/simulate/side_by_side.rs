//! `simulate --compare`: the 2D/3D controller and the fixed rules α = 0.4 and 0.5 timed side
//! by side, in interleaved repeats (`--repeat`).

use crate::common;
use mpm_dt::controller::ControllerConfig;
use mpm_dt::nd::problems::PlaneWave;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::SolverNd;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use serde_json::{json, Value};
use std::time::Instant;

/// Wall time of one more controlled run of `template` to `t_end` on one process (a repeat;
/// the run is deterministic, only its time is new).
fn timed_controller<const D: usize>(
    template: &SolverNd<D>,
    scenario: &ScenarioNd,
    config: &ControllerConfig,
) -> Result<f64, String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let mut s = template.clone();
    // The limits on the solver's threads, as `simulate --threads` sets them.
    let threads = (s.threads() > 1).then(|| s.threads());
    let mut controller = common::controller_nd::controller_for(scenario, config.clone(), None)?
        .with_threads(threads)
        .map_err(|e| e.to_string())?;
    let start = Instant::now();
    controller
        .run_until(&mut s, scenario.t_end, &mut |_| {})
        .map_err(|e| format!("a repeated controlled run failed: {e}"))?;
    Ok(start.elapsed().as_secs_f64())
}

/// The timed runs of `--compare`.
pub struct SideBySide {
    /// The controller's wall times: its first run (the one `simulate` reports, whose
    /// callback also reads the refresh counts), then its repeats.
    pub ours_runs: Vec<f64>,
    /// Their median.
    pub ours_median: f64,
    /// One JSON object per fixed rule: steps, error, median wall time and its runs,
    /// `wall_ratio` (medians) and `wall_ratio_of_pairs` (the range within each repeat);
    /// both ratios `null` when the controlled run did not reach `t_end`.
    pub rules: Value,
}

/// Runs the fixed rules α = 0.4 and 0.5 from `template` to `t_end` and repeats the timed
/// runs: repeat 0 is the controller's run already made (`(wall, reached)`: its time and
/// whether it reached `t_end`) then the rules; in every other repeat the rules go first
/// (`common::repeats`). A controlled run that did not reach `t_end` is not repeated, and
/// the rules then run once.
pub fn fixed_rules<const D: usize>(
    template: &SolverNd<D>,
    scenario: &ScenarioNd,
    config: &ControllerConfig,
    wave: Option<&PlaneWave<D>>,
    (wall, reached): (f64, bool),
    repeat: usize,
) -> Result<SideBySide, String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let repeat = if reached { repeat } else { 1 };
    let alphas = [0.4, 0.5];
    // Round 0: the controller's run already made, then the rules (their runs are kept).
    let first_runs: Vec<_> = alphas
        .iter()
        .map(|&alpha| common::fixed_rule_nd::run_alpha(template.clone(), alpha, scenario.t_end))
        .collect();
    // Policy 0 is the controller, 1.. the rules.
    let mut walls: Vec<Vec<f64>> = std::iter::once(vec![wall])
        .chain(first_runs.iter().map(|r| vec![r.wall_s]))
        .collect();
    common::repeats::more_rounds(&mut walls, repeat, |i| match i {
        0 => timed_controller(template, scenario, config),
        i => Ok(
            common::fixed_rule_nd::run_alpha(template.clone(), alphas[i - 1], scenario.t_end)
                .wall_s,
        ),
    })?;
    let ours_runs = walls.remove(0);
    let walls_rules = walls;
    let ours_median = common::repeats::median(&ours_runs);
    let mut rules = Vec::new();
    for ((alpha, run), walls) in alphas.iter().zip(&first_runs).zip(&walls_rules) {
        let (steps, blew_up) = (run.solver.step_count(), run.blew_up.is_some());
        let w = common::repeats::median(walls);
        let err = wave.map(|wv| wv.velocity_error(&run.solver.view()));
        eprintln!(
            "simulate: alpha {alpha}: {steps} steps, {w:.3} s (median of {}), blew up {blew_up}, error {err:?}",
            walls.len()
        );
        rules.push(json!({
            "alpha": alpha, "steps": steps, "wall_s": w, "wall_s_runs": walls,
            "blew_up": blew_up, "velocity_error_linf": err,
            "wall_ratio": reached.then(|| ours_median / w),
            "wall_ratio_of_pairs": reached.then(|| common::repeats::ratio_range(&ours_runs, walls)),
        }));
    }
    Ok(SideBySide {
        ours_runs,
        ours_median,
        rules: json!(rules),
    })
}
