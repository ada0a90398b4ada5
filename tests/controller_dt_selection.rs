//! Property tests of the controller's step selection (proptest; regressions are committed
//! under `proptest-regressions/`).

mod common;

use common::{all_finite, MockStepper, RandomError, ScriptedLimit};
use mpm_dt::controller::{
    bound, Controller, ControllerConfig, ControllerError, Decision, FilterPreset, Outcome,
};
use mpm_dt::limit::StepLimit;
use mpm_dt::{Shape, Stepper};
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[derive(Clone, Debug)]
struct Case {
    proposals: Vec<f64>,
    dt_max: Option<f64>,
    error_max: f64,
    nan_probability: f64,
    t_end: f64,
    filter: FilterPreset,
    hold_growth: f64,
    seed: u64,
}

fn case() -> impl Strategy<Value = Case> {
    (
        prop::collection::vec(1e-4f64..0.05, 1..5),
        prop::option::of(1e-3f64..0.05),
        0.2f64..2.5,
        0.0f64..0.3,
        0.02f64..0.3,
        prop::sample::select(vec![
            FilterPreset::I,
            FilterPreset::Pi,
            FilterPreset::Pid,
            FilterPreset::H211,
            FilterPreset::H0211,
            FilterPreset::H0321,
            FilterPreset::H312,
        ]),
        (prop::sample::select(vec![1.0, 1.05, 1.5]), any::<u64>()),
    )
        .prop_map(
            |(
                proposals,
                dt_max,
                error_max,
                nan_probability,
                t_end,
                filter,
                (hold_growth, seed),
            )| Case {
                proposals,
                dt_max,
                error_max,
                nan_probability,
                t_end,
                filter,
                hold_growth,
                seed,
            },
        )
}

struct Run {
    decisions: Vec<Decision>,
    end: Result<(), String>,
    times_ok: bool,
    finite_ok: bool,
    config: ControllerConfig,
    rejections_at_end: Option<(u32, u32)>,
}

fn run(c: &Case) -> Run {
    let mut stepper = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.3, c.seed);
    stepper.faults.nan_probability = c.nan_probability;
    let config = ControllerConfig {
        dt_max: c.dt_max,
        filter: c.filter,
        hold_growth: c.hold_growth,
        ..ControllerConfig::default()
    };
    let limits: Vec<Box<dyn StepLimit>> = vec![
        Box::new(ScriptedLimit {
            name: "scripted".into(),
            proposals: c.proposals.clone(),
            k: 0,
        }),
        Box::new(RandomError {
            rng: ChaCha8Rng::seed_from_u64(c.seed),
            max: c.error_max,
        }),
    ];
    let mut controller = Controller::new(config.clone(), limits).expect("valid config");
    let mut decisions = Vec::new();
    let (mut times_ok, mut finite_ok) = (true, true);
    let mut end = Ok(());
    let mut rejections_at_end = None;
    while stepper.time() < c.t_end && (c.t_end - stepper.time()) > 1e-15 {
        match controller.step(&mut stepper, c.t_end) {
            Ok(ds) => decisions.extend(ds),
            Err(e) => {
                if let ControllerError::TooManyRejections { count, last, .. } = &e {
                    rejections_at_end = Some((*count, last.attempt));
                }
                end = Err(e.to_string());
                break;
            }
        }
        times_ok &= stepper.time() <= c.t_end;
        finite_ok &= all_finite(&stepper);
    }
    Run {
        decisions,
        end,
        times_ok,
        finite_ok,
        config,
        rejections_at_end,
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E),
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "proptest-regressions/controller_dt_selection.txt",
        ))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn dt_selection_rules_hold(c in case()) {
        let r = run(&c);
        prop_assert!(!r.decisions.is_empty() || r.rejections_at_end.is_some(), "nothing happened");
        prop_assert!(r.times_ok, "t passed t_end");
        prop_assert!(r.finite_ok, "a non-finite state was accepted");
        let cfg = &r.config;
        let mut last_accepted: Option<&Decision> = None;
        let mut prev: Option<&Decision> = None;
        for d in &r.decisions {
            // Never above any limit's proposal, dt_max, or t_end.
            for l in &d.limits {
                if let Some(p) = l.proposal {
                    prop_assert!(d.dt <= p, "dt {} > {} proposal {}", d.dt, l.name, p);
                }
            }
            if let Some(m) = cfg.dt_max {
                prop_assert!(d.dt <= m);
            }
            prop_assert!(d.t + d.dt <= c.t_end);
            prop_assert!(d.dt > 0.0 && d.dt.is_finite());
            if let Some(p) = prev {
                if p.step == d.step {
                    // A retry: strictly smaller, shrink within bounds.
                    prop_assert_eq!(p.outcome, Outcome::Rejected);
                    prop_assert_eq!(d.attempt, p.attempt + 1);
                    let ratio = d.dt / p.dt;
                    let hi = if d.attempt >= 3 { cfg.max_shrink_repeated } else { cfg.max_shrink_first };
                    prop_assert!(d.dt < p.dt, "retry did not shrink");
                    prop_assert!(ratio <= hi * (1.0 + 1e-12), "retry ratio {} > {}\n{}\n{}", ratio, hi, p.to_json_line(), d.to_json_line());
                    if d.binding == bound::RETRY {
                        prop_assert!(ratio >= cfg.min_shrink * (1.0 - 1e-12), "retry ratio {} < min_shrink", ratio);
                    }
                } else {
                    prop_assert_eq!(d.attempt, 1);
                }
            }
            if d.attempt == 1 {
                if let Some(a) = last_accepted {
                    let g = if a.attempt > 1 { 1.0 } else { cfg.max_growth };
                    prop_assert!(d.dt <= g * a.dt * (1.0 + 1e-12), "growth {} after attempt {}", d.dt / a.dt, a.attempt);
                    // The hold band: growth within (1, hold_growth] is not taken when a
                    // limit's proposal binds; a held step repeats the last one exactly,
                    // strictly below every limit's proposal (some bound, a proposal or the
                    // filter's, lay inside the band).
                    if d.binding == bound::HOLD {
                        prop_assert_eq!(d.dt.to_bits(), a.dt.to_bits());
                        for l in &d.limits {
                            if let Some(p) = l.proposal {
                                prop_assert!(p > d.dt, "held at {} with {} proposing {}", d.dt, l.name, p);
                            }
                        }
                    } else if d.limits.iter().any(|l| l.name == d.binding) {
                        prop_assert!(d.dt <= a.dt || d.dt > cfg.hold_growth * a.dt, "growth {} inside the hold band {}", d.dt / a.dt, cfg.hold_growth);
                    }
                }
            }
            if d.outcome == Outcome::Accepted {
                last_accepted = Some(d);
            }
            prev = Some(d);
        }
        // An unfinished run ends with a typed error, within the rejection limit.
        if let Some((count, attempt)) = r.rejections_at_end {
            prop_assert_eq!(count, cfg.max_consecutive_rejections);
            prop_assert_eq!(attempt, cfg.max_consecutive_rejections);
        }
    }

    #[test]
    fn same_inputs_same_decisions(c in case()) {
        let a = run(&c);
        let b = run(&c);
        let la: Vec<String> = a.decisions.iter().map(Decision::to_json_line).collect();
        let lb: Vec<String> = b.decisions.iter().map(Decision::to_json_line).collect();
        prop_assert_eq!(la, lb);
        prop_assert_eq!(a.end, b.end);
    }
}

