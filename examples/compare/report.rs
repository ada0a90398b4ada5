//! The 1D comparison's ratios and its table (module docs of `compare`).

use crate::args::Args;
use crate::PolicyResult;
use mpm_dt::scenario::Scenario;
use serde::Serialize;

/// Step ratio `steps(policy)/steps(mpm-dt)` and error ratio against one fixed rule.
#[derive(Debug, Serialize)]
pub(crate) struct Ratio {
    against: String,
    /// Whether the fixed policy stayed stable.
    stable: bool,
    steps_ratio: Option<f64>,
    /// Whether the policy took exactly mpm-dt's number of steps.
    same_step_count: bool,
    /// mpm-dt's final velocity error divided by the policy's (≤ 1 is "equal or better"),
    /// synchronised velocities.
    error_ratio: Option<f64>,
    /// The same ratio for the raw particle velocities.
    error_ratio_raw: Option<f64>,
    /// mpm-dt's wall time to the end divided by the policy's (< 1: mpm-dt ends sooner).
    wall_ratio: Option<f64>,
}

/// `a/b` when both exist and `b > 0`.
fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

pub(crate) fn ratios(results: &[PolicyResult]) -> Vec<Ratio> {
    let Some(ours) = results.iter().find(|r| r.policy == "mpm-dt") else {
        return Vec::new();
    };
    // Against 0.3, 0.4 and 0.5, and against the fixed rule with mpm-dt's step count.
    let fixed = [0.3, 0.4, 0.5].map(|alpha| format!("alpha={alpha}"));
    let matched = results
        .iter()
        .find(|r| r.policy.starts_with("matched"))
        .map(|r| r.policy.clone());
    fixed
        .into_iter()
        .chain(matched)
        .filter_map(|name| {
            let r = results.iter().find(|r| r.policy == name)?;
            Some(Ratio {
                against: name,
                stable: !r.blew_up,
                steps_ratio: (!ours.blew_up && ours.steps > 0)
                    .then(|| r.steps as f64 / ours.steps as f64),
                same_step_count: r.steps == ours.steps,
                error_ratio: ratio(ours.velocity_error_linf, r.velocity_error_linf),
                error_ratio_raw: ratio(ours.velocity_error_linf_raw, r.velocity_error_linf_raw),
                // Against a rule that blew up, or when mpm-dt did, there is no time to the
                // end to compare: `None`.
                wall_ratio: (!r.blew_up && !ours.blew_up)
                    .then(|| ratio(Some(ours.wall_s), Some(r.wall_s)))
                    .flatten(),
            })
        })
        .collect()
}

fn opt(v: Option<f64>, width: usize) -> String {
    match v {
        Some(x) => format!("{x:>width$.3e}"),
        None => format!("{:>width$}", "null"),
    }
}

