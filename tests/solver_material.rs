//! Materials: the tangent modulus is `E_t = F dσ/dF`, the stored energy's derivative is the
//! stress (`dW/dF = σ` in 1D, where Cauchy = first Piola–Kirchhoff), and the neo-Hookean
//! wave speed depends on `F` while the linear one does not. Checked by central
//! differences over a range of stretches.

use mpm_dt::mpm::Material;

#[test]
fn tangent_modulus_is_f_times_the_stress_slope() {
    for material in [
        Material::LinearElastic {
            youngs_modulus: 3.0,
        },
        Material::NeoHookean {
            youngs_modulus: 3.0,
        },
    ] {
        for k in 0..40 {
            let f = 0.3 + 0.05 * k as f64;
            let d = 1e-6 * f;
            let slope = (material.stress(f + d) - material.stress(f - d)) / (2.0 * d);
            let et = material.tangent_modulus(f);
            assert!(
                (f * slope - et).abs() < 1e-7 * et,
                "{material:?} F = {f}: {} vs {et}",
                f * slope
            );
        }
        assert!((material.tangent_modulus(1.0) - 3.0).abs() < 1e-15);
        assert!(material.stress(1.0).abs() < 1e-15);
    }
}

#[test]
fn neo_hookean_energy_derivative_is_the_stress() {
    let m = Material::NeoHookean {
        youngs_modulus: 2.0,
    };
    for k in 0..40 {
        let f = 0.3 + 0.05 * k as f64;
        let d = 1e-6 * f;
        let dw = (m.energy_density(0.0, f + d) - m.energy_density(0.0, f - d)) / (2.0 * d);
        assert!(
            (dw - m.stress(f)).abs() < 1e-7,
            "F = {f}: dW/dF = {dw}, σ = {}",
            m.stress(f)
        );
        assert!(m.energy_density(0.0, f) >= 0.0);
    }
    // Linear: the small-strain energy σ²/(2E).
    let l = Material::LinearElastic {
        youngs_modulus: 2.0,
    };
    assert!((l.energy_density(0.5, 1.0) - 0.0625).abs() < 1e-15);
}

#[test]
fn only_the_neo_hookean_wave_speed_depends_on_stretch() {
    let (lin, neo) = (
        Material::LinearElastic {
            youngs_modulus: 4.0,
        },
        Material::NeoHookean {
            youngs_modulus: 4.0,
        },
    );
    // At fixed density, c = √(E_t/ρ).
    assert!((lin.wave_speed(0.5, 1.0) - 2.0).abs() < 1e-15);
    assert!((lin.wave_speed(2.0, 1.0) - 2.0).abs() < 1e-15);
    assert!((neo.wave_speed(1.0, 1.0) - 2.0).abs() < 1e-15);
    // E_t = (E/2)(F + 1/F) = 5 at F = 2 and at F = 1/2.
    assert!((neo.wave_speed(2.0, 1.0) - 5f64.sqrt()).abs() < 1e-14);
    assert!((neo.wave_speed(0.5, 1.0) - 5f64.sqrt()).abs() < 1e-14);
}
