//! Capability: the d-dimensional eq 56 operator — the matrix-free Lanczos `λmax(M⁻¹K)`
//! equals the dense symmetric eigenvalue, uniform GIMP and linear layouts give
//! `dt_eq56 = h_min/(√2 c_p)`, `dt_eq56 ≤ dt_full_map ≤ 1.003·dt_empirical` on small 2D and
//! 3D layouts, and the controller runs 2D and 3D solvers without blow-up.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::limits_nd::critical::{critical_table, lambda_max};
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::{Boundary, Dim, Dimension, Stepper, ViewNd};

fn material(nu: f64) -> MaterialNd {
    MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: nu,
    }
}

#[path = "common/jitter.rs"]
mod jitter;
use jitter::jitter;

fn solver<const D: usize>(
    cells: [usize; D],
    lengths: [f64; D],
    shape: ShapeNd,
    nu: f64,
    jittered: bool,
    inclusion: bool,
) -> SolverNd<D> {
    let grid = GridNd::<D>::new([Boundary::Periodic; D], cells, lengths);
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1.0, material(nu));
    if jittered {
        jitter(&mut particles, 0.4, 12345);
    }
    if inclusion {
        // The particles in the first cell of every axis are 10× stiffer.
        for p in 0..particles.len() {
            if (0..D).all(|a| particles.x[p][a] < grid.h[a]) {
                particles.material[p] = MaterialNd::LinearElastic {
                    youngs_modulus: 10.0,
                    poisson_ratio: nu,
                };
            }
        }
    }
    SolverNd::new(grid, shape, particles, Vector::<D>::zeros()).unwrap()
}

fn check_dense<const D: usize>(label: &str, s: &SolverNd<D>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let t = critical_table(s, None);
    let dense = t
        .lambda_max_dense
        .expect("small enough for the dense check");
    let rel = (t.lambda_max_nodal - dense).abs() / dense;
    eprintln!(
        "{label}: λmax {:.9e} (dense {:.9e}), dt_eq56 = {:.6} h_min/c_p",
        t.lambda_max_nodal,
        dense,
        t.dt_eq56 / t.dt_sound
    );
    assert!(
        rel < 1e-6,
        "{label}: Lanczos {} vs dense {dense}",
        t.lambda_max_nodal
    );
}

#[test]
fn lanczos_matches_the_dense_eigenvalue_in_2d() {
    check_dense(
        "2D uniform GIMP",
        &solver([6, 5], [1.0, 1.0], ShapeNd::Gimp, 0.0, false, false),
    );
    check_dense(
        "2D jittered GIMP ν=0.3",
        &solver([6, 6], [1.0, 1.0], ShapeNd::Gimp, 0.3, true, false),
    );
    check_dense(
        "2D linear",
        &solver([6, 6], [1.0, 1.0], ShapeNd::Linear, 0.3, true, false),
    );
    check_dense(
        "2D B-spline",
        &solver([6, 6], [1.0, 1.0], ShapeNd::BSpline2, 0.3, true, false),
    );
    check_dense(
        "2D inclusion",
        &solver([6, 6], [1.0, 1.0], ShapeNd::Gimp, 0.3, false, true),
    );
    check_dense(
        "2D anisotropic",
        &solver([6, 4], [1.0, 2.0], ShapeNd::Gimp, 0.3, false, false),
    );
}

#[test]
fn lanczos_matches_the_dense_eigenvalue_in_3d() {
    check_dense(
        "3D uniform GIMP",
        &solver([4, 4, 3], [1.0; 3], ShapeNd::Gimp, 0.3, false, false),
    );
    check_dense(
        "3D jittered B-spline",
        &solver([4, 4, 4], [1.0; 3], ShapeNd::BSpline2, 0.3, true, false),
    );
    check_dense(
        "3D linear",
        &solver([4, 4, 4], [1.0; 3], ShapeNd::Linear, 0.0, true, false),
    );
}

