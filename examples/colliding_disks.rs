//! Two elastic disks collide (Sulsky, Chen & Schreyer 1994), under mpm-dt's controller and
//! under the fixed rule `dt = 0.4·min_a h_a/(c_p + |v_a|)`, side by side.
//!
//! ```text
//! cargo run --release --example colliding_disks -- [--scenario FILE] [--plot FILE.svg] [--json] [--repeat N]
//! ```
//!
//! The default scenario is `scenarios/nd/colliding_disks.json`: the unit square of the
//! classic test, cells of 0.05 (20×20 on the square), disks of radius 0.2 at (0.2, 0.2)
//! and (0.8, 0.8) moving at ±(0.1, 0.1), E = 1000, ν = 0.3, ρ = 1000, 4 particles per cell,
//! to t = 3.5. The fixed rule also runs at α = 0.3, 0.5 and 0.9 for the table
//! (`other_alphas`; a run that blows up says where). The reference solver's walls hold their nodes at rest, which would glue the
//! disks (they touch the square's sides) to the walls; so the grid adds one free cell on
//! every side (22×22 cells on [0, 1.1]², the square shifted by one cell).
//! `scenarios/nd/colliding_spheres.json` is the 3D counterpart. The run prints both runs'
//! steps, wall time and energies; the controlled run and the α = 0.4 run are repeated
//! `--repeat` times (default 5), interleaved (each going first in every other pair), and
//! each policy's wall time is the median of
//! its repeats (the runs are deterministic: only the time differs; a 10 ms run is at the
//! mercy of a shared machine), with the range of the per-pair ratios; `--plot` draws the kinetic, strain and total energy and
//! the step against time for both (the USL step dissipates energy, so the total drifts down
//! in both runs).

#[path = "common/controller_nd.rs"]
mod controller_nd;
#[path = "common/repeats.rs"]
mod repeats;

use mpm_dt::controller::Outcome;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::SolverNd;
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde_json::json;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Energies and steps of one run: `(t, kinetic, strain, dt)` per accepted step.
#[derive(Default)]
struct History {
    rows: Vec<(f64, f64, f64, f64)>,
    wall_s: f64,
    error: Option<String>,
}

fn record<const D: usize>(h: &mut History, s: &SolverNd<D>, dt: f64)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    h.rows
        .push((s.time(), s.kinetic_energy(), s.strain_energy(), dt));
}

fn controlled<const D: usize>(mut s: SolverNd<D>, scenario: &ScenarioNd) -> History
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let mut h = History::default();
    record(&mut h, &s, f64::NAN);
    let config = match scenario.controller_config() {
        Ok(c) => c,
        Err(e) => {
            h.error = Some(e.to_string());
            return h;
        }
    };
    // The scenario's gravity goes to the growth monitor's energy.
    let mut controller = match controller_nd::controller_for::<D>(scenario, config, None) {
        Ok(c) => c,
        Err(e) => {
            h.error = Some(e.to_string());
            return h;
        }
    };
    // Only the policy's own work is timed: the energy history recorded for the plot is
    // the harness's, and would add the same time to every step of every run.
    let mut stepping = Duration::ZERO;
    while s.time() < scenario.t_end * (1.0 - 1e-14) {
        let start = Instant::now();
        let step = controller.step(&mut s, scenario.t_end);
        stepping += start.elapsed();
        match step {
            Ok(decisions) => {
                let dt = decisions
                    .iter()
                    .rfind(|d| d.outcome == Outcome::Accepted)
                    .map_or(f64::NAN, |d| d.dt);
                record(&mut h, &s, dt);
            }
            Err(e) => {
                h.error = Some(e.to_string());
                break;
            }
        }
    }
    h.wall_s = stepping.as_secs_f64();
    h
}

fn fixed_rule<const D: usize>(mut s: SolverNd<D>, alpha: f64, t_end: f64) -> History
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let mut h = History::default();
    record(&mut h, &s, f64::NAN);
    let e0 = s.total_energy();
    let mut stepping = Duration::ZERO;
    while s.time() < t_end * (1.0 - 1e-14) {
        // Timed: the rule and the step, as in `controlled`.
        let start = Instant::now();
        let step = SoundSpeed::unit_step(&s.view())
            .map_err(|e| e.to_string())
            .and_then(|u| {
                let dt = (alpha * u).min(t_end - s.time());
                s.try_step(dt)
                    .and_then(|_| s.accept())
                    .map(|_| dt)
                    .map_err(|e| e.to_string())
            });
        stepping += start.elapsed();
        let dt = match step {
            Ok(dt) => dt,
            Err(e) => {
                h.error = Some(e);
                break;
            }
        };
        let e = s.total_energy();
        if e.is_nan() || e > 10.0 * e0 {
            h.error = Some(format!("energy above 10x its start at t = {}", s.time()));
            break;
        }
        record(&mut h, &s, dt);
    }
    h.wall_s = stepping.as_secs_f64();
    h
}

