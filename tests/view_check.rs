//! Capability: the view checked at the door. Each misuse a user's 2D solver can make of its
//! view — an array one element short, a grid of another size than the arrays, weights that
//! are not a partition of unity, gradients missing their `1/h`, a NaN in the initial state
//! — ends the controller's run at once with a typed `ControllerError::InvalidView` naming
//! the array, the particle or node and the value: no panic, no silent run. Valid views
//! (periodic, walls, 3D, a decomposed grid) pass.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig, ControllerError};
use mpm_dt::limit::StepLimit;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::{GridNd, SolverNd, Vector, WeightsNd};
use mpm_dt::sound_speed::{SoundSpeed, SoundSpeedConfig};
use mpm_dt::{StepError, Stepper, ViewError, ViewNd};
use proptest::prelude::*;

/// A misuse of the view, applied to the committed view a solver hands over.
#[derive(Clone, Copy, Debug)]
enum Misuse {
    /// The array at this position of [`ARRAYS`] has its last `cut` elements left out.
    Truncate(usize, usize),
    /// The grid has one more cell along axis 0 than the arrays were built for.
    GridOneCellBigger,
    /// Every weight halved: rows sum to 0.5.
    HalfWeights,
    /// Gradients in cell coordinates (multiplied by `h`: the `1/h` missing).
    GradientsWithoutInverseH,
    /// Particle `p`'s velocity is NaN.
    NanVelocity(usize),
}

/// The arrays a truncation can hit, in the order of [`Misuse::Truncate`].
const ARRAYS: [&str; 14] = [
    "x",
    "v",
    "sigma",
    "F",
    "volume0",
    "mass",
    "lame_lambda",
    "lame_mu",
    "density",
    "node_mass",
    "node_velocity",
    "node_acceleration",
    "node_active",
    "weights",
];

/// A 2D solver whose committed view carries one misuse (its trials are the inner
/// solver's own: a controller that let the misuse through would run on).
struct Tampered {
    inner: SolverNd<2>,
    misuse: Misuse,
    grid: GridNd<2>,
    weights: WeightsNd<2>,
    v: Vec<Vector<2>>,
}

impl Tampered {
    fn new(inner: SolverNd<2>, misuse: Misuse) -> Self {
        let view = inner.view();
        let mut grid = view.grid.clone();
        grid.cells[0] += 1;
        let w = view.weights.to_stored();
        let n = w.n_particles();
        let h = view.grid.h[0];
        let rows = |n: usize, f: &dyn Fn(usize, usize) -> (f64, Vector<2>)| {
            let nodes: Vec<u32> = (0..n).flat_map(|p| w.nodes_of(p).to_vec()).collect();
            let (s, g): (Vec<f64>, Vec<Vector<2>>) = (0..n)
                .flat_map(|p| (0..w.width()).map(move |k| (p, k)))
                .map(|(p, k)| f(p, k))
                .unzip();
            WeightsNd::from_rows(w.n_nodes(), w.width(), nodes, s, g).expect("rows")
        };
        let weights = match misuse {
            Misuse::HalfWeights => rows(n, &|p, k| (0.5 * w.s_of(p)[k], w.grad_of(p)[k])),
            Misuse::GradientsWithoutInverseH => {
                rows(n, &|p, k| (w.s_of(p)[k], h * w.grad_of(p)[k]))
            }
            // The last `k` particles' rows left out.
            Misuse::Truncate(which, k) if ARRAYS[which] == "weights" => {
                rows(n.saturating_sub(k), &|p, k| (w.s_of(p)[k], w.grad_of(p)[k]))
            }
            _ => w.clone(),
        };
        let mut v = view.v.to_vec();
        if let Misuse::NanVelocity(p) = misuse {
            v[p][1] = f64::NAN;
        }
        Self {
            inner,
            misuse,
            grid,
            weights,
            v,
        }
    }
}

/// `s` without its last `cut` elements.
fn cut<T>(s: &[T], cut: usize) -> &[T] {
    &s[..s.len().saturating_sub(cut)]
}

