//! Capability: `Controller::<D>::standard(config)` builds the standard controller in every
//! dimension from the config alone, gravity included (`config.gravity`, the 2D/3D growth
//! monitor's potential energy), and takes the same steps as the limits built by hand.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{ConfigError, Controller, ControllerConfig, ControllerError, Decision};
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::{Boundary, Stepper};

fn with_gravity(g: &[f64]) -> ControllerConfig {
    ControllerConfig {
        gravity: Some(g.to_vec()),
        ..ControllerConfig::default()
    }
}

#[test]
fn gravity_is_refused_in_1d_and_needs_one_finite_component_per_axis() {
    match Controller::<1>::standard(with_gravity(&[-9.8])) {
        Err(ControllerError::Config(ConfigError::NotInDimension { field, dim: 1, .. })) => {
            assert_eq!(field, "gravity")
        }
        other => panic!("1D gravity: {:?}", other.map(|_| ())),
    }
    for (dim, g) in [(2, &[0.0, -9.8, 0.0][..]), (3, &[0.0, -9.8][..])] {
        let result = if dim == 2 {
            Controller::<2>::standard(with_gravity(g)).map(|_| ())
        } else {
            Controller::<3>::standard(with_gravity(g)).map(|_| ())
        };
        match result {
            Err(ControllerError::Config(ConfigError::WrongLength { field, len, dim: d })) => {
                assert_eq!((field, len, d), ("gravity", g.len(), dim))
            }
            other => panic!("{dim}D with {g:?}: {other:?}"),
        }
    }
    match Controller::<2>::standard(with_gravity(&[0.0, f64::NAN])) {
        Err(ControllerError::Config(ConfigError::OutOfRange { field, .. })) => {
            assert_eq!(field, "gravity")
        }
        other => panic!("NaN gravity: {:?}", other.map(|_| ())),
    }
    assert!(Controller::<2>::standard(with_gravity(&[0.0, -9.8])).is_ok());
    assert!(Controller::<3>::standard(with_gravity(&[0.0, 0.0, -9.8])).is_ok());
    let parsed = ControllerConfig::from_json(r#"{"gravity": [0.0, -9.8]}"#).unwrap();
    assert_eq!(parsed.gravity, Some(vec![0.0, -9.8]));
}

/// A neo-Hookean block under gravity `g` on a periodic grid, with a shear wave.
fn falling_block(g: f64) -> SolverNd<2> {
    let grid = GridNd::<2>::new([Boundary::Periodic; 2], [8, 8], [1.0, 1.0]);
    let material = MaterialNd::NeoHookean {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2, 2], 1.0, material);
    for p in 0..particles.len() {
        let y = particles.x[p][1];
        particles.v[p][0] = 0.05 * (2.0 * std::f64::consts::PI * y).sin();
    }
    SolverNd::new(grid, ShapeNd::Gimp, particles, Vector::<2>::new(0.0, g)).unwrap()
}

/// Every decision's outcome and step (bits) of a run to `t_end`, and the end state.
fn run(mut controller: Controller<2>, g: f64, t_end: f64) -> (Vec<String>, Vec<u64>) {
    let mut solver = falling_block(g);
    let mut log = Vec::new();
    let mut record = |d: &Decision| log.push(format!("{:?} {:e}", d.outcome, d.dt));
    match controller.run_until(&mut solver, t_end, &mut record) {
        Ok(_) | Err(ControllerError::GrowthPersists { .. }) => {}
        Err(e) => panic!("run failed: {e}"),
    }
    let view = solver.view();
    let end = view.x.iter().chain(view.v.iter());
    let bits = end.flat_map(|x| x.iter().map(|c| c.to_bits())).collect();
    (log, bits)
}

#[test]
fn the_standard_controller_is_the_standard_limits_with_the_configs_gravity() {
    let g = -2.0;
    let config = with_gravity(&[0.0, g]);
    let by_hand = Controller::<2>::new(
        config.clone(),
        standard_limits::<2>(&config, Vector::<2>::new(0.0, g)),
    )
    .unwrap();
    let standard = run(Controller::<2>::standard(config).unwrap(), g, 1.0);
    assert_eq!(standard, run(by_hand, g, 1.0));
    // The gravity reaches the growth monitor: without it the falling block's energy
    // rises and the run differs.
    let blind = run(
        Controller::<2>::standard(ControllerConfig::default()).unwrap(),
        g,
        1.0,
    );
    assert_ne!(standard.0, blind.0, "config.gravity changed nothing");
}
