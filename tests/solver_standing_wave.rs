//! The reference solver runs the standing wave (vibrating bar) and stays close to the
//! exact solution of `mpm_dt::problems::StandingWave`.

use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::scenario::Scenario;
use mpm_dt::{Boundary, Grid, Shape, Stepper};

/// Runs `steps` steps of `dt`, accepting each.
fn run(stepper: &mut ReferenceStepper, dt: f64, steps: usize) {
    for _ in 0..steps {
        stepper.try_step(dt).expect("stable step");
        stepper.accept().expect("trial pending");
    }
}

/// `max_p |v_p − v(X_p, t)|` against the exact solution at the initial positions `x0`.
fn velocity_error(stepper: &ReferenceStepper, wave: &StandingWave, x0: &[f64]) -> f64 {
    let view = stepper.view();
    wave.velocity_error_linf(x0, view.v, view.t)
}

#[test]
fn periodic_standing_wave_follows_exact_solution_for_a_quarter_period() {
    let (cells, ppc) = (32, 2);
    let wave = StandingWave::new(1e-4, 1.0, 1.0, 1.0, 1.0);
    let grid = Grid::new(Boundary::Periodic, cells, 1.0);
    let init = wave.uniform_particles(&grid, ppc);
    let x0 = init.x.clone();
    let material = Material::LinearElastic {
        youngs_modulus: 1.0,
    };
    let mut s = ReferenceStepper::new(grid.clone(), Shape::Gimp, material, init).unwrap();
    let dt = 0.1 * grid.h;
    let steps = (0.25 * wave.period() / dt).round() as usize;
    run(&mut s, dt, steps);
    let amp = wave.amplitude * wave.wave_speed();
    let err = velocity_error(&s, &wave, &x0);
    assert_eq!(s.step_count(), steps as u64);
    assert!(
        err < 0.02 * amp,
        "velocity error {err:e} vs amplitude {amp:e}"
    );
    // Energy is conserved to a fraction of a percent over the quarter period.
    let e0 = wave.energy();
    let e = s.total_energy();
    assert!((e - e0).abs() < 5e-3 * e0, "energy {e:e} vs exact {e0:e}");
}

#[test]
fn clamped_fundamental_mode_runs_and_keeps_ends_at_rest() {
    let scenario = Scenario::from_json(
        r#"{"cells": 20, "boundary": "fixed", "particles": {"per_cell": 3},
            "initial": {"standing_wave": {"amplitude": 1e-4, "mode": 0.5}}}"#,
    )
    .unwrap();
    let wave = scenario.standing_wave().unwrap();
    let mut s = scenario.build().unwrap();
    let x0 = s.view().x.to_vec();
    let h = s.grid().h;
    let dt = 0.1 * h;
    let steps = (0.5 * wave.period() / dt).round() as usize;
    run(&mut s, dt, steps);
    let view = s.view();
    // Constrained nodes (ghosts and both ends) stay at rest.
    for i in [0, 1, view.n_nodes() - 2, view.n_nodes() - 1] {
        assert_eq!(
            view.node_velocity[i].to_bits(),
            0.0f64.to_bits(),
            "node {i}"
        );
        assert!(!view.node_active[i]);
    }
    let amp = wave.amplitude * wave.wave_speed();
    let err = velocity_error(&s, &wave, &x0);
    assert!(
        err < 0.03 * amp,
        "velocity error {err:e} vs amplitude {amp:e}"
    );
}

#[test]
fn view_weights_reproduce_the_stored_nodal_sums() {
    // The lazily computed view weights are those the step used: m_i = Σ S m_p (eq 7) and
    // m_i v_i = Σ S m_p v_p (eq 17) hold for the committed state after a few steps.
    let scenario = Scenario::from_json(r#"{"cells": 16, "particles": {"per_cell": 3}}"#).unwrap();
    let mut s = scenario.build().unwrap();
    run(&mut s, 0.01, 7);
    let view = s.view();
    let mut m = vec![0.0; view.n_nodes()];
    let mut p = vec![0.0; view.n_nodes()];
    for q in 0..view.n_particles() {
        for (i, sw, _) in view.weights.row(q) {
            m[i] += sw * view.mass[q];
            p[i] += sw * view.mass[q] * view.v[q];
        }
    }
    for i in 0..view.n_nodes() {
        assert!(
            (m[i] - view.node_mass[i]).abs() <= 1e-14,
            "mass at node {i}"
        );
        let v = p[i] / m[i];
        assert!(
            (v - view.node_velocity[i]).abs() <= 1e-14,
            "velocity at node {i}"
        );
    }
}

#[test]
fn neo_hookean_bar_keeps_its_energy_and_reports_tangent_and_density() {
    let scenario = Scenario::from_json(
        r#"{"cells": 32, "material": "neo_hookean",
            "initial": {"standing_wave": {"amplitude": 0.05, "mode": 1}}}"#,
    )
    .unwrap();
    let mut s = scenario.build().unwrap();
    let e0 = s.total_energy();
    let dt = 0.1 * s.grid().h;
    let quarter = (0.25 / dt).round() as usize; // a quarter period: largest strain
    run(&mut s, dt, quarter);
    let material = *s.material();
    {
        let view = s.view();
        // Strains of a few per cent: the tangent modulus differs from E somewhere.
        assert!(view.f.iter().any(|&f| (f - 1.0).abs() > 0.01));
        for p in 0..view.n_particles() {
            let f = view.f[p];
            assert_eq!(
                view.tangent_modulus[p].to_bits(),
                material.tangent_modulus(f).to_bits()
            );
            let rho = view.mass[p] / (f * view.volume0[p]);
            assert_eq!(view.density[p].to_bits(), rho.to_bits());
        }
    }
    run(&mut s, dt, 3 * quarter);
    let e = s.total_energy();
    assert!((e - e0).abs() < 1e-2 * e0, "energy {e:e} vs initial {e0:e}");
}