impl Stepper<2> for Tampered {
    fn time(&self) -> f64 {
        self.inner.time()
    }
    fn step_count(&self) -> u64 {
        self.inner.step_count()
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.inner.try_step(dt)
    }
    fn accept(&mut self) -> Result<(), StepError> {
        self.inner.accept()
    }
    fn reject(&mut self) {
        self.inner.reject()
    }
    fn view(&self) -> ViewNd<'_, 2> {
        let view = self.inner.view();
        match self.misuse {
            Misuse::Truncate(which, k) => {
                let mut t = view;
                match ARRAYS[which] {
                    "x" => t.x = cut(view.x, k),
                    "v" => t.v = cut(view.v, k),
                    "sigma" => t.sigma = cut(view.sigma, k),
                    "F" => t.f = cut(view.f, k),
                    "volume0" => t.volume0 = cut(view.volume0, k),
                    "mass" => t.mass = cut(view.mass, k),
                    "lame_lambda" => t.lame_lambda = cut(view.lame_lambda, k),
                    "lame_mu" => t.lame_mu = cut(view.lame_mu, k),
                    "density" => t.density = cut(view.density, k),
                    "node_mass" => t.node_mass = cut(view.node_mass, k),
                    "node_velocity" => t.node_velocity = cut(view.node_velocity, k),
                    "node_acceleration" => t.node_acceleration = cut(view.node_acceleration, k),
                    "node_active" => t.node_active = cut(view.node_active, k),
                    "weights" => t.weights = (&self.weights).into(),
                    other => unreachable!("{other}"),
                }
                t
            }
            Misuse::GridOneCellBigger => ViewNd {
                grid: &self.grid,
                ..view
            },
            Misuse::HalfWeights | Misuse::GradientsWithoutInverseH => ViewNd {
                weights: (&self.weights).into(),
                ..view
            },
            Misuse::NanVelocity(_) => ViewNd {
                v: &self.v,
                summary: None,
                ..view
            },
        }
    }
    fn trial_view(&self) -> Option<ViewNd<'_, 2>> {
        self.inner.trial_view()
    }
}

