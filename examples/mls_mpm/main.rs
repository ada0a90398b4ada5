//! A foreign scheme under mpm-dt: a compact 2D MLS-MPM / APIC solver ([`solver`]) written
//! against the public `Stepper<2>` trait only, on taichi's `mpm88` scene with an elastic
//! jelly in place of its fluid.
//!
//! ```text
//! cargo run --release --example mls_mpm -- [--grid N] [--t-end T] [--fixed-dt DT] [--find-failure] [--rules] [--fluid] [--eq56] [--generic] [--repeat N]
//! ```
//!
//! The scene: a box `[0, 1]²` of `N×N` cells (default 128) with walls three cells thick,
//! 8192 particles at seeded random positions in the square `[0.2, 0.6]²` moving at
//! `(0, −1)`, gravity 9.8 downwards, a fixed-corotated jelly with E = 400, ν = 0.2, ρ = 1,
//! particle volume `(h/2)²` — mpm88's setup, whose shipped step is `dt = 2·10⁻⁴`.
//!
//! * `--fixed-dt DT` runs the scene with a fixed step;
//! * `--rules` also runs the rules of thumb `dt = α·h/(c_p + |v|)` for α = 0.3, 0.4, 0.5, 0.9;
//! * `--find-failure` finds the smallest fixed step at which the run blows up before `t_end`
//!   (non-finite values, a particle through a wall, `det F ≤ 0`, or kinetic plus elastic
//!   energy above 10× the energy the block has to give: its initial kinetic energy plus
//!   its potential energy above the floor) by a 1 % scan from mpm88's step and a bisection
//!   (`find_failure`);
//! * every run also drives the scene with mpm-dt's controller (the standard 2D limits: sound
//!   speed, eq 56 stability on the solver's own weights, growth; no tuning) and prints both.
//!   The stability limit is told the scheme's velocity transfer, APIC with quadratic
//!   B-splines (`TransferNd::Apic { inertia: 0.25 }`: `D_p = h²/4`, a property of the
//!   scheme): its limit is `√(2(1 + p)/λmax)` with `p` the transfer's Rayleigh quotient on
//!   the top mode (`limits_nd::transfer`). `--eq56` analyses the paper's FLIP step instead
//!   (`√(2/λmax)`), which is conservative for this scheme;
//! * `--repeat N` times the fixed-step run and the controlled run `N` times, interleaved
//!   (the controller first in every other repeat), and prints their median wall times, the
//!   ratio of the medians and the range of the ratios within a repeat: single runs of a
//!   second or two vary by several per cent on a shared machine.

mod model;
mod mpm88;
#[path = "../common/repeats.rs"]
mod repeats;
mod solver;
mod summary;

use mpm88::{build, Scene, MPM88_DT};
use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::Stepper;
use solver::MlsMpm;
use std::process::ExitCode;

/// How a fixed-step run ended.
#[derive(Debug)]
struct FixedRun {
    steps: u64,
    blew_up: Option<String>,
    wall_s: f64,
    energy: (f64, f64, f64),
}

/// Energy the block can give: kinetic plus potential above the floor (y = 0).
fn energy_budget(s: &MlsMpm) -> f64 {
    let (k, e, p) = s.energies();
    // `p = −Σ m g·x = Σ m 9.8 y`, the potential energy above y = 0.
    k + e + p
}

fn run_fixed(scene: Scene, dt: f64) -> FixedRun {
    run_rule(scene, &|_| Ok(dt))
}

