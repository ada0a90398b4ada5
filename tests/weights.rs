//! Weights `S` and `D` (eqs 6, 7, 17, 18, 21, 24) for random particle positions, both
//! shapes and both boundaries, including particles whose GIMP domain straddles a node or
//! the periodic wrap.
//!
//! * Reproduction of constants and linears: `Σ_i S_ip = 1`, `Σ_i S_ip (X_i − x_p) = 0`,
//!   `Σ_i D_ip = 0`, `Σ_i D_ip (X_i − x_p) = 1`, with `X_i − x_p` the periodic minimum image.
//! * GIMP weights equal their definitions `S_ip = (1/l_p) ∫ N_i χ_p dx` and
//!   `D_ip = (1/l_p) ∫ N_i′ χ_p dx`, computed here by Gauss–Legendre quadrature on the
//!   sub-intervals of `[x_p − l_p/2, x_p + l_p/2]` between the kinks of the hat (the nodes),
//!   where the integrands are polynomials of degree ≤ 1, with every periodic image of the hat.
//! * `Weights::compute` and `Weights::compute_into` (into a reused buffer) store exactly,
//!   bit for bit, `Shape::stencil` slot by slot at `Grid::storage_index`.

use mpm_dt::shape::MAX_NODES;
use mpm_dt::{Boundary, Grid, Shape, Weights};
use proptest::prelude::*;

/// Hat `N_i` of node position `xi` (all periodic images on a periodic grid) at `x`.
fn hat(grid: &Grid, xi: f64, x: f64) -> f64 {
    let one = |d: f64| (1.0 - d.abs() / grid.h).max(0.0);
    match grid.boundary {
        Boundary::Fixed => one(x - xi),
        Boundary::Periodic => (-2..=2)
            .map(|m| one(x - xi - m as f64 * grid.length()))
            .sum(),
    }
}

/// Derivative `N_i′` (all periodic images), one-sided from the right at kinks.
fn hat_slope(grid: &Grid, xi: f64, x: f64) -> f64 {
    let one = |d: f64| {
        if d.abs() < grid.h {
            -d.signum() / grid.h
        } else {
            0.0
        }
    };
    match grid.boundary {
        Boundary::Fixed => one(x - xi),
        Boundary::Periodic => (-2..=2)
            .map(|m| one(x - xi - m as f64 * grid.length()))
            .sum(),
    }
}

/// `∫_a^b g` by 2-point Gauss–Legendre on the pieces between lattice points.
fn integrate(grid: &Grid, a: f64, b: f64, g: impl Fn(f64) -> f64) -> f64 {
    let mut cuts = vec![a];
    let first = ((a - grid.origin) / grid.h).ceil() as i64;
    let mut j = first;
    loop {
        let xj = grid.origin + j as f64 * grid.h;
        if xj >= b {
            break;
        }
        if xj > a {
            cuts.push(xj);
        }
        j += 1;
    }
    cuts.push(b);
    let r = 0.5 / 3f64.sqrt();
    cuts.windows(2)
        .map(|w| {
            let (lo, hi) = (w[0], w[1]);
            let (mid, len) = (0.5 * (lo + hi), hi - lo);
            0.5 * len * (g(mid - r * len) + g(mid + r * len))
        })
        .sum()
}

fn grid_strategy() -> impl Strategy<Value = Grid> {
    // Periodic rings need ≥ 3 cells (the solver refuses fewer: a particle would touch one
    // node twice and the minimum-image offsets would be ambiguous).
    prop_oneof![
        (3usize..12, 0.1f64..10.0).prop_map(|(c, l)| Grid::new(Boundary::Periodic, c, l)),
        (1usize..12, 0.1f64..10.0).prop_map(|(c, l)| Grid::new(Boundary::Fixed, c, l)),
    ]
}

