//! The reference solver on threads ([`SolverNd::set_threads`]): the same state, bit for bit,
//! on 1, 2 and 3 threads; within round-off of the unthreaded solver; a failed threaded
//! step names the same particle and leaves the state as it was; and under the controller
//! the same decisions on any number of threads.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::{Boundary, Dim, Dimension, Stepper, ViewNd};

/// A jittered, sheared block under gravity filling the grid (seeded): several chunks of
/// particles and many slabs, so that every phase of the threaded step runs in parallel.
fn solver<const D: usize>(
    shape: ShapeNd,
    boundary: Boundary,
    material: MaterialNd,
    cells: usize,
) -> SolverNd<D> {
    let grid = GridNd::<D>::new([boundary; D], [cells; D], [1.0; D]);
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1000.0, material);
    let mut seed = 0x5eed_u64;
    let mut jitter = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.2 / cells as f64
    };
    for p in 0..particles.len() {
        let x = particles.x[p];
        for a in 0..D {
            particles.x[p][a] += jitter();
        }
        particles.v[p][0] = 0.5 * (x[D - 1] - 0.5);
        particles.v[p][D - 1] = -0.3 * (x[0] - 0.5) + 20.0 * jitter();
    }
    let mut gravity = Vector::<D>::zeros();
    gravity[D - 1] = -9.8;
    SolverNd::new(grid, shape, particles, gravity).expect("a valid set-up")
}

/// Every particle and nodal value of the committed state, as bits.
fn bits<const D: usize>(s: &SolverNd<D>) -> Vec<u64>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let v = s.view();
    let mut out = vec![v.t.to_bits()];
    for p in 0..v.x.len() {
        out.extend(v.x[p].iter().chain(&v.v[p]).map(|c| c.to_bits()));
        out.extend(v.sigma[p].iter().chain(v.f[p].iter()).map(|c| c.to_bits()));
        out.extend([v.density[p], v.lame_lambda[p], v.lame_mu[p]].map(f64::to_bits));
    }
    out.extend(v.node_mass.iter().map(|m| m.to_bits()));
    for i in 0..v.node_mass.len() {
        out.extend(v.node_velocity[i].iter().map(|c| c.to_bits()));
        out.extend(v.node_acceleration[i].iter().map(|c| c.to_bits()));
        out.push(u64::from(v.node_active[i]));
    }
    if let Some(sum) = v.summary {
        out.extend([sum.kinetic, sum.strain].map(f64::to_bits));
        out.extend(sum.first_moment.iter().map(|c| c.to_bits()));
        out.extend([sum.element_bound, sum.sound_unit_step].map(|b| b.map_or(1, f64::to_bits)));
    }
    out
}

/// The largest difference between two states' positions and velocities, relative to the
/// largest value.
fn relative_difference<const D: usize>(a: &SolverNd<D>, b: &SolverNd<D>) -> f64
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let (a, b) = (a.view(), b.view());
    let mut worst: f64 = 0.0;
    for (fa, fb) in [(a.x, b.x), (a.v, b.v)] {
        let scale = fa.iter().map(|x| x.amax()).fold(0.0, f64::max);
        for (p, q) in fa.iter().zip(fb) {
            worst = worst.max((p - q).amax() / scale);
        }
    }
    worst
}

fn steps<const D: usize>(s: &mut SolverNd<D>, n: usize, dt: f64)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    for _ in 0..n {
        s.try_step(dt).expect("a stable step");
        s.accept().expect("accepted");
    }
}

const NEO_HOOKEAN: MaterialNd = MaterialNd::NeoHookean {
    youngs_modulus: 1e5,
    poisson_ratio: 0.3,
};
const LINEAR: MaterialNd = MaterialNd::LinearElastic {
    youngs_modulus: 1e5,
    poisson_ratio: 0.3,
};

/// Runs `cases` on 1, 2 and 3 threads and unthreaded: the threaded states are the same
/// bit for bit, and within `1e-10` of the unthreaded one.
fn same_on_any_number_of_threads<const D: usize>(
    cells: usize,
    cases: &[(ShapeNd, Boundary, MaterialNd)],
) where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    for &(shape, boundary, material) in cases {
        let make = |threads: Option<usize>, summarize: bool| {
            let mut s = solver::<D>(shape, boundary, material, cells);
            s.set_threads(threads).expect("a thread pool");
            s.provide_summary(summarize);
            s
        };
        // 0.3 of the sound-speed step h/c_p (ρ = 1000, E = 1e5, ν = 0.3).
        let dt = 0.3 / cells as f64 / (1.35e5_f64 / 1000.0).sqrt();
        for summarize in [false, true] {
            let mut plain = make(None, summarize);
            steps(&mut plain, 12, dt);
            let mut first: Option<SolverNd<D>> = None;
            for threads in [1, 2, 3] {
                let mut s = make(Some(threads), summarize);
                assert_eq!(s.threads(), threads);
                steps(&mut s, 12, dt);
                match &first {
                    None => first = Some(s),
                    Some(one) => assert!(
                        bits(one) == bits(&s),
                        "{D}D {shape:?} {boundary:?}: {threads} threads differ from 1"
                    ),
                }
            }
            let one = first.expect("a threaded run");
            let diff = relative_difference(&one, &plain);
            assert!(
                diff <= 1e-10,
                "{D}D {shape:?} {boundary:?}: {diff:e} from unthreaded"
            );
        }
    }
}

