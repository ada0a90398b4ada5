//! Bad input gives typed errors, never a panic.

mod stability_common;

use mpm_dt::stability::{
    bound58, Bound58Reading, Eq56Operator, FullMap, NodalOperator, SoundSpeed, SoundSpeedConfig,
    Stability, StabilityConfig, StabilityError,
};
use mpm_dt::{LimitError, Shape, StepLimit};
use stability_common::*;

fn base() -> Fixture {
    Fixture::new(periodic(8, 1.0), Shape::Gimp, uniform(8, 1.0, 2), 1.0, 1.0)
}

#[test]
fn nan_stress_is_a_typed_error() {
    let mut fx = base();
    fx.sigma[3] = f64::NAN;
    let err = Eq56Operator::new(&fx.view()).unwrap_err();
    assert!(
        matches!(
            err,
            StabilityError::InvalidField {
                field: "sigma",
                index: 3,
                ..
            }
        ),
        "{err}"
    );
    let err = bound58(&fx.view(), 0.01, Bound58Reading::Paper).unwrap_err();
    assert!(matches!(
        err,
        StabilityError::InvalidField { field: "sigma", .. }
    ));
    let err = Stability::default().propose(&fx.view()).unwrap_err();
    assert!(
        matches!(
            err,
            LimitError::InvalidState {
                field: "sigma",
                index: 3,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn zero_modulus_is_a_typed_error() {
    let mut fx = base();
    fx.modulus[5] = 0.0;
    let err = Eq56Operator::new(&fx.view()).unwrap_err();
    assert!(matches!(
        err,
        StabilityError::InvalidField {
            field: "tangent_modulus",
            index: 5,
            ..
        }
    ));
    let err = StepLimit::<1>::propose(&mut SoundSpeed::default(), &fx.view()).unwrap_err();
    assert!(matches!(
        err,
        LimitError::InvalidState {
            field: "tangent_modulus",
            index: 5,
            ..
        }
    ));
    assert!(FullMap::new(&fx.view()).is_err());
}

#[test]
fn empty_nodes_are_typed_errors() {
    let mut fx = base();
    fx.node_active.iter_mut().for_each(|a| *a = false);
    assert_eq!(
        Eq56Operator::new(&fx.view()).unwrap_err(),
        StabilityError::NoActiveNodes
    );
    let mut fx = base();
    fx.node_mass[2] = 0.0; // still marked active: inconsistent
    assert!(matches!(
        Eq56Operator::new(&fx.view()).unwrap_err(),
        StabilityError::InvalidField {
            field: "node_mass",
            index: 2,
            ..
        }
    ));
    let mut fx = base();
    fx.x.clear();
    fx.v.clear();
    fx.sigma.clear();
    fx.f.clear();
    fx.volume0.clear();
    fx.mass.clear();
    fx.modulus.clear();
    fx.density.clear();
    assert_eq!(
        Eq56Operator::new(&fx.view()).unwrap_err(),
        StabilityError::NoParticles
    );
}

#[test]
fn a_non_positive_active_mass_on_the_served_path_is_a_typed_error() {
    // The served pass does not test the masses (a trusted pass summary vouches for them);
    // without one the tracker scans them first, and the anchor that follows reports the bad
    // one at once. (Here the pass's diagonal test, for the zero mass, and its drop trigger,
    // for the infinite one, would anchor too; inside a zero block only the scan sees an
    // infinite mass: the unit test of `active_masses_positive`.)
    let mut fx = base();
    let k = NodalOperator::new(&fx.view())
        .expect("valid")
        .stiffness()
        .clone();
    fx.stiffness = Some(k);
    let mut limit = Stability::default();
    limit.propose(&fx.view()).expect("valid state: anchors");
    let served = limit.propose(&fx.view()).expect("valid state: served");
    assert_eq!(served.metrics.get("lambda_factorisations"), Some(&0.0));
    for bad in [0.0, f64::INFINITY] {
        let mut fx = fx.clone();
        fx.node_mass[2] = bad; // still marked active
        let err = limit.clone().propose(&fx.view()).unwrap_err();
        assert!(
            matches!(
                err,
                LimitError::InvalidState {
                    field: "node_mass",
                    index: 2,
                    ..
                }
            ),
            "{bad}: {err}"
        );
    }
}

#[test]
fn mismatched_lengths_and_bad_config_are_typed_errors() {
    let mut fx = base();
    fx.density.pop();
    assert!(matches!(
        Eq56Operator::new(&fx.view()).unwrap_err(),
        StabilityError::LengthMismatch {
            field: "density",
            ..
        }
    ));
    assert!(SoundSpeed::new(SoundSpeedConfig { alpha: -1.0 }).is_err());
    assert!(Stability::new(StabilityConfig {
        safety: 1.5,
        ..Default::default()
    })
    .is_err());
    let mut s = Stability::default();
    assert!(s.set_safety(f64::NAN).is_err());
    assert!(s.set_safety(0.5).is_ok());
    assert!(bound58(&base().view(), -1.0, Bound58Reading::Paper).is_err());
    assert!(FullMap::new(&base().view())
        .unwrap()
        .spectral_radius(f64::INFINITY)
        .is_err());
}
