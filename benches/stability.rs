//! One warm λmax update vs one reference solver step at 10⁵ particles (same run).
//!
//! `cargo bench --bench stability`. The groups measure, on a GIMP bar with 5·10⁴ cells and
//! two particles per cell after one step of a standing wave:
//!
//! * `solver_step` — one `try_step` of the reference solver (the trial is discarded);
//! * `operator_build` — building the eq 56 operator from the view (`O(n)`);
//! * `operator_apply` — one application of `B` (`O(nnz)`);
//! * `gershgorin_bound` — the `O(nnz)` rigorous upper bound on λmax;
//! * `nodal_build` — building the nodal form `C = M^{1/2} K_N M^{1/2}` from the view's `D`
//!   weights (one pass over the particles, reusing the allocations as `Stability` does);
//! * `nodal_apply` — one application of `C` (`O(5 n_nodes)`);
//! * `nodal_update_warm` — one warm Lanczos update on prebuilt nodal operators of two states
//!   one step apart (alternating, no periodic restart): the tracker's own cost;
//! * `nodal_rebuild_from_stepper_kn` — building `C`'s bands from the stepper's `K_N` (what an
//!   anchor does before its certificate);
//! * `certificate_ldlt` — one `LDLᵀ` inertia test of `μI − C` (the certificate);
//! * `pencil_prepare_from_stepper_kn`, `certificate_pencil` — the same test on the pencil
//!   `μ diag(m) − K_N` from the stepper's `K_N` (what an anchor runs: the bands prepared
//!   once, no operator build), its preparation and one test;
//! * `propose_*` — `Stability::propose` as the controller runs it (the stepper provides
//!   `K_N`), alternating between two states one step apart:
//!   `propose_lanczos_with_restarts` / `propose_lanczos_warm_only` — the Lanczos tracking of
//!   `Tracking::Lanczos(Refresh::every_step())` with and without the cold restart every 10
//!   updates (the previous default); `propose_certified` — the default certified tracking
//!   (a Rayleigh-quotient pass per proposal, an `LDLᵀ` certificate every 20: the mean
//!   per-step cost); `propose_certified_served_only` — the served pass alone (no
//!   certificate); `propose_certified_every_step` — a certificate at every proposal;
//!   `propose_certified_served_same_state` — the served pass on one state, repeatedly;
//!   `propose_certified_served_after_step` — the served pass on the state the solver's step
//!   (untimed) has just written, as in a run (criterion's thousands of steps let the mode
//!   localise: the long-run cost); `propose_certified_served_windowed_after_step` — the
//!   same on a fresh anchor's mode tapered to 512 nodes (`CertifiedConfig::localise`, the
//!   default: the cost early in a run); `propose_certified_served_dense_after_step` — the
//!   same with `localise` off, the anchor's Lanczos vector non-zero everywhere (the cost
//!   early in a run before round 8, and wherever a window is refused);
//!   `propose_certified_served_dense_in_cache` — the dense pass with its data in cache.
//!   These are the λmax update of issue 4's goal.
//!
//! It also prints, over 30 steps of the default `Stability`, the Lanczos applications and
//! the `LDLᵀ` factorisations of each proposal (the anchors), and a 400-step controlled run
//! (`controller_run`).
#![allow(missing_docs)]

#[path = "stability/timed.rs"]
mod timed;

use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkGroup, Criterion};
use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::mpm::{Material, ReferenceStepper};
use mpm_dt::problems::StandingWave;
use mpm_dt::stability::certificate::{below_shift, below_shift_pencil, Pencil};
use mpm_dt::stability::{
    CertifiedConfig, Eq56Operator, LambdaMaxTracker, LanczosConfig, NodalOperator, Refresh,
    Stability, StabilityConfig, SymmetricOperator, Tracking,
};
use mpm_dt::View;
use mpm_dt::{Boundary, Grid, Shape, StepLimit, Stepper};
use std::cell::RefCell;
use std::hint::black_box;
use std::rc::Rc;
use std::time::{Duration, Instant};
use timed::Timed;

