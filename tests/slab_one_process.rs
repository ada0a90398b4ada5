//! Capability: the grid-decomposed solver (`SolverNd::new_slab`) on one process — the
//! path every process of a split run takes, with the split described in the view
//! (`ViewNd::split`) and the stability tracker working through it — runs a scenario under
//! the controller as the undivided solver does (same steps to 10⁻¹², same temporal errors
//! to 10⁻⁹, same particle state to 10⁻¹⁰), and a rejected trial leaves its state bit for bit. Several processes are
//! tested under MPI in `tests/mpi_ranks.rs` (feature `mpi`).

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, Outcome};
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::{SolverNd, Vector};
use mpm_dt::reduce::SingleProcess;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use std::rc::Rc;

fn scenario(file: &str) -> ScenarioNd {
    ScenarioNd::from_file(format!(
        "{}/scenarios/nd/{file}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .expect("scenario")
}

/// The accepted steps of a controlled run to `t_end` with their temporal errors `dsm`
/// (`None` where the check was deferred), and the final state.
fn run<const D: usize>(
    mut s: SolverNd<D>,
    scenario: &ScenarioNd,
    t_end: f64,
) -> (Vec<(f64, Option<f64>)>, Vec<f64>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let config = scenario.controller_config().expect("config");
    let limits = standard_limits::<D>(&config, Vector::<D>::zeros());
    let mut controller = Controller::<D>::new(config, limits).expect("controller");
    let mut dts = Vec::new();
    controller
        .run_until(&mut s, t_end, &mut |d| {
            if d.outcome == Outcome::Accepted {
                dts.push((d.dt, d.dsm));
            }
        })
        .expect("the run reaches t_end");
    // The state in run-wide particle order.
    let view = s.view();
    let mut rows: Vec<(u64, Vec<f64>)> = s
        .particle_ids()
        .iter()
        .enumerate()
        .map(|(p, &id)| {
            (
                id,
                view.x[p].iter().chain(view.v[p].iter()).copied().collect(),
            )
        })
        .collect();
    rows.sort_by_key(|r| r.0);
    (dts, rows.into_iter().flat_map(|r| r.1).collect())
}

/// Runs `file` both ways to `t_end`; returns the steps and how many were checked.
fn same_run<const D: usize>(file: &str, t_end: f64) -> (usize, usize)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let sc = scenario(file);
    let (plain, _) = sc.build::<D>().expect("build");
    let (slab, _) = sc
        .build_slab::<D>(Rc::new(SingleProcess))
        .expect("build_slab");
    assert!(slab.view().split.is_some() && plain.view().split.is_none());
    let (dt_a, x_a) = run(plain, &sc, t_end);
    let (dt_b, x_b) = run(slab, &sc, t_end);
    assert_eq!(dt_a.len(), dt_b.len(), "{file}: steps");
    let last = dt_a.len() - 1;
    for (k, ((a, ea), (b, eb))) in dt_a.iter().zip(&dt_b).enumerate() {
        let scale = if k == last { t_end } else { *a };
        assert!(
            (a - b).abs() <= 1e-12 * scale,
            "{file}: step {k}: {a} vs {b}"
        );
        // The temporal error through the id pairing (the slab's particles are matched by
        // run-wide id where they moved) is the undivided run's, up to summation order
        // (and to round-off where it is round-off: a rigid flight's dsm is ~10⁻¹⁵); both
        // runs defer the same checks.
        let (Some(ea), Some(eb)) = (ea, eb) else {
            assert_eq!(
                ea.is_some(),
                eb.is_some(),
                "{file}: step {k}: deferred in one run"
            );
            continue;
        };
        assert!(
            (ea - eb).abs() <= 1e-9 * ea.abs() + 1e-12,
            "{file}: step {k}: dsm {ea} vs {eb}"
        );
    }
    let worst = x_a
        .iter()
        .zip(&x_b)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let measured: Vec<f64> = dt_a.iter().filter_map(|(_, e)| *e).collect();
    let dsm_max = measured.iter().fold(0.0f64, |m, e| m.max(*e));
    eprintln!(
        "{file}: {} steps ({} checked), largest dsm {dsm_max:.2e}, largest state difference {worst:.2e}",
        dt_a.len(),
        measured.len()
    );
    assert!(!measured.is_empty(), "{file}: no step was checked");
    assert!(worst <= 1e-10, "{file}: {worst}");
    (dt_a.len(), measured.len())
}

#[test]
fn one_slab_runs_as_the_undivided_solver() {
    // The disks' checks are deferred (dsm ≤ 0.1); the 3D wave's are not (dsm up to 0.46).
    let (steps, checked) = same_run::<2>("colliding_disks.json", 1.0);
    assert!(checked < steps, "no check deferred on the disks");
    same_run::<2>("periodic_disks_2d.json", 0.5);
    same_run::<3>("plane_s_3d_bspline.json", 0.5);
}

#[test]
fn a_rejected_slab_trial_restores_the_state_bit_for_bit() {
    let sc = scenario("colliding_disks.json");
    let (mut s, _) = sc
        .build_slab::<2>(Rc::new(SingleProcess))
        .expect("build_slab");
    for _ in 0..5 {
        s.try_step(0.01).unwrap();
        s.accept().unwrap();
    }
    let bits = |s: &SolverNd<2>| -> Vec<u64> {
        let v = s.view();
        v.x.iter()
            .chain(v.v)
            .flat_map(|x| x.iter().map(|c| c.to_bits()))
            .chain(v.sigma.iter().flat_map(|t| t.iter().map(|c| c.to_bits())))
            .chain(v.node_mass.iter().map(|m| m.to_bits()))
            .chain(s.particle_ids().iter().copied())
            .collect()
    };
    let before = bits(&s);
    // A trial that fails (a step that throws particles through the walls) and one that
    // succeeds, both rejected.
    assert!(s.try_step(50.0).is_err());
    s.reject();
    assert_eq!(bits(&s), before);
    s.try_step(0.01).unwrap();
    // The trial moved the particles (the rejection below has something to undo).
    assert!(s.trial_view().expect("a trial").x != s.view().x);
    s.reject();
    assert_eq!(bits(&s), before);
    assert_eq!(s.step_count(), 5);
}
