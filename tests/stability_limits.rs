//! The SoundSpeed and Stability step limits.

mod stability_common;

use mpm_dt::stability::{Bound58Reading, SoundSpeed, SoundSpeedConfig, Stability, StabilityConfig};
use mpm_dt::{RejectCause, Shape, StepLimit, Verdict};
use stability_common::*;

#[test]
fn sound_speed_proposes_alpha_h_over_each_particles_c_plus_v() {
    let mut fx = Fixture::new(
        periodic(10, 2.0),
        Shape::Gimp,
        uniform(10, 2.0, 2),
        4.0,
        9.0,
    );
    fx.modulus[3] = 16.0; // c = 2 there
    fx.v[7] = -0.5;
    let mut lim = SoundSpeed::new(SoundSpeedConfig { alpha: 0.6 }).unwrap();
    let p = StepLimit::<1>::propose(&mut lim, &fx.view()).unwrap();
    let h = 0.2;
    // c = 1.5 everywhere but particle 3: the largest c_p + |v_p| is 2 (particle 3 at rest,
    // and particle 7, 1.5 + 0.5), not c_max + ‖v‖_∞ = 2.5 of two different particles.
    assert!((p.dt - 0.6 * h / 2.0).abs() < 1e-15, "{}", p.dt);
    assert!((p.metrics["dt_sound_unit"] - h / 2.0).abs() < 1e-15);
    assert!((SoundSpeed::dt_eq49(&fx.view()).unwrap() - h / 2.0).abs() < 1e-15);
    assert_eq!(StepLimit::<1>::name(&lim), "sound_speed");
}

#[test]
fn stability_proposes_safety_times_dt_eq56_and_reports_metrics() {
    let fx = Fixture::new(
        periodic(16, 1.0),
        Shape::Gimp,
        jittered(16, 1.0, 2, 0.6, 2),
        1.0,
        4.0,
    );
    let view = fx.view();
    let dense = dense_dt56(&view);
    let mut lim = Stability::new(StabilityConfig {
        safety: 0.8,
        ..Default::default()
    })
    .unwrap();
    let p = lim.propose(&view).unwrap();
    // The first proposal anchors: a certified upper bound on λmax within the default margin
    // (10⁻³) above it, so dt_eq56 lies in [dense/√(1.001), dense].
    let within = |dt_eq56: f64| dt_eq56 <= dense && dt_eq56 >= dense / (1.0f64 + 1e-3).sqrt();
    assert!(within(p.dt / 0.8), "{} vs {}", p.dt, 0.8 * dense);
    assert!(within(p.metrics["dt_eq56"]));
    assert!(
        p.metrics["lambda_certified"] > 0.5,
        "first proposal not certified"
    );
    assert!(p.metrics.contains_key("lambda_max"));
    lim.set_safety(0.4).unwrap();
    let p2 = lim.propose(&view).unwrap();
    assert!(within(p2.dt / 0.4), "{} vs {}", p2.dt, 0.4 * dense);
    // The second proposal is served by the Rayleigh quotient: no Lanczos application.
    assert!(p2.metrics["lanczos_applications"] < 0.5);
    assert!(p2.metrics["lambda_certified"] < 0.5);
}

#[test]
fn stability_judge_accepts_below_and_rejects_above_the_critical_step() {
    let mut fx = Fixture::new(
        periodic(16, 1.0),
        Shape::Gimp,
        uniform(16, 1.0, 2),
        1.0,
        1.0,
    );
    let tau = 2.0 * std::f64::consts::PI;
    fx.sigma = fx.x.iter().map(|x| (tau * x).sin()).collect();
    let view = fx.view();
    let mut lim = Stability::default();
    let p = lim.propose(&view).unwrap();
    let d56 = p.metrics["dt_eq56"];
    let ok = lim.judge(&view, &view, p.dt).unwrap();
    assert_eq!(ok.verdict, Verdict::Accept);
    assert!(ok.metrics.contains_key("bound58"));
    let bad = lim.judge(&view, &view, 1.2 * d56).unwrap();
    assert!(
        matches!(bad.verdict, Verdict::Reject { cause: RejectCause::Stability, suggested_dt: Some(s) } if s <= d56)
    );
}

/// On a jittered layout with a smooth stress, eq 58 (consistent reading, energy norm) is ≤ 1
/// below the critical step (it is a lower bound on ρ(A) = 1 there) and exceeds 1 at 1.5·dt_eq56,
/// so the judgement rejects through the bound itself.
#[test]
fn eq58_exceeds_one_above_the_critical_step_on_a_jittered_layout() {
    let mut fx = Fixture::new(
        periodic(20, 1.0),
        Shape::Gimp,
        jittered(20, 1.0, 2, 0.9, 21),
        1.0,
        1.0,
    );
    let tau = 2.0 * std::f64::consts::PI;
    fx.sigma =
        fx.x.iter()
            .map(|x| (tau * x).sin() + 0.3 * (2.0 * tau * x).cos())
            .collect();
    let view = fx.view();
    let d56 = dense_dt56(&view);
    let above = mpm_dt::stability::bound58(&view, 1.5 * d56, Bound58Reading::Consistent)
        .unwrap()
        .unwrap();
    assert!(above.value_energy > 1.0, "{above:?}");
    for f in [0.3, 0.6, 0.99] {
        let below = mpm_dt::stability::bound58(&view, f * d56, Bound58Reading::Consistent)
            .unwrap()
            .unwrap();
        assert!(below.value_energy <= 1.0 + 1e-12, "{f}: {below:?}");
    }
    // The limit with the proposal check disabled in effect (tolerance large) still rejects
    // through eq 58.
    let mut lim = Stability::new(StabilityConfig {
        tol: 0.01,
        ..Default::default()
    })
    .unwrap();
    lim.propose(&view).unwrap();
    let j = lim.judge(&view, &view, 1.5 * d56).unwrap();
    assert!(j.metrics["bound58"] > 1.01);
    assert!(matches!(
        j.verdict,
        Verdict::Reject {
            cause: RejectCause::Stability,
            ..
        }
    ));
}

