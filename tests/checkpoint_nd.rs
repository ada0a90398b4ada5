//! Checkpoint/restart in 2D and 3D: a controller rebuilt from a JSON checkpoint, driving a
//! copy of the solver saved at the same step, takes the same decisions bit for bit as the
//! run that went on — through an impact, where the stability limit refreshes `λmax`, tracks
//! its calibrated bound and the growth monitor keeps its energy history.

use mpm_dt::controller::{standard_limits, Controller, ControllerCheckpoint};
use mpm_dt::limit::{LimitError, StepLimit};
use mpm_dt::limits_nd::{StabilityNd, StabilityNdConfig};
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::{SolverNd, Vector};
use mpm_dt::sound_speed::{SoundSpeed, SoundSpeedConfig};
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};

fn scenario(file: &str) -> ScenarioNd {
    let path = format!("{}/scenarios/nd/{file}", env!("CARGO_MANIFEST_DIR"));
    ScenarioNd::from_file(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn controller<const D: usize>(scenario: &ScenarioNd) -> (Controller<D>, Vector<D>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let config = scenario.controller_config().unwrap();
    let gravity = scenario
        .gravity
        .as_ref()
        .map_or(Vector::<D>::zeros(), |g| Vector::<D>::from_column_slice(g));
    let limits = standard_limits::<D>(&config, gravity);
    (Controller::<D>::new(config, limits).unwrap(), gravity)
}

/// Runs `file` to `t_save`, saves the controller (through JSON) and the solver, runs on to
/// `t_end`; then restores both and runs the same stretch again. Returns the two decision
/// logs and the number of λmax refreshes in the compared stretch.
fn straight_and_restarted<const D: usize>(file: &str, t_save: f64, t_end: f64) -> [Vec<String>; 2]
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let scenario = scenario(file);
    let (mut solver, _): (SolverNd<D>, _) = scenario.build::<D>().unwrap();
    let (mut c, gravity) = controller::<D>(&scenario);
    c.run_until(&mut solver, t_save, &mut |_| {}).unwrap();
    let json = serde_json::to_string(&c.checkpoint()).unwrap();
    let mut saved_solver = solver.clone();

    let mut straight = Vec::new();
    c.run_until(&mut solver, t_end, &mut |d| straight.push(d.to_json_line()))
        .unwrap();

    let checkpoint: ControllerCheckpoint = serde_json::from_str(&json).unwrap();
    let config = checkpoint.config.clone();
    let limits = standard_limits::<D>(&config, gravity);
    let mut restored = Controller::<D>::from_checkpoint(checkpoint, limits).unwrap();
    let mut restarted = Vec::new();
    restored
        .run_until(&mut saved_solver, t_end, &mut |d| {
            restarted.push(d.to_json_line())
        })
        .unwrap();
    assert_eq!(c.stats(), restored.stats());
    let bits = |s: &SolverNd<D>| {
        let v = s.view();
        v.x.iter()
            .chain(v.v.iter())
            .flat_map(|u| u.iter().map(|x| x.to_bits()))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&solver), bits(&saved_solver));
    [straight, restarted]
}

/// The decisions in a log at which the stability limit refreshed `λmax` (it reports its
/// `refreshes` count on those).
fn refreshes_in(log: &[String]) -> usize {
    log.iter().filter(|l| l.contains("\"refreshes\"")).count()
}

#[test]
fn colliding_disks_restart_through_the_impact_is_bit_identical() {
    // The disks meet at t ≈ 1.2: the stretch 1.0 → 2.0 holds the impact.
    let [straight, restarted] = straight_and_restarted::<2>("colliding_disks.json", 1.0, 2.0);
    assert!(straight.len() > 20, "{} decisions", straight.len());
    assert!(
        refreshes_in(&straight) >= 1,
        "the stretch refreshes λmax at least once"
    );
    assert_eq!(straight, restarted);
}

#[test]
fn colliding_spheres_restart_is_bit_identical() {
    let [straight, restarted] = straight_and_restarted::<3>("colliding_spheres.json", 1.0, 1.6);
    assert!(straight.len() > 10, "{} decisions", straight.len());
    assert_eq!(straight, restarted);
}

#[test]
fn the_sound_speed_limit_keeps_its_lowered_alpha() {
    let config = SoundSpeedConfig { alpha: 0.4 };
    let mut lowered = SoundSpeed::new(config).unwrap();
    StepLimit::<2>::scale_safety(&mut lowered, 0.5);
    let saved = StepLimit::<2>::save_state(&lowered).unwrap();
    let mut fresh = SoundSpeed::new(config).unwrap();
    StepLimit::<2>::restore_state(&mut fresh, &saved).unwrap();
    assert_eq!(fresh.config().alpha.to_bits(), 0.2f64.to_bits());
    // A limit already lowered takes back a larger α up to the configured one.
    let earlier = serde_json::json!({"alpha": 0.3});
    StepLimit::<2>::restore_state(&mut lowered, &earlier).unwrap();
    assert_eq!(lowered.config().alpha.to_bits(), 0.3f64.to_bits());
    // An α above the configured one, or none, is refused with the limit's name.
    for bad in [serde_json::json!({"alpha": 0.8}), serde_json::json!({})] {
        let e = StepLimit::<2>::restore_state(&mut fresh, &bad).unwrap_err();
        assert!(
            matches!(&e, LimitError::Restore { limit, .. } if limit == "sound_speed"),
            "{e}"
        );
    }
}

#[test]
fn a_stability_state_that_does_not_fit_is_refused() {
    let mut limit = StabilityNd::<3>::new(StabilityNdConfig::default()).unwrap();
    let fresh = StepLimit::<3>::save_state(&limit).unwrap();
    let mut odd = fresh.clone();
    odd["x_ref"] = serde_json::json!([0.5, 0.5]); // not three numbers a particle
    let mut unsafe_safety = fresh.clone();
    unsafe_safety["safety"] = serde_json::json!(2.0);
    let mut unpaired = fresh.clone();
    unpaired["x_ref"] = serde_json::json!([0.5, 0.5, 0.5]); // one particle, no moduli pair
    let mut negative = fresh.clone();
    negative["lambda"] = serde_json::json!(-1.0);
    let mut shrinking = fresh.clone();
    shrinking["diag_growth"] = serde_json::json!(0.5);
    let bad_states = [
        odd,
        unsafe_safety,
        unpaired,
        negative,
        shrinking,
        serde_json::json!({"lambda": "x"}),
    ];
    for bad in bad_states {
        let e = StepLimit::<3>::restore_state(&mut limit, &bad).unwrap_err();
        assert!(
            matches!(&e, LimitError::Restore { limit, .. } if limit == "stability"),
            "{e}"
        );
    }
    StepLimit::<3>::restore_state(&mut limit, &fresh).unwrap();
}
