//! A 2D or 3D scenario run under the controller with its particles split over MPI ranks.
//!
//! ```text
//! cargo build --release --features mpi --example mpi_simulate
//! mpirun -np 4 target/release/examples/mpi_simulate --scenario scenarios/nd/gimp_2d_1e5.json
//!        [--t-end T] [--decomposition slab|particles] [--out DIR]
//! ```
//!
//! Every rank reads the scenario and keeps its part:
//!
//! * `slab` (the default, `SolverNd::new_slab`): the grid is cut into slabs along its last
//!   axis; each rank holds its slab's nodes plus two ghost planes each side and the
//!   particles inside it, completes the nodal sums with its neighbours after each particle
//!   → grid pass and hands particles that leave its slab to the neighbour;
//! * `particles` (`SolverNd::new_distributed`): a block of particles per rank, the whole
//!   grid on every rank, the nodal sums completed with one `MPI_Allreduce` per pass.
//!
//! The controller's limits see the rank's particles and nodes; the stability tracker's
//! Lanczos products and dot products are completed over the ranks, and the controller
//! agrees on every step and verdict (`mpm_dt::reduce`). So 1, 2 and 4 ranks take the same
//! steps, up to the order of the floating-point sums.
//!
//! Rank 0 prints the summary (JSON): particles, ranks, steps, rejections, mean `dt`, the
//! final time, the total energy, wall time and the time spent in the controller's and the
//! solver's reductions and exchanges, and how many particles ended on another rank than
//! they started on. With `--out DIR` every rank writes `DIR/rank-R.json`: its steps' `dt`
//! (hex bits) and its particles' run-wide indices (`id`) and final positions and
//! velocities.
//! Exit status 0 when the run reached `t_end`, 1 when it ended with an error, 2 on bad
//! arguments.

#[path = "common/controller_nd.rs"]
mod controller_nd;

use mpm_dt::controller::Outcome;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::Vector;
use mpm_dt::reduce::{MpiReduce, Reduce, Timed};
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use serde_json::json;
use std::process::ExitCode;
use std::rc::Rc;
use std::time::Instant;

struct Args {
    scenario: String,
    t_end: Option<f64>,
    slab: bool,
    out: Option<std::path::PathBuf>,
}

fn parse() -> Result<Args, String> {
    let mut scenario = None;
    let mut t_end = None;
    let mut out = None;
    let mut slab = true;
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--scenario" => scenario = Some(value()?),
            "--t-end" => {
                let t: f64 = value()?.parse().map_err(|e| format!("--t-end: {e}"))?;
                if !(t > 0.0 && t.is_finite()) {
                    return Err("--t-end must be positive".into());
                }
                t_end = Some(t);
            }
            "--out" => out = Some(value()?.into()),
            "--decomposition" => {
                slab = match value()?.as_str() {
                    "slab" => true,
                    "particles" => false,
                    other => {
                        return Err(format!("--decomposition: slab or particles, not {other}"))
                    }
                }
            }
            other => return Err(format!("unknown argument {other}")),
        }
    }
    Ok(Args {
        scenario: scenario.ok_or("--scenario FILE is required")?,
        t_end,
        slab,
        out,
    })
}

fn run<const D: usize>(
    scenario: &ScenarioNd,
    args: &Args,
    reduce: Rc<Timed<MpiReduce>>,
) -> Result<(), String>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    let (rank, size) = (reduce.rank(), reduce.size());
    let shared: Rc<dyn Reduce> = reduce.clone();
    let (mut solver, _) = if args.slab {
        scenario.build_slab::<D>(Rc::clone(&shared))
    } else {
        scenario.build_distributed::<D>(Rc::clone(&shared))
    }
    .map_err(|e| e.to_string())?;
    let started_here: std::collections::HashSet<u64> =
        solver.particle_ids().iter().copied().collect();
    let mut n_total = [solver.n_particles() as f64];
    shared.sum(&mut n_total);
    let config = scenario.controller_config().map_err(|e| e.to_string())?;
    // The scenario's gravity goes to the growth monitor's energy.
    let mut controller = controller_nd::controller_for::<D>(scenario, config, Some(&shared))?;
    let t_end = args.t_end.unwrap_or(scenario.t_end);
    let start = Instant::now();
    let mut dts: Vec<String> = Vec::new();
    let result = controller
        .run_until(&mut solver, t_end, &mut |d| {
            if d.outcome == Outcome::Accepted {
                dts.push(format!("{:016x}", d.dt.to_bits()));
            }
        })
        .map(|_| ());
    let wall_s = start.elapsed().as_secs_f64();
    let arrived = solver
        .particle_ids()
        .iter()
        .filter(|id| !started_here.contains(id))
        .count();
    let mut energy = [
        solver.kinetic_energy(),
        solver.strain_energy(),
        arrived as f64,
    ];
    shared.sum(&mut energy);
    let stats = controller.stats();
    if rank == 0 {
        println!(
            "{}",
            json!({
                "particles": n_total[0],
                "ranks": size,
                "steps_accepted": stats.accepted,
                "steps_rejected": stats.rejected,
                "dt_mean": stats.dt_mean(),
                "t_final": solver.time(),
                "energy_kinetic": energy[0],
                "energy_strain": energy[1],
                "wall_s": wall_s,
                "reduce_s": reduce.spent().as_secs_f64(),
                "reductions": reduce.calls(),
                "decomposition": if args.slab { "slab" } else { "particles" },
                "particles_on_another_rank": energy[2],
                "error": result.as_ref().err().map(|e| e.to_string()),
            })
        );
    }
    if let Some(dir) = &args.out {
        let view = solver.view();
        let flat =
            |f: &[Vector<D>]| -> Vec<f64> { f.iter().flat_map(|v| v.iter().copied()).collect() };
        let record = json!({
            "rank": rank,
            "dt_bits": dts,
            "id": solver.particle_ids(),
            "arrived": arrived,
            "rejected": stats.rejected,
            "x": flat(view.x),
            "v": flat(view.v),
            "error": result.as_ref().err().map(|e| e.to_string()),
        });
        let path = dir.join(format!("rank-{rank}.json"));
        std::fs::write(&path, record.to_string())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    result.map_err(|e| e.to_string())
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!(
                "mpi_simulate: {e}\nusage: mpi_simulate --scenario FILE [--t-end T] \
                 [--decomposition slab|particles] [--out DIR]"
            );
            return ExitCode::from(2);
        }
    };
    let Some(universe) = mpi::initialize() else {
        eprintln!("mpi_simulate: MPI could not be initialised");
        return ExitCode::from(1);
    };
    let reduce = Rc::new(Timed::new(MpiReduce::new(universe.world())));
    let rank = reduce.rank();
    // Every rank reads the file; an unreadable one fails on every rank alike.
    let result = ScenarioNd::from_file(&args.scenario)
        .map_err(|e| e.to_string())
        .and_then(|s| match s.dim {
            2 => run::<2>(&s, &args, reduce),
            3 => run::<3>(&s, &args, reduce),
            d => Err(format!("mpi_simulate runs 2D and 3D scenarios, not {d}D")),
        });
    drop(universe);
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mpi_simulate: rank {rank}: {e}");
            ExitCode::from(1)
        }
    }
}