fn bench(c: &mut Criterion) {
    let (mut s, grid, dt) = warmed_bar();
    let mut g = c.benchmark_group("stability_1e5");
    g.sample_size(20);
    g.bench_function("solver_step", |b| {
        b.iter(|| {
            s.try_step(black_box(dt)).expect("stable step");
            s.reject();
        })
    });
    let view = s.view();
    bench_operators(&mut g, &view, &grid);
    // Per-step cost in a run: a persistent limit proposing alternately for two states one
    // step apart (each proposal warm-started from the other state's eigenvector). With the
    // default settings this includes the periodic cold restarts (1 in 10 proposals); with
    // `restart_every = 0` it is the typical warm update.
    let mut s_next = s.clone();
    s_next.try_step(dt).expect("stable step");
    s_next.accept().expect("trial pending");
    let next = s_next.view();
    bench_nodal_update_warm(&mut g, &view, &next);
    // The limit as the controller runs it: the stepper provides K_N in its own pass, and
    // `Stability::propose` alternates between two states one step apart.
    let mut sk = s.clone();
    sk.provide_nodal_stiffness(true);
    // As the controller asks: the pass summary vouches for the nodal masses, which the
    // served pass then does not scan.
    sk.provide_summary(true);
    sk.try_step(dt).expect("stable step");
    sk.accept().expect("trial pending");
    let mut sk_next = sk.clone();
    sk_next.try_step(dt).expect("stable step");
    sk_next.accept().expect("trial pending");
    let (view_k, next_k) = (sk.view(), sk_next.view());
    assert!(view_k.nodal_stiffness.is_some() && next_k.nodal_stiffness.is_some());
    bench_stepper_kn(&mut g, &view_k);
    bench_propose(&mut g, &view_k, &next_k);
    bench_served_same_state(&mut g, &view_k);
    bench_served_fresh_anchor(&mut g, &sk, dt);
    bench_served_in_run(&mut g, &sk, dt);
    g.finish();
    controller_run(&s);
}

/// The benchmark group of [`bench`].
type Group<'a> = BenchmarkGroup<'a, WallTime>;

/// The GIMP bar of the module docs after a default `Stability` warmed over 5 steps (and
/// the print of its next 30 proposals): the stepper, its grid and the step.
fn warmed_bar() -> (ReferenceStepper, Grid, f64) {
    let cells = 50_000;
    let grid = Grid::new(Boundary::Periodic, cells, 1.0);
    let wave = StandingWave::new(0.01, 1.0, 1.0, 1.0, 1.0);
    let init = wave.uniform_particles(&grid, 2);
    let mut s = ReferenceStepper::new(
        grid.clone(),
        Shape::Gimp,
        Material::LinearElastic {
            youngs_modulus: 1.0,
        },
        init,
    )
    .expect("valid set-up");
    let dt = 0.5 * grid.h;
    // Warm the tracker over 5 steps, then move one more step.
    let mut limit = Stability::default();
    for _ in 0..5 {
        limit.propose(&s.view()).expect("valid state");
        s.try_step(dt).expect("stable step");
        s.accept().expect("trial pending");
    }
    print_default_stability(&limit, &s, dt);
    (s, grid, dt)
}

/// Prints the Lanczos applications and `LDLᵀ` factorisations of the default `Stability`
/// (a copy of `limit`) over 30 steps from `s`.
fn print_default_stability(limit: &Stability, s: &ReferenceStepper, dt: f64) {
    let mut l = limit.clone();
    let mut s2 = s.clone();
    let (mut apps, mut factorisations) = (Vec::new(), Vec::new());
    for _ in 0..30 {
        let p = l.propose(&s2.view()).expect("valid state");
        apps.push(p.metrics["lanczos_applications"] as usize);
        factorisations.push(p.metrics["lambda_factorisations"] as usize);
        s2.try_step(dt).expect("stable step");
        s2.accept().expect("trial pending");
    }
    eprintln!(
        "default Stability over 30 steps: Lanczos applications {apps:?}, \
         LDLᵀ factorisations {factorisations:?}"
    );
}

