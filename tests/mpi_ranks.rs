//! Capability (feature `mpi`): the controller makes one decision for a run split over MPI
//! ranks. Runs `examples/mpi_controller` and `examples/mpi_simulate` under `mpirun` (build
//! them first: `cargo build --features mpi --examples`; `.ci/run` does) and checks that
//!
//! * a scenario whose grid is cut into slabs over 1, 2 and 4 ranks (`SolverNd::new_slab`:
//!   colliding disks and spheres of 10⁵ particles, disks colliding across a periodic
//!   boundary), with particles moving between ranks, takes the same accepted steps and
//!   rejections, `dt` equal to 10⁻¹², and ends in the same particle state to 10⁻¹⁰;
//! * so does a scenario whose particles are split over the ranks with the whole grid on
//!   each (`SolverNd::new_distributed`, 2D and 3D, moving bodies included);
//! * on 2 and 4 ranks every rank takes the same accepted steps, bit for bit, as many as
//!   the undivided run;
//! * a rank whose trial goes non-finite once makes every rank reject that attempt, and all
//!   go on to `t_end` together;
//! * a rank whose trials stay non-finite ends every rank with too many rejections, and a
//!   rank that fails fatally ends the others with "another process failed" — no rank hangs
//!   (each run has a time limit).
#![cfg(feature = "mpi")]

use serde_json::Value;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

fn example_named(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let path = exe
        .parent()
        .and_then(|d| d.parent())
        .expect("target/<profile>")
        .join("examples")
        .join(name);
    assert!(
        path.exists(),
        "{} not found: run `cargo build --features mpi --examples` first",
        path.display()
    );
    path
}

/// Runs `mpirun -np n mpi_controller args… --out DIR` (killed after 120 s: a hang fails
/// the test) and returns the exit code and every rank's record, ordered by rank.
fn run(n: usize, args: &[&str]) -> (Option<i32>, Vec<Value>) {
    run_example("mpi_controller", n, args)
}

