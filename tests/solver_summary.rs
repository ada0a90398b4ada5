//! The reference solver's pass summary (`mpm_dt::pass_summary`): its numbers are the
//! library's own, bit for bit, its observed fields equal the lazily computed ones, and a
//! controlled run takes the same decisions with and without it.

#[path = "common/without_summary.rs"]
mod without_summary;

use mpm_dt::controller::{total_energy, Controller, ControllerConfig, Decision};
use mpm_dt::scenario::Scenario;
use mpm_dt::stability::SoundSpeed;
use mpm_dt::{Stepper, View};
use without_summary::WithoutSummary;

/// Scenarios covering both shapes, both boundaries, both materials, particle counts that
/// are not multiples of 4 and that span several blocks of the pass (256 particles).
const SCENARIOS: [&str; 4] = [
    r#"{"cells": 301, "particles": {"per_cell": 2}}"#,
    r#"{"cells": 37, "boundary": "fixed", "shape": "linear", "material": "neo_hookean",
        "initial": {"standing_wave": {"amplitude": 0.05, "mode": 0.5}}}"#,
    r#"{"cells": 90, "particles": {"per_cell": 3}, "material": "neo_hookean",
        "initial": {"standing_wave": {"amplitude": 0.2, "mode": 1}}}"#,
    r#"{"cells": 4, "particles": {"positions": [0.01, 0.2, 0.33, 0.5, 0.61, 0.9, 0.99]}}"#,
];

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn summary_is_the_librarys_own_numbers() {
    for text in SCENARIOS {
        let scenario = Scenario::from_json(text).unwrap();
        let mut with = scenario.build().unwrap();
        let mut without = scenario.build().unwrap();
        assert!(with.provide_summary(true));
        assert!(
            with.view().summary.is_none(),
            "{text}: the initial state has none"
        );
        let dt = 0.3 * with.grid().h / scenario.wave_speed();
        for _ in 0..20 {
            for s in [&mut with, &mut without] {
                s.try_step(dt).unwrap();
                s.accept().unwrap();
            }
            let (a, b) = (with.view(), without.view());
            let summary = a.summary.expect("a summary after a step");
            assert!(b.summary.is_none());
            // Same state, and the fields the pass wrote equal the lazy cells' values.
            assert_eq!(bits(a.x), bits(b.x), "{text}");
            assert_eq!(bits(a.tangent_modulus), bits(b.tangent_modulus), "{text}");
            assert_eq!(bits(a.density), bits(b.density), "{text}");
            assert_eq!(a.node_active, b.node_active, "{text}");
            // The reductions, as the limits compute them from a view without a summary.
            assert_eq!(
                summary.total_energy.to_bits(),
                total_energy(&b).to_bits(),
                "{text}"
            );
            let c2 = (0..b.n_particles())
                .map(|p| b.tangent_modulus[p] / b.density[p])
                .fold(0.0, f64::max);
            let speed = b.v.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            assert_eq!(summary.max_wave_speed_sq.to_bits(), c2.to_bits(), "{text}");
            assert_eq!(summary.max_speed.to_bits(), speed.to_bits(), "{text}");
            let limit = SoundSpeed::default();
            assert_eq!(
                limit.dt(&a).unwrap().to_bits(),
                limit.dt(&b).unwrap().to_bits(),
                "{text}"
            );
        }
        // A rejected trial leaves the committed state's summary; switching off drops it
        // from the next states.
        with.try_step(dt).unwrap();
        with.reject();
        assert!(with.view().summary.is_some());
        with.provide_summary(false);
        with.try_step(dt).unwrap();
        with.accept().unwrap();
        assert!(with.view().summary.is_none(), "{text}");
    }
}

#[test]
fn controlled_runs_decide_the_same_with_and_without_the_summary() {
    for text in SCENARIOS {
        let scenario = Scenario::from_json(text).unwrap();
        // About 70 steps of the stability limit (≈ 0.7 h/c).
        let t_end = 50.0 * scenario.build().unwrap().grid().h / scenario.wave_speed();
        let lines = |stepper: &mut dyn Stepper| -> Vec<String> {
            let mut c = Controller::standard(ControllerConfig::default()).unwrap();
            let mut out = Vec::new();
            c.run_until(stepper, t_end, &mut |d: &Decision| {
                out.push(d.to_json_line())
            })
            .unwrap();
            out
        };
        let mut with = scenario.build().unwrap();
        let mut without = WithoutSummary(scenario.build().unwrap());
        let (a, b) = (lines(&mut with), lines(&mut without));
        assert!(a.len() > 10, "{text}: {} decisions", a.len());
        assert_eq!(a, b, "{text}");
        assert!(with.view().summary.is_some());
        assert!(without.view().summary.is_none());
    }
}

/// A summary is trusted only on the view it was stamped for: a view rebuilt with a field
/// replaced falls back to the checks (here a NaN stress is reported as a typed error
/// instead of being vouched for), and a deserialized summary carries no stamp.
#[test]
fn a_summary_is_trusted_only_on_its_own_view() {
    let scenario = Scenario::from_json(SCENARIOS[0]).unwrap();
    let mut s = scenario.build().unwrap();
    s.provide_summary(true);
    let dt = 0.3 * s.grid().h / scenario.wave_speed();
    s.try_step(dt).unwrap();
    s.accept().unwrap();
    let view = s.view();
    let summary = view.trusted_summary().expect("trusted on its own view");
    let mut sigma = view.sigma.to_vec();
    sigma[7] = f64::NAN;
    let rebuilt = View {
        sigma: &sigma,
        ..view
    };
    assert!(
        rebuilt.summary.is_some(),
        "the field is copied by the struct update"
    );
    assert!(rebuilt.trusted_summary().is_none());
    let err = SoundSpeed::default().dt(&rebuilt).unwrap_err();
    assert!(
        err.to_string().contains("sigma") || err.to_string().contains("σ"),
        "{err}"
    );
    assert!(SoundSpeed::default().dt(&view).is_ok());
    let json = serde_json::to_string(&summary).unwrap();
    let back: mpm_dt::PassSummary = serde_json::from_str(&json).unwrap();
    assert_eq!(back.total_energy.to_bits(), summary.total_energy.to_bits());
    assert!(!back.describes(&view));
}
