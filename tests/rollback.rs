//! `try_step` + `reject` leaves the committed state bit-identical (every field compared
//! with `f64::to_bits`), for random dt sequences, boundaries, shapes and materials; failed
//! trials leave it untouched too; and a rejected-then-retried step gives exactly the state
//! of a run that never rejected.

use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::{Initial, MaterialKind, Particles, Scenario};
use mpm_dt::{Boundary, Shape, Stepper, View};
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;

/// Every number a view exposes, as bits (lazy fields included).
fn snapshot(v: &View<'_>) -> Vec<u64> {
    let mut bits = vec![v.t.to_bits(), v.step];
    for field in [
        v.x,
        v.v,
        v.sigma,
        v.f,
        v.volume0,
        v.mass,
        v.tangent_modulus,
        v.density,
        v.node_mass,
        v.node_velocity,
        v.node_acceleration,
    ] {
        bits.extend(field.iter().map(|x| x.to_bits()));
    }
    bits.extend(v.node_active.iter().map(|&a| a as u64));
    for p in 0..v.n_particles() {
        for (i, s, d) in v.weights.row(p) {
            bits.extend([i as u64, s.to_bits(), d.to_bits()]);
        }
    }
    bits
}

/// One attempt: a step size (as a multiple of h/c, or a bad value) and whether to keep it.
#[derive(Clone, Debug)]
enum Attempt {
    Step { factor: f64, accept: bool },
    Huge,
    Bad(f64),
}

fn attempt() -> impl Strategy<Value = Attempt> {
    prop_oneof![
        8 => (0.001f64..0.7, any::<bool>()).prop_map(|(factor, accept)| Attempt::Step { factor, accept }),
        1 => Just(Attempt::Huge),
        1 => prop_oneof![Just(0.0), Just(-1.0), Just(f64::NAN), Just(f64::INFINITY)].prop_map(Attempt::Bad),
    ]
}

fn scenario() -> impl Strategy<Value = Scenario> {
    (
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        3usize..12,
        1usize..4,
        0.001f64..0.3,
    )
        .prop_map(|(periodic, gimp, neo, cells, ppc, amplitude)| Scenario {
            cells,
            boundary: if periodic {
                Boundary::Periodic
            } else {
                Boundary::Fixed
            },
            shape: if gimp { Shape::Gimp } else { Shape::Linear },
            material: if neo {
                MaterialKind::NeoHookean
            } else {
                MaterialKind::LinearElastic
            },
            particles: Particles {
                per_cell: Some(ppc),
                ..Particles::default()
            },
            initial: Initial::StandingWave {
                amplitude,
                mode: 1.0,
            },
            ..Scenario::default()
        })
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 96,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E),
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "proptest-regressions/rollback.txt",
        ))),
        ..ProptestConfig::default()
    }
}

fn dt_of(s: &ReferenceStepper, scenario: &Scenario, a: &Attempt) -> f64 {
    let hc = s.grid().h / scenario.wave_speed();
    match a {
        Attempt::Step { factor, .. } => factor * hc,
        Attempt::Huge => 1e4 * hc,
        Attempt::Bad(dt) => *dt,
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn reject_restores_the_committed_state_bit_for_bit(
        scenario in scenario(),
        attempts in prop::collection::vec(attempt(), 1..40),
    ) {
        let mut s = scenario.build().unwrap();
        for a in &attempts {
            let before = snapshot(&s.view());
            let dt = dt_of(&s, &scenario, a);
            match s.try_step(dt) {
                Ok(()) => {
                    // Force the trial's lazy fields too, then decide.
                    let trial = s.trial_view().expect("trial pending after Ok");
                    prop_assert_eq!(trial.step, s.step_count() + 1);
                    let _ = snapshot(&trial);
                    if matches!(a, Attempt::Step { accept: true, .. }) {
                        s.accept().unwrap();
                    } else {
                        s.reject();
                        prop_assert!(s.trial_view().is_none());
                        prop_assert_eq!(snapshot(&s.view()), before);
                    }
                }
                Err(_) => {
                    // A failed trial leaves no trial and the state untouched.
                    prop_assert!(s.trial_view().is_none());
                    prop_assert!(s.accept().is_err());
                    prop_assert_eq!(snapshot(&s.view()), before);
                }
            }
        }
    }

    #[test]
    fn a_rejected_then_retried_step_equals_a_direct_step(
        scenario in scenario(),
        // The second number is the step first tried and thrown away; 1e4·h/c makes that trial
        // fail (a failed pass must not leave anything behind either).
        factors in prop::collection::vec((0.01f64..0.6, prop_oneof![4 => 0.01f64..2.0, 1 => Just(1e4)]), 1..15),
    ) {
        let mut direct = scenario.build().unwrap();
        let mut retried = scenario.build().unwrap();
        let hc = direct.grid().h / scenario.wave_speed();
        for (f, g) in factors {
            // The retried run first tries (and rejects) another step size.
            if retried.try_step(g * hc).is_ok() {
                let _ = snapshot(&retried.trial_view().unwrap());
            }
            retried.reject();
            let ok_direct = direct.try_step(f * hc).is_ok();
            let ok_retried = retried.try_step(f * hc).is_ok();
            prop_assert_eq!(ok_direct, ok_retried);
            if !ok_direct {
                break;
            }
            direct.accept().unwrap();
            retried.accept().unwrap();
            prop_assert_eq!(snapshot(&direct.view()), snapshot(&retried.view()));
        }
    }
}