/// A run whose every step is `rule(state)`, clamped to `t_end` (blow-up criteria as
/// [`run_fixed`]).
fn run_rule(scene: Scene, rule: &dyn Fn(&MlsMpm) -> Result<f64, String>) -> FixedRun {
    let mut s = build(Scene {
        summary: false,
        ..scene
    })
    .without_views();
    let budget = energy_budget(&s);
    // Only the rule and the step are timed, as the controlled run's `Controller::step`: the
    // blow-up checks below are the harness's.
    let mut stepping = std::time::Duration::ZERO;
    let mut blew_up = None;
    while s.time() < scene.t_end - 1e-12 {
        let start = std::time::Instant::now();
        let dt = match rule(&s) {
            Ok(dt) => dt,
            Err(e) => {
                blew_up = Some(e);
                break;
            }
        };
        let step = dt.min(scene.t_end - s.time());
        let stepped = s.try_step(step).and_then(|_| s.accept());
        stepping += start.elapsed();
        if let Err(e) = stepped {
            blew_up = Some(e.to_string());
            break;
        }
        let view = s.view();
        if let Some(p) = view.f.iter().position(|f| f.determinant() <= 0.0) {
            blew_up = Some(format!("det F <= 0 at particle {p}, t = {}", s.time()));
            break;
        }
        let (k, e, _) = s.energies();
        if !(k + e).is_finite() || k + e > 10.0 * budget {
            blew_up = Some(format!(
                "energy {:.3e} > 10x budget at t = {}",
                k + e,
                s.time()
            ));
            break;
        }
    }
    FixedRun {
        steps: s.step_count(),
        blew_up,
        wall_s: stepping.as_secs_f64(),
        energy: s.energies(),
    }
}

/// How the controlled run ended.
struct ControlledRun {
    steps: u64,
    rejected: u64,
    dt_mean: f64,
    dt_min: f64,
    wall_s: f64,
    error: Option<String>,
    /// The λmax refreshes and what bound the steps, for the log.
    refreshes: String,
    /// What the controller holds ([`Controller::memory_bytes`]), for the log.
    memory: String,
}

/// The scene under mpm-dt's standard 2D limits (sound speed, eq 56 stability, growth),
/// with no tuning.
fn run_controlled(scene: Scene) -> ControlledRun {
    let mut s = build(scene);
    let config = mpm88::controller_config(scene, &ControllerConfig::default());
    let start = std::time::Instant::now();
    let mut controller = match Controller::<2>::standard(config) {
        Ok(c) => c,
        Err(e) => {
            return ControlledRun {
                steps: 0,
                rejected: 0,
                dt_mean: f64::NAN,
                dt_min: f64::NAN,
                wall_s: 0.0,
                error: Some(e.to_string()),
                refreshes: String::new(),
                memory: String::new(),
            }
        }
    };
    let mut refreshes = (0.0, 0.0);
    let mut ratios = Vec::new();
    let mut on_bound = 0.0;
    let error = controller
        .run_until(&mut s, scene.t_end, &mut |d| {
            for l in &d.limits {
                if let (Some(&r), Some(&a)) = (
                    l.metrics.get("refreshes"),
                    l.metrics.get("lanczos_applications"),
                ) {
                    refreshes = (r, a);
                    ratios.extend(l.metrics.get("bound_ratio"));
                }
                on_bound = l
                    .metrics
                    .get("bound_proposals")
                    .copied()
                    .unwrap_or(on_bound);
            }
        })
        .err()
        .map(|e| e.to_string());
    let wall_s = start.elapsed().as_secs_f64();
    let stats = controller.stats();
    let [lo, hi] = ratios.iter().fold([f64::INFINITY, 0.0f64], |[lo, hi], &r| {
        [lo.min(r), hi.max(r)]
    });
    let median = if ratios.is_empty() {
        f64::NAN
    } else {
        repeats::median(&ratios)
    };
    let refreshes = format!(
        "  stability refreshes: {} (Lanczos products {}), {on_bound} proposals on the element bound, bound/λmax at the refreshes {lo:.2} … {median:.2} … {hi:.2}; steps bound by {:?}",
        refreshes.0, refreshes.1, stats.binding
    );
    let n = s.view().x.len().max(1);
    let memory = format!(
        "  controller memory: {} B held, {:.1} B a particle ({n} particles, {} nodes)",
        controller.memory_bytes(),
        controller.memory_bytes() as f64 / n as f64,
        s.view().node_mass.len()
    );
    ControlledRun {
        memory,
        steps: stats.accepted,
        rejected: stats.rejected,
        dt_mean: stats.dt_mean().unwrap_or(f64::NAN),
        dt_min: stats.dt_min_chosen.or(stats.dt_min).unwrap_or(f64::NAN),
        wall_s,
        error,
        refreshes,
    }
}