pub(crate) fn print_table(
    path: &str,
    results: &[PolicyResult],
    ratios: &[Ratio],
    large_amplitude: bool,
) {
    println!("scenario {path}");
    println!(
        "{:<21} {:>7} {:>8} {:>7} {:>10} {:>12} {:>12} {:>12} {:>9} {:>10}",
        "policy",
        "steps",
        "rejected",
        "blew_up",
        "t_final",
        "v_err_linf",
        "v_err_raw",
        "energy_drift",
        "wall_s",
        "dt_mean"
    );
    for r in results {
        println!(
            "{:<21} {:>7} {:>8} {:>7} {:>10.4} {} {} {} {:>9.3} {}",
            r.policy,
            r.steps,
            r.rejected,
            if r.blew_up { "YES" } else { "no" },
            r.t_final,
            opt(r.velocity_error_linf, 12),
            opt(r.velocity_error_linf_raw, 12),
            opt(r.energy_drift, 12),
            r.wall_s,
            opt(r.dt_mean, 10),
        );
        if let Some(f) = &r.failure {
            println!("    {}: {f}", r.policy);
        }
    }
    for q in ratios {
        let verdict = match (q.stable, q.steps_ratio) {
            (false, _) => "the fixed rule blew up".to_string(),
            (true, None) => "mpm-dt blew up".to_string(),
            (true, Some(s)) if q.against.starts_with("matched") => {
                let errors = format!(
                    "error ratio {} (raw {})",
                    q.error_ratio.map_or("null".into(), |e| format!("{e:.3}")),
                    q.error_ratio_raw
                        .map_or("null".into(), |e| format!("{e:.3}")),
                );
                if q.same_step_count {
                    let verdict = match q.error_ratio {
                        Some(e) if e <= 1.0 => "at least as accurate with as many steps",
                        Some(_) => "LESS accurate with as many steps",
                        None => {
                            "of unknown relative accuracy (no exact solution, or both errors 0)"
                        }
                    };
                    format!("same step count, {errors} → mpm-dt {verdict}")
                } else {
                    format!(
                        "no stable fixed multiplier hits mpm-dt's step count; the closest stable \
                         one takes {s:.3}× its steps, {errors}"
                    )
                }
            }
            (true, Some(s)) => {
                format!(
                    "{:.2}× fewer steps, error ratio {} (raw {})",
                    s,
                    q.error_ratio
                        .map_or("unavailable".into(), |e| format!("{e:.3}")),
                    q.error_ratio_raw
                        .map_or("unavailable".into(), |e| format!("{e:.3}")),
                )
            }
        };
        let wall = q
            .wall_ratio
            .map_or("unavailable".into(), |w| format!("{w:.3}"));
        println!("mpm-dt vs {}: {verdict}; wall_ratio {wall}", q.against);
    }
    if large_amplitude {
        println!("note: large amplitude — the linear standing wave is a reference, not the exact solution");
    }
}

/// Prints the comparison: one JSON document with `--json`, else the table, the wall-ratio
/// ranges and the errors of the fixed rules with mpm-dt's step count.
pub(crate) fn print_results(
    args: &Args,
    scenario: &Scenario,
    particles: usize,
    results: &[PolicyResult],
    repeat: usize,
    pair_ranges: &[(String, [f64; 2])],
    same_count: &[(f64, Option<f64>)],
) {
    let ratios = ratios(results);
    // Displacement amplitude `A/κ` (velocity amplitude `A c`, `ω = c κ`) above half a cell:
    // particles cross cells and the linear small-amplitude solution is only a reference.
    let large_amplitude = scenario.standing_wave().is_some_and(|w| {
        let displacement = w.amplitude / w.wavenumber();
        displacement > 0.5 * scenario.length / scenario.cells as f64
    });
    if args.json {
        let doc = serde_json::json!({
            "dim": 1,
            "scenario": args.scenario,
            "t_end": scenario.t_end,
            "particles": particles,
            "exact_solution_is_reference_only": large_amplitude,
            "policies": results,
            "ratios": ratios,
            "tracking": args.tracking.as_ref().map_or("scenario", |t| t.0.as_str()),
            "repeats": repeat,
            "wall_ratio_of_pairs": pair_ranges
                .iter()
                .map(|(against, range)| serde_json::json!({"against": against, "range": range}))
                .collect::<Vec<_>>(),
            "matched_same_step_count": same_count
                .iter()
                .map(|&(alpha, error)| serde_json::json!({"alpha": alpha, "velocity_error_linf": error}))
                .collect::<Vec<_>>(),
        });
        println!("{doc}");
    } else {
        print_table(&args.scenario, results, &ratios, large_amplitude);
        if repeat > 1 {
            println!(
                "wall times: medians of {repeat} interleaved runs per policy (the matched rule: one)"
            );
            for (against, [lo, hi]) in pair_ranges {
                println!("mpm-dt vs {against}: wall ratio within a repeat {lo:.3} … {hi:.3}");
            }
        }
        let errors: Vec<f64> = same_count.iter().filter_map(|&(_, e)| e).collect();
        if errors.len() > 1 {
            let lo = errors.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = errors.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            println!(
                "fixed rules with mpm-dt's step count: {} multipliers, error {lo:.4e} … {hi:.4e}",
                errors.len()
            );
        }
    }
}