#[test]
fn uniform_gimp_and_linear_layouts_give_h_over_root_two_c() {
    for (shape, nu, cells, lengths) in [
        (ShapeNd::Gimp, 0.0, [8, 8], [1.0, 1.0]),
        (ShapeNd::Gimp, 0.3, [8, 8], [1.0, 1.0]),
        (ShapeNd::Linear, 0.3, [8, 8], [1.0, 1.0]),
        (ShapeNd::Gimp, 0.3, [8, 4], [1.0, 1.0]),
    ] {
        let s = solver(cells, lengths, shape, nu, false, false);
        let view = s.view();
        let dt = (2.0 / lambda_max(&view)).sqrt();
        let c_p = material(nu).p_modulus().sqrt();
        let ratio = dt * c_p / view.grid.h_min();
        eprintln!("{shape:?} ν={nu} cells {cells:?}: dt_eq56 = {ratio:.6} h_min/c_p");
        assert!(
            (ratio - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6,
            "{shape:?} ν={nu} {cells:?}: {ratio}"
        );
    }
}

fn controlled_run<const D: usize>(mut s: SolverNd<D>, t_end: f64) -> (u64, f64)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let n = s.n_particles();
    let view = s.view();
    let c = view.p_wave_speed(0);
    let v: Vec<Vector<D>> = (0..n)
        .map(|p| {
            let mut v = Vector::<D>::zeros();
            v[0] = 1e-2 * c * (2.0 * std::f64::consts::PI * view.x[p][0]).sin();
            v
        })
        .collect();
    let sigma = vec![mpm_dt::nd::Tensor::<D>::zeros(); n];
    s.set_velocity_and_stress(&v, &sigma).unwrap();
    let e0 = s.total_energy();
    let config = ControllerConfig::default();
    let limits = standard_limits::<D>(&config, Vector::<D>::zeros());
    let mut controller = Controller::<D>::new(config, limits).unwrap();
    controller.run_until(&mut s, t_end, &mut |_| {}).unwrap();
    let e = s.total_energy();
    assert!(e.is_finite() && e <= 1.01 * e0, "energy {e} from {e0}");
    let stats = controller.stats();
    (stats.accepted, stats.dt_mean().unwrap())
}

#[test]
fn the_controller_runs_2d_and_3d_solvers_without_blow_up() {
    let s2 = solver([16, 16], [1.0, 1.0], ShapeNd::Gimp, 0.3, true, false);
    let h = s2.grid().h_min();
    let c = material(0.3).p_modulus().sqrt();
    let (steps, mean) = controlled_run(s2, 2.0);
    eprintln!(
        "2D jittered GIMP: {steps} steps, mean dt {:.4} h/c_p",
        mean * c / h
    );
    assert!(mean * c / h > 0.5);
    let s3 = solver([6, 6, 6], [1.0; 3], ShapeNd::BSpline2, 0.3, false, false);
    let h = s3.grid().h_min();
    let (steps, mean) = controlled_run(s3, 1.0);
    eprintln!(
        "3D uniform B-spline: {steps} steps, mean dt {:.4} h/c_p",
        mean * c / h
    );
    assert!(mean * c / h > 0.5);
}

/// The ordering of the critical steps on small 2D and 3D layouts: eq 56 (the stress part
/// of the step) ≤ the frozen-particle full map (velocity and stress) ≤ the empirical
/// blow-up step of real runs at amplitude 10⁻⁴ (4000 steps), to 0.3 %.
#[test]
fn eq56_full_map_and_empirical_steps_are_ordered_in_2d_and_3d() {
    fn check<const D: usize>(label: &str, s: &SolverNd<D>)
    where
        Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
    {
        let t = critical_table(s, Some((1e-4, 4000)));
        let full = t.dt_full_map.expect("small enough for the full map");
        let empirical = t.dt_empirical.expect("small enough for the bisection");
        eprintln!(
            "{label}: dt_eq56 {:.6}, full map {:.6}, empirical {:.6} (units h_min/c_p)",
            t.dt_eq56 / t.dt_sound,
            full / t.dt_sound,
            empirical / t.dt_sound
        );
        assert!(
            t.dt_eq56 <= full * (1.0 + 1e-6),
            "{label}: eq 56 above the full map"
        );
        assert!(
            full <= empirical * 1.003,
            "{label}: full map above the empirical step"
        );
    }
    check(
        "2D GIMP uniform",
        &solver([4, 4], [1.0; 2], ShapeNd::Gimp, 0.3, false, false),
    );
    check(
        "2D GIMP jittered",
        &solver([4, 4], [1.0; 2], ShapeNd::Gimp, 0.3, true, false),
    );
    check(
        "2D linear jittered",
        &solver([4, 4], [1.0; 2], ShapeNd::Linear, 0.3, true, false),
    );
    check(
        "2D B-spline, inclusion",
        &solver([4, 4], [1.0; 2], ShapeNd::BSpline2, 0.3, false, true),
    );
    check(
        "2D GIMP anisotropic",
        &solver([4, 4], [1.0, 0.5], ShapeNd::Gimp, 0.3, false, false),
    );
    // 3D at one particle per cell (the map's size grows as 9 unknowns a particle).
    let grid = GridNd::<3>::new([Boundary::Periodic; 3], [3; 3], [1.0; 3]);
    let mut particles = ParticlesNd::uniform(&grid, [1; 3], 1.0, material(0.3));
    jitter(&mut particles, 0.3, 12345);
    // (At one particle per cell uGIMP with its full-cell domain is the quadratic B-spline.)
    for shape in [ShapeNd::Gimp, ShapeNd::Linear] {
        let s =
            SolverNd::new(grid.clone(), shape, particles.clone(), Vector::<3>::zeros()).unwrap();
        check(&format!("3D {shape:?} jittered, 1 per cell"), &s);
    }
}

