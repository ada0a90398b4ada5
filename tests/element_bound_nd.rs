//! Capability: the element bound `max_p λ_p` is an upper bound on the dense `λmax(M⁻¹K)`
//! on random small layouts of every shape in 2D and 3D (property test), it is within a
//! small factor of it on a uniform layout (the reference solver's own, from its weight
//! factors, at least the library's), and the stability limit steps on it only where
//! it is tight: the steps it proposes never exceed the frozen-particle limit it certifies.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig, Outcome};
use mpm_dt::limits_nd::element_bound::element_bound;
use mpm_dt::limits_nd::sound_speed::pass_unit_step;
use mpm_dt::limits_nd::stiffness::dense_lambda_max;
use mpm_dt::limits_nd::{StabilityNd, StabilityNdConfig, STABILITY};
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::reduce::SingleProcess;
use mpm_dt::sound_speed::SoundSpeed;
use mpm_dt::{Boundary, Dim, Dimension, Stepper, ViewNd};
use proptest::prelude::*;

#[path = "common/opt_in.rs"]
mod opt_in;
use opt_in::OptIn;

/// A jittered layout with seeded random velocities and moduli per particle.
fn layout<const D: usize>(
    cells: usize,
    shape: ShapeNd,
    boundary: Boundary,
    jitter: f64,
    poisson: f64,
    seed: u64,
) -> SolverNd<D> {
    let grid = GridNd::<D>::new([boundary; D], [cells; D], [1.0; D]);
    let material = MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: poisson,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1.0, material);
    let mut s = seed;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for p in 0..particles.len() {
        for a in 0..D {
            particles.x[p][a] += jitter * particles.domain[p][a] * next();
            particles.v[p][a] = 0.01 * next();
        }
    }
    SolverNd::new(grid, shape, particles, Vector::<D>::zeros()).unwrap()
}

/// `(bound, dense λmax)` of a layout; also checks that the bound the reference solver
/// hands over from its weight factors ([`mpm_dt::nd::factor_metric`]) is at least the
/// library's (it sums the whole stencil, inactive nodes included) and finite where the
/// library's is.
fn bound_and_dense<const D: usize>(s: &mut SolverNd<D>) -> (f64, f64)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    s.provide_summary(true);
    let view = s.view();
    let bound = element_bound(&view, &SingleProcess).lambda;
    let supplied = view
        .summary
        .and_then(|x| x.element_bound)
        .expect("supplied");
    assert!(
        supplied >= bound * (1.0 - 1e-12) && (supplied.is_finite() || bound.is_infinite()),
        "supplied bound {supplied:e} against the library's {bound:e}"
    );
    let dense = dense_lambda_max(&view).expect("dense eigenvalues");
    same_sound_step(&view);
    // After a step the solver hands over what its own step's pass accumulated.
    let dt = 0.1 * SoundSpeed::unit_step(&view).expect("a finite state");
    s.try_step(dt)
        .and_then(|_| s.accept())
        .expect("a small step");
    same_sound_step(&s.view());
    (bound, dense)
}

/// The speed-of-sound unit step the solver hands over is the library's, bit for bit.
fn same_sound_step<const D: usize>(view: &ViewNd<'_, D>) {
    let supplied = view
        .summary
        .and_then(|x| x.sound_unit_step)
        .expect("supplied");
    let library = pass_unit_step(view).expect("a finite state");
    assert_eq!(
        supplied.to_bits(),
        library.to_bits(),
        "{supplied:e} against {library:e}"
    );
}

fn shape_of(i: usize) -> ShapeNd {
    [ShapeNd::Gimp, ShapeNd::Linear, ShapeNd::BSpline2][i % 3]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn the_bound_is_above_the_dense_lambda_max_in_2d(
        seed in any::<u64>(),
        shape in 0usize..3,
        fixed in any::<bool>(),
        jitter in 0.0f64..0.45,
        poisson in 0.0f64..0.45,
    ) {
        let shape = shape_of(shape);
        // Quadratic B-splines run on periodic axes only.
        let boundary = if fixed && shape != ShapeNd::BSpline2 { Boundary::Fixed } else { Boundary::Periodic };
        let mut s = layout::<2>(5, shape, boundary, jitter, poisson, seed);
        let (bound, dense) = bound_and_dense(&mut s);
        prop_assert!(dense > 0.0);
        prop_assert!(bound >= dense * (1.0 - 1e-9), "{shape:?} {boundary:?}: bound {bound:e} < dense {dense:e}");
    }

    #[test]
    fn the_bound_is_above_the_dense_lambda_max_in_3d(
        seed in any::<u64>(),
        shape in 0usize..3,
        jitter in 0.0f64..0.45,
        poisson in 0.0f64..0.45,
    ) {
        let shape = shape_of(shape);
        let mut s = layout::<3>(3, shape, Boundary::Periodic, jitter, poisson, seed);
        let (bound, dense) = bound_and_dense(&mut s);
        prop_assert!(dense > 0.0);
        prop_assert!(bound >= dense * (1.0 - 1e-9), "{shape:?}: bound {bound:e} < dense {dense:e}");
    }
}

