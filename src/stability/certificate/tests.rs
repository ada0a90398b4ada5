//! Unit tests of [`super`].

use super::*;
use nalgebra::SymmetricEigen;

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn brackets_the_dense_lambda_max() {
    let mut seed = 7;
    for n in [1, 2, 3, 4, 5, 6, 7, 8, 9, 17, 40] {
        for periodic in [false, true] {
            let diag: Vec<f64> = (0..n).map(|_| 1.0 + 3.0 * lcg(&mut seed)).collect();
            let mut off: Vec<[f64; 2]> = (0..n)
                .map(|_| [lcg(&mut seed) - 0.5, 0.3 * (lcg(&mut seed) - 0.5)])
                .collect();
            if !periodic {
                for (i, o) in off.iter_mut().enumerate() {
                    if i + 1 >= n {
                        o[0] = 0.0;
                    }
                    if i + 2 >= n {
                        o[1] = 0.0;
                    }
                }
            }
            let eig = SymmetricEigen::new(band_to_dense(&diag, &off, periodic)).eigenvalues;
            let lmax = eig.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert!(
                below_shift(&diag, &off, periodic, lmax * (1.0 + 1e-9) + 1e-12),
                "n {n} periodic {periodic}: just above λmax {lmax} not certified"
            );
            assert!(
                !below_shift(&diag, &off, periodic, lmax * (1.0 - 1e-9)),
                "n {n} periodic {periodic}: just below λmax {lmax} certified"
            );
        }
    }
}

#[test]
fn the_pencil_test_agrees_with_the_test_on_c() {
    let mut seed = 11;
    for n in [7, 8, 9, 17, 40] {
        for periodic in [false, true] {
            // K = Σ_p k_p d_p d_pᵀ from random particles on three consecutive nodes (so
            // positive semi-definite like the stepper's), random masses, some inactive.
            let mut k = crate::NodalStiffness {
                diag: vec![0.0; n],
                upper1: vec![0.0; n],
                upper2: vec![0.0; n],
                c2_ref: 1.0,
            };
            let span = if periodic { n } else { n - 2 };
            for _ in 0..3 * n {
                let base = ((lcg(&mut seed) * span as f64) as usize).min(span - 1);
                let d = [
                    lcg(&mut seed) - 0.5,
                    lcg(&mut seed) - 0.5,
                    lcg(&mut seed) - 0.5,
                ];
                let kp = 0.5 + lcg(&mut seed);
                for a in 0..3 {
                    k.diag[(base + a) % n] += kp * d[a] * d[a];
                    for b in a + 1..3 {
                        let upper = if b - a == 1 {
                            &mut k.upper1
                        } else {
                            &mut k.upper2
                        };
                        upper[(base + a) % n] += kp * d[a] * d[b];
                    }
                }
            }
            let mass: Vec<f64> = (0..n).map(|_| 0.05 + lcg(&mut seed)).collect();
            let active: Vec<bool> = (0..n).map(|i| i % 5 != 3).collect();
            // C's bands: K_ij/√(m_i m_j) between active nodes, zero rows elsewhere.
            let s: Vec<f64> = (0..n)
                .map(|i| if active[i] { 1.0 / mass[i].sqrt() } else { 0.0 })
                .collect();
            let diag: Vec<f64> = (0..n).map(|i| k.diag[i] * s[i] * s[i]).collect();
            let off: Vec<[f64; 2]> = (0..n)
                .map(|i| {
                    let u = k.upper(i);
                    [1, 2].map(|j| u[j - 1] * s[i] * s[(i + j) % n])
                })
                .collect();
            let eig = SymmetricEigen::new(band_to_dense(&diag, &off, periodic)).eigenvalues;
            let lmax = eig.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for (mu, expect) in [(lmax * (1.0 + 1e-9), true), (lmax * (1.0 - 1e-9), false)] {
                assert_eq!(
                    below_shift_pencil(&k, &mass, &active, periodic, mu),
                    Some(expect),
                    "n {n} periodic {periodic}: μ = {mu} against λmax {lmax}"
                );
                assert_eq!(below_shift(&diag, &off, periodic, mu), expect);
            }
        }
    }
    let k = crate::NodalStiffness {
        diag: vec![1.0; 6],
        upper1: vec![0.0; 6],
        upper2: vec![0.0; 6],
        c2_ref: 1.0,
    };
    assert_eq!(
        below_shift_pencil(&k, &[1.0; 6], &[true; 6], true, 2.0),
        None
    );
    let mut k = crate::NodalStiffness {
        diag: vec![1.0; 9],
        upper1: vec![0.1; 9],
        upper2: vec![0.0; 9],
        c2_ref: 1.0,
    };
    assert_eq!(
        below_shift_pencil(&k, &[1.0; 8], &[true; 9], true, 2.0),
        None
    );
    assert_eq!(
        below_shift_pencil(&k, &[1.0; 9], &[true; 9], true, 2.0),
        Some(true)
    );
    k.upper1[4] = f64::NAN;
    assert_eq!(
        below_shift_pencil(&k, &[1.0; 9], &[true; 9], true, 2.0),
        Some(false)
    );
}