/// `operator_build`, `gershgorin_bound`, `operator_apply`, `nodal_build`,
/// `certificate_ldlt` and `nodal_apply` on `view`.
fn bench_operators(g: &mut Group<'_>, view: &View<'_>, grid: &Grid) {
    g.bench_function("operator_build", |b| {
        b.iter(|| black_box(Eq56Operator::new(view).expect("valid")))
    });
    let op = Eq56Operator::new(view).expect("valid");
    g.bench_function("gershgorin_bound", |b| {
        b.iter(|| black_box(op.gershgorin_bound()))
    });
    let x = vec![1.0; op.dim()];
    let mut y = vec![0.0; op.dim()];
    let mut work = vec![0.0; grid.n_nodes()];
    g.bench_function("operator_apply", |b| {
        b.iter(|| op.apply(black_box(&x), &mut y, &mut work))
    });
    let mut nodal = NodalOperator::new(view).expect("valid");
    g.bench_function("nodal_build", |b| {
        b.iter(|| nodal.rebuild(black_box(view)).expect("valid"))
    });
    {
        let lam = LambdaMaxTracker::default()
            .update(&nodal)
            .expect("valid")
            .lambda_b;
        // A certificate that fails stops at its first non-positive pivot: the bench must
        // time one that runs through, so the shift grows until it certifies.
        let (d, o) = nodal.bands();
        let mut lam = lam * 1.001;
        while !below_shift(d, o, nodal.is_periodic(), lam) {
            lam *= 1.001;
        }
        g.bench_function("certificate_ldlt", |b| {
            b.iter(|| black_box(nodal.eigenvalues_below(black_box(lam * 1.001))))
        });
    }
    let xn = vec![1.0; nodal.dim()];
    let mut yn = vec![0.0; nodal.dim()];
    let mut nwork = Vec::new();
    g.bench_function("nodal_apply", |b| {
        b.iter(|| nodal.apply(black_box(&xn), &mut yn, &mut nwork))
    });
}

/// `nodal_update_warm`: warm Lanczos updates alternating between the nodal operators of
/// `view` and `next`, one step apart.
fn bench_nodal_update_warm(g: &mut Group<'_>, view: &View<'_>, next: &View<'_>) {
    let ops = [
        NodalOperator::new(view).expect("valid"),
        NodalOperator::new(next).expect("valid"),
    ];
    let mut tracker = LambdaMaxTracker::new(LanczosConfig {
        restart_every: 0,
        ..LanczosConfig::default()
    })
    .expect("valid config");
    tracker.update(&ops[0]).expect("valid");
    let mut apps = Vec::new();
    for k in 1..=10 {
        apps.push(tracker.update(&ops[k % 2]).expect("valid").applications);
    }
    eprintln!("nodal warm updates alternating two states: applications {apps:?}");
    let mut k = 0;
    g.bench_function("nodal_update_warm", |b| {
        b.iter(|| {
            k += 1;
            black_box(tracker.update(&ops[k % 2]).expect("valid"))
        })
    });
}

/// `nodal_rebuild_from_stepper_kn`, `pencil_prepare_from_stepper_kn` and
/// `certificate_pencil` on `view_k`, whose stepper provided `K_N`.
fn bench_stepper_kn(g: &mut Group<'_>, view_k: &View<'_>) {
    let mut op = NodalOperator::new(view_k).expect("valid");
    g.bench_function("nodal_rebuild_from_stepper_kn", |b| {
        b.iter(|| op.rebuild(black_box(view_k)).expect("valid"))
    });
    let lam = LambdaMaxTracker::default()
        .update(&op)
        .expect("valid")
        .lambda_b;
    let k = view_k.nodal_stiffness.expect("provided");
    assert_eq!(
        below_shift_pencil(k, view_k.node_mass, view_k.node_active, true, lam * 1.001),
        Some(true)
    );
    let mut pencil = Pencil::default();
    assert!(pencil.prepare(k, view_k.node_mass, view_k.node_active, true));
    assert!(pencil.below_shift(lam * 1.001));
    g.bench_function("pencil_prepare_from_stepper_kn", |b| {
        b.iter(|| black_box(pencil.prepare(k, view_k.node_mass, view_k.node_active, true)))
    });
    g.bench_function("certificate_pencil", |b| {
        b.iter(|| black_box(pencil.below_shift(black_box(lam * 1.001))))
    });
}

/// The Lanczos tracking of `Tracking::Lanczos(Refresh::every_step())`, a cold restart every
/// `restart_every` updates (0: never).
fn lanczos(restart_every: usize) -> StabilityConfig {
    StabilityConfig {
        lanczos: LanczosConfig {
            restart_every,
            ..LanczosConfig::default()
        },
        tracking: Tracking::Lanczos(Refresh::every_step()),
        ..StabilityConfig::default()
    }
}