#[test]
fn a_2d_run_is_the_same_on_any_number_of_threads() {
    same_on_any_number_of_threads::<2>(
        48,
        &[
            (ShapeNd::Gimp, Boundary::Fixed, NEO_HOOKEAN),
            (ShapeNd::BSpline2, Boundary::Periodic, LINEAR),
            (ShapeNd::Linear, Boundary::Periodic, NEO_HOOKEAN),
        ],
    );
}

#[test]
fn a_3d_run_is_the_same_on_any_number_of_threads() {
    same_on_any_number_of_threads::<3>(
        14,
        &[
            (ShapeNd::Gimp, Boundary::Fixed, LINEAR),
            (ShapeNd::BSpline2, Boundary::Periodic, NEO_HOOKEAN),
        ],
    );
}

/// A step too large for the layout fails on threads as it does on one: the same error
/// (the lowest-numbered particle), and the committed state is untouched bit for bit.
#[test]
fn a_failed_threaded_step_names_the_same_particle_and_restores_the_state() {
    let mut errors = Vec::new();
    for threads in [None, Some(1), Some(2)] {
        let mut s = solver::<2>(ShapeNd::Gimp, Boundary::Fixed, NEO_HOOKEAN, 48);
        s.set_threads(threads).expect("a thread pool");
        steps(&mut s, 3, 1e-4);
        let before = bits(&s);
        let err = s.try_step(5.0).expect_err("a step of 5 s leaves the box");
        s.reject();
        assert_eq!(bits(&s), before, "{threads:?}");
        errors.push(err.to_string());
    }
    assert!(errors.windows(2).all(|w| w[0] == w[1]), "{errors:?}");
}

/// Under the controller a threaded solver takes the same steps on 1 and 2 threads, with
/// the limits' passes on 1 or 2 threads of their own: the same steps and temporal errors
/// (`dsm`) bit for bit. With the limits on the calling thread the temporal error's sums
/// are taken in one chunk instead of two, so `dsm` and the steps agree to round-off.
#[test]
fn the_controller_takes_the_same_steps_on_one_and_two_threads() {
    let mut runs = Vec::new();
    for (solver_threads, limit_threads) in [(1, Some(1)), (2, Some(2)), (1, None)] {
        // 48² cells, 9 216 particles: the layout guard's and the temporal error's passes
        // run in two ranges.
        let mut s = solver::<2>(ShapeNd::Gimp, Boundary::Fixed, NEO_HOOKEAN, 48);
        s.set_threads(Some(solver_threads)).expect("a thread pool");
        let config = ControllerConfig::default();
        let limits = standard_limits::<2>(&config, Vector::<2>::from([0.0, -9.8]));
        let mut c = Controller::<2>::new(config, limits)
            .and_then(|c| c.with_threads(limit_threads))
            .expect("a controller");
        let mut taken = Vec::new();
        for _ in 0..20 {
            let decisions = c.step(&mut s, 1.0).expect("an accepted step");
            taken.extend(decisions.iter().map(|d| (d.dt, d.dsm)));
        }
        runs.push(taken);
    }
    let bits = |run: &[(f64, Option<f64>)]| -> Vec<(u64, Option<u64>)> {
        run.iter()
            .map(|(dt, dsm)| (dt.to_bits(), dsm.map(f64::to_bits)))
            .collect()
    };
    assert!(runs[0].len() >= 20);
    assert!(runs[0].iter().filter(|(_, dsm)| dsm.is_some()).count() >= 10);
    assert_eq!(bits(&runs[0]), bits(&runs[1]));
    assert_eq!(runs[0].len(), runs[2].len());
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
    for ((dt1, dsm1), (dt0, dsm0)) in runs[0].iter().zip(&runs[2]) {
        assert!(close(*dt1, *dt0), "step {dt1} against {dt0}");
        match (dsm1, dsm0) {
            (Some(a), Some(b)) => assert!(close(*a, *b), "dsm {a} against {b}"),
            (a, b) => assert_eq!(a.is_some(), b.is_some()),
        }
    }
}
