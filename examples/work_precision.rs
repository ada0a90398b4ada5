//! Work–precision diagrams: the time-stepping error of each step policy against its wall
//! time, on one scene, the standard comparison of time integrators (Hairer & Wanner).
//!
//! ```text
//! cargo run --release --example work_precision -- (--scenario FILE | --mpm88 jelly|fluid)
//!     [--json] [--plot FILE.svg] [--alpha A,B,...] [--tol T,U,...] [--reference-alpha A]
//!     [--repeat N] [--t-end T]
//! ```
//!
//! `--t-end` runs the scene to `T` instead of its own end time (a horizon where the
//! converged reference exists: before a splash or a separation makes the end state depend
//! on every step).
//!
//! `--scenario` takes a scenario of any dimension (reference solvers); `--mpm88` runs
//! taichi's mpm88 jelly or fluid on the MLS-MPM solver of the `mls_mpm` example, whose
//! shipped step `2·10⁻⁴` s is one more point (`shipped dt=…`).
//!
//! The **error** of a run is the distance of its end state from the same solver's run with
//! a converged step (`measure`): the RMS over particles of the position and of the velocity
//! differences, relative to the motion's scales, and the total energy's difference
//! relative to the initial energy. The reference is the fixed rule at
//! `α_ref/2` (`--reference-alpha`, default 0.025, so the reference runs at 0.0125); the run
//! at `α_ref` is measured against it too, and its error (`reference_change`: how much
//! halving the reference's step changes it) must be at most a tenth of the smallest error
//! plotted for the diagram to show time-stepping errors rather than the reference's own
//! (`reference_converged`).
//!
//! The **points**: the fixed rules `dt = α·h/(c + |v|)` (default α = 0.2, 0.3, 0.4, 0.5,
//! 0.7; `--alpha`), mpm-dt's standard controller with the scene's config (`mpm-dt
//! default`, `rtol = atol_rel = 0.05` unless the scene sets them) and with its temporal
//! tolerance set to each of `--tol` (default 0.01, 0.003, 0.001, 3·10⁻⁴, 10⁻⁴, 3·10⁻⁵,
//! 10⁻⁵) — `rtol = atol_rel = tol` (the temporal error limit's weight is
//! `atol_rel·‖u‖_∞ + rtol·|u_p|`; `atol_rel` follows `rtol` unless a scene sets it, and is
//! set here too so that a scene's own `atol_rel` cannot hold the points).
//! The **wall time** is the median of `--repeat` (default 3) timed runs of each point,
//! interleaved (each round visits every point, in reversed order every other round); the
//! runs are deterministic, so only their times differ.
//!
//! `--json` prints one JSON document on stdout: `scene`, `particles`, `scales`,
//! `reference` (`alpha`, `steps`, `reference_change`, `reference_converged`), `points`
//! (`policy`, `steps`, `rejected`, `failure`, `wall_s`, `wall_s_runs`, `errors`:
//! `position`, `velocity`, `energy`; `energy_change` = `(E − E₀)/E₀` at the end), `fixed_time_to_match` (per controller point and
//! measure, the wall time of the fixed-rule curve at the controller's error, interpolated
//! log–log between adjacent rules, over the controller's wall time; `null` when no rule's
//! error brackets it) and `load` (`/proc/loadavg` before and after). `--plot` draws the
//! diagram (one panel per measure). Progress goes to stderr. Exit status: 0 at the end
//! (and for `--help`), 1 when a scenario cannot be read or run or the reference run fails,
//! 2 for a usage error.

#[path = "work_precision/diagram.rs"]
mod diagram;
#[path = "work_precision/measure.rs"]
mod measure;
#[path = "mls_mpm/model.rs"]
#[allow(dead_code)]
mod model;
#[path = "mls_mpm/mpm88.rs"]
#[allow(dead_code)]
mod mpm88;
#[path = "work_precision/plot.rs"]
mod plot;
#[path = "common/repeats.rs"]
#[allow(dead_code)]
mod repeats;
#[path = "work_precision/runs.rs"]
mod runs;
#[path = "work_precision/scene.rs"]
mod scene;
#[path = "mls_mpm/solver.rs"]
#[allow(dead_code)]
mod solver;
// The MLS-MPM solver's pass totals (`mls_mpm`), under the name its solver expects.
#[path = "mls_mpm/summary.rs"]
#[allow(dead_code)]
mod summary;

