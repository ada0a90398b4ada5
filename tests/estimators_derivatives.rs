//! Nodal derivatives by finite differences (eqs 42, 43 corrected), one-sided at walls, and
//! the least-squares recovery from particles.

use mpm_dt::estimators::derivatives::{fornberg_weights, nodal_derivatives};
use mpm_dt::estimators::table1::positions;
use mpm_dt::estimators::{EstimatorError, Layout, Recovery};
use mpm_dt::{Boundary, Grid, Shape, Weights};

#[test]
fn fornberg_reproduces_the_classical_stencils() {
    let w = fornberg_weights(0.0, &[-1.0, 0.0, 1.0], 2);
    assert_eq!(w[1], vec![-0.5, 0.0, 0.5]);
    assert_eq!(w[2], vec![1.0, -2.0, 1.0]);
    let w = fornberg_weights(0.0, &[-2.0, -1.0, 0.0, 1.0, 2.0], 4);
    let third = [-0.5, 1.0, 0.0, -1.0, 0.5];
    let fourth = [1.0, -4.0, 6.0, -4.0, 1.0];
    for k in 0..5 {
        assert!((w[3][k] - third[k]).abs() < 1e-12 && (w[4][k] - fourth[k]).abs() < 1e-12);
    }
    // One-sided second derivative (2, −5, 4, −1).
    let w = fornberg_weights(0.0, &[0.0, 1.0, 2.0, 3.0], 2);
    for (a, b) in w[2].iter().zip([2.0, -5.0, 4.0, -1.0]) {
        assert!((a - b).abs() < 1e-12);
    }
}

/// Eq 43 as printed, (σ_{i+2} − 2σ_{i+1} + 2σ_{i−1} + σ_{i−2})/h³, has weights summing to 2:
/// it does not annihilate constants. The corrected operator does.
#[test]
fn printed_eq43_is_not_a_difference_operator_and_the_fix_is() {
    let printed: f64 = [1.0, -2.0, 0.0, 2.0, 1.0].iter().sum();
    assert!((printed - 2.0).abs() < 1e-15);
    let g = Grid::new(Boundary::Periodic, 10, 1.0);
    let d = nodal_derivatives(&g, &[3.0; 10], &[true; 10]).expect("valid");
    for k in 1..=4 {
        assert!(d.order(k).expect("order").iter().all(|v| v.abs() < 1e-9));
    }
}

/// On a fixed grid, interior and one-sided (wall, ghost) stencils alike are exact for the
/// polynomials their order allows: quadratics for the value, first and second derivatives,
/// cubics for the third and fourth.
#[test]
fn one_sided_wall_stencils_are_exact_on_polynomials() {
    let g = Grid::new(Boundary::Fixed, 12, 1.2);
    let xs = g.node_positions();
    let usable: Vec<bool> = (0..g.n_nodes()).map(|i| !g.is_constrained(i)).collect();
    let quad: Vec<f64> = xs.iter().map(|x| 1.0 + 2.0 * x - 3.0 * x * x).collect();
    let d = nodal_derivatives(&g, &quad, &usable).expect("valid");
    for (i, x) in xs.iter().enumerate() {
        assert!(
            (d.value[i] - (1.0 + 2.0 * x - 3.0 * x * x)).abs() < 1e-9,
            "node {i}"
        );
        assert!((d.first[i] - (2.0 - 6.0 * x)).abs() < 1e-9, "node {i}");
        assert!((d.second[i] + 6.0).abs() < 1e-8, "node {i}");
    }
    let cubic: Vec<f64> = xs.iter().map(|x| x * x * x).collect();
    let d = nodal_derivatives(&g, &cubic, &usable).expect("valid");
    for i in 0..g.n_nodes() {
        assert!((d.third[i] - 6.0).abs() < 1e-6, "node {i}: {}", d.third[i]);
        assert!(d.fourth[i].abs() < 1e-4, "node {i}: {}", d.fourth[i]);
    }
}