fn plot(
    path: &str,
    title: &str,
    runs: &[(&str, &History, RGBColor)],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (1100, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(520);
    let t1 = runs
        .iter()
        .flat_map(|(_, h, _)| h.rows.last().map(|r| r.0))
        .fold(0.0, f64::max)
        .max(1e-12);
    plot_energies(&top, title, runs, t1)?;
    plot_steps(&bottom, runs, t1)?;
    root.present()?;
    Ok(())
}

/// The energy panel of [`plot`]: each run's total, kinetic and strain energy against time
/// up to `t1`.
fn plot_energies(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    runs: &[(&str, &History, RGBColor)],
    t1: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let e_max = runs
        .iter()
        .flat_map(|(_, h, _)| h.rows.iter().map(|r| r.1 + r.2))
        .fold(0.0, f64::max)
        .max(1e-300);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 24))
        .margin(14)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t1 * 1.02, 0.0..e_max * 1.35)?;
    chart
        .configure_mesh()
        .x_desc("time t (s)")
        .y_desc("energy (J per unit thickness)")
        .axis_desc_style(("sans-serif", 18))
        .label_style(("sans-serif", 15))
        .draw()?;
    for &(name, h, colour) in runs {
        let total: Vec<(f64, f64)> = h.rows.iter().map(|r| (r.0, r.1 + r.2)).collect();
        let kinetic: Vec<(f64, f64)> = h.rows.iter().map(|r| (r.0, r.1)).collect();
        let strain: Vec<(f64, f64)> = h.rows.iter().map(|r| (r.0, r.2)).collect();
        chart
            .draw_series(LineSeries::new(total, colour.stroke_width(3)))?
            .label(format!("{name}: total"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3))
            });
        chart
            .draw_series(DashedLineSeries::new(kinetic, 8, 4, colour.stroke_width(2)))?
            .label(format!("{name}: kinetic (dashed)"))
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (9, 0)], colour.stroke_width(2))
                    + PathElement::new(vec![(14, 0), (23, 0)], colour.stroke_width(2))
            });
        chart
            .draw_series(DashedLineSeries::new(strain, 2, 4, colour.stroke_width(2)))?
            .label(format!("{name}: strain (dotted)"))
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (2, 0)], colour.stroke_width(2))
                    + PathElement::new(vec![(7, 0), (9, 0)], colour.stroke_width(2))
                    + PathElement::new(vec![(14, 0), (16, 0)], colour.stroke_width(2))
                    + PathElement::new(vec![(21, 0), (23, 0)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 15))
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()?;
    Ok(())
}

/// The step panel of [`plot`]: each run's dt against time up to `t1`.
fn plot_steps(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    runs: &[(&str, &History, RGBColor)],
    t1: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let dt_max = runs
        .iter()
        .flat_map(|(_, h, _)| h.rows.iter().map(|r| r.3).filter(|d| d.is_finite()))
        .fold(0.0, f64::max)
        .max(1e-300);
    let mut chart = ChartBuilder::on(area)
        .margin(14)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t1 * 1.02, 0.0..dt_max * 1.4)?;
    chart
        .configure_mesh()
        .x_desc("time t (s)")
        .y_desc("time step dt (s)")
        .axis_desc_style(("sans-serif", 18))
        .label_style(("sans-serif", 15))
        .draw()?;
    for &(name, h, colour) in runs {
        // The last step, shortened to land on t_end, is left out of the line.
        let n = h.rows.len().saturating_sub(1);
        let pts: Vec<(f64, f64)> = h.rows[..n]
            .iter()
            .filter(|r| r.3.is_finite())
            .map(|r| (r.0, r.3))
            .collect();
        chart
            .draw_series(LineSeries::new(pts, colour.stroke_width(2)))?
            .label(format!("{name}: dt"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 15))
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()?;
    Ok(())
}