use std::process::ExitCode;

const USAGE: &str =
    "usage: work_precision (--scenario FILE | --mpm88 jelly|fluid) [--json] [--plot FILE.svg] \
[--alpha A,B,...] [--tol T,U,...] [--reference-alpha A] [--repeat N] [--t-end T] [--staggered-kick]";

/// Command-line options (module docs).
struct Args {
    scenario: String,
    json: bool,
    plot: Option<String>,
    alphas: Vec<f64>,
    tols: Vec<f64>,
    reference_alpha: f64,
    repeat: usize,
    /// Runs to this time instead of the scene's own end time.
    t_end: Option<f64>,
    /// The 1D reference solver's staggered kick, in every run.
    staggered_kick: bool,
}

fn list(name: &str, v: Option<String>) -> Result<Vec<f64>, String> {
    let v = v.ok_or(format!("{name} needs a value"))?;
    v.split(',')
        .map(|a| match a.trim().parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
            _ => Err(format!("{name}: {a:?} is not a positive number")),
        })
        .collect()
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        scenario: String::new(),
        json: false,
        plot: None,
        alphas: vec![0.2, 0.3, 0.4, 0.5, 0.7],
        tols: vec![0.01, 0.003, 0.001, 3e-4, 1e-4, 3e-5, 1e-5],
        reference_alpha: 0.025,
        repeat: 3,
        t_end: None,
        staggered_kick: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--scenario" => a.scenario = it.next().ok_or("--scenario needs a value")?,
            "--mpm88" => {
                a.scenario = match it.next().as_deref() {
                    Some(k @ ("jelly" | "fluid")) => format!("mpm88-{k}"),
                    _ => return Err("--mpm88 needs jelly or fluid".into()),
                }
            }
            "--json" => a.json = true,
            "--staggered-kick" => a.staggered_kick = true,
            "--plot" => a.plot = Some(it.next().ok_or("--plot needs a value")?),
            "--alpha" => a.alphas = list("--alpha", it.next())?,
            "--tol" => a.tols = list("--tol", it.next())?,
            "--reference-alpha" => {
                a.reference_alpha = match list("--reference-alpha", it.next())?.as_slice() {
                    [x] if *x <= 0.05 => *x,
                    _ => return Err("--reference-alpha: one number, at most 0.05".into()),
                }
            }
            "--repeat" => a.repeat = repeats::parse_repeat(it.next())?,
            "--t-end" => {
                a.t_end = match list("--t-end", it.next())?.as_slice() {
                    [t] => Some(*t),
                    _ => return Err("--t-end: one positive number".into()),
                }
            }
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if a.scenario.is_empty() {
        return Err("--scenario or --mpm88 is required".into());
    }
    Ok(a)
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}

fn main() -> ExitCode {
    if std::env::args().skip(1).any(|a| a == "-h" || a == "--help") {
        println!("{USAGE}");
        return ExitCode::SUCCESS;
    }
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let load_before = load();
    let scene = match scene::Scene::open(&args.scenario) {
        Ok(s) if args.staggered_kick && !s.is_one_d() => {
            eprintln!("error: --staggered-kick: only the 1D reference solver has a staggered kick");
            return ExitCode::from(2);
        }
        Ok(mut s) => {
            s.staggered_kick = args.staggered_kick;
            match args.t_end {
                Some(t) => s.until(t),
                None => s,
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let result = diagram::diagram(
        &scene,
        &args.alphas,
        &args.tols,
        args.reference_alpha,
        args.repeat,
    );
    let mut doc = match result {
        Ok(d) => d,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    doc.load = [load_before, load()];
    if let Some(path) = &args.plot {
        let title = format!("{} ({} particles)", args.scenario, doc.particles);
        if let Err(e) = plot::plot(path, &title, &doc.plot_points()) {
            eprintln!("error: plot {path}: {e}");
            return ExitCode::from(1);
        }
    }
    if args.json {
        match serde_json::to_string(&doc) {
            Ok(s) => println!("{s}"),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        }
    } else {
        doc.print_table();
    }
    ExitCode::SUCCESS
}