/// The certified tracking with a certificate every `certify_every` proposals.
fn certified(certify_every: u32) -> StabilityConfig {
    StabilityConfig {
        tracking: Tracking::Certified(CertifiedConfig {
            certify_every,
            ..CertifiedConfig::default()
        }),
        ..StabilityConfig::default()
    }
}

/// The `propose_lanczos_*` and `propose_certified*` groups alternating between `view_k` and
/// `next_k`, one step apart.
fn bench_propose(g: &mut Group<'_>, view_k: &View<'_>, next_k: &View<'_>) {
    for (name, config) in [
        ("propose_lanczos_with_restarts", lanczos(10)),
        ("propose_lanczos_warm_only", lanczos(0)),
        ("propose_certified", certified(20)),
        ("propose_certified_served_only", certified(u32::MAX)),
        ("propose_certified_every_step", certified(1)),
    ] {
        let mut l = Stability::new(config).expect("valid config");
        l.propose(view_k).expect("valid");
        l.propose(next_k).expect("valid");
        let mut toggle = false;
        g.bench_function(name, |b| {
            b.iter(|| {
                toggle = !toggle;
                black_box(
                    l.propose(if toggle { view_k } else { next_k })
                        .expect("valid"),
                )
            })
        });
    }
}

/// `propose_certified_served_same_state`: the served pass on `view_k` proposed repeatedly.
fn bench_served_same_state(g: &mut Group<'_>, view_k: &View<'_>) {
    // The served pass on one state proposed repeatedly (its data stays in cache), against
    // the alternating pair above (twice the data).
    let mut l = Stability::new(certified(u32::MAX)).expect("valid config");
    l.propose(view_k).expect("valid");
    g.bench_function("propose_certified_served_same_state", |b| {
        b.iter(|| black_box(l.propose(view_k).expect("valid")))
    });
}

/// `propose_certified_served_dense_after_step`, `…_windowed_after_step` and
/// `…_dense_in_cache`: the served pass from a fresh anchor on `sk`, one step of `dt` on.
fn bench_served_fresh_anchor(g: &mut Group<'_>, sk: &ReferenceStepper, dt: f64) {
    // A fresh anchor's mode: the limit just anchored (cold start) and a state one step
    // on, both copied for each sample (untimed, which also flushes the caches as a step
    // does). With `localise` off the mode is the anchor's Lanczos vector, non-zero
    // everywhere (as in a run's first ~100–300 steps before round 8, and still where a
    // window would lose more than `margin / 10` of its quotient); with it (the default)
    // it is tapered to 512 nodes.
    let start = sk.clone();
    let anchored = |localise| {
        let mut l = Stability::new(StabilityConfig {
            tracking: Tracking::Certified(CertifiedConfig {
                certify_every: u32::MAX,
                localise,
                ..CertifiedConfig::default()
            }),
            ..StabilityConfig::default()
        })
        .expect("valid config");
        l.propose(&start.view()).expect("valid");
        l
    };
    let (dense, windowed) = (anchored(false), anchored(true));
    for (name, fresh) in [
        ("propose_certified_served_dense_after_step", &dense),
        ("propose_certified_served_windowed_after_step", &windowed),
    ] {
        g.bench_function(name, |b| {
            b.iter_batched(
                || {
                    let mut next = start.clone();
                    next.try_step(dt).expect("stable step");
                    next.accept().expect("trial pending");
                    (fresh.clone(), next)
                },
                |(mut l, next)| {
                    let p = l.propose(&next.view()).expect("valid");
                    assert_eq!(p.metrics.get("lambda_factorisations"), Some(&0.0));
                    (l, next, p)
                },
                BatchSize::LargeInput,
            )
        });
    }
    // The dense pass with its data in cache: one stepped state, proposed on from a fresh
    // copy of the anchored limit each time (the pass's inputs, 2.5 MB, fit the L3 cache).
    let stepped = {
        let mut next = start.clone();
        next.try_step(dt).expect("stable step");
        next.accept().expect("trial pending");
        next
    };
    g.bench_function("propose_certified_served_dense_in_cache", |b| {
        b.iter_batched(
            || dense.clone(),
            |mut l| {
                let p = l.propose(&stepped.view()).expect("valid");
                assert_eq!(p.metrics.get("lambda_factorisations"), Some(&0.0));
                (l, p)
            },
            BatchSize::LargeInput,
        )
    });
}