#[test]
fn chains_side_by_side_decide_as_one_chain() {
    // Random pentadiagonal matrices, shifts around λmax and the smallest eigenvalue
    // (where pivots fail early, late, or in a border): two, three and four chains agree
    // with the single chain, and with dense eigenvalues away from ties.
    let mut seed = 23;
    // From 16 nodes (four chains of 2 on a periodic grid, where every node is among the
    // first two and the last two of its chain) although only 32 nodes split in four.
    for n in [16, 17, 18, 19, 20, 23, 24, 31, 32, 33, 64, 101] {
        for periodic in [false, true] {
            let diag: Vec<f64> = (0..n).map(|_| 1.0 + 3.0 * lcg(&mut seed)).collect();
            let mut off: Vec<[f64; 2]> = (0..n)
                .map(|_| [lcg(&mut seed) - 0.5, 0.6 * (lcg(&mut seed) - 0.5)])
                .collect();
            if !periodic {
                off[n - 2][1] = 0.0;
                off[n - 1] = [0.0; 2];
            }
            let eig = SymmetricEigen::new(band_to_dense(&diag, &off, periodic)).eigenvalues;
            let lmax = eig.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let lmin = eig.iter().copied().fold(f64::INFINITY, f64::min);
            for t in 0..=40 {
                let mu = lmin + (lmax - lmin) * (t as f64 / 36.0 - 0.05);
                let a = |k: usize| mu - diag[k];
                let o = |k: usize, j: usize| off[k][j];
                let chain = positive_definite_chain(n, periodic, a, o);
                let two = positive_definite_chains::<2>(n, periodic, a, o);
                let three = positive_definite_chains::<3>(n, periodic, a, o);
                let four = positive_definite_chains::<4>(n, periodic, a, o);
                assert_eq!(
                    (two, three, four),
                    (chain, chain, chain),
                    "n {n} periodic {periodic} μ {mu}"
                );
                if (mu - lmax).abs() > 1e-9 * lmax.abs() {
                    assert_eq!(chain, mu > lmax, "n {n} periodic {periodic} μ {mu}");
                }
            }
        }
    }
}

#[test]
fn non_finite_input_is_never_certified() {
    let diag = vec![1.0; 10];
    let mut off = vec![[0.1, 0.0]; 10];
    assert!(below_shift(&diag, &off, true, 2.0));
    off[4][0] = f64::NAN;
    assert!(!below_shift(&diag, &off, true, 2.0));
    assert!(!below_shift(&diag, &[[0.0; 2]; 10], true, f64::INFINITY));
    // An infinite entry in the periodic border (single chain, 8 nodes): μ − C(6, 6) = ∞.
    let mut diag = vec![1.0; 8];
    diag[6] = f64::NEG_INFINITY;
    assert!(!below_shift(&diag, &[[0.0; 2]; 8], true, 2.0));
}