fn scenario(name: &str) -> ScenarioNd {
    ScenarioNd::from_file(format!(
        "{}/scenarios/nd/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .expect("scenario")
}

/// A periodic 2D plane wave (16² cells, GIMP) with a misuse.
fn tampered(misuse: Misuse) -> Tampered {
    let (solver, _) = scenario("plane_p_2d.json").build::<2>().expect("solver");
    Tampered::new(solver, misuse)
}

/// Runs the standard 2D controller (or `limits`) on `s` and returns the error it ends
/// with, checking that it ended before any attempt and at the initial state.
fn door_error(s: &mut Tampered, limits: Option<Vec<Box<dyn StepLimit<2>>>>) -> ViewError {
    let config = ControllerConfig::default();
    let limits = limits.unwrap_or_else(|| standard_limits(&config, Vector::<2>::zeros()));
    let mut c = Controller::<2>::new(config, limits).expect("controller");
    let mut attempts = 0;
    let err = c
        .run_until(s, 0.5, &mut |_| attempts += 1)
        .expect_err("a misused view must end the run");
    assert_eq!(attempts, 0, "ended before the first trial: {err}");
    assert_eq!(s.step_count(), 0);
    match err {
        ControllerError::InvalidView {
            t,
            step,
            trial,
            source,
        } => {
            assert_eq!((t.to_bits(), step, trial), (0.0f64.to_bits(), 0, false));
            source
        }
        e => panic!("expected InvalidView, got {e}"),
    }
}

#[test]
fn lame_mu_one_short_is_named_not_a_panic() {
    let mut s = tampered(Misuse::Truncate(7, 1));
    let n = s.inner.view().n_particles();
    let e = door_error(&mut s, None);
    assert_eq!(
        e,
        ViewError::Length {
            array: "lame_mu",
            len: n - 1,
            expected: n,
            count: "particles"
        }
    );
    assert!(e.to_string().contains("lame_mu has length"), "{e}");
}

#[test]
fn mass_one_short_is_named_not_a_panic() {
    let mut s = tampered(Misuse::Truncate(5, 1));
    let n = s.inner.view().n_particles();
    let e = door_error(&mut s, None);
    assert!(
        matches!(e, ViewError::Length { array: "mass", len, .. } if len == n - 1),
        "{e}"
    );
}

#[test]
fn x_one_short_is_named_without_the_temporal_limit() {
    let mut s = tampered(Misuse::Truncate(0, 1));
    // Only the sound-speed limit, which reads `x` nowhere.
    let e = door_error(
        &mut s,
        Some(vec![Box::new(
            SoundSpeed::new(SoundSpeedConfig { alpha: 0.5 }).unwrap(),
        )]),
    );
    assert_eq!(e.array(), "x", "{e}");
}

#[test]
fn a_grid_one_cell_bigger_than_the_arrays_is_named() {
    let mut s = tampered(Misuse::GridOneCellBigger);
    let nodes = s.inner.view().n_nodes();
    let e = door_error(&mut s, None);
    // 16 × 16 periodic nodes; the grid says 17 × 16.
    assert_eq!(
        e,
        ViewError::Grid {
            grid_nodes: 17 * 16,
            array_nodes: nodes,
            cells: vec![17, 16]
        }
    );
}

#[test]
fn weight_rows_summing_to_one_half_are_refused() {
    let mut s = tampered(Misuse::HalfWeights);
    let e = door_error(&mut s, None);
    let ViewError::PartitionOfUnity { particle, sum } = e else {
        panic!("{e}");
    };
    assert_eq!(particle, 0);
    assert!((sum - 0.5).abs() < 1e-12, "{sum}");
}

#[test]
fn gradients_missing_their_inverse_h_are_refused() {
    let mut s = tampered(Misuse::GradientsWithoutInverseH);
    let h = s.inner.view().grid.h[0];
    let e = door_error(&mut s, None);
    let ViewError::GradientMoment {
        particle,
        row,
        col,
        value,
        expected,
    } = e
    else {
        panic!("{e}");
    };
    // Σ_i (X_i − x_p) ⊗ ∇S_ip = h I instead of I.
    assert_eq!((particle, row, col), (0, 0, 0));
    assert_eq!(expected.to_bits(), 1.0f64.to_bits());
    assert!((value - h).abs() < 1e-9 * h.max(1.0), "{value} vs h = {h}");
    assert!(e.to_string().contains("missing a 1/h"), "{e}");
}

#[test]
fn a_nan_velocity_at_t0_is_named_at_once() {
    let mut s = tampered(Misuse::NanVelocity(11));
    let e = door_error(&mut s, None);
    let ViewError::NonFinite {
        array,
        index,
        value,
    } = e
    else {
        panic!("{e}");
    };
    assert_eq!((array, index), ("v", 11));
    assert!(value.is_nan());
    assert!(e.to_string().contains("non-finite v at particle 11"), "{e}");
}

/// Every shipped 2D/3D kind of view passes: periodic and walled, GIMP, linear and
/// quadratic B-spline, 3D, neo-Hookean disks after some steps.
#[test]
fn valid_views_pass() {
    for name in [
        "plane_p_2d.json",
        "jittered_2d.json",
        "periodic_disks_2d.json",
        "colliding_disks.json",
        "linear_small_mass_2d.json",
        "inclusion_2d.json",
        "anisotropic_2d.json",
    ] {
        let sc = scenario(name);
        let (mut s, _) = sc.build::<2>().expect("solver");
        s.view().check().unwrap_or_else(|e| panic!("{name}: {e}"));
        let gravity = sc
            .gravity
            .as_deref()
            .map_or_else(Vector::<2>::zeros, Vector::<2>::from_column_slice);
        let config = ControllerConfig::default();
        let mut c = Controller::<2>::new(config.clone(), standard_limits(&config, gravity))
            .expect("controller");
        for _ in 0..5 {
            c.step(&mut s, 10.0)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            s.view().check().unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
    // The views of a grid-decomposed solver (window, global node map, particle ids) on
    // one process, across a periodic axis and between walls.
    for name in ["periodic_disks_2d.json", "colliding_disks.json"] {
        let reduce = std::rc::Rc::new(mpm_dt::reduce::SingleProcess);
        let (mut s, _) = scenario(name).build_slab::<2>(reduce).expect("solver");
        assert!(s.view().split.is_some(), "{name}: a split view");
        for _ in 0..3 {
            s.view()
                .check()
                .unwrap_or_else(|e| panic!("{name} (slab): {e}"));
            s.try_step(1e-3).expect("trial");
            s.accept().expect("accept");
        }
    }
    for name in ["colliding_spheres.json", "plane_s_3d_bspline.json"] {
        let (s, _) = scenario(name).build::<3>().expect("solver");
        s.view().check().unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Truncating any array of a valid view by any number of elements is a typed error
    /// naming that array: no panic, no run on it.
    #[test]
    fn a_truncated_array_is_named(which in 0..ARRAYS.len(), k in 1usize..40) {
        let mut s = tampered(Misuse::Truncate(which, k));
        let e = door_error(&mut s, None);
        let particles = which < 9 || ARRAYS[which] == "weights";
        let full = if particles { s.inner.view().n_particles() } else { s.inner.view().n_nodes() };
        prop_assert_eq!(e.array(), ARRAYS[which], "{}", e);
        let ViewError::Length { len, expected, .. } = e else {
            return Err(TestCaseError::fail(format!("not a length error: {e}")));
        };
        prop_assert_eq!((len, expected), (full - k, full));
    }
}

/// MLS-MPM's effective gradients `∇S_ip = (4/h²) S_ip (X_i − x_p)` of a quadratic B-spline
/// satisfy the identities, also for stencils that wrap around a periodic box (node offsets
/// by minimum image); with `4/h` instead of `4/h²` they are refused.
#[test]
fn mls_gradients_pass_also_across_a_periodic_boundary() {
    let (solver, _) = scenario("plane_p_2d.json").build::<2>().expect("solver");
    let view = solver.view();
    let grid = view.grid;
    let h = grid.h[0];
    let l = grid.length(0);
    // Every particle moved by 0.37 h and wrapped: many stencils straddle x = 0 or y = 0.
    let x: Vec<Vector<2>> = view
        .x
        .iter()
        .map(|x| x.map(|c| (c + 0.37 * h).rem_euclid(l)))
        .collect();
    let rows = |inv: f64| {
        let (mut nodes, mut s, mut g) = (vec![], vec![], vec![]);
        for xp in &x {
            let base = xp.map(|c| (c / h - 0.5).floor());
            for b in 0..3 {
                for a in 0..3 {
                    let j = [base[0] as i64 + a, base[1] as i64 + b];
                    let node = Vector::<2>::new(j[0] as f64 * h, j[1] as f64 * h);
                    let d = node - xp;
                    let w1 = |r: f64| match r.abs() / h {
                        q if q < 0.5 => 0.75 - q * q,
                        q if q < 1.5 => 0.5 * (1.5 - q).powi(2),
                        _ => 0.0,
                    };
                    let w = w1(d[0]) * w1(d[1]);
                    nodes.push(grid.flat_index(j).expect("periodic") as u32);
                    s.push(w);
                    g.push(inv * w * d);
                }
            }
        }
        WeightsNd::from_rows(grid.n_nodes(), 9, nodes, s, g).expect("rows")
    };
    let mls = rows(4.0 / (h * h));
    let moved = ViewNd {
        x: &x,
        weights: (&mls).into(),
        summary: None,
        ..view
    };
    moved.check().expect("MLS gradients are complete");
    let wrong = rows(4.0 / h);
    let e = ViewNd {
        weights: (&wrong).into(),
        ..moved
    }
    .check()
    .unwrap_err();
    assert!(
        matches!(e, ViewError::GradientMoment { value, .. } if (value - h).abs() < 1e-9),
        "{e}"
    );
}

/// Weight rows a solver filled in place (`WeightsNd::storage_mut`, unchecked): a node index
/// past the grid and a NaN weight are named with their particle.
#[test]
fn rows_filled_in_place_are_checked() {
    let (solver, _) = scenario("plane_p_2d.json").build::<2>().expect("solver");
    let view = solver.view();
    let n = view.n_particles();
    let mut w = view.weights.to_stored();
    let (nodes, s, _) = w.storage_mut(n);
    let kept = nodes[9 * 7 + 2];
    nodes[9 * 7 + 2] = view.n_nodes() as u32;
    s[9 * 11 + 4] = f64::NAN;
    let e = ViewNd {
        weights: (&w).into(),
        ..view
    }
    .check()
    .unwrap_err();
    assert!(
        matches!(e, ViewError::NodeOutOfRange { array: "weights.nodes", index: 7, node, .. } if node == view.n_nodes()),
        "{e}"
    );
    let (nodes, _, _) = w.storage_mut(n);
    nodes[9 * 7 + 2] = kept;
    let e = ViewNd {
        weights: (&w).into(),
        ..view
    }
    .check()
    .unwrap_err();
    assert!(
        matches!(e, ViewError::NonFinite { array: "weights.s", index: 11, value } if value.is_nan()),
        "{e}"
    );
}
