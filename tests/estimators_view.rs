//! The estimators read from a solver's `View` (what the Stability limit calls): `Ea_i` of
//! eq 33, the eq 33 bracket, and the eq 44 local stress error.

use mpm_dt::estimators::local_stress::{local_stress_error, local_stress_error_from};
use mpm_dt::estimators::node_to_particle::gradient_error;
use mpm_dt::estimators::particle_to_node::stress_divergence_error_with;
use mpm_dt::estimators::table1::positions;
use mpm_dt::estimators::{
    eq33_bracket, eq33_bracket_nearest_node, linf, nodal_derivatives, stress_divergence_error,
    EstimatorError, Layout, Recovery,
};
use mpm_dt::{Boundary, Grid, Shape, View, WeightKind, Weights};
use std::f64::consts::PI;

const K: f64 = 2.0 * PI;

/// Owned arrays behind a hand-built view: the standing wave at phase π/4, ρ = E = 1.
struct State {
    grid: Grid,
    x: Vec<f64>,
    v: Vec<f64>,
    sigma: Vec<f64>,
    f: Vec<f64>,
    volume0: Vec<f64>,
    mass: Vec<f64>,
    modulus: Vec<f64>,
    density: Vec<f64>,
    weights: Weights,
    node_mass: Vec<f64>,
    node_velocity: Vec<f64>,
    node_acceleration: Vec<f64>,
    node_active: Vec<bool>,
}

impl State {
    fn new(boundary: Boundary, cells: usize, ppc: usize, jitter: f64) -> Self {
        let grid = Grid::new(boundary, cells, 1.0);
        let x = positions(cells, ppc, jitter, 3);
        let np = x.len();
        let vol = grid.h / ppc as f64;
        let amp = (PI / 4.0).sin();
        let v: Vec<f64> = x.iter().map(|x| amp * (K * x).sin()).collect();
        let sigma: Vec<f64> = x.iter().map(|x| amp * (K * x).cos()).collect();
        let weights = Weights::compute(&grid, Shape::Gimp, &x, &vec![vol; np]);
        let nn = grid.n_nodes();
        let mass = vec![vol; np];
        let mut node_mass = vec![0.0; nn];
        weights.scatter(WeightKind::S, &mass, &mut node_mass);
        let node_active: Vec<bool> = (0..nn)
            .map(|i| node_mass[i] > 1e-12 && !grid.is_constrained(i))
            .collect();
        let mv: Vec<f64> = v.iter().zip(&mass).map(|(v, m)| v * m).collect();
        let mut node_velocity = vec![0.0; nn];
        weights.scatter(WeightKind::S, &mv, &mut node_velocity);
        let sv: Vec<f64> = sigma.iter().map(|s| s * vol).collect();
        let mut node_acceleration = vec![0.0; nn];
        weights.scatter(WeightKind::D, &sv, &mut node_acceleration);
        for i in 0..nn {
            if node_active[i] {
                node_velocity[i] /= node_mass[i];
                node_acceleration[i] /= -node_mass[i];
            } else {
                node_velocity[i] = 0.0;
                node_acceleration[i] = 0.0;
            }
        }
        Self {
            grid,
            x,
            v,
            sigma,
            f: vec![1.0; np],
            volume0: vec![vol; np],
            mass,
            modulus: vec![1.0; np],
            density: vec![1.0; np],
            weights,
            node_mass,
            node_velocity,
            node_acceleration,
            node_active,
        }
    }

    fn view(&self) -> View<'_> {
        View {
            t: 0.125,
            step: 0,
            grid: &self.grid,
            x: &self.x,
            v: &self.v,
            sigma: &self.sigma,
            f: &self.f,
            volume0: &self.volume0,
            mass: &self.mass,
            tangent_modulus: &self.modulus,
            density: &self.density,
            weights: (&self.weights).into(),
            node_mass: &self.node_mass,
            node_velocity: &self.node_velocity,
            node_acceleration: &self.node_acceleration,
            node_active: &self.node_active,
            nodal_stiffness: None,
            summary: None,
        }
    }

    /// True `Ea_i = ∂σ/∂x(X_i)/ρ − a_i` on active nodes (0 elsewhere).
    fn true_ea(&self) -> Vec<f64> {
        let amp = (PI / 4.0).sin();
        (0..self.grid.n_nodes())
            .map(|i| {
                if self.node_active[i] {
                    -amp * K * (K * self.grid.node_x(i)).sin() - self.node_acceleration[i]
                } else {
                    0.0
                }
            })
            .collect()
    }
}

