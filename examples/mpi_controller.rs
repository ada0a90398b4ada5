//! One controlled run across MPI ranks, with faults injected: a 2D problem is split over
//! the ranks — its grid cut into slabs (`SolverNd::new_slab`, the default) or its
//! particles (`--decomposition particles`, `SolverNd::new_distributed`) — and the
//! controllers agree, through `reduce::MpiReduce`, on one step and one verdict per attempt.
//!
//! ```text
//! cargo build --release --features mpi --example mpi_controller
//! mpirun -np 4 target/release/examples/mpi_controller [--cells N] [--t-end T]
//!        [--fail-rank R --fail-step K [--once]] [--abort-rank R --fail-step K]
//!        [--throw-rank R --fail-step K [--once]] [--decomposition slab|particles] [--out DIR]
//! ```
//!
//! The problem: a plane P wave on a periodic unit square of `N×N` cells (default 16), GIMP,
//! 2×2 particles per cell, Young's modulus 1, split by particle over the ranks. `--fail-rank R --fail-step K` makes rank
//! `R`'s trials non-finite from step `K` on (every rank must reject, and the run ends with too
//! many rejections everywhere), with `--once` only its first attempt at step `K` (every rank
//! rejects once and goes on); `--abort-rank R` makes its trial fail with an error no smaller
//! step can fix (that rank ends with it, the others with "another process failed");
//! `--throw-rank R` makes rank `R` take its trial at step `K` with a step 10⁴ times too
//! large, so that the solver's own trial fails on that rank only (its particles' `F`
//! inverts or their values overflow) while it takes part in the exchanges of the trial.
//!
//! Every rank prints one JSON line on stdout: its rank, a digest of the accepted steps' `dt`
//! bits (equal digests: the same steps, bit for bit), the rejections by cause, the final time and its error,
//! the run's wall time and the time spent in the controller's reductions (`reduce_s`,
//! `reductions`: the cost of agreeing, waiting for slower ranks included). With `--out DIR`
//! each rank also writes that line, with every step's `dt` bits, to `DIR/rank-R.json`
//! (lines from several ranks can interleave on a shared terminal).
//! Exit status 0 when the run reached `t_end`, 1 when it ended with an error, 2 on bad
//! arguments.

use mpi::topology::Communicator;
use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig, Outcome};
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::reduce::{MpiReduce, Reduce, Timed};
use mpm_dt::stepper::StepError;
use mpm_dt::{Boundary, Stepper, ViewNd};
use serde_json::json;
use std::process::ExitCode;
use std::rc::Rc;
use std::time::Instant;

/// The reference solver, with a fault injected on request.
struct Faulty {
    inner: SolverNd<2>,
    /// From this step on the trial fails: `(step, fatal)`.
    fail_from: Option<(u64, bool)>,
    /// Only the first attempt at that step fails.
    once: bool,
    /// The trial at this step is taken with a step 10⁴ times too large.
    throw_at: Option<u64>,
}

impl Stepper<2> for Faulty {
    fn time(&self) -> f64 {
        self.inner.time()
    }
    fn step_count(&self) -> u64 {
        self.inner.step_count()
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        // The trial runs in any case: its reductions need every rank.
        let thrown = self.throw_at == Some(self.inner.step_count());
        if thrown && self.once {
            self.throw_at = None;
        }
        let trial = self.inner.try_step(if thrown { dt * 1e4 } else { dt });
        match self.fail_from {
            Some((k, fatal)) if self.inner.step_count() >= k => {
                if self.once {
                    self.fail_from = None;
                }
                self.inner.reject();
                let (t, step) = (self.inner.time(), self.inner.step_count());
                Err(if fatal {
                    StepError::Other(format!("injected failure at step {step}"))
                } else {
                    StepError::NonFinite {
                        field: "v",
                        index: 0,
                        t,
                        step,
                        dt,
                    }
                })
            }
            _ => trial,
        }
    }
    fn accept(&mut self) -> Result<(), StepError> {
        self.inner.accept()
    }
    fn reject(&mut self) {
        self.inner.reject()
    }
    fn view(&self) -> ViewNd<'_, 2> {
        self.inner.view()
    }
    fn trial_view(&self) -> Option<ViewNd<'_, 2>> {
        self.inner.trial_view()
    }
}

