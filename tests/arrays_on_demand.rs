//! Capability: a stepper that hands over its arrays on demand
//! (`Stepper::provide_arrays_on_demand`, as a solver on a GPU or in Python would) is run
//! by the controller on its summaries, with the arrays loaded only for the calls that read
//! them: the run is the eager one bit for bit where every step needs them, within the
//! calibrated bound's margin where the summaries serve, a blown-up trial found by its
//! summary is rejected with the particle named, and a stepper that does not load ends the
//! run with an error.

use mpm_dt::controller::{standard_limits, Controller, ControllerConfig, ControllerError};
use mpm_dt::controller::{Decision, Outcome};
use mpm_dt::nd::Vector;
use mpm_dt::{RejectCause, Stepper};

#[path = "common/jitter.rs"]
mod jitter;
#[path = "common/moving_block.rs"]
mod moving_block;
#[path = "common/on_demand.rs"]
mod on_demand;

use on_demand::OnDemand;

const GRAVITY: [f64; 2] = [0.0, -0.5];

/// A controlled run of `stepper` to `t_end` with `config`: its decisions, or the error.
fn run(
    stepper: &mut dyn Stepper<2>,
    config: ControllerConfig,
    t_end: f64,
) -> (Vec<Decision>, Result<(), ControllerError>) {
    let limits = standard_limits::<2>(&config, Vector::<2>::from(GRAVITY));
    let mut controller = Controller::<2>::new(config, limits).unwrap();
    let mut decisions = Vec::new();
    let result = controller
        .run_until(stepper, t_end, &mut |d| decisions.push(d.clone()))
        .map(|_| ());
    (decisions, result)
}

/// The accepted steps of a list of decisions.
fn accepted(decisions: &[Decision]) -> Vec<f64> {
    decisions
        .iter()
        .filter(|d| d.outcome == Outcome::Accepted)
        .map(|d| d.dt)
        .collect()
}

fn block(bound: bool) -> OnDemand {
    OnDemand::new(moving_block::moving_block(GRAVITY), bound)
}

/// Where every step needs the arrays — a summary without the element bound (the
/// stability limit's guard then reads them at every proposal), or the temporal error
/// checked at every trial — the run on demand is the eager run bit for bit, and every
/// state is loaded.
#[test]
fn where_every_step_reads_the_arrays_the_run_is_the_eager_one() {
    let every_check: ControllerConfig =
        serde_json::from_str(r#"{"temporal": {"max_deferred": 0}, "stability": {"safety": 0.95}}"#)
            .unwrap();
    for (bound, config) in [(false, ControllerConfig::default()), (true, every_check)] {
        let mut eager = block(bound);
        eager.offer = false;
        let (eager_d, r) = run(&mut eager, config.clone(), 3.0);
        r.unwrap();
        let mut lazy = block(bound);
        let (lazy_d, r) = run(&mut lazy, config, 3.0);
        r.unwrap();
        let (a, b) = (accepted(&eager_d), accepted(&lazy_d));
        assert!(a.len() > 30, "only {} steps", a.len());
        assert_eq!(a.len(), b.len(), "bound {bound}");
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.to_bits(), y.to_bits(), "bound {bound}: {x} against {y}");
        }
        assert_eq!(eager.loads, 0);
        assert!(
            lazy.loads >= a.len(),
            "bound {bound}: {} loads for {} steps",
            lazy.loads,
            a.len()
        );
    }
}

/// With the element bound in the summaries and the default limits, the arrays are
/// loaded for the temporal error's checks, the layout guard's cadence, the door checks
/// and the refreshes only: on fewer than half of the states; the run takes the eager
/// run's number of steps within 5 % (the guard's factor is carried between its checks,
/// `limits_nd::stability::on_summary`; on this block they are the same steps), with no
/// more rejections.
#[test]
fn with_the_bound_in_the_summary_most_steps_read_no_arrays() {
    let mut eager = block(true);
    eager.offer = false;
    let (eager_d, r) = run(&mut eager, ControllerConfig::default(), 12.0);
    r.unwrap();
    let mut lazy = block(true);
    let (lazy_d, r) = run(&mut lazy, ControllerConfig::default(), 12.0);
    r.unwrap();
    let (a, b) = (accepted(&eager_d), accepted(&lazy_d));
    let largest_change = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (y / x - 1.0).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "eager {} steps; on demand {} steps, {} loads; steps differ by {largest_change:.2e} at most",
        a.len(),
        b.len(),
        lazy.loads
    );
    let rejected = |d: &[Decision]| d.iter().filter(|d| d.outcome == Outcome::Rejected).count();
    assert!(rejected(&lazy_d) <= rejected(&eager_d));
    assert!(
        (b.len() as f64 - a.len() as f64).abs() <= 0.05 * a.len() as f64,
        "{} steps on demand against {} eager",
        b.len(),
        a.len()
    );
    assert!(
        2 * lazy.loads < b.len(),
        "{} loads for {} steps",
        lazy.loads,
        b.len()
    );
}