/// On uniform layouts the bound is within a small factor of the truth (it is not a
/// vacuous `+∞` or a far-off number), and GIMP's vanishing edge gradients do not make it
/// infinite.
#[test]
fn the_bound_is_finite_and_within_a_small_factor_on_uniform_layouts() {
    for shape in [ShapeNd::Gimp, ShapeNd::BSpline2] {
        let mut s = layout::<2>(6, shape, Boundary::Periodic, 0.0, 0.3, 1);
        let (bound, dense) = bound_and_dense(&mut s);
        let ratio = bound / dense;
        eprintln!("{shape:?}: bound / dense λmax = {ratio:.3}");
        // Measured (ν = 0.3): GIMP 3.33, quadratic B-splines 4.75 (the top mode spreads over
        // many particles; the bound is the largest single particle's).
        assert!(
            ratio.is_finite() && (1.0..6.0).contains(&ratio),
            "{shape:?}: bound / dense = {ratio}"
        );
    }
}

/// Under the controller, whatever the tracking did (Lanczos or the bound), no accepted
/// step of a moving jittered layout exceeds `√(2/λ_dense)` of its own state by more than
/// the Lanczos margin: the bound mode never oversteps the frozen-particle limit.
#[test]
fn controlled_steps_stay_below_the_frozen_particle_limit() {
    let mut s = layout::<2>(6, ShapeNd::BSpline2, Boundary::Periodic, 0.3, 0.3, 5);
    let config = ControllerConfig::default();
    let limits = standard_limits::<2>(&config, Vector::<2>::zeros());
    let mut controller = Controller::<2>::new(config, limits).unwrap();
    for _ in 0..40 {
        let dense = dense_lambda_max(&s.view()).unwrap();
        let decisions = controller.step(&mut s, 100.0).unwrap();
        let decision = decisions.last().unwrap();
        let limit = (2.0 / dense).sqrt();
        assert!(
            decision.dt <= 1.02 * limit,
            "step {} dt {} above the frozen limit {}",
            decision.step,
            decision.dt,
            limit
        );
    }
}

/// The accepted steps of a controlled run with the stability limit set by `stability`.
fn steps_of(
    stepper: &mut dyn Stepper<2>,
    stability: StabilityNdConfig,
    t_end: f64,
) -> (Vec<f64>, u64) {
    let config = ControllerConfig::default();
    let mut limits = standard_limits::<2>(&config, Vector::<2>::zeros());
    for limit in limits.iter_mut() {
        if limit.name() == STABILITY {
            *limit = Box::new(StabilityNd::<2>::new(stability.clone()).unwrap());
        }
    }
    let mut controller = Controller::<2>::new(config, limits).unwrap();
    let mut steps = Vec::new();
    let mut bound_proposals = 0;
    controller
        .run_until(stepper, t_end, &mut |d| {
            if d.outcome == Outcome::Accepted {
                steps.push(d.dt);
            }
            for l in d.limits.iter().filter(|l| l.name == STABILITY) {
                // Proposals on the raw bound or on the calibrated one.
                let of = |key: &str| l.metrics.get(key).copied().unwrap_or(0.0) as u64;
                bound_proposals =
                    bound_proposals.max(of("bound_proposals") + of("calibrated_proposals"));
            }
        })
        .unwrap();
    (steps, bound_proposals)
}

