//! Capability: the full map's critical step reduced to the nodes
//! (`stability::nodal_full_map`) equals the dense full map's on small 1D, 2D and 3D
//! layouts of every shape — uniform, jittered, walled, with a stiff inclusion — and scales
//! to layouts of 10⁴ unknowns and more, where the dense map is not assembled.

mod stability_common;

use mpm_dt::limits_nd::full_map::critical_dt as dense_critical_dt;
use mpm_dt::limits_nd::nodal_full_map::critical_dt_nodal;
use mpm_dt::limits_nd::stiffness::lambda_max;
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
use mpm_dt::stability::nodal_full_map::critical_dt_nodal_1d;
use mpm_dt::stability::{FullMap, FullMapConfig};
use mpm_dt::{Boundary, Dim, Dimension, Shape, Stepper, ViewNd};
use stability_common::{fixed, jittered, periodic, small_mass, uniform, Fixture};

fn material(e: f64, nu: f64) -> MaterialNd {
    MaterialNd::LinearElastic {
        youngs_modulus: e,
        poisson_ratio: nu,
    }
}

#[path = "common/jitter.rs"]
mod jitter;
use jitter::jitter;

struct Layout<const D: usize> {
    boundary: Boundary,
    cells: [usize; D],
    per_cell: usize,
    shape: ShapeNd,
    jitter: f64,
    inclusion: bool,
}

fn solver<const D: usize>(l: &Layout<D>) -> SolverNd<D> {
    let grid = GridNd::<D>::new([l.boundary; D], l.cells, [1.0; D]);
    let mut particles = ParticlesNd::uniform(&grid, [l.per_cell; D], 1.0, material(1.0, 0.3));
    if l.jitter > 0.0 {
        jitter(&mut particles, l.jitter, 12345);
    }
    if l.inclusion {
        for p in 0..particles.len() {
            if (0..D).all(|a| particles.x[p][a] < 2.0 * grid.h[a]) {
                particles.material[p] = material(10.0, 0.3);
            }
        }
    }
    SolverNd::new(grid, l.shape, particles, Vector::<D>::zeros()).unwrap()
}

fn compare<const D: usize>(label: &str, l: Layout<D>)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let s = solver(&l);
    let view = s.view();
    let lambda = lambda_max(&view);
    let eq56 = (2.0 / lambda).sqrt();
    let dense = dense_critical_dt(&view, eq56)
        .expect("small enough for the dense map")
        .expect("the dense search brackets a critical step");
    let nodal = critical_dt_nodal(&view).expect("active nodes");
    eprintln!(
        "{label}: eq56 {eq56:.8}, dense {dense:.8}, nodal {:.8} ({} products, converged {}), ratio {:.3e}",
        nodal.dt,
        nodal.products,
        nodal.converged,
        nodal.dt / dense - 1.0
    );
    assert!(nodal.converged, "{label}: Lanczos did not converge");
    assert!(
        (nodal.dt / dense - 1.0).abs() < 1e-6,
        "{label}: nodal {} vs dense {dense}",
        nodal.dt
    );
}

#[test]
fn the_nodal_reduction_matches_the_dense_map_in_2d_and_3d() {
    use Boundary::{Fixed, Periodic};
    for shape in [ShapeNd::Gimp, ShapeNd::Linear, ShapeNd::BSpline2] {
        for (jit, inc) in [(0.0, false), (0.4, false), (0.4, true)] {
            // The reference solver has no B-spline on a walled axis.
            let walls: &[Boundary] = match shape {
                ShapeNd::BSpline2 => &[Periodic],
                _ => &[Periodic, Fixed],
            };
            for &boundary in walls {
                compare(
                    &format!("2D {shape:?} jitter {jit} inclusion {inc} {boundary:?}"),
                    Layout::<2> {
                        boundary,
                        cells: [3, 3],
                        per_cell: 2,
                        shape,
                        jitter: jit,
                        inclusion: inc,
                    },
                );
            }
        }
        compare(
            &format!("3D {shape:?} jittered"),
            Layout::<3> {
                boundary: Periodic,
                cells: [3, 3, 3],
                per_cell: 1,
                shape,
                jitter: 0.3,
                inclusion: false,
            },
        );
    }
}

