//! The vectorised validation of a view (`check_view` / `SoundSpeed::speeds`) reports exactly
//! what the field-by-field check reports — same field, same index, same value, the first
//! failing check in the documented order — and `SoundSpeed::speeds` equals the plain
//! per-particle maxima bit for bit.

mod stability_common;

use mpm_dt::stability::{Eq56Operator, SoundSpeed, StabilityError};
use mpm_dt::Shape;
use stability_common::*;

/// The field-by-field reference: lengths, then finite `x, v, σ` and positive finite
/// `F, V⁰, m, E_t, ρ` (first failing field, first index), then active nodal masses.
fn reference(fx: &Fixture) -> Result<(), StabilityError> {
    let n = fx.x.len();
    if n == 0 {
        return Err(StabilityError::NoParticles);
    }
    let fields: [(&'static str, &[f64], bool); 8] = [
        ("x", &fx.x, false),
        ("v", &fx.v, false),
        ("sigma", &fx.sigma, false),
        ("F", &fx.f, true),
        ("volume0", &fx.volume0, true),
        ("mass", &fx.mass, true),
        ("tangent_modulus", &fx.modulus, true),
        ("density", &fx.density, true),
    ];
    for (field, values, positive) in fields {
        for (index, &value) in values.iter().enumerate() {
            if !value.is_finite() || (positive && value <= 0.0) {
                return Err(StabilityError::InvalidField {
                    field,
                    index,
                    value,
                });
            }
        }
    }
    let mut any = false;
    for (index, (&m, &active)) in fx.node_mass.iter().zip(&fx.node_active).enumerate() {
        if active {
            if !(m.is_finite() && m > 0.0) {
                return Err(StabilityError::InvalidField {
                    field: "node_mass",
                    index,
                    value: m,
                });
            }
            any = true;
        }
    }
    if any {
        Ok(())
    } else {
        Err(StabilityError::NoActiveNodes)
    }
}

fn fixture() -> Fixture {
    // 37 cells × 3 particles = 111: not a multiple of the scans' lane count.
    let mut fx = Fixture::new(
        periodic(37, 1.0),
        Shape::Gimp,
        uniform(37, 1.0, 3),
        1.0,
        1.0,
    );
    for p in 0..fx.x.len() {
        let s = p as f64;
        fx.v[p] = 0.01 * (0.37 * s).sin();
        fx.sigma[p] = 0.02 * (0.11 * s).cos();
        fx.modulus[p] = 1.0 + 0.5 * (0.7 * s).sin();
        fx.density[p] = 1.0 + 0.25 * (0.3 * s).cos();
    }
    fx
}

fn field_mut(fx: &mut Fixture, field: usize) -> &mut Vec<f64> {
    match field {
        0 => &mut fx.x,
        1 => &mut fx.v,
        2 => &mut fx.sigma,
        3 => &mut fx.f,
        4 => &mut fx.volume0,
        5 => &mut fx.mass,
        6 => &mut fx.modulus,
        _ => &mut fx.density,
    }
}

fn plain_speeds(fx: &Fixture) -> (f64, f64) {
    let view = fx.view();
    let c = (0..fx.x.len())
        .map(|p| view.wave_speed(p))
        .fold(0.0, f64::max);
    let v = fx.v.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    (c, v)
}

fn assert_same(fx: &Fixture, what: &str) {
    let expected = reference(fx);
    let speeds = SoundSpeed::speeds(&fx.view());
    match &expected {
        Ok(()) => {
            let (c, v) = speeds.unwrap_or_else(|e| panic!("{what}: {e}"));
            let (pc, pv) = plain_speeds(fx);
            assert_eq!(
                (c.to_bits(), v.to_bits()),
                (pc.to_bits(), pv.to_bits()),
                "{what}"
            );
        }
        Err(e) => {
            let got = speeds.expect_err(what);
            // Compare through Debug so that NaN values compare equal.
            assert_eq!(format!("{got:?}"), format!("{e:?}"), "{what}");
        }
    }
    let op = Eq56Operator::new(&fx.view()).err();
    assert_eq!(
        op.map(|e| format!("{e:?}")),
        expected.err().map(|e| format!("{e:?}")),
        "{what} (operator)"
    );
}

#[test]
fn valid_views_pass_with_the_plain_maxima() {
    let fx = fixture();
    assert_same(&fx, "valid");
    // Huge but finite values overflow the scan's sums: a false alarm, still valid.
    let mut fx = fixture();
    fx.x[5] = 1.7e308;
    fx.v[5] = 1.7e308;
    fx.sigma[100] = -1.7e308;
    fx.f[100] = 1.7e308;
    assert_same(&fx, "huge finite values");
}

#[test]
fn every_bad_value_in_every_field_is_reported_as_field_by_field() {
    let bad = [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        0.0,
        -0.0,
        -1.0,
        f64::MIN_POSITIVE / 2.0,
    ];
    let n = fixture().x.len();
    for field in 0..8 {
        for &value in &bad {
            for index in [0, 1, 7, 8, 63, n - 3, n - 1] {
                let mut fx = fixture();
                field_mut(&mut fx, field)[index] = value;
                assert_same(&fx, &format!("field {field} [{index}] = {value}"));
                // A second bad value in an earlier field at a later index wins.
                if field > 0 {
                    field_mut(&mut fx, field - 1)[n - 1] = f64::NAN;
                    assert_same(
                        &fx,
                        &format!("field {field} [{index}] and field {} [last]", field - 1),
                    );
                }
            }
        }
    }
}

#[test]
fn bad_active_node_masses_and_no_active_node() {
    for &value in &[f64::NAN, f64::INFINITY, 0.0, -0.0, -2.0] {
        let mut fx = fixture();
        let last = fx.node_mass.len() - 1;
        for i in [0, 5, last] {
            fx.node_mass[i] = value;
        }
        assert_same(&fx, &format!("node mass {value}"));
        // Inactive nodes are not checked.
        for i in [0, 5, last] {
            fx.node_active[i] = false;
        }
        assert_same(&fx, &format!("inactive node mass {value}"));
    }
    let mut fx = fixture();
    fx.node_active.iter_mut().for_each(|a| *a = false);
    assert_same(&fx, "no active node");
}
