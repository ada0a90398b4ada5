//! The growth monitor: a step a little above the critical one makes the checkerboard grow
//! slowly; the monitor detects it, rejects, and lowers the limits' safety so the run
//! stays bounded — while the same run without the monitor blows up. (With the temporal error
//! limit on, its dsm also rises on the growing checkerboard and the filter keeps the run
//! bounded by itself; it is switched off here to test the monitor alone.) (With the temporal error
//! limit on, its dsm also rises on the growing checkerboard and the filter keeps the run
//! bounded by itself; it is switched off here to test the monitor alone.)

mod common;

use common::{all_finite, MockStepper, SoundSpeedMock};
use mpm_dt::controller::{Controller, ControllerConfig, GrowthConfig};
use mpm_dt::limit::{RejectCause, StepLimit};
use mpm_dt::Shape;

/// 16 cells × 2 GIMP particles: the frozen critical step is ≈ 0.75 h/c; the limit proposes
/// 0.77 h/(c + |v|), a few per cent too large.
fn run(growth: bool) -> (MockStepper, Controller, f64) {
    let mut s = MockStepper::standing_wave(16, 2, 1.0, 1e-2, Shape::Gimp, 0.0, 2);
    let e0 = s.energy();
    // The temporal error limit is switched off: a growing checkerboard also raises its dsm
    // (with it on, the filter alone keeps this run bounded); the monitor is tested here.
    let mut config = ControllerConfig {
        growth: GrowthConfig {
            enabled: growth,
            ..GrowthConfig::default()
        },
        ..ControllerConfig::default()
    };
    config.temporal.enabled = false;
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(SoundSpeedMock {
        alpha: 0.77,
        safety_scale: 1.0,
    })];
    let mut c = Controller::with_default_limits(config, limits).unwrap();
    for _ in 0..1500 {
        if c.step(&mut s, f64::INFINITY).is_err() || !all_finite(&s) || s.energy() > 10.0 * e0 {
            break;
        }
    }
    (s, c, e0)
}

#[test]
fn growth_is_detected_and_backed_off() {
    let (s, c, e0) = run(false);
    eprintln!(
        "no monitor: {:?} E/E0 {:.3e} finite {}",
        c.stats(),
        s.energy() / e0,
        all_finite(&s)
    );
    assert!(
        !all_finite(&s) || s.energy() > 10.0 * e0 || c.stats().accepted < 1500,
        "without the monitor the run was expected to blow up"
    );

    let (s, c, e0) = run(true);
    assert_eq!(c.stats().accepted, 1500, "{:?}", c.stats());
    assert!(all_finite(&s));
    assert!(s.energy() < 2.0 * e0, "energy {} from {e0}", s.energy());
    assert!(c.stats().growth_events >= 1);
    assert_eq!(
        c.stats()
            .rejected_by_cause
            .get(&RejectCause::Growth)
            .copied(),
        Some(c.stats().growth_events)
    );
    assert!(c.state().safety_scale < 1.0);
    eprintln!(
        "growth events {}, safety scale {:.3}, dt range [{:.4}, {:.4}] h/c",
        c.stats().growth_events,
        c.state().safety_scale,
        c.stats().dt_min.unwrap() * 16.0,
        c.stats().dt_max.unwrap() * 16.0
    );
}