#[test]
fn the_nodal_reduction_matches_the_dense_map_in_1d() {
    let layouts = [
        ("uniform ppc2", periodic(16, 1.0), uniform(16, 1.0, 2)),
        (
            "jittered ppc2",
            periodic(16, 1.0),
            jittered(16, 1.0, 2, 0.8, 4),
        ),
        (
            "jittered ppc3",
            periodic(12, 1.0),
            jittered(12, 1.0, 3, 0.8, 7),
        ),
        ("small mass", periodic(16, 1.0), small_mass(16, 1.0, 5)),
        ("fixed ends ppc2", fixed(16, 1.0), uniform(16, 1.0, 2)),
        (
            "fixed ends jittered",
            fixed(16, 1.0),
            jittered(16, 1.0, 2, 0.8, 9),
        ),
    ];
    for (name, grid, x) in layouts {
        for shape in [Shape::Gimp, Shape::Linear] {
            let fx = Fixture::new(grid.clone(), shape, x.clone(), 1.0, 1.0);
            let view = fx.view();
            let eq56 = stability_common::dense_dt56(&view);
            let dense = FullMap::new(&view)
                .unwrap()
                .critical_dt(0.5 * eq56, FullMapConfig::default())
                .unwrap();
            let nodal = critical_dt_nodal_1d(&view).unwrap().expect("active nodes");
            eprintln!(
                "1D {name} {shape:?}: eq56 {eq56:.8}, dense {dense:.8}, nodal {:.8} ({} products), ratio {:.3e}",
                nodal.dt,
                nodal.products,
                nodal.dt / dense - 1.0
            );
            assert!(
                nodal.converged,
                "{name} {shape:?}: Lanczos did not converge"
            );
            assert!(
                (nodal.dt / dense - 1.0).abs() < 1e-6,
                "{name} {shape:?}: nodal {} vs dense {dense}",
                nodal.dt
            );
        }
    }
}

/// The reduction where the dense map is not assembled: on a uniform periodic layout the
/// critical step in cells is the same on any even number of cells (the top mode is the
/// grid's checkerboard), so the reduction on 32 × 32 cells (20 480 unknowns of the particle
/// state) must equal the dense map on 4 × 4 (320), scaled by the cell size; on a jittered
/// 3D layout of 36 864 unknowns it must converge between eq 56's step and `√2` times it
/// (the bounds `0 ≤ Q_s ≤ I` give).
#[test]
fn the_reduction_reaches_layouts_the_dense_map_cannot_take() {
    let layout = |cells: usize| Layout::<2> {
        boundary: Boundary::Periodic,
        cells: [cells, cells],
        per_cell: 2,
        shape: ShapeNd::Gimp,
        jitter: 0.0,
        inclusion: false,
    };
    let small = solver(&layout(4));
    let view = small.view();
    let eq56 = (2.0 / lambda_max(&view)).sqrt();
    let dense = dense_critical_dt(&view, eq56).unwrap().unwrap();
    let large = solver(&layout(32));
    let nodal = critical_dt_nodal(&large.view()).expect("active nodes");
    eprintln!(
        "uniform 2D GIMP: dense on 4x4 {dense:.8}, nodal on 32x32 {:.8} x 8 ({} products)",
        nodal.dt * 8.0,
        nodal.products
    );
    assert!(nodal.converged);
    assert!((nodal.dt * 8.0 / dense - 1.0).abs() < 1e-6);

    let jittered = solver(&Layout::<3> {
        boundary: Boundary::Periodic,
        cells: [8, 8, 8],
        per_cell: 2,
        shape: ShapeNd::BSpline2,
        jitter: 0.4,
        inclusion: false,
    });
    let view = jittered.view();
    let eq56 = (2.0 / lambda_max(&view)).sqrt();
    let nodal = critical_dt_nodal(&view).expect("active nodes");
    eprintln!(
        "jittered 3D B-spline, 36 864 unknowns: eq56 {eq56:.8}, nodal {:.8} ({} products)",
        nodal.dt, nodal.products
    );
    assert!(nodal.converged);
    assert!(eq56 * (1.0 - 1e-9) <= nodal.dt && nodal.dt <= std::f64::consts::SQRT_2 * eq56);
}