/// The 2D/3D stability limit built by hand checks its config like the 1D one: a field out
/// of its range is a typed error naming it.
#[test]
fn the_stability_limit_refuses_a_config_field_out_of_range() {
    use mpm_dt::config_error::ConfigError;
    use mpm_dt::limits_nd::{StabilityNd, StabilityNdConfig, TransferNd};
    assert!(StabilityNd::<2>::new(StabilityNdConfig::default()).is_ok());
    let cases: [(StabilityNdConfig, &str); 3] = [
        (
            StabilityNdConfig {
                safety: 1.5,
                ..Default::default()
            },
            "stability.safety",
        ),
        (
            StabilityNdConfig {
                refresh_cells: f64::NAN,
                ..Default::default()
            },
            "stability_nd.refresh_cells",
        ),
        (
            StabilityNdConfig {
                transfer: TransferNd::Apic { inertia: -0.25 },
                ..Default::default()
            },
            "stability_nd.transfer.apic.inertia",
        ),
    ];
    for (config, name) in cases {
        match StabilityNd::<3>::new(config) {
            Err(ConfigError::OutOfRange { field, .. }) => assert_eq!(field, name),
            other => panic!("{name}: {other:?}"),
        }
    }
}

/// The growth monitor's own energy (no summary handed over) weighs the stress with each
/// particle's moduli as the first view reported them: a later view reporting stiffer
/// tangent moduli for the same stress gives the same energy, where the view's own moduli
/// would give a lower one (module docs of `limits_nd::growth`).
#[test]
fn the_growth_monitor_keeps_the_moduli_of_its_first_view() {
    use mpm_dt::limits_nd::GrowthNd;
    use mpm_dt::nd::Tensor;
    use mpm_dt::StepLimit;
    let s = solver::<2>([4, 4], [1.0, 1.0], ShapeNd::Gimp, 0.3, false, false);
    let view = s.view();
    let n = view.n_particles();
    let sigma: Vec<Tensor<2>> = (0..n)
        .map(|p| Tensor::<2>::new(0.1 + 1e-3 * p as f64, 0.02, 0.02, -0.05))
        .collect();
    let lambda: Vec<f64> = view.lame_lambda.iter().map(|l| 2.0 * l).collect();
    let mu: Vec<f64> = view.lame_mu.iter().map(|m| 3.0 * m).collect();
    let first = ViewNd {
        sigma: &sigma,
        summary: None,
        ..view
    };
    let stiffer = ViewNd {
        lame_lambda: &lambda,
        lame_mu: &mu,
        ..first
    };
    let mut monitor = GrowthNd::<2>::new(Vector::<2>::zeros(), 25, 0.1);
    let own = monitor.energies(&stiffer);
    monitor.propose(&first).expect("no opinion");
    let kept = monitor.energies(&stiffer);
    assert_eq!(kept, monitor.energies(&first));
    assert!(
        kept.1 > 0.0 && own.1 < 0.5 * kept.1,
        "own {own:?}, kept {kept:?}"
    );
}
