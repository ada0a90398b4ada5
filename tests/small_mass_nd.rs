//! Capability: on a 2D linear-hat layout with nearly empty nodes (the edge column of a
//! block has its particles at 0.97 and 0.99 of their cells, so the node at the block's edge
//! carries 1–3 % of a normal nodal mass; `scenarios/nd/linear_small_mass_2d.json`) the
//! fixed rule `dt = α·min_a h_a/(c_p + |v_a|)` blows up for α = 0.3, 0.4 and 0.5, and the
//! controller, which tracks `λmax(M⁻¹K)` as the light node comes and goes, runs to
//! `t_end` without energy growth.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::Controller;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::{SolverNd, Vector};
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::Stepper;

fn scenario() -> ScenarioNd {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/nd/linear_small_mass_2d.json"
    );
    ScenarioNd::from_file(path).expect("shipped scenario")
}

/// Runs the fixed rule; `Some(t)` when it blew up (a failed trial or the energy above 10×
/// its start) at time `t`.
fn fixed_rule(mut s: SolverNd<2>, alpha: f64, t_end: f64) -> Option<f64> {
    let e0 = s.total_energy();
    while s.time() < t_end * (1.0 - 1e-12) {
        let dt = (alpha * SoundSpeed::unit_step(&s.view()).ok()?).min(t_end - s.time());
        let failed = s.try_step(dt).and_then(|_| s.accept()).is_err();
        let e = s.total_energy();
        if failed || e.is_nan() || e > 10.0 * e0 {
            return Some(s.time());
        }
    }
    None
}

#[test]
fn fixed_rules_blow_up_where_the_controller_runs_through() {
    let sc = scenario();
    let (solver, _) = sc.build::<2>().unwrap();
    for alpha in [0.3, 0.4, 0.5] {
        let blew = fixed_rule(solver.clone(), alpha, sc.t_end);
        eprintln!("alpha {alpha}: blew up at {blew:?}");
        assert!(blew.is_some(), "alpha {alpha} ran through");
    }
    let mut s = solver;
    let e0 = s.total_energy();
    let config = sc.controller_config().unwrap();
    let limits = standard_limits::<2>(&config, Vector::<2>::zeros());
    let mut controller = Controller::<2>::new(config, limits).unwrap();
    controller.run_until(&mut s, sc.t_end, &mut |_| {}).unwrap();
    let stats = controller.stats();
    let e = s.total_energy();
    eprintln!(
        "controller: {} steps, dt {:.2e}..{:.2e}, energy {e:.4e} from {e0:.4e}",
        stats.accepted,
        stats.dt_min.unwrap(),
        stats.dt_max.unwrap()
    );
    assert!(e.is_finite() && e <= 1.01 * e0, "energy {e} from {e0}");
}