/// The stability limit on the full map ([`StabilityNdConfig::full_map`]) proposes the
/// full map's critical step at a refresh: `√(2/(θ*(1 + tol)))` at safety 1, to the
/// Lanczos tolerance, on a jittered GIMP and B-spline layout, walled and periodic; with it
/// off, eq 56's.
#[test]
fn the_stability_limit_on_the_full_map_proposes_its_critical_step() {
    use mpm_dt::limits_nd::{StabilityNd, StabilityNdConfig};
    use mpm_dt::StepLimit;
    for (shape, boundary) in [
        (ShapeNd::Gimp, Boundary::Fixed),
        (ShapeNd::BSpline2, Boundary::Periodic),
    ] {
        let s = solver(&Layout::<2> {
            boundary,
            cells: [6, 6],
            per_cell: 2,
            shape,
            jitter: 0.4,
            inclusion: true,
        });
        let view = s.view();
        let exact = critical_dt_nodal(&view).expect("active nodes").dt;
        let eq56 = (2.0 / lambda_max(&view)).sqrt();
        let tol = 1e-8;
        let propose = |full_map: bool| {
            let config = StabilityNdConfig {
                safety: 1.0,
                tol,
                max_iter: 200,
                full_map,
                ..StabilityNdConfig::default()
            };
            StabilityNd::<2>::new(config)
                .unwrap()
                .propose(&view)
                .unwrap()
                .dt
        };
        let (on, off) = (propose(true), propose(false));
        eprintln!(
            "{shape:?} {boundary:?}: eq56 {eq56:.8}, full map {exact:.8}; proposed {on:.8} on, {off:.8} off"
        );
        assert!((on / exact - 1.0).abs() < 1e-6, "{on} vs {exact}");
        assert!((off / eq56 - 1.0).abs() < 1e-6, "{off} vs {eq56}");
        assert!(on > 1.03 * off);
    }
}

/// On the raw element bound (bound mode) the full map's gain is not taken: the bound
/// certifies eq 56's step, so the proposals there are the same with the setting on or off,
/// while the refresh's proposal is the full map's.
#[test]
fn proposals_on_the_raw_bound_do_not_take_the_full_maps_gain() {
    use mpm_dt::limits_nd::{StabilityNd, StabilityNdConfig};
    use mpm_dt::StepLimit;
    let s = solver(&Layout::<2> {
        boundary: Boundary::Periodic,
        cells: [6, 6],
        per_cell: 2,
        shape: ShapeNd::Gimp,
        jitter: 0.4,
        inclusion: false,
    });
    let view = s.view();
    let proposals = |full_map: bool| {
        let config = StabilityNdConfig {
            bound_drift: -1.0,
            bound_slack: 100.0,
            full_map,
            ..StabilityNdConfig::default()
        };
        let mut limit = StabilityNd::<2>::new(config).unwrap();
        let first = limit.propose(&view).unwrap();
        let second = limit.propose(&view).unwrap();
        let on_bound = second.metrics.contains_key("bound_proposals");
        (first.dt, second.dt, on_bound)
    };
    let (on, off) = (proposals(true), proposals(false));
    eprintln!("full map on: {on:?}; off: {off:?}");
    assert!(on.2 && off.2, "the second proposal is on the bound");
    assert!(
        on.0 > 1.03 * off.0,
        "the refresh's proposal is the full map's"
    );
    assert_eq!(
        on.1.to_bits(),
        off.1.to_bits(),
        "on the bound the same step"
    );
}
