//! The estimators off the paper's uniform periodic layouts: jittered particles (fixed-width
//! GIMP domains that overlap or leave gaps), jittered domains that still tile the bar, and
//! fixed (clamped) ends. Index (eq 48) within [0.8, 1.25] for N ≥ 40 with least-squares
//! recovery.

use mpm_dt::estimators::table1::{self, Config, CASES, CELLS, PPC};
use mpm_dt::estimators::Recovery;
use mpm_dt::Boundary;
use proptest::prelude::*;

fn check(config: &Config) {
    for case in CASES {
        for ppc in PPC {
            if config.tiling && ppc < 2 {
                continue;
            }
            for cells in CELLS.into_iter().filter(|&n| n >= 40) {
                let r = table1::run_case(config, case, cells, ppc).expect("runs");
                assert!(
                    r.error_norm.is_finite() && r.error_norm > 0.0,
                    "{config:?} {r:?}"
                );
                assert!((0.8..=1.25).contains(&r.index), "{config:?} {r:?}");
            }
        }
    }
}

#[test]
fn fixed_ends_uniform() {
    for recovery in [Recovery::LeastSquares, Recovery::Mapped] {
        check(&Config {
            boundary: Boundary::Fixed,
            recovery,
            ..Config::default()
        });
    }
}

#[test]
fn jittered_periodic_and_fixed() {
    for boundary in [Boundary::Periodic, Boundary::Fixed] {
        for (jitter, seed) in [(0.5, 7), (1.0, 11)] {
            check(&Config {
                boundary,
                jitter,
                seed,
                recovery: Recovery::LeastSquares,
                ..Config::default()
            });
        }
    }
}

#[test]
fn jittered_tiling_domains_periodic_and_fixed() {
    for boundary in [Boundary::Periodic, Boundary::Fixed] {
        for (jitter, seed) in [(0.5, 5), (1.0, 13)] {
            check(&Config {
                boundary,
                jitter,
                seed,
                tiling: true,
                recovery: Recovery::LeastSquares,
                ..Config::default()
            });
        }
    }
}

/// The paper's own recovery (eq 17 then eqs 42/43) is not enough on jittered layouts: the
/// eq 17 error changes from node to node there and differencing amplifies it. This test
/// documents that known limitation: somewhere the index leaves [0.8, 1.25].
#[test]
fn mapped_recovery_degrades_on_jittered_layouts() {
    let config = Config {
        boundary: Boundary::Fixed,
        jitter: 0.5,
        seed: 7,
        recovery: Recovery::Mapped,
        ..Config::default()
    };
    let worst = CASES
        .into_iter()
        .flat_map(|case| PPC.into_iter().map(move |ppc| (case, ppc)))
        .map(|(case, ppc)| {
            let r = table1::run_case(&config, case, 80, ppc).expect("runs");
            (r.index.ln()).abs()
        })
        .fold(0.0_f64, f64::max);
    assert!(worst > 1.25_f64.ln(), "worst |ln index| = {worst}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E), ..ProptestConfig::default() })]
    #[test]
    fn jittered_index_stays_near_one(
        seed in 0u64..1_000_000,
        jitter in 0.05f64..1.0,
        case in 1u8..=5,
        ppc in prop::sample::select(vec![1usize, 2, 4, 8]),
        cells in prop::sample::select(vec![40usize, 80]),
        fixed in any::<bool>(),
        tiling in any::<bool>(),
    ) {
        let config = Config {
            boundary: if fixed { Boundary::Fixed } else { Boundary::Periodic },
            jitter,
            seed,
            recovery: Recovery::LeastSquares,
            // A jittered tiling needs two particles per cell.
            tiling: tiling && ppc >= 2,
            ..Config::default()
        };
        let r = table1::run_case(&config, case, cells, ppc).expect("runs");
        prop_assert!((0.8..=1.25).contains(&r.index), "{:?}", r);
    }
}