/// A grid, particle positions as fractions of the domain, and width fractions of `h`.
fn case() -> impl Strategy<Value = (Grid, Vec<f64>, Vec<f64>)> {
    (
        grid_strategy(),
        prop::collection::vec(
            prop_oneof![
                // Anywhere, near the ends (the wrap / ghost nodes), or on a node.
                3 => 0.0f64..1.0,
                1 => 0.0f64..1e-9,
                1 => (1.0 - 1e-9)..1.0f64,
                1 => (0usize..12).prop_map(|k| k as f64 / 12.0),
            ],
            1..20,
        ),
        prop::collection::vec(0.01f64..=1.0, 20),
    )
        .prop_map(|(g, fr, wf)| {
            let l = g.length();
            let top = match g.boundary {
                Boundary::Periodic => l * (1.0 - f64::EPSILON),
                Boundary::Fixed => l,
            };
            let xs = fr.iter().map(|f| (f * l).min(top)).collect::<Vec<_>>();
            let ws = wf[..xs.len()].iter().map(|f| f * g.h).collect();
            (g, xs, ws)
        })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_CA5E),
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::Direct("proptest-regressions/weights.txt"),
        )),
        ..ProptestConfig::default()
    })]

    #[test]
    fn weights_reproduce_constants_and_linears((grid, xs, ws) in case()) {
        for shape in [Shape::Gimp, Shape::Linear] {
            let w = Weights::compute(&grid, shape, &xs, &ws);
            prop_assert_eq!(w.n_particles(), xs.len());
            for (p, &x) in xs.iter().enumerate() {
                let s: f64 = w.s_of(p).iter().sum();
                let d: f64 = w.d_of(p).iter().sum();
                let sx: f64 = w.row(p).map(|(i, s, _)| s * grid.offset(i, x)).sum();
                let dx: f64 = w.row(p).map(|(i, _, d)| d * grid.offset(i, x)).sum();
                let tol = 1e-12;
                prop_assert!((s - 1.0).abs() < tol, "{:?} p={} Σ S = {}", shape, p, s);
                prop_assert!(sx.abs() < tol * grid.h, "{:?} p={} Σ S (X−x) = {}", shape, p, sx);
                prop_assert!(d.abs() < tol / grid.h.min(ws[p]), "{:?} p={} Σ D = {}", shape, p, d);
                prop_assert!((dx - 1.0).abs() < 1e-11, "{:?} p={} Σ D (X−x) = {}", shape, p, dx);
                prop_assert!(w.s_of(p).iter().all(|&s| s >= -1e-15), "negative S");
            }
        }
    }

    /// `compute_into` a reused buffer gives `compute`'s bits, and both agree with
    /// `Shape::stencil` to round-off node by node (they are the branch-free forms of the
    /// crate-private `stencil` module, which the 1D solver shares; near a cell boundary the
    /// two may pick different first nodes, the extra node then carrying a round-off weight).
    #[test]
    fn computed_weights_are_shape_stencils_to_round_off(
        cases in prop::collection::vec(case(), 1..4),
    ) {
        // One buffer reused across grids, shapes and particle counts.
        let mut reused = Weights::new(0, 0);
        for (grid, xs, ws) in cases {
            for shape in [Shape::Gimp, Shape::Linear] {
                let bits = |w: &Weights| -> Vec<(usize, u64, u64)> {
                    (0..w.n_particles())
                        .flat_map(|p| w.row(p).map(|(i, s, d)| (i, s.to_bits(), d.to_bits())).collect::<Vec<_>>())
                        .collect()
                };
                let computed = Weights::compute(&grid, shape, &xs, &ws);
                reused.compute_into(&grid, shape, &xs, &ws);
                prop_assert_eq!(computed.n_nodes(), grid.n_nodes());
                prop_assert_eq!(reused.n_nodes(), grid.n_nodes());
                prop_assert_eq!(reused.width(), MAX_NODES);
                prop_assert_eq!(bits(&reused), bits(&computed));
                for (p, (&x, &l)) in xs.iter().zip(&ws).enumerate() {
                    let st = shape.stencil(x - grid.origin, l, grid.h);
                    let mut expected = vec![(0.0, 0.0); grid.n_nodes()];
                    for k in 0..MAX_NODES {
                        if let Some(i) = grid.storage_index(st.first + k as i64) {
                            expected[i].0 += st.s[k];
                            expected[i].1 += st.d[k];
                        }
                    }
                    let mut got = vec![(0.0, 0.0); grid.n_nodes()];
                    for (i, s, d) in computed.row(p) {
                        got[i].0 += s;
                        got[i].1 += d;
                    }
                    for (i, (e, g)) in expected.iter().zip(&got).enumerate() {
                        prop_assert!((e.0 - g.0).abs() < 1e-12, "{:?} p={} i={} S {} vs {}", shape, p, i, g.0, e.0);
                        prop_assert!((e.1 - g.1).abs() < 1e-12 / grid.h.min(l), "{:?} p={} i={} D {} vs {}", shape, p, i, g.1, e.1);
                    }
                }
            }
        }
    }

    #[test]
    fn gimp_weights_equal_their_integrals((grid, xs, ws) in case()) {
        let w = Weights::compute(&grid, Shape::Gimp, &xs, &ws);
        for (p, (&x, &l)) in xs.iter().zip(&ws).enumerate() {
            let (a, b) = (x - 0.5 * l, x + 0.5 * l);
            // Sum stored entries per node (tiny periodic grids repeat a node).
            let mut s_node = vec![0.0; grid.n_nodes()];
            let mut d_node = vec![0.0; grid.n_nodes()];
            for (i, s, d) in w.row(p) {
                s_node[i] += s;
                d_node[i] += d;
            }
            for i in 0..grid.n_nodes() {
                let xi = grid.node_x(i);
                let s_q = integrate(&grid, a, b, |y| hat(&grid, xi, y)) / l;
                let d_q = integrate(&grid, a, b, |y| hat_slope(&grid, xi, y)) / l;
                prop_assert!((s_node[i] - s_q).abs() < 1e-12, "p={} i={} S={} quad={}", p, i, s_node[i], s_q);
                prop_assert!((d_node[i] - d_q).abs() < 1e-11 / grid.h, "p={} i={} D={} quad={}", p, i, d_node[i], d_q);
            }
        }
    }
}

#[test]
fn gimp_domain_straddling_the_wrap_weights_both_ends() {
    // A particle at x = 0.01 of width h/2 on [0, 1) with 10 cells reaches back to x = −0.015,
    // i.e. across the wrap onto the last cell.
    let grid = Grid::new(Boundary::Periodic, 10, 1.0);
    let w = Weights::compute(&grid, Shape::Gimp, &[0.01], &[0.05]);
    let mut s_node = [0.0; 10];
    for (i, s, _) in w.row(0) {
        s_node[i] += s;
    }
    // Quadrature of the last node's hat over [−0.015, 0.035] — only [−0.015, 0] counts.
    let expected_last = (0.015f64 * 0.015 / (2.0 * 0.1)) / 0.05;
    assert!((s_node[9] - expected_last).abs() < 1e-14, "{}", s_node[9]);
    assert!(s_node[0] > 0.5 && s_node[1] > 0.0);
    assert!((s_node.iter().sum::<f64>() - 1.0).abs() < 1e-14);
}