/// The hold band on a scripted limit whose proposals rise by 2 % then 20 % and fall by 2 %
/// (no temporal error, so the limit binds every step): the 2 % rise is held, the 20 % rise
/// is taken, the fall is followed; with `hold_growth = 1` every proposal is followed.
#[test]
fn hold_band_keeps_small_rises_only() {
    let proposals = vec![1.0e-3, 1.02e-3, 1.224e-3, 1.2e-3];
    let dts = |hold_growth: f64| {
        let c = Case {
            proposals: proposals.clone(),
            dt_max: None,
            error_max: 0.0,
            nan_probability: 0.0,
            t_end: 1.0,
            filter: FilterPreset::I,
            hold_growth,
            seed: 7,
        };
        let r = run(&c);
        r.decisions
            .iter()
            .take(4)
            .map(|d| (d.dt, d.binding.clone()))
            .collect::<Vec<_>>()
    };
    let held = dts(1.05);
    assert_eq!(
        held,
        vec![
            (1.0e-3, "scripted".to_string()),
            (1.0e-3, bound::HOLD.to_string()),
            (1.224e-3, "scripted".to_string()),
            (1.2e-3, "scripted".to_string()),
        ]
    );
    let followed: Vec<f64> = dts(1.0).into_iter().map(|(dt, _)| dt).collect();
    assert_eq!(followed, proposals);
}

/// A step shortened to land on `t_end` is not held by the next run: with a limit proposing
/// 1.0e-3 and `dt_min` = 0.98e-3, a first run ending on a 0.97e-3 landing step is followed
/// by a second run at 1.0e-3 (holding the landing step would fall below `dt_min` and end it
/// with `StepTooSmall`). Also: a limit tying with `t_end` is not held.
#[test]
fn hold_band_skips_landing_steps() {
    let mut stepper = MockStepper::standing_wave(8, 2, 1.0, 1e-2, Shape::Gimp, 0.3, 5);
    let config = ControllerConfig {
        dt_min: 0.98e-3,
        hold_growth: 1.05,
        temporal: mpm_dt::controller::TemporalErrorConfig {
            enabled: false,
            ..Default::default()
        },
        ..ControllerConfig::default()
    };
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(ScriptedLimit {
        name: "scripted".into(),
        proposals: vec![1.0e-3],
        k: 0,
    })];
    let mut controller = Controller::new(config, limits).expect("valid config");
    let t1 = 5.0e-3 + 0.97e-3;
    let mut first = Vec::new();
    controller
        .run_until(&mut stepper, t1, &mut |d| first.push(d.clone()))
        .expect("first run");
    let last = first.last().expect("decisions");
    assert_eq!(last.binding, bound::T_END);
    assert!((last.dt - 0.97e-3).abs() < 1e-15, "{}", last.dt);
    let mut second = Vec::new();
    controller
        .run_until(&mut stepper, t1 + 3.0e-3, &mut |d| second.push(d.clone()))
        .expect("second run: the landing step is not held");
    assert_eq!(second[0].binding, "scripted");
    assert_eq!(second[0].dt.to_bits(), 1.0e-3f64.to_bits());
    // Two steps of 1.0e-3 then a landing step of exactly the proposal: a tie, not a hold.
    assert_eq!(second.len(), 3);
    assert!(second.iter().all(|d| d.binding != bound::HOLD));
}