struct Args {
    cells: usize,
    t_end: f64,
    fail: Option<(usize, bool)>,
    throw: Option<usize>,
    slab: bool,
    fail_step: u64,
    once: bool,
    out: Option<std::path::PathBuf>,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        cells: 16,
        t_end: 1.0,
        fail: None,
        throw: None,
        slab: true,
        fail_step: 5,
        once: false,
        out: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--cells" => a.cells = value()?.parse().map_err(|e| format!("--cells: {e}"))?,
            "--t-end" => a.t_end = value()?.parse().map_err(|e| format!("--t-end: {e}"))?,
            "--fail-rank" => a.fail = Some((value()?.parse().map_err(|e| format!("{e}"))?, false)),
            "--abort-rank" => a.fail = Some((value()?.parse().map_err(|e| format!("{e}"))?, true)),
            "--throw-rank" => a.throw = Some(value()?.parse().map_err(|e| format!("{e}"))?),
            "--decomposition" => {
                a.slab = match value()?.as_str() {
                    "slab" => true,
                    "particles" => false,
                    other => {
                        return Err(format!("--decomposition: slab or particles, not {other}"))
                    }
                }
            }
            "--fail-step" => a.fail_step = value()?.parse().map_err(|e| format!("{e}"))?,
            "--once" => a.once = true,
            "--out" => a.out = Some(value()?.into()),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if a.cells < 2 || !(a.t_end > 0.0 && a.t_end.is_finite()) {
        return Err("--cells must be ≥ 2 and --t-end positive".into());
    }
    Ok(a)
}

fn problem(cells: usize, slab: bool, reduce: Rc<dyn Reduce>) -> Result<SolverNd<2>, String> {
    let grid = GridNd::<2>::new([Boundary::Periodic; 2], [cells; 2], [1.0; 2]);
    let material = MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2; 2], 1.0, material);
    let c = material.p_modulus().sqrt();
    for p in 0..particles.len() {
        let x = particles.x[p][0];
        particles.v[p] = Vector::<2>::new(1e-2 * c * (2.0 * std::f64::consts::PI * x).sin(), 0.0);
    }
    let gravity = Vector::<2>::zeros();
    if slab {
        SolverNd::new_slab(grid, ShapeNd::Gimp, particles, gravity, reduce)
    } else {
        SolverNd::new_distributed(grid, ShapeNd::Gimp, particles, gravity, reduce)
    }
    .map_err(|e| e.to_string())
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("mpi_controller: {e}");
            return ExitCode::from(2);
        }
    };
    let Some(universe) = mpi::initialize() else {
        eprintln!("mpi_controller: MPI could not be initialised");
        return ExitCode::from(1);
    };
    let world = universe.world();
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    let clock = Rc::new(Timed::new(MpiReduce::new(world)));
    let reduce: Rc<dyn Reduce> = clock.clone();
    let solver = match problem(args.cells, args.slab, Rc::clone(&reduce)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("mpi_controller: rank {rank}: {e}");
            return ExitCode::from(1);
        }
    };
    let mut stepper = Faulty {
        inner: solver,
        fail_from: args
            .fail
            .filter(|&(r, _)| r == rank)
            .map(|(_, fatal)| (args.fail_step, fatal)),
        once: args.once,
        throw_at: args.throw.filter(|&r| r == rank).map(|_| args.fail_step),
    };
    let config = ControllerConfig::default();
    let limits = standard_limits::<2>(&config, Vector::<2>::zeros());
    let controller = match Controller::<2>::new(config, limits) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("mpi_controller: {e}");
            return ExitCode::from(1);
        }
    };
    let mut controller = controller.with_reduce(reduce);
    let start = Instant::now();
    let mut dts: Vec<String> = Vec::new();
    let mut rejected: std::collections::BTreeMap<String, u64> = Default::default();
    let result = controller.run_until(&mut stepper, args.t_end, &mut |d| match d.outcome {
        Outcome::Accepted => dts.push(format!("{:016x}", d.dt.to_bits())),
        Outcome::Rejected => {
            let cause = d.cause.map_or("none", |c| c.as_str()).to_string();
            *rejected.entry(cause).or_default() += 1;
        }
    });
    let wall_s = start.elapsed().as_secs_f64();
    // FNV-1a over the steps' bits: equal digests, equal steps (for the terminal; the
    // files of `--out` hold every step).
    let digest = dts
        .iter()
        .flat_map(|h| h.bytes())
        .fold(0xcbf29ce484222325u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x100000001b3)
        });
    let mut line = json!({
        "rank": rank,
        "size": size,
        "steps": dts.len(),
        "dt_digest": format!("{digest:016x}"),
        "rejected": rejected,
        "t": stepper.time(),
        "energy_local": stepper.inner.total_energy(),
        "error": result.as_ref().err().map(|e| e.to_string()),
        "wall_s": wall_s,
        "reduce_s": clock.spent().as_secs_f64(),
        "reductions": clock.calls(),
    });
    println!("{line}");
    if let Some(dir) = &args.out {
        line["dt_bits"] = json!(dts);
        let path = dir.join(format!("rank-{rank}.json"));
        if let Err(e) = std::fs::write(&path, line.to_string()) {
            eprintln!("mpi_controller: cannot write {}: {e}", path.display());
            return ExitCode::from(1);
        }
    }
    drop(universe);
    if result.is_ok() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