#[test]
fn ea_from_a_view_estimates_the_true_error() {
    for (boundary, jitter) in [
        (Boundary::Periodic, 0.0),
        (Boundary::Fixed, 0.0),
        (Boundary::Periodic, 0.7),
        (Boundary::Fixed, 0.7),
    ] {
        let s = State::new(boundary, 80, 4, jitter);
        let est = stress_divergence_error(&s.view()).expect("estimates");
        let err = s.true_ea();
        let index = linf(&est) / linf(&err);
        let worst = est
            .iter()
            .zip(&err)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            (0.8..=1.25).contains(&index),
            "{boundary:?} {jitter}: index {index}"
        );
        assert!(
            worst < 0.2 * linf(&err),
            "{boundary:?} {jitter}: pointwise {worst}"
        );
    }
}

/// On a uniform layout the consistency defects vanish and `Ea_i` is exactly eq 33 with the
/// bracket: `Ea_i = (1/m_i) Σ_p D_ip V_p Δσ_{pi}` (sign true − computed).
#[test]
fn ea_is_the_weighted_sum_of_the_eq33_bracket() {
    let s = State::new(Boundary::Periodic, 40, 2, 0.0);
    let view = s.view();
    let bracket = eq33_bracket(&view).expect("bracket");
    let w = s.weights.width();
    assert_eq!(bracket.len(), s.x.len() * w);
    let mut sum = vec![0.0; s.grid.n_nodes()];
    for p in 0..s.x.len() {
        for (k, (i, _, d)) in s.weights.row(p).enumerate() {
            sum[i] += d * s.volume0[p] * bracket[p * w + k] / s.node_mass[i];
        }
    }
    let ea = stress_divergence_error(&view).expect("ea");
    let scale = linf(&ea);
    for (a, b) in ea.iter().zip(&sum) {
        assert!((a - b).abs() < 1e-9 * scale, "{a} vs {b}");
    }
    let nearest = eq33_bracket_nearest_node(&view).expect("nearest");
    assert_eq!(nearest.len(), s.x.len());
    // Mapped (the paper's recovery) agrees with least squares on uniform layouts.
    let mapped = stress_divergence_error_with(&view, Recovery::Mapped).expect("mapped");
    let diff = mapped
        .iter()
        .zip(&ea)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 0.05 * scale, "{diff} vs {scale}");
}

#[test]
fn eq44_combines_its_parts() {
    let s = State::new(Boundary::Periodic, 40, 2, 0.0);
    let view = s.view();
    let dt = 0.3 * s.grid.h;
    let le = local_stress_error(&view, dt, Recovery::LeastSquares).expect("eq 44");
    let layout = Layout::from_view(&view).expect("layout");
    let ea = stress_divergence_error(&view).expect("ea");
    let v_next: Vec<f64> = s
        .node_velocity
        .iter()
        .zip(&s.node_acceleration)
        .map(|(v, a)| v + dt * a)
        .collect();
    let dv = nodal_derivatives(&s.grid, &v_next, &layout.node_active).expect("derivs");
    let ev = gradient_error(&layout, &dv).expect("ev");
    let mut carried = vec![0.0; s.x.len()];
    s.weights.gather(WeightKind::D, &ea, &mut carried);
    for p in 0..s.x.len() {
        let expected = dt * (ev[p] + dt * carried[p]);
        assert!((le[p] - expected).abs() <= 1e-12 * (1.0 + expected.abs()));
    }
    let from = local_stress_error_from(&layout, &s.modulus, dt, &ev, &ea).expect("from");
    assert_eq!(from, le);
    assert!(matches!(
        local_stress_error(&view, -1.0, Recovery::LeastSquares),
        Err(EstimatorError::Argument { name: "dt", .. })
    ));
}

#[test]
fn bad_views_are_typed_errors() {
    let mut s = State::new(Boundary::Periodic, 20, 2, 0.0);
    s.sigma[5] = f64::NAN;
    assert!(matches!(
        stress_divergence_error(&s.view()),
        Err(EstimatorError::InvalidValue { index: 5, .. })
    ));
    let mut s = State::new(Boundary::Periodic, 20, 2, 0.0);
    s.f[2] = -0.5;
    assert!(matches!(
        stress_divergence_error(&s.view()),
        Err(EstimatorError::InvalidValue {
            field: "f",
            index: 2,
            ..
        })
    ));
    let mut s = State::new(Boundary::Periodic, 20, 2, 0.0);
    s.mass.pop();
    assert!(matches!(
        stress_divergence_error(&s.view()),
        Err(EstimatorError::Length { field: "mass", .. })
    ));
}