fn run_example(name: &str, n: usize, args: &[&str]) -> (Option<i32>, Vec<Value>) {
    static RUNS: AtomicUsize = AtomicUsize::new(0);
    let k = RUNS.fetch_add(1, Ordering::SeqCst);
    let dir = std::env::temp_dir().join(format!("mpm-dt-mpi-{}-{k}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut child = Command::new("mpirun")
        .args([
            "--allow-run-as-root",
            "--oversubscribe",
            "-np",
            &n.to_string(),
        ])
        .arg(example_named(name))
        .args(args)
        .arg("--out")
        .arg(&dir)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("mpirun starts (OpenMPI installed?)");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("mpirun -np {n} {args:?} did not end within 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let records: Vec<Value> = (0..n)
        .map(|r| {
            let path = dir.join(format!("rank-{r}.json"));
            let text = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            serde_json::from_str(&text).expect("JSON")
        })
        .collect();
    let _ = std::fs::remove_dir_all(&dir);
    (status.code(), records)
}

fn dts(v: &Value) -> Vec<String> {
    v["dt_bits"]
        .as_array()
        .expect("dt_bits")
        .iter()
        .map(|s| s.as_str().expect("hex").to_string())
        .collect()
}

#[test]
fn every_rank_takes_the_same_steps() {
    let (code, alone) = run(1, &[]);
    assert_eq!(code, Some(0));
    for n in [2, 4] {
        let (code, ranks) = run(n, &[]);
        assert_eq!(code, Some(0), "{n} ranks");
        for r in &ranks {
            assert_eq!(r["t"].as_f64(), Some(1.0), "{n} ranks: {r}");
            // Bit for bit across the ranks of one run.
            assert_eq!(dts(r), dts(&ranks[0]), "{n} ranks: rank {}", r["rank"]);
        }
        // And the same number of steps as the undivided run (the values to 1e-12: the
        // scenario test below).
        assert_eq!(dts(&ranks[0]).len(), dts(&alone[0]).len(), "{n} ranks");
    }
}

#[test]
fn a_non_finite_trial_on_one_rank_rejects_everywhere() {
    let (code, ranks) = run(4, &["--fail-rank", "2", "--fail-step", "9", "--once"]);
    assert_eq!(code, Some(0));
    for r in &ranks {
        let cause = if r["rank"] == 2 {
            "non_finite"
        } else {
            "other_rank"
        };
        assert_eq!(r["rejected"][cause].as_u64(), Some(1), "{r}");
        assert_eq!(dts(r), dts(&ranks[0]));
        assert_eq!(r["t"].as_f64(), Some(1.0));
    }
}

#[test]
fn a_trial_failing_inside_the_solver_on_one_rank_rejects_everywhere() {
    for decomposition in ["slab", "particles"] {
        let (_, clean) = run(4, &["--decomposition", decomposition]);
        let (code, ranks) = run(
            4,
            &[
                "--throw-rank",
                "2",
                "--fail-step",
                "9",
                "--once",
                "--decomposition",
                decomposition,
            ],
        );
        assert_eq!(code, Some(0), "{decomposition}");
        for r in &ranks {
            let cause = if r["rank"] == 2 {
                "non_finite"
            } else {
                "other_rank"
            };
            assert_eq!(
                r["rejected"][cause].as_u64(),
                Some(1),
                "{decomposition}: {r}"
            );
            assert_eq!(r["t"].as_f64(), Some(1.0));
            assert_eq!(dts(r), dts(&ranks[0]));
        }
        // Up to the failure the run is the clean one, bit for bit.
        assert_eq!(dts(&ranks[0])[..9], dts(&clean[0])[..9], "{decomposition}");
    }
    // A rank whose trials keep failing inside the solver ends every rank, none hangs.
    let (code, ranks) = run(4, &["--throw-rank", "1", "--fail-step", "5"]);
    every_rank_gave_up_after_5_steps(code, &ranks);
}

/// Every rank ended the run with exit status 1 after 5 steps, on "consecutive rejections".
fn every_rank_gave_up_after_5_steps(code: Option<i32>, ranks: &[Value]) {
    assert_eq!(code, Some(1));
    for r in ranks {
        let error = r["error"].as_str().expect("an error on every rank");
        assert!(error.contains("consecutive rejections"), "{r}");
        assert_eq!(r["steps"].as_u64(), Some(5));
    }
}

#[test]
fn a_failing_rank_ends_every_rank_with_an_error() {
    let (code, ranks) = run(4, &["--fail-rank", "1", "--fail-step", "5"]);
    every_rank_gave_up_after_5_steps(code, &ranks);
    let (code, ranks) = run(4, &["--abort-rank", "2", "--fail-step", "7"]);
    assert_eq!(code, Some(1));
    for r in &ranks {
        let error = r["error"].as_str().expect("an error on every rank");
        if r["rank"] == 2 {
            assert!(error.contains("injected failure"), "{r}");
        } else {
            assert!(error.contains("another process failed"), "{r}");
        }
        assert_eq!(r["steps"].as_u64(), Some(7));
    }
}

/// The particles' final positions and velocities in run-wide particle order (the ranks'
/// records gathered by `id`).
fn state(ranks: &[Value]) -> Vec<f64> {
    let mut rows: Vec<(u64, Vec<f64>)> = Vec::new();
    for r in ranks {
        let ids = r["id"].as_array().expect("id");
        let numbers = |f: &str| -> Vec<f64> {
            r[f].as_array()
                .expect("state")
                .iter()
                .map(|v| v.as_f64().expect("number"))
                .collect()
        };
        let (x, v) = (numbers("x"), numbers("v"));
        let d = x.len().checked_div(ids.len()).unwrap_or(0);
        for (k, id) in ids.iter().enumerate() {
            let mut row = x[k * d..(k + 1) * d].to_vec();
            row.extend_from_slice(&v[k * d..(k + 1) * d]);
            rows.push((id.as_u64().expect("id"), row));
        }
    }
    rows.sort_by_key(|(id, _)| *id);
    rows.into_iter().flat_map(|(_, row)| row).collect()
}

fn dt_values(r: &Value) -> Vec<f64> {
    dts(r)
        .iter()
        .map(|h| f64::from_bits(u64::from_str_radix(h, 16).expect("hex")))
        .collect()
}

/// Runs `file` to `t_end` on 1, 2 and 4 ranks with `decomposition` and checks the steps,
/// rejections and final states against the single rank's. Returns the particles that
/// ended on another rank than they started on, per rank count.
fn same_run_on_1_2_4_ranks(file: &str, t_end: &str, decomposition: &str) -> Vec<u64> {
    let path = format!("{}/{file}", env!("CARGO_MANIFEST_DIR"));
    let args = [
        "--scenario",
        path.as_str(),
        "--t-end",
        t_end,
        "--decomposition",
        decomposition,
    ];
    let (code, one) = run_example("mpi_simulate", 1, &args);
    assert_eq!(code, Some(0), "{file}");
    let reference_dt = dt_values(&one[0]);
    let t_end: f64 = t_end.parse().expect("t_end");
    let reference = state(&one);
    let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut moved = Vec::new();
    for n in [2, 4] {
        let (code, ranks) = run_example("mpi_simulate", n, &args);
        assert_eq!(code, Some(0), "{file} on {n} ranks");
        let mut worst_dt = 0.0f64;
        for r in &ranks {
            assert_eq!(r["rejected"], one[0]["rejected"], "{file} on {n} ranks");
            let dt = dt_values(r);
            assert_eq!(dt.len(), reference_dt.len(), "{file} on {n} ranks: steps");
            let last = dt.len() - 1;
            for (k, (a, b)) in dt.iter().zip(&reference_dt).enumerate() {
                // The last step is cut to end at t_end: `t_end − t` carries the rounding of
                // the sum of the earlier steps, so it is compared on the scale of t_end.
                let scale = if k == last { t_end } else { *b };
                let rel = (a - b).abs() / scale;
                worst_dt = worst_dt.max(rel);
                assert!(rel <= 1e-12, "{file} on {n} ranks: step {k}: dt {a} vs {b}");
            }
        }
        let s = state(&ranks);
        assert_eq!(s.len(), reference.len());
        let worst = s
            .iter()
            .zip(&reference)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let arrived: u64 = ranks
            .iter()
            .map(|r| r["arrived"].as_u64().unwrap_or(0))
            .sum();
        eprintln!(
            "{file} ({decomposition}) on {n} ranks: largest dt difference {worst_dt:.2e}, \
             largest state difference {worst:.2e} (scale {scale:.2e}), {arrived} particles \
             ended on another rank"
        );
        assert!(
            worst <= 1e-10 * scale.max(1.0),
            "{file} on {n} ranks: {worst}"
        );
        moved.push(arrived);
    }
    moved
}

#[test]
fn a_grid_cut_into_slabs_runs_the_same_on_1_2_4_ranks() {
    for (file, t_end) in [
        ("scenarios/nd/colliding_disks_1e5.json", "0.1"),
        ("scenarios/nd/colliding_spheres_1e5.json", "0.2"),
        ("scenarios/nd/periodic_disks_2d.json", "1"),
    ] {
        let moved = same_run_on_1_2_4_ranks(file, t_end, "slab");
        assert!(
            moved.iter().all(|&m| m > 0),
            "{file}: particles must cross rank boundaries: {moved:?}"
        );
    }
}

#[test]
fn a_scenario_split_by_particle_ends_in_the_same_state() {
    for (file, t_end) in [
        ("scenarios/nd/plane_p_2d.json", "0.5"),
        ("scenarios/nd/plane_s_3d_bspline.json", "2"),
        ("scenarios/nd/colliding_disks.json", "1.5"),
    ] {
        same_run_on_1_2_4_ranks(file, t_end, "particles");
    }
}