/// A stepper that loads a state's particle arrays alone where they suffice (the temporal
/// error's checks against their history read no weights or nodal fields) takes the same
/// steps bit for bit, with fewer full loads (a state whose particles were loaded and whose
/// nodal fields a later call reads is read twice).
#[test]
fn loading_the_particles_alone_takes_the_same_steps() {
    same_steps_loading_particles_alone(ControllerConfig::default(), 12.0);
}

/// Runs the block to `t_end` loading in full and loading the particles alone; asserts
/// the same accepted steps bit for bit; returns the rejected attempts.
fn same_steps_loading_particles_alone(config: ControllerConfig, t_end: f64) -> usize {
    let mut full = block(true);
    let (full_d, r) = run(&mut full, config.clone(), t_end);
    r.unwrap();
    let mut alone = block(true);
    alone.particles_alone = true;
    let (alone_d, r) = run(&mut alone, config, t_end);
    r.unwrap();
    let (a, b) = (accepted(&full_d), accepted(&alone_d));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.to_bits(), y.to_bits(), "{x} against {y}");
    }
    eprintln!(
        "{} steps: {} full loads; particles alone {} + {} full",
        a.len(),
        full.loads,
        alone.particle_loads,
        alone.loads
    );
    assert!(alone.particle_loads > 0 && alone.loads < full.loads);
    assert!(alone.loads + alone.particle_loads >= full.loads);
    let rejected = |d: &[Decision]| d.iter().filter(|x| x.outcome != Outcome::Accepted).count();
    assert_eq!(rejected(&full_d), rejected(&alone_d));
    rejected(&full_d)
}

/// A stepper that does not hand over on demand and shows a view without its nodal arrays
/// is refused at the door, naming the view (not read as a summary-only view).
#[test]
fn a_view_without_nodal_arrays_is_refused_where_not_on_demand() {
    let mut broken = block(true);
    broken.offer = false;
    broken.hide_nodal = true;
    let (_, r) = run(&mut broken, ControllerConfig::default(), 0.5);
    match r {
        Err(ControllerError::InvalidView { .. }) => {}
        other => panic!("expected InvalidView, got {other:?}"),
    }
}

/// A trial whose summary is not finite has its arrays loaded; the stepper's read names
/// the particle, the trial is rejected as non-finite and retried with a smaller step.
#[test]
fn a_non_finite_summary_is_rejected_with_the_particle_named() {
    let mut lazy = block(true);
    lazy.poison_trials = 1;
    let (d, r) = run(&mut lazy, ControllerConfig::default(), 0.5);
    r.unwrap();
    let first = &d[0];
    assert_eq!(first.outcome, Outcome::Rejected);
    assert_eq!(first.cause, Some(RejectCause::NonFinite));
    assert_eq!(first.rejected_by.as_deref(), Some("stepper"));
    let message = first.message.as_deref().unwrap_or("");
    assert!(message.contains("particle 3"), "{message}");
    assert_eq!(d[1].outcome, Outcome::Accepted);
    assert!(d[1].dt < first.dt);
}

/// A stepper that offers its arrays on demand and does not load them ends the run with
/// the stepper's error, before any limit reads an empty view.
#[test]
fn a_stepper_that_does_not_load_ends_the_run() {
    let mut broken = block(true);
    broken.refuse_to_load = true;
    let (d, r) = run(&mut broken, ControllerConfig::default(), 0.5);
    assert!(d.is_empty(), "{} decisions", d.len());
    match r {
        Err(ControllerError::Stepper { source, .. }) => {
            let m = source.to_string();
            assert!(m.contains("without its arrays"), "{m}");
        }
        other => panic!("expected the stepper's error, got {other:?}"),
    }
}
