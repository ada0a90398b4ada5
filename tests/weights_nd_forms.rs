//! Capability: the reference solver's weights, formed when a pass reads a row, read the
//! same, bit for bit, as the stored rows formed by `nd::fields::compute_weights` at the
//! same positions — through `with_row`, `for_each_in_row` and `to_stored` — for every
//! shape, periodic and fixed walls, in 2D and 3D; they hold no memory per particle.

use mpm_dt::nd::fields::compute_weights;
use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector, WeightsNd};
use mpm_dt::{Boundary, Dim, Dimension, Stepper, ViewNd};

/// A jittered layout moved by a few steps, so that stencils straddle cells and walls.
fn solver<const D: usize>(shape: ShapeNd, boundary: Boundary) -> SolverNd<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let grid = GridNd::<D>::new([boundary; D], [5; D], [1.0; D]);
    let material = MaterialNd::LinearElastic {
        youngs_modulus: 1.0,
        poisson_ratio: 0.3,
    };
    let mut particles = ParticlesNd::uniform(&grid, [2; D], 1.0, material);
    let mut seed = 11u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for p in 0..particles.len() {
        for a in 0..D {
            particles.x[p][a] += 0.4 * particles.domain[p][a] * next();
            particles.v[p][a] = 0.05 * next();
        }
    }
    let mut s = SolverNd::new(grid, shape, particles, Vector::<D>::zeros()).unwrap();
    for _ in 0..3 {
        s.try_step(0.01).unwrap();
        s.accept().unwrap();
    }
    s
}

fn rows_of<const D: usize>(w: &WeightsNd<D>, p: usize) -> (Vec<u32>, Vec<u64>, Vec<u64>) {
    w.with_row(p, |nodes, s, grad| {
        (
            nodes.to_vec(),
            s.iter().map(|x| x.to_bits()).collect(),
            grad.iter()
                .flat_map(|g| g.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                .collect(),
        )
    })
}

fn formed_rows_match_stored_rows<const D: usize>(shape: ShapeNd, boundary: Boundary)
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let s = solver::<D>(shape, boundary);
    let view = s.view();
    let formed = view.weights;
    assert!(formed.is_formed(), "the solver stores no weights");
    assert_eq!(formed.bytes_per_particle(), 0);
    let domain = vec![view.grid.h.map(|h| h / 2.0).into(); view.n_particles()];
    let mut stored = WeightsNd::<D>::default();
    compute_weights(view.grid, shape, view.x, &domain, &mut stored).unwrap();
    assert_eq!(formed.n_particles(), stored.n_particles());
    assert_eq!(formed.width(), stored.width());
    assert_eq!(formed.n_nodes(), stored.n_nodes());
    for p in 0..view.n_particles() {
        let want = rows_of(&stored, p);
        let got = formed.with_row(p, |nodes, s, grad| {
            (
                nodes.to_vec(),
                s.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                grad.iter()
                    .flat_map(|g| g.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                    .collect::<Vec<_>>(),
            )
        });
        assert_eq!(got, want, "{D}D {shape:?} particle {p}");
        let mut visited = (Vec::new(), Vec::new(), Vec::new());
        formed.for_each_in_row(p, |i, w, g| {
            visited.0.push(i as u32);
            visited.1.push(w.to_bits());
            visited.2.extend(g.iter().map(|x| x.to_bits()));
        });
        assert_eq!(visited, want, "{D}D {shape:?} particle {p} (visitor)");
    }
    // Every row formed into stored weights: the stored rows, equal.
    assert_eq!(formed.to_stored(), stored);
}

#[test]
fn formed_rows_read_as_the_stored_rows_in_2d() {
    for (shape, boundary) in [
        (ShapeNd::Gimp, Boundary::Fixed),
        (ShapeNd::Gimp, Boundary::Periodic),
        (ShapeNd::Linear, Boundary::Fixed),
        (ShapeNd::BSpline2, Boundary::Periodic),
    ] {
        formed_rows_match_stored_rows::<2>(shape, boundary);
    }
}

#[test]
fn formed_rows_read_as_the_stored_rows_in_3d() {
    for (shape, boundary) in [
        (ShapeNd::Gimp, Boundary::Fixed),
        (ShapeNd::Linear, Boundary::Periodic),
        (ShapeNd::BSpline2, Boundary::Periodic),
    ] {
        formed_rows_match_stored_rows::<3>(shape, boundary);
    }
}

/// A periodic axis of fewer cells than a stencil's nodes per axis (GIMP reaches 3 nodes;
/// one cell has one node): every node of a row wraps onto the axis, the rows pass the
/// view's checks (partition of unity, complete gradients, nodes in range), and steps run.
/// (Quadratic B-splines need 3 cells per axis and refuse fewer.)
#[test]
fn a_periodic_axis_of_one_cell_wraps_every_stencil_node() {
    use mpm_dt::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd, SolverNd, Vector};
    use mpm_dt::{Boundary, Stepper};
    for shape in [ShapeNd::Gimp, ShapeNd::Linear] {
        let grid = GridNd::<2>::new([Boundary::Periodic; 2], [1, 4], [0.25, 1.0]);
        let material = MaterialNd::LinearElastic {
            youngs_modulus: 1.0,
            poisson_ratio: 0.3,
        };
        let mut particles = ParticlesNd::uniform(&grid, [2, 2], 1.0, material);
        for p in 0..particles.len() {
            particles.v[p][1] = 1e-3 * (2.0 * std::f64::consts::PI * particles.x[p][1]).sin();
        }
        let mut s = SolverNd::new(grid, shape, particles, Vector::<2>::zeros()).unwrap();
        for _ in 0..5 {
            s.view()
                .check()
                .unwrap_or_else(|e| panic!("{shape:?}: {e}"));
            s.try_step(0.01).unwrap();
            s.accept().unwrap();
        }
    }
}