/// Second-order convergence of eqs 42 and 43 (corrected) on a periodic sine.
#[test]
fn eqs_42_43_converge_at_second_order() {
    let k = 2.0 * std::f64::consts::PI;
    let err = |n: usize| {
        let g = Grid::new(Boundary::Periodic, n, 1.0);
        let xs = g.node_positions();
        let u: Vec<f64> = xs.iter().map(|x| (k * x).sin()).collect();
        let d = nodal_derivatives(&g, &u, &vec![true; n]).expect("valid");
        let e2 = xs
            .iter()
            .zip(&d.second)
            .map(|(x, v)| (v + k * k * (k * x).sin()).abs())
            .fold(0.0, f64::max);
        let e3 = xs
            .iter()
            .zip(&d.third)
            .map(|(x, v)| (v + k * k * k * (k * x).cos()).abs())
            .fold(0.0, f64::max);
        (e2, e3)
    };
    let (a2, a3) = err(40);
    let (b2, b3) = err(80);
    assert!(((a2 / b2).log2() - 2.0).abs() < 0.05);
    assert!(((a3 / b3).log2() - 2.0).abs() < 0.05);
}

#[test]
fn bad_nodal_input_is_a_typed_error() {
    let g = Grid::new(Boundary::Periodic, 4, 1.0);
    assert!(matches!(
        nodal_derivatives(&g, &[0.0; 4], &[true; 4]),
        Err(EstimatorError::TooFewNodes { .. })
    ));
    let g = Grid::new(Boundary::Fixed, 10, 1.0);
    let mut usable = vec![true; 13];
    usable[6] = false;
    assert!(matches!(
        nodal_derivatives(&g, &[0.0; 13], &usable),
        Err(EstimatorError::Gap { node: 6 })
    ));
    assert!(matches!(
        nodal_derivatives(&g, &[0.0; 12], &[true; 13]),
        Err(EstimatorError::Length { .. })
    ));
    let mut v = vec![0.0; 13];
    v[3] = f64::NAN;
    assert!(matches!(
        nodal_derivatives(&g, &v, &[true; 13]),
        Err(EstimatorError::InvalidValue { index: 3, .. })
    ));
}

/// Least-squares recovery differentiates a quartic particle field exactly on a jittered
/// layout, at every node including walls and ghosts.
#[test]
fn least_squares_recovery_is_exact_for_quartics() {
    let g = Grid::new(Boundary::Fixed, 16, 1.0);
    let x = positions(16, 3, 0.8, 42);
    let w = vec![g.h / 3.0; x.len()];
    let weights = Weights::compute(&g, Shape::Gimp, &x, &w);
    let layout = Layout::new(&g, &weights, &x, &w, &w).expect("valid layout");
    let f = |x: f64| 0.3 - x + 2.0 * x * x - 4.0 * x.powi(3) + 5.0 * x.powi(4);
    let u: Vec<f64> = x.iter().map(|&x| f(x)).collect();
    let d = Recovery::LeastSquares
        .nodal_derivatives(&layout, &u)
        .expect("fits");
    for (i, xn) in g.node_positions().into_iter().enumerate() {
        let exact = [
            f(xn),
            -1.0 + 4.0 * xn - 12.0 * xn * xn + 20.0 * xn.powi(3),
            4.0 - 24.0 * xn + 60.0 * xn * xn,
            -24.0 + 120.0 * xn,
            120.0,
        ];
        for (k, e) in exact.iter().enumerate() {
            let got = d.order(k).expect("order")[i];
            assert!(
                (got - e).abs() < 1e-6 * (1.0 + e.abs()),
                "node {i} order {k}: {got} vs {e}"
            );
        }
    }
}

#[test]
fn least_squares_reports_too_few_particles() {
    let g = Grid::new(Boundary::Periodic, 20, 1.0);
    let x = vec![0.1, 0.2, 0.3];
    let w = vec![0.05; 3];
    let weights = Weights::compute(&g, Shape::Gimp, &x, &w);
    let layout = Layout::new(&g, &weights, &x, &w, &w).expect("valid layout");
    assert!(matches!(
        Recovery::LeastSquares.nodal_derivatives(&layout, &[1.0, 2.0, 3.0]),
        Err(EstimatorError::Recovery { .. })
    ));
}