/// The smallest fixed step (in units of h/c_p) that blows up, as a bracket `(stable, blows
/// up)`: a scan by 1 % from mpm88's step — up while it is stable, down while it blows up —
/// then a bisection between the last stable and the first unstable step. A bisection over
/// a wide bracket alone is not enough: the splashing fluid's unstable steps are not an
/// interval (with this layout 2.39–2.40·10⁻⁴ s blow up before t = 0.3 and 2.41–2.80·10⁻⁴
/// do not), so it can answer a step far above the smallest failing one. A failing window
/// narrower than the scan's 1 % can still be missed.
fn find_failure(scene: Scene) -> (f64, f64) {
    let s = build(scene);
    let unit = s.grid().h[0] / s.p_wave_speed();
    let blows_up = |x: f64| {
        let r = run_fixed(scene, x * unit);
        eprintln!(
            "  dt = {:.4e} ({x:.4} h/c_p): {}",
            x * unit,
            r.blew_up.as_deref().unwrap_or("stable")
        );
        r.blew_up.is_some()
    };
    let start = MPM88_DT / unit;
    let (mut lo, mut hi) = if blows_up(start) {
        let mut hi = start;
        while hi > 1e-3 && blows_up(hi / 1.01) {
            hi /= 1.01;
        }
        (hi / 1.01, hi)
    } else {
        let mut lo = start;
        while lo < 4.0 && !blows_up(lo * 1.01) {
            lo *= 1.01;
        }
        (lo, lo * 1.01)
    };
    for _ in 0..6 {
        let mid = 0.5 * (lo + hi);
        if blows_up(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (lo * unit, hi * unit)
}

/// The command line's choices.
struct Options {
    scene: Scene,
    fixed: Option<f64>,
    failure: bool,
    rules: bool,
    repeat: usize,
}

/// The options from the command line, or the exit code to end with (`--help`, a bad
/// argument).
fn parse_args() -> Result<Options, ExitCode> {
    let mut scene = Scene {
        n_grid: 128,
        t_end: 0.5,
        fluid: false,
        apic: true,
        summary: true,
    };
    let mut fixed = None;
    let mut failure = false;
    let mut rules = false;
    let mut repeat = 1;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = |name: &str| -> Result<f64, String> {
            args.next()
                .ok_or(format!("{name} needs a value"))?
                .parse::<f64>()
                .map_err(|e| format!("{name}: {e}"))
        };
        let parsed = match a.as_str() {
            "--grid" => value("--grid").map(|v| scene.n_grid = v as usize),
            "--t-end" => value("--t-end").map(|v| scene.t_end = v),
            "--fixed-dt" => value("--fixed-dt").map(|v| fixed = Some(v)),
            "--fluid" => {
                scene.fluid = true;
                Ok(())
            }
            "--eq56" => {
                scene.apic = false;
                Ok(())
            }
            "--generic" => {
                scene.summary = false;
                Ok(())
            }
            "--find-failure" => {
                failure = true;
                Ok(())
            }
            "--rules" => {
                rules = true;
                Ok(())
            }
            "--repeat" => repeats::parse_repeat(args.next()).map(|n| repeat = n),
            "--help" | "-h" => {
                println!("usage: mls_mpm [--grid N] [--t-end T] [--fixed-dt DT] [--find-failure] [--rules] [--fluid] [--eq56] [--generic] [--repeat N]");
                return Err(ExitCode::SUCCESS);
            }
            other => Err(format!("unknown argument {other}")),
        };
        if let Err(e) = parsed {
            eprintln!("error: {e}");
            return Err(ExitCode::from(2));
        }
    }
    if scene.n_grid < 16 || scene.n_grid > 4096 || scene.t_end.is_nan() || scene.t_end <= 0.0 {
        eprintln!("error: --grid must be in 16..=4096 and --t-end positive");
        return Err(ExitCode::from(2));
    }
    Ok(Options {
        scene,
        fixed,
        failure,
        rules,
        repeat,
    })
}

/// Runs and prints the rules of thumb `dt = α·h/(c_p + |v|)`, re-evaluated every step.
fn print_rules(scene: Scene) {
    for alpha in [0.3, 0.4, 0.5, 0.9] {
        let r = run_rule(scene, &|s: &MlsMpm| {
            SoundSpeed::unit_step(&s.view())
                .map(|u| alpha * u)
                .map_err(|e| e.to_string())
        });
        println!(
            "alpha = {alpha}: {} steps, {:.2} s wall, {}",
            r.steps,
            r.wall_s,
            r.blew_up.as_deref().unwrap_or("stable")
        );
    }
}

/// Times `repeat` interleaved rounds of the fixed-step and the controlled run (`r` and `c`
/// are the first) and prints the medians and the ratios.
fn print_repeats(scene: Scene, dt: f64, repeat: usize, r: &FixedRun, c: &ControlledRun) {
    // The two runs above were the first repeat; the repeats after it alternate the order.
    let mut walls = [vec![r.wall_s], vec![c.wall_s]];
    let _: Result<(), std::convert::Infallible> = repeats::more_rounds(&mut walls, repeat, |i| {
        Ok(if i == 0 {
            run_fixed(scene, dt).wall_s
        } else {
            run_controlled(scene).wall_s
        })
    });
    let (fixed_median, ours_median) = (repeats::median(&walls[0]), repeats::median(&walls[1]));
    let [lo, hi] = repeats::ratio_range(&walls[1], &walls[0]);
    println!(
        "wall times over {repeat} interleaved runs: fixed dt median {fixed_median:.2} s, controller median {ours_median:.2} s, ratio {:.3} (within a repeat {lo:.3} … {hi:.3})",
        ours_median / fixed_median
    );
}

fn main() -> ExitCode {
    let Options {
        scene,
        fixed,
        failure,
        rules,
        repeat,
    } = match parse_args() {
        Ok(o) => o,
        Err(code) => return code,
    };
    let s = build(scene);
    let unit = s.grid().h[0] / s.p_wave_speed();
    println!(
        "MLS-MPM {}, {}x{} cells, {} particles, h/c_p = {:.4e} s, mpm88's dt = {:.1e} s = {:.3} h/c_p",
        if scene.fluid { "fluid (mpm88)" } else { "jelly" },
        scene.n_grid,
        scene.n_grid,
        8192,
        unit,
        MPM88_DT,
        MPM88_DT / unit
    );
    let failure_step = failure.then(|| find_failure(scene));
    if let Some((lo, hi)) = failure_step {
        println!(
            "failure step: stable at {:.4e} s ({:.3} h/c_p), blows up at {:.4e} s ({:.3} h/c_p); mpm88's dt is {:.3} of it",
            lo,
            lo / unit,
            hi,
            hi / unit,
            MPM88_DT / hi
        );
    }
    let dt = fixed.unwrap_or(MPM88_DT);
    let r = run_fixed(scene, dt);
    println!(
        "fixed dt = {dt:.3e} s ({:.3} h/c_p): {} steps, {:.2} s wall, {}; energies (kinetic, elastic, potential) = {:.4e}, {:.4e}, {:.4e}",
        dt / unit,
        r.steps,
        r.wall_s,
        r.blew_up.as_deref().unwrap_or("stable"),
        r.energy.0,
        r.energy.1,
        r.energy.2
    );
    if rules {
        // The rules of thumb: dt = α·h/(c_p + |v|), re-evaluated every step.
        print_rules(scene);
    }
    let c = run_controlled(scene);
    eprintln!("{}", c.refreshes);
    eprintln!("{}", c.memory);
    println!(
        "mpm-dt controller: {} steps ({} rejected), mean dt {:.4e} s ({:.3} h/c_p), min dt {:.4e} s, {:.2} s wall, {}",
        c.steps,
        c.rejected,
        c.dt_mean,
        c.dt_mean / unit,
        c.dt_min,
        c.wall_s,
        c.error.as_deref().unwrap_or("reached t_end")
    );
    if repeat > 1 && c.error.is_none() && r.blew_up.is_none() {
        print_repeats(scene, dt, repeat, &r, &c);
    }
    if let Some((_, hi)) = failure_step {
        println!(
            "controller mean dt / failure step = {:.3}; steps against the fixed dt: {:.2}x fewer",
            c.dt_mean / hi,
            r.steps as f64 / c.steps.max(1) as f64
        );
    }
    if c.error.is_some() {
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