/// `propose_certified_served_after_step`: the served pass on the states a run from `sk`
/// with steps of `dt` writes, the steps untimed.
fn bench_served_in_run(g: &mut Group<'_>, sk: &ReferenceStepper, dt: f64) {
    // The served pass as a run meets it: on the state the solver's step has just written
    // (its `K_N` and masses fresh from the pass, the mode out of cache), the step itself
    // untimed. Proposals that anchored (about 1 in 300 here: the quotient's drop trigger)
    // are stepped past and not counted: this is the served pass alone.
    let mut l = Stability::new(certified(u32::MAX)).expect("valid config");
    let mut run = sk.clone();
    l.propose(&run.view()).expect("valid");
    g.bench_function("propose_certified_served_after_step", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            let mut served = 0;
            while served < iters {
                run.try_step(dt).expect("stable step");
                run.accept().expect("trial pending");
                let start = Instant::now();
                let p = black_box(l.propose(&run.view()).expect("valid"));
                let elapsed = start.elapsed();
                if p.metrics.get("lambda_factorisations") == Some(&0.0) {
                    total += elapsed;
                    served += 1;
                }
            }
            total
        })
    });
}

/// The per-step cost of the default `Stability` limit in a real run — 400 controlled steps
/// of the 10⁵-particle standing wave, anchors and their fall-backs included — against the
/// bare solver step timed in the same process, interleaved (a bare step, 10 controlled
/// steps, …) so that both see the same machine load. Printed, not a criterion group: the
/// quantity is a mean over an evolving run, which criterion's repeated closure cannot give.
fn controller_run(start: &ReferenceStepper) {
    let steps = 400;
    let log = Rc::new(RefCell::new(Vec::with_capacity(steps)));
    let timed = Timed {
        inner: Stability::default(),
        log: Rc::clone(&log),
    };
    let mut controlled = start.clone();
    let mut controller =
        Controller::with_default_limits(ControllerConfig::default(), vec![Box::new(timed)])
            .expect("controller");
    let mut bare = start.clone();
    let dt = 0.5 * start.grid().h;
    let mut bare_time = Duration::ZERO;
    let mut bare_steps = 0;
    for k in 0..steps {
        if k % 10 == 0 {
            let t = Instant::now();
            bare.try_step(black_box(dt)).expect("stable step");
            bare_time += t.elapsed();
            bare.reject();
            bare_steps += 1;
        }
        controller
            .step(&mut controlled, f64::INFINITY)
            .expect("controlled step");
    }
    let log = log.borrow();
    // The first proposal is the cold start (a tight Lanczos from scratch): reported apart.
    let (cold, run) = log.split_first().expect("proposals");
    let bare_step = bare_time.as_secs_f64() / bare_steps as f64;
    let mean = |xs: &[&(Duration, f64, f64)]| {
        xs.iter().map(|x| x.0.as_secs_f64()).sum::<f64>() / xs.len().max(1) as f64
    };
    let served: Vec<_> = run.iter().filter(|x| x.1 == 0.0).collect();
    let pencil: Vec<_> = run.iter().filter(|x| x.1 > 0.0 && x.2 == 0.0).collect();
    let lanczos: Vec<_> = run.iter().filter(|x| x.2 > 0.0).collect();
    let all: Vec<_> = run.iter().collect();
    eprintln!(
        "controller run, 10⁵ particles, {} proposals after the cold start ({:.1} ms): \
         mean propose {:.0} µs = {:.3} of a bare solver step ({:.0} µs, {} timed); served \
         {} × {:.0} µs; anchors on the pencil alone {} × {:.0} µs; anchors with Lanczos {} × \
         {:.0} µs",
        run.len(),
        cold.0.as_secs_f64() * 1e3,
        mean(&all) * 1e6,
        mean(&all) / bare_step,
        bare_step * 1e6,
        bare_steps,
        served.len(),
        mean(&served) * 1e6,
        pencil.len(),
        mean(&pencil) * 1e6,
        lanczos.len(),
        mean(&lanczos) * 1e6,
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