/// A stepper that supplies the bound from its pass takes exactly the generic path's steps
/// when the bound's numbers are the same and the policy is the same (`product_cost` 0);
/// with the default cost model it may step on the bound more often (fewer Lanczos runs,
/// shorter steps), never above the bound's own step.
#[test]
fn opting_in_takes_the_generic_paths_steps() {
    let safety = ControllerConfig::default().stability.unwrap().safety;
    let same_policy = StabilityNdConfig {
        safety,
        product_cost: 0.0,
        // Loose enough that this layout steps on the bound (its ratio is 2–3).
        bound_slack: 10.0,
        // The raw bound's policy: the calibrated one reads the motion guard on the
        // generic path only, so its steps differ by design (next test).
        bound_drift: -1.0,
        ..StabilityNdConfig::default()
    };
    let make = || layout::<2>(8, ShapeNd::Gimp, Boundary::Periodic, 0.3, 0.3, 11);
    let (generic, generic_bound) = steps_of(
        &mut OptIn {
            solver: make(),
            on: false,
        },
        same_policy.clone(),
        1.0,
    );
    let (opted, opted_bound) = steps_of(
        &mut OptIn {
            solver: make(),
            on: true,
        },
        same_policy,
        1.0,
    );
    assert!(
        generic_bound > 0,
        "the bound was never stepped on: the test is vacuous"
    );
    assert_eq!(generic_bound, opted_bound);
    assert_eq!(generic.len(), opted.len());
    for (a, b) in generic.iter().zip(&opted) {
        assert_eq!(a.to_bits(), b.to_bits(), "steps differ: {a} against {b}");
    }
}

/// Under the default policy (the calibrated bound) a stepper that supplies the bound and
/// one that does not take the same number of steps within 10 %, both mostly on the
/// calibrated bound: the generic path reads the motion guard and re-anchors it where the
/// opted-in one reads the bound every step, so their sequences differ by the bound's
/// drift margin, not more.
#[test]
fn opting_in_and_not_take_the_same_steps_within_the_drift() {
    let policy = StabilityNdConfig {
        safety: ControllerConfig::default().stability.unwrap().safety,
        ..StabilityNdConfig::default()
    };
    let make = || layout::<2>(8, ShapeNd::Gimp, Boundary::Periodic, 0.3, 0.3, 11);
    let mut runs = [false, true].map(|on| {
        let (steps, calibrated) = steps_of(&mut OptIn { solver: make(), on }, policy.clone(), 8.0);
        eprintln!(
            "opt-in {on}: {} steps, {calibrated} on the calibrated bound",
            steps.len()
        );
        assert!(
            calibrated * 2 > steps.len() as u64,
            "opt-in {on}: {calibrated} of {} steps on the calibrated bound",
            steps.len()
        );
        steps
    });
    let [generic, opted] = std::mem::take(&mut runs);
    let (n_g, n_o) = (generic.len() as f64, opted.len() as f64);
    assert!(
        (n_o - n_g).abs() <= 0.1 * n_g,
        "{n_o} steps opted in against {n_g} on the generic path"
    );
}

/// On the linear-hat layout with nearly empty nodes (`linear_small_mass_2d`), where the
/// bound is tight at the light node and the limit steps on it, no accepted step exceeds
/// the frozen-particle limit `√(2/λ_dense)` of the state it starts from.
#[test]
fn steps_on_the_light_node_layout_stay_below_the_frozen_particle_limit() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/nd/linear_small_mass_2d.json"
    );
    let sc = mpm_dt::nd::scenario::ScenarioNd::from_file(path).unwrap();
    let (mut s, _) = sc.build::<2>().unwrap();
    let config = sc.controller_config().unwrap();
    let limits = standard_limits::<2>(&config, Vector::<2>::zeros());
    let mut controller = Controller::<2>::new(config, limits).unwrap();
    let (mut worst, mut on_bound) = (0.0f64, 0.0);
    while s.time() < sc.t_end * (1.0 - 1e-12) {
        let dense = dense_lambda_max(&s.view()).unwrap();
        let decisions = controller.step(&mut s, sc.t_end).unwrap();
        let decision = decisions.last().unwrap();
        worst = worst.max(decision.dt / (2.0 / dense).sqrt());
        for l in decision.limits.iter().filter(|l| l.name == STABILITY) {
            // Steps on the raw bound or on the calibrated one (the default).
            let of = |key: &str| l.metrics.get(key).copied().unwrap_or(0.0);
            on_bound = f64::max(on_bound, of("bound_proposals") + of("calibrated_proposals"));
        }
    }
    eprintln!("largest step over the frozen limit: {worst:.4}; {on_bound} steps on the bound");
    assert!(
        on_bound > 0.0,
        "the bound was never stepped on: the test is vacuous"
    );
    assert!(worst <= 1.0, "a step {worst}× the frozen-particle limit");
}