fn run<const D: usize>(
    scenario: &ScenarioNd,
    plot_path: Option<&str>,
    as_json: bool,
    repeat: usize,
) -> Result<bool, String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let (s, _) = scenario.build::<D>().map_err(|e| e.to_string())?;
    eprintln!(
        "colliding bodies: {D}D, {} particles, cells {:?}, to t = {}",
        s.n_particles(),
        s.grid().cells,
        scenario.t_end
    );
    let e0 = s.total_energy();
    let mut ours = controlled(s.clone(), scenario);
    let mut fixed = fixed_rule(s.clone(), 0.4, scenario.t_end);
    // Interleaved repeats of the two timed policies: the median wall time of each, and the
    // range of the ratios of the pairs.
    // A controlled run that failed is not repeated, and has no wall ratio.
    let reached = ours.error.is_none();
    let repeat = if reached { repeat } else { 1 };
    let mut walls = [vec![ours.wall_s], vec![fixed.wall_s]];
    let _: Result<(), std::convert::Infallible> = repeats::more_rounds(&mut walls, repeat, |i| {
        Ok(if i == 0 {
            controlled(s.clone(), scenario).wall_s
        } else {
            fixed_rule(s.clone(), 0.4, scenario.t_end).wall_s
        })
    });
    let [walls_ours, walls_fixed] = walls;
    let ratio_range = repeats::ratio_range(&walls_ours, &walls_fixed);
    ours.wall_s = repeats::median(&walls_ours);
    fixed.wall_s = repeats::median(&walls_fixed);
    // The other rules of thumb, for the table (not plotted; one run each, so their
    // `wall_ratio` is against the controller's median from a single run of theirs).
    let others: Vec<(f64, History)> = [0.3, 0.5, 0.9]
        .into_iter()
        .map(|alpha| (alpha, fixed_rule(s.clone(), alpha, scenario.t_end)))
        .collect();
    let summary = |h: &History| {
        let last = h.rows.last().copied().unwrap_or_default();
        let e = last.1 + last.2;
        json!({
            "steps": h.rows.len().saturating_sub(1),
            "wall_s": h.wall_s,
            "t_final": last.0,
            "energy_final": e,
            "energy_drift": (e - e0) / e0,
            "error": h.error,
        })
    };
    let out = json!({
        "energy_initial": e0,
        "mpm_dt": summary(&ours),
        "alpha_0_4": summary(&fixed),
        "other_alphas": others
            .iter()
            .map(|(alpha, h)| {
                let mut v = summary(h);
                v["alpha"] = json!(alpha);
                v["wall_ratio"] = json!(reached.then(|| ours.wall_s / h.wall_s));
                v
            })
            .collect::<Vec<_>>(),
        "steps_ratio": fixed.rows.len().saturating_sub(1) as f64 / ours.rows.len().saturating_sub(1).max(1) as f64,
        "wall_ratio": reached.then(|| ours.wall_s / fixed.wall_s),
        "repeats": repeat,
        "wall_ratio_of_pairs": reached.then_some(ratio_range),
    });
    if as_json {
        println!("{out}");
    } else {
        println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
    }
    if let Some(path) = plot_path {
        let title = format!("colliding bodies ({D}D): energies and time step");
        plot(
            path,
            &title,
            &[
                ("mpm-dt", &ours, RGBColor(230, 120, 0)),
                ("alpha = 0.4", &fixed, RGBColor(31, 119, 180)),
            ],
        )
        .map_err(|e| format!("cannot draw {path}: {e}"))?;
    }
    Ok(ours.error.is_none())
}

fn main() -> ExitCode {
    let mut scenario_path = "scenarios/nd/colliding_disks.json".to_string();
    let (mut plot_path, mut as_json, mut repeat) = (None, false, 5usize);
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--scenario" => match it.next() {
                Some(p) => scenario_path = p,
                None => {
                    eprintln!("error: --scenario needs a file");
                    return ExitCode::from(2);
                }
            },
            "--plot" => plot_path = it.next(),
            "--json" => as_json = true,
            "--repeat" => match repeats::parse_repeat(it.next()) {
                Ok(n) => repeat = n,
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(2);
                }
            },
            "--help" | "-h" => {
                println!(
                    "usage: colliding_disks [--scenario FILE] [--plot FILE.svg] [--json] [--repeat N]"
                );
                return ExitCode::SUCCESS;
            }
            other => {
                eprintln!("error: unknown argument {other}");
                return ExitCode::from(2);
            }
        }
    }
    let result = std::fs::read_to_string(&scenario_path)
        .map_err(|e| format!("cannot read {scenario_path}: {e}"))
        .and_then(|text| ScenarioNd::from_json(&text).map_err(|e| e.to_string()))
        .and_then(|s| match s.dim {
            2 => run::<2>(&s, plot_path.as_deref(), as_json, repeat),
            3 => run::<3>(&s, plot_path.as_deref(), as_json, repeat),
            d => Err(format!("colliding_disks runs 2D or 3D scenarios, not {d}D")),
        });
    match result {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => {
            eprintln!("error: the controlled run did not reach t_end");
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