/// A saved and restored Stability limit proposes bit-identically; `scale_safety` multiplies
/// the safety factor (and α for SoundSpeed); invalid factors are ignored.
#[test]
fn checkpoint_and_scale_safety() {
    let mut fx = Fixture::new(
        periodic(16, 1.0),
        Shape::Gimp,
        jittered(16, 1.0, 2, 0.6, 9),
        1.0,
        1.0,
    );
    let mut a = Stability::default();
    a.propose(&fx.view()).unwrap();
    let safety = StabilityConfig::default().safety;
    a.scale_safety(0.5);
    assert!((a.safety() - 0.5 * safety).abs() < 1e-15);
    a.scale_safety(2.0);
    a.scale_safety(f64::NAN);
    assert!((a.safety() - 0.5 * safety).abs() < 1e-15);
    let saved = a.save_state().unwrap();
    let mut b = Stability::default();
    b.restore_state(&saved).unwrap();
    for step in 0..12 {
        for x in fx.x.iter_mut() {
            *x = fx.grid.wrap(*x + 1e-3 * (step as f64 + *x).sin() / 16.0);
        }
        fx.refresh();
        let pa = a.propose(&fx.view()).unwrap();
        let pb = b.propose(&fx.view()).unwrap();
        assert_eq!(pa.dt.to_bits(), pb.dt.to_bits());
    }
    assert!(b
        .restore_state(&serde_json::json!({"safety": 3.0}))
        .is_err());
    let mut s = SoundSpeed::new(SoundSpeedConfig { alpha: 0.5 }).unwrap();
    StepLimit::<1>::scale_safety(&mut s, 0.5);
    assert!((s.config().alpha - 0.25).abs() < 1e-15);
    // The same limit in 2D takes the same factor.
    StepLimit::<2>::scale_safety(&mut s, 0.5);
    assert!((s.config().alpha - 0.125).abs() < 1e-15);
}

/// The opt-in cached [`mpm_dt::stability::Refresh`] policy serves most proposals from the cached
/// λmax, yet follows a linear-hat layout whose critical step collapses as particles slide into
/// a small-mass configuration: every proposal stays below the exact eq 56 step of its own
/// layout and within a few per cent of what an update at every step would propose.
#[test]
fn cached_lambda_max_follows_a_collapsing_layout() {
    let cells = 32;
    let (start, end) = collapse_layouts(cells);
    let mut fx = Fixture::new(periodic(cells, 1.0), Shape::Linear, start.clone(), 1.0, 1.0);
    let mut cached = Stability::new(StabilityConfig {
        tracking: mpm_dt::stability::Tracking::Lanczos(mpm_dt::stability::Refresh::cached()),
        ..StabilityConfig::default()
    })
    .unwrap();
    let mut every = Stability::new(StabilityConfig {
        tracking: mpm_dt::stability::Tracking::Lanczos(mpm_dt::stability::Refresh::every_step()),
        ..StabilityConfig::default()
    })
    .unwrap();
    let safety = StabilityConfig::default().safety;
    let steps = 400;
    let mut updates = 0;
    for s in 0..=steps {
        let a = s as f64 / steps as f64;
        fx.x = interpolate(&start, &end, a);
        fx.refresh();
        let view = fx.view();
        let p = cached.propose(&view).unwrap();
        let q = every.propose(&view).unwrap();
        if p.metrics["lanczos_applications"] > 0.0 {
            updates += 1;
        }
        let exact = dense_dt56(&view);
        assert!(p.dt <= exact, "step {s}: proposed {} > exact {exact}", p.dt);
        assert!(
            p.dt >= 0.9 * q.dt,
            "step {s}: cached {} vs every-step {} (safety {safety})",
            p.dt,
            q.dt
        );
    }
    eprintln!("{updates} λmax updates in {steps} proposals");
    assert!(updates < steps / 3, "{updates} updates in {steps} steps");
    assert!(updates > 1, "the collapse must trigger updates");
}

#[test]
fn default_limit_equals_the_default_config() {
    let mut fx = Fixture::new(
        periodic(16, 1.0),
        Shape::Gimp,
        jittered(16, 1.0, 2, 0.5, 4),
        1.0,
        1.0,
    );
    let mut a = Stability::default();
    let mut b = Stability::new(StabilityConfig::default()).unwrap();
    let h = fx.grid.h;
    for step in 0..30 {
        for (p, x) in fx.x.iter_mut().enumerate() {
            *x += 2e-3 * h * ((p + step) as f64).sin();
        }
        fx.refresh();
        let view = fx.view();
        let (pa, pb) = (a.propose(&view).unwrap(), b.propose(&view).unwrap());
        assert_eq!(pa.dt.to_bits(), pb.dt.to_bits(), "step {step}");
    }
}
