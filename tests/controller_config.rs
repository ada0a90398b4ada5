//! Controller configuration: defaults, validation naming the field, serde round trips
//! (proptest), and the Söderlind filter presets.

use mpm_dt::controller::{
    ConfigError, ControllerConfig, FilterPreset, GrowthConfig, GrowthIndicator, SoderlindFilter,
    TemporalErrorConfig,
};
use mpm_dt::limits_nd::StabilityNdConfig;
use mpm_dt::stability::{SoundSpeedConfig, StabilityConfig};
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;

/// Exact comparison of coefficient arrays (they are literal constants).
fn bits(k: [f64; 5]) -> [u64; 5] {
    k.map(f64::to_bits)
}

#[test]
fn defaults_are_valid_and_documented_values() {
    let c = ControllerConfig::default();
    c.validate().unwrap();
    assert_eq!(c.max_consecutive_rejections, 7);
    assert_eq!(c.filter, FilterPreset::Pid);
    assert_eq!(
        bits(c.filter.coefficients()),
        bits([0.58, -0.21, 0.1, 0.0, 0.0])
    );
}

#[test]
fn invalid_values_name_their_field() {
    let cases: Vec<(&str, &str)> = vec![
        (r#"{"safety": 1.5}"#, "safety"),
        (r#"{"max_growth": 0.5}"#, "max_growth"),
        (r#"{"hold_growth": 0.99}"#, "hold_growth"),
        (r#"{"min_shrink": 0.0}"#, "min_shrink"),
        (r#"{"max_shrink_repeated": 0.05}"#, "max_shrink_repeated"),
        (r#"{"dt_initial": -1.0}"#, "dt_initial"),
        (r#"{"dt_min": -1.0}"#, "dt_min"),
        (
            r#"{"max_consecutive_rejections": 0}"#,
            "max_consecutive_rejections",
        ),
        (r#"{"temporal": {"rtol": -1.0}}"#, "temporal.rtol"),
        (r#"{"temporal": {"balance": 0.0}}"#, "temporal.balance"),
        (r#"{"temporal": {"lag": -1.0}}"#, "temporal.lag"),
        (
            r#"{"temporal": {"defer_below": 1.0}}"#,
            "temporal.defer_below",
        ),
        (
            r#"{"temporal": {"defer_below": -0.1}}"#,
            "temporal.defer_below",
        ),
        (r#"{"growth": {"factor": 1.0}}"#, "growth.factor"),
        (r#"{"growth": {"windows": 1}}"#, "growth.windows"),
        (
            r#"{"filter": {"custom": [0.0, 0.0, 0.0, 0.0, 0.0]}}"#,
            "filter",
        ),
    ];
    for (json, field) in cases {
        let err = ControllerConfig::from_json(json).unwrap_err();
        match &err {
            ConfigError::OutOfRange { field: f, .. } => assert_eq!(*f, field, "{json}"),
            e => panic!("{json}: unexpected {e}"),
        }
        assert!(err.to_string().contains(field));
    }
    let err = ControllerConfig::from_json(r#"{"dt_min": 1.0, "dt_max": 0.5}"#).unwrap_err();
    assert!(matches!(
        err,
        ConfigError::Inconsistent {
            field: "dt_max",
            other: "dt_min",
            ..
        }
    ));
    let err = ControllerConfig::from_json(r#"{"saftey": 0.5}"#).unwrap_err();
    assert!(
        matches!(&err, ConfigError::Parse { message, .. } if message.contains("saftey")),
        "{err}"
    );
    // The JSON reader's error is kept as the source, with its line and column.
    let err = ControllerConfig::from_json("{\n  \"safety\": 0.5,,\n}").unwrap_err();
    let ConfigError::Parse {
        source: Some(json), ..
    } = &err
    else {
        panic!("{err:?}");
    };
    assert!(json.get().is_syntax(), "{json}");
    assert_eq!(json.get().line(), 2, "{json}");
    let source = std::error::Error::source(&err).map(|e| e.to_string());
    assert_eq!(source, Some(json.to_string()));
}

#[test]
fn presets_carry_sundials_coefficients() {
    assert_eq!(
        bits(FilterPreset::I.coefficients()),
        bits([1.0, 0.0, 0.0, 0.0, 0.0])
    );
    assert_eq!(
        bits(FilterPreset::Pi.coefficients()),
        bits([0.8, -0.31, 0.0, 0.0, 0.0])
    );
    assert_eq!(
        bits(FilterPreset::H211.coefficients()),
        bits([0.25, 0.25, 0.0, -0.25, 0.0])
    );
    assert_eq!(
        bits(FilterPreset::H0211.coefficients()),
        bits([0.5, 0.5, 0.0, -0.5, 0.0])
    );
    assert_eq!(
        bits(FilterPreset::H0321.coefficients()),
        bits([1.25, 0.5, -0.75, 0.25, 0.75])
    );
    assert_eq!(
        bits(FilterPreset::H312.coefficients()),
        bits([0.125, 0.25, 0.125, -0.375, -0.125])
    );
}

#[test]
fn filter_follows_the_soderlind_formula() {
    // I controller, order p = 1: h' = h · ε^(−1/2).
    let mut f = SoderlindFilter::new(FilterPreset::I, 1);
    assert!(f.proposal().is_none());
    f.record(0.1, 0.25);
    assert!((f.proposal().unwrap() - 0.2).abs() < 1e-15);
    // PI with two entries: h' = h ε₀^(−0.8/2) ε₁^(0.31/2) (h₀/h₁)^0.
    let mut f = SoderlindFilter::new(FilterPreset::Pi, 1);
    f.record(0.1, 0.5);
    f.record(0.2, 0.25);
    let expect = 0.2 * 0.25f64.powf(-0.4) * 0.5f64.powf(0.155);
    assert!((f.proposal().unwrap() - expect).abs() < 1e-14);
    // H312 with full history.
    let mut f = SoderlindFilter::new(FilterPreset::H312, 1);
    f.record(0.1, 0.9);
    f.record(0.12, 0.8);
    f.record(0.15, 0.5);
    let k = FilterPreset::H312.coefficients();
    let expect = 0.15
        * 0.5f64.powf(-k[0] / 2.0)
        * 0.8f64.powf(-k[1] / 2.0)
        * 0.9f64.powf(-k[2] / 2.0)
        * (0.15f64 / 0.12).powf(k[3])
        * (0.12f64 / 0.1).powf(k[4]);
    assert!((f.proposal().unwrap() - expect).abs() < 1e-14);
    // dsm = 0 is floored, never infinite.
    let mut f = SoderlindFilter::new(FilterPreset::I, 1);
    f.record(1.0, 0.0);
    assert!(f.proposal().unwrap().is_finite());
    // restart keeps only the newest entry.
    let mut f = SoderlindFilter::new(FilterPreset::Pid, 1);
    f.record(0.1, 0.5);
    f.record(0.1, 0.5);
    f.restart(0.3, 0.25);
    assert_eq!(f.history.len(), 1);
}

/// Random configurations with every setting in range.
fn config() -> impl Strategy<Value = ControllerConfig> {
    (
        (
            prop::option::of(1e-6f64..1.0),
            0.0f64..1e-6,
            prop::option::of(1e-3f64..10.0),
            0.1f64..1.0,
            1.0f64..20.0,
        ),
        (
            0.01f64..0.1,
            0.1f64..0.99,
            0.1f64..0.99,
            0.01f64..0.99,
            1u32..20,
            1u32..4,
        ),
        prop::sample::select(vec![
            FilterPreset::I,
            FilterPreset::Pi,
            FilterPreset::Pid,
            FilterPreset::ExpGus,
            FilterPreset::ImpGus,
            FilterPreset::H211,
            FilterPreset::H0211,
            FilterPreset::H0321,
            FilterPreset::H312,
            FilterPreset::Custom([0.7, -0.4, 0.1, 0.2, -0.3]),
        ]),
        (
            any::<bool>(),
            1e-6f64..1.0,
            0.0f64..1.0,
            0.0f64..1.0,
            0.0f64..1.0,
            prop::option::of(0.01f64..100.0),
            0u32..20,
            0.0f64..0.99,
        ),
        (
            any::<bool>(),
            any::<bool>(),
            1u32..100,
            2u32..8,
            1.01f64..10.0,
            0.0f64..1e-3,
            0.1f64..0.99,
            prop_oneof![Just(0.0), 0.0f64..1.0],
        ),
    )
        .prop_map(assemble)
}

/// The top-level settings `config` draws: `dt_initial`, `dt_min`, `dt_max`, `safety`,
/// `max_growth`.
type Steps = (Option<f64>, f64, Option<f64>, f64, f64);
/// The shrink settings `config` draws (`reject_shrink` also sets `hold_growth`), then
/// `max_consecutive_rejections` and `order`.
type Shrinks = (f64, f64, f64, f64, u32, u32);
/// The temporal error settings `config` draws.
type Temporal = (bool, f64, f64, f64, f64, Option<f64>, u32, f64);
/// The growth monitor's settings `config` draws (they also pick the standard limits).
type Growth = (bool, bool, u32, u32, f64, f64, f64, f64);

/// The configuration from the values `config` drew.
fn assemble(
    (a, b, filter, t, g): (Steps, Shrinks, FilterPreset, Temporal, Growth),
) -> ControllerConfig {
    ControllerConfig {
        dt_initial: a.0,
        dt_min: a.1,
        dt_max: a.2,
        safety: a.3,
        max_growth: a.4,
        hold_growth: 1.0 + (a.4 - 1.0) * b.3,
        min_shrink: b.0,
        max_shrink_first: b.1,
        max_shrink_repeated: b.2,
        reject_shrink: b.3,
        max_consecutive_rejections: b.4,
        order: b.5,
        filter,
        temporal: TemporalErrorConfig {
            enabled: t.0,
            rtol: t.1,
            atol_rel: Some(t.2),
            atol_v: t.3,
            atol_sigma: t.4,
            balance: t.5,
            lag: t.5,
            max_deferred: t.6,
            defer_below: t.7,
        },
        growth: GrowthConfig {
            enabled: g.0,
            indicator: if g.1 {
                GrowthIndicator::Energy
            } else {
                GrowthIndicator::Checkerboard
            },
            window: g.2,
            windows: g.3,
            factor: g.4,
            floor: g.5,
            safety_factor: g.6,
            min_safety_scale: g.7,
            energy_confirm: g.5,
            energy_tol: g.4 - 1.0,
        },
        // The standard limits: present or left out, with in-range settings.
        stability: g.0.then_some(StabilityConfig {
            safety: b.1,
            ..StabilityConfig::default()
        }),
        sound_speed: g.1.then_some(SoundSpeedConfig { alpha: g.4 }),
        // In-range tracking settings (its safety is `stability.safety`, not in JSON).
        stability_nd: StabilityNdConfig {
            refresh_cells: b.2,
            bound_slack: t.7 - 0.5,
            bound_age: g.2,
            ..StabilityNdConfig::default()
        },
        gravity: g.0.then(|| vec![0.0, -g.4]),
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E),
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "proptest-regressions/controller_config.txt",
        ))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn configs_round_trip_through_json(c in config()) {
        let json = serde_json::to_string(&c).unwrap();
        let back: ControllerConfig = serde_json::from_str(&json).unwrap();
        prop_assert_eq!(&back, &c);
        let pretty = serde_json::to_string_pretty(&c).unwrap();
        let back: ControllerConfig = serde_json::from_str(&pretty).unwrap();
        prop_assert_eq!(back, c);
    }
}