/// Per proposal of an APIC stability limit driven along a jittered B-spline layout: the
/// running counts of Lanczos refreshes and of calibrated proposals, and the transfer gain
/// `1 + p` the proposal carries. From step
/// `fluid_from` on, particle 0 reports no shear stiffness (`μ_t = 0`); `summary`: the
/// stepper supplies the element bound (else the generic path).
fn apic_counts(fluid_from: usize, summary: bool, steps: usize) -> Vec<(f64, f64, f64)> {
    use mpm_dt::limits_nd::TransferNd;
    use mpm_dt::StepLimit;
    let config = StabilityNdConfig {
        transfer: TransferNd::Apic { inertia: 0.25 },
        // A refresh every 10 proposals at most: the fluid check runs at refreshes.
        max_age: 10,
        ..StabilityNdConfig::default()
    };
    let mut s = layout::<2>(8, ShapeNd::BSpline2, Boundary::Periodic, 0.3, 0.3, 11);
    s.provide_summary(summary);
    let mut limit = StabilityNd::<2>::new(config).unwrap();
    let (mut refreshes, mut calibrated) = (0.0, 0.0);
    let mut counts = Vec::new();
    for step in 0..steps {
        let view = s.view();
        let mut mu = view.lame_mu.to_vec();
        if step >= fluid_from {
            mu[0] = 0.0;
        }
        let view = ViewNd {
            lame_mu: &mu,
            ..view
        };
        let proposal = limit.propose(&view).expect("a proposal");
        let of = |key: &str, last: f64| proposal.metrics.get(key).copied().unwrap_or(last);
        refreshes = of("refreshes", refreshes);
        calibrated = of("calibrated_proposals", calibrated);
        counts.push((refreshes, calibrated, of("transfer_gain", f64::NAN)));
        s.try_step(0.5 * proposal.dt)
            .and_then(|_| s.accept())
            .expect("a stable step");
    }
    counts
}

/// Under APIC the calibrated bound serves a solid (every particle with shear stiffness)
/// and never a layout with one particle without it (a fluid), which keeps the raw-bound
/// policy from its first refresh on; a solid that turns fluid mid-run stops calibrating
/// at the next refresh, for good, on either path (`limits_nd::bound_tracking`, "Under
/// APIC").
#[test]
fn under_apic_the_calibrated_bound_serves_solids_only() {
    let solid = apic_counts(usize::MAX, true, 30).last().unwrap().1;
    assert!(
        solid >= 20.0,
        "{solid} of 30 proposals calibrated on a solid"
    );
    let fluid = apic_counts(0, true, 30).last().unwrap().1;
    assert!(
        fluid < 0.5,
        "{fluid} proposals calibrated with a fluid particle"
    );
    for summary in [true, false] {
        let counts = apic_counts(20, summary, 90);
        assert!(counts[19].1 >= 10.0, "solid phase: {:?}", counts[19]);
        // The first refresh at or after the switch, and no calibrated proposal after it.
        let at = (20..counts.len())
            .find(|&k| counts[k].0 > counts[k - 1].0)
            .unwrap_or_else(|| panic!("no refresh after the switch: {counts:?}"));
        let last = counts.last().unwrap();
        assert_eq!(
            last.1.to_bits(),
            counts[at].1.to_bits(),
            "summary {summary}: calibrated proposals after the refresh at {at}: {counts:?}"
        );
        assert!(last.0 > counts[19].0);
    }
}

/// Under APIC the transfer's gain `1 + p` lifts a solid's step and not a fluid's: from the
/// first refresh that meets a particle without shear stiffness on, the proposals carry
/// gain 1 (eq 56 itself; `limits_nd::bound_tracking`, "Under APIC", measured on the mpm88
/// fluid, which the gain took above its failure step).
#[test]
fn under_apic_the_transfer_gain_lifts_solids_only() {
    let solid = apic_counts(usize::MAX, true, 30);
    assert!(
        solid.iter().all(|c| c.2 > 1.01),
        "a solid's gains: {solid:?}"
    );
    let fluid = apic_counts(0, true, 30);
    assert!(
        fluid.iter().all(|c| c.2.to_bits() == 1f64.to_bits()),
        "a fluid's gains: {fluid:?}"
    );
    let switch = apic_counts(20, true, 60);
    let at = (20..switch.len())
        .find(|&k| switch[k].0 > switch[k - 1].0)
        .unwrap_or_else(|| panic!("no refresh after the switch: {switch:?}"));
    assert!(switch[..20].iter().all(|c| c.2 > 1.01));
    assert!(
        switch[at..].iter().all(|c| c.2.to_bits() == 1f64.to_bits()),
        "{switch:?}"
    );
}
