//! Linear-hat weights with a drifting gap in the particle layout: the node nearest the gap
//! has a tiny mass, so the critical step collapses each time the gap crosses a node. Fixed
//! α = 0.4 sound-speed stepping (eq 49 generalised) blows up; the controller, which tracks
//! λmax of eq 56 as the particles move, survives to t_end.

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::limit::StepLimit;
use mpm_dt::mpm::{Material, ParticleInit, ReferenceStepper};
use mpm_dt::problems::{uniform_positions, StandingWave};
use mpm_dt::stability::{SoundSpeed, SoundSpeedConfig, Stability, StabilityConfig};
use mpm_dt::{Boundary, Grid, Shape, Stepper};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const CELLS: usize = 32;
const DRIFT: f64 = 0.02;
const T_END: f64 = 1.2;

/// Two particles per cell; the four around node 11 pushed to the far edges of its two cells
/// (leaving ~0.3 % of a typical nodal mass), then the whole layout shifted by h/2 so the gap
/// starts between nodes. Velocity: uniform drift 0.02 c (the gap reaches the next node at
/// t ≈ 0.8) plus a standing wave A = 10⁻³ and 10⁻⁶ noise. Measured (eq 56, tracked):
/// dt_eq56 falls from 0.70 h/c to ≈ 0.14 h/c as the gap crosses the node, below α = 0.4's
/// 0.39 h/c.
fn build() -> ReferenceStepper {
    let grid = Grid::new(Boundary::Periodic, CELLS, 1.0);
    let h = grid.h;
    let mut x = uniform_positions(&grid, 2);
    let k = 11;
    let xk = k as f64 * h;
    x[2 * (k - 1)] = xk - h + 0.001 * h;
    x[2 * (k - 1) + 1] = xk - h + 0.002 * h;
    x[2 * k] = xk + h - 0.002 * h;
    x[2 * k + 1] = xk + h - 0.001 * h;
    let x: Vec<f64> = x.into_iter().map(|x| grid.wrap(x + 0.5 * h)).collect();
    let wave = StandingWave::new(1e-3, 1.0, 1.0, 1.0, 1.0);
    let mut init: ParticleInit = wave.particle_init(x);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for v in init.v.iter_mut() {
        *v += DRIFT + 1e-6 * (rng.random::<f64>() - 0.5);
    }
    ReferenceStepper::new(
        grid,
        Shape::Linear,
        Material::LinearElastic {
            youngs_modulus: 1.0,
        },
        init,
    )
    .expect("valid setup")
}

/// Blown up: a failed step, or energy above 10× its start.
fn blew_up(s: &ReferenceStepper, e0: f64) -> bool {
    let e = s.total_energy();
    e.is_nan() || e > 10.0 * e0
}

#[test]
fn controller_survives_where_sound_speed_stepping_blows_up() {
    // α = 0.4 sound-speed stepping.
    let mut s = build();
    let e0 = s.total_energy();
    let mut sound = SoundSpeed::new(SoundSpeedConfig { alpha: 0.4 }).unwrap();
    let mut failed = false;
    while s.time() < T_END && !failed {
        let dt = StepLimit::<1>::propose(&mut sound, &s.view())
            .unwrap()
            .dt
            .min(T_END - s.time());
        failed = s.try_step(dt).is_err() || s.accept().is_err() || blew_up(&s, e0);
    }
    assert!(
        failed,
        "α = 0.4 sound-speed stepping was expected to blow up (t = {})",
        s.time()
    );
    let t_fail = s.time();

    // The controller: stability (eq 56 tracked), temporal error, growth monitor.
    let mut s = build();
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(
        Stability::new(StabilityConfig::default()).unwrap(),
    )];
    let mut c = Controller::with_default_limits(ControllerConfig::default(), limits).unwrap();
    let mut dts = Vec::new();
    let mut lambda = Vec::new();
    c.run_until(&mut s, T_END, &mut |d| {
        if d.outcome == mpm_dt::controller::Outcome::Accepted {
            dts.push(d.dt);
            lambda.extend(d.lambda_max);
        }
    })
    .unwrap_or_else(|e| panic!("controller failed: {e}"));
    assert!((s.time() - T_END).abs() < 1e-12);
    assert!(!blew_up(&s, e0), "energy {} from {e0}", s.total_energy());
    let (lo, hi) = dts
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &d| (a.min(d), b.max(d)));
    eprintln!(
        "sound speed blew up at t = {t_fail:.3}; controller: {} steps, {} rejected, dt in [{:.4}, {:.4}] h/c, λmax up to {:.1}, binding {:?}",
        c.stats().accepted,
        c.stats().rejected,
        lo * CELLS as f64,
        hi * CELLS as f64,
        lambda.iter().cloned().fold(0.0, f64::max),
        c.stats().binding
    );
    // The step really collapsed and recovered as the gap crossed nodes.
    assert!(hi > 2.0 * lo, "dt did not vary: [{lo}, {hi}]");
}
