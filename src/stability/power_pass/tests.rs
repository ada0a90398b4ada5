//! Unit tests of [`super`].

use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random bands, masses and activity (about one node in 8 inactive, its `z` zero or not).
fn case(n: usize, seed: u64, stale: bool) -> (NodalStiffness, Vec<f64>, Vec<bool>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let k = NodalStiffness {
        diag: (0..n).map(|_| rng.random_range(0.5..2.0)).collect(),
        upper1: (0..n).map(|_| rng.random_range(-1.0..0.0)).collect(),
        upper2: (0..n).map(|_| rng.random_range(-0.2..0.2)).collect(),
        c2_ref: 1.0,
    };
    let mass: Vec<f64> = (0..n).map(|_| rng.random_range(0.1..1.0)).collect();
    let active: Vec<bool> = (0..n).map(|_| rng.random::<f64>() > 0.125).collect();
    let z = (0..n)
        .map(|i| {
            let v = rng.random_range(-1.0..1.0);
            if active[i] || stale {
                v
            } else {
                0.0
            }
        })
        .collect();
    (k, mass, active, z)
}

/// The pass by one sequential scalar loop over the wrapped rows (the definition):
/// quotient, diagonal flag, stale flag, `max |z|` and the power step.
fn reference(
    k: &NodalStiffness,
    mass: &[f64],
    active: &[bool],
    z: &[f64],
    (rho_prev, bound, floor): (f64, f64, f64),
) -> (f64, bool, bool, f64, Vec<f64>) {
    let inp = Inputs::new(k, (mass, active), (rho_prev, bound, floor));
    let (mut num, mut den, mut above, mut stale) = (0.0, 0.0, false, false);
    let next = (0..z.len())
        .map(|i| {
            let y = inp.wrapped_row(z, i);
            num += z[i] * y;
            if active[i] {
                den += mass[i] * z[i] * z[i];
                above |= k.diag[i] > bound * mass[i];
                let step = y * inp.inv_rho / mass[i];
                if step.abs() >= floor {
                    step
                } else {
                    0.0
                }
            } else {
                stale |= z[i] != 0.0;
                0.0
            }
        })
        .collect();
    let max_abs = z.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    (num / den, above, stale, max_abs, next)
}

/// The pass in both builds on one case: the dispatched build (AVX2 where the CPU has
/// it) and the portable one, each on its own copy of `z`.
fn both_builds(
    k: &NodalStiffness,
    (mass, active): (&[f64], &[bool]),
    z: &[f64],
    scalars: (f64, f64, f64),
) -> [(Lane, Vec<f64>); 2] {
    let inputs = Inputs::new(k, (mass, active), scalars);
    let (mut fast, mut portable) = (z.to_vec(), z.to_vec());
    let lane = dispatch(&inputs, &mut fast);
    [(lane, fast), (pass(&inputs, &mut portable), portable)]
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_vector_builds_agree_bit_for_bit_and_match_the_sequential_definition() {
    // Sizes with no chunk (4–7 nodes), one chunk, every tail length, and long runs;
    // each without flushing and with a floor that flushes about half of the power step.
    // Zero stretches: from 64 nodes in the middle, whole zero blocks from 134 nodes —
    // the first block (134: nodes 0–69 zero), the last interior step (135: nodes
    // 60–134 zero), and blocks inside (1001).
    let sizes = [4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 64, 134, 135, 1001];
    for (seed, n) in sizes.into_iter().enumerate() {
        for flush in [false, true] {
            let (mut k, mass, active, mut z) = case(n, seed as u64, false);
            let zero = match n {
                134 => 0..70,
                135 => 60..135,
                _ if n >= 64 => n / 4..n / 2,
                _ => 0..0,
            };
            z[zero.clone()].fill(0.0);
            // A NaN in `K_N` well inside a zero block is never multiplied: proof that
            // the block was skipped (a computed block would poison the quotient).
            let skipped = (n >= 134).then(|| {
                let j = zero.start + 8;
                k.upper1[j] = f64::NAN;
                j
            });
            let (rho_prev, bound) = (1.3, 2.5);
            let floor = if flush {
                let (.., unflushed) = reference(&k, &mass, &active, &z, (rho_prev, bound, 0.0));
                let mut sizes: Vec<f64> = unflushed.iter().map(|v| v.abs()).collect();
                sizes.sort_by(f64::total_cmp);
                sizes[sizes.len() / 2]
            } else {
                0.0
            };
            let scalars = (rho_prev, bound, floor);
            let [(fast, fz), (portable, pz)] = both_builds(&k, (&mass, &active), &z, scalars);
            let case = format!("n = {n}, flush {flush}");
            assert_eq!(
                bits(&fz),
                bits(&pz),
                "{case}: power steps differ between builds"
            );
            for (a, b) in [
                (fast.num, portable.num),
                (fast.den, portable.den),
                (fast.max_abs, portable.max_abs),
            ] {
                assert_eq!(
                    a.to_bits(),
                    b.to_bits(),
                    "{case}: sums differ between builds"
                );
            }
            assert_eq!((fast.above, fast.stale), (portable.above, portable.stale));
            let p = power_pass(&k, &mass, &active, &mut z.clone(), rho_prev, bound, floor)
                .expect("valid pass");
            assert_eq!(p.rayleigh.to_bits(), (fast.num / fast.den).to_bits());
            if let Some(j) = skipped {
                assert!(
                    p.rayleigh.is_finite(),
                    "{case}: the block at {j} was computed"
                );
                k.upper1[j] = 0.0;
            }
            // The in-place pass computes from the mode on entry, as an out-of-place one
            // (equal values; a skipped block's zeros are `+0.0` where the definition may
            // give `−0.0` without a floor).
            let (rho, above, _, max_abs, next) = reference(&k, &mass, &active, &z, scalars);
            assert_eq!(p.diagonal_above, above, "{case}");
            assert_eq!(p.max_abs.to_bits(), max_abs.to_bits(), "{case}");
            if flush {
                let zeros = next.iter().filter(|&&v| v == 0.0).count();
                assert!(
                    zeros >= n / 2 && zeros < n,
                    "{case}: {zeros} values flushed"
                );
            }
            assert_eq!(fz, next, "{case}: power step differs from the definition");
            assert!(
                (p.rayleigh - rho).abs() <= 1e-12 * rho.abs().max(1.0),
                "{case}: quotient {} vs sequential {rho}",
                p.rayleigh
            );
        }
    }
}

#[test]
fn the_mass_scan_refuses_what_a_zero_block_would_hide() {
    // An infinite mass at an active node inside a zero block: the pass serves (the block
    // is not computed, the diagonal test cannot fire), so the caller's scan must refuse.
    let (k, mut mass, active, mut z) = case(1001, 11, false);
    z[300..600].fill(0.0);
    let j = (400..500).find(|&j| active[j]).expect("an active node");
    mass[j] = f64::INFINITY;
    assert!(power_pass(&k, &mass, &active, &mut z, 1.0, 100.0, 0.0).is_some());
    assert!(!active_masses_positive(&mass, &active));
    for bad in [0.0, -1.0, f64::NAN] {
        mass[j] = bad;
        assert!(!active_masses_positive(&mass, &active), "{bad}");
    }
    mass[j] = 0.5;
    assert!(active_masses_positive(&mass, &active));
    // Inactive nodes may hold anything.
    let i = (0..1001).find(|&i| !active[i]).expect("an inactive node");
    mass[i] = f64::INFINITY;
    assert!(active_masses_positive(&mass, &active));
}

#[test]
fn a_nonzero_mode_at_an_inactive_node_and_bad_sizes_are_refused() {
    let (k, mass, active, mut z) = case(64, 8, true);
    assert!(active.iter().any(|&a| !a));
    assert!(power_pass(&k, &mass, &active, &mut z, 1.0, 10.0, 0.0).is_none());
    let (k, mass, active, z) = case(64, 9, false);
    // Sizes that do not fit leave the mode untouched.
    let mut untouched = z.clone();
    assert!(power_pass(&k, &mass[..63], &active, &mut untouched, 1.0, 10.0, 0.0).is_none());
    assert_eq!(untouched, z);
    let mut short = z[..3].to_vec();
    assert!(power_pass(&k, &mass[..3], &active[..3], &mut short, 1.0, 1.0, 0.0).is_none());
    // The diagonal test fires on one heavy diagonal entry at an active node in a chunk.
    let mut k2 = k.clone();
    let j = (2..60)
        .find(|&j| active[j])
        .expect("an active interior node");
    k2.diag[j] = 1e3 * mass[j];
    // … and in a zero block, where only the diagonal test runs.
    let (mut k3, mass3, active3, mut z3) = case(1001, 10, false);
    z3[300..600].fill(0.0);
    let j3 = (400..500).find(|&j| active3[j]).expect("an active node");
    k3.diag[j3] = 1e3 * mass3[j3];
    for (kd, expect) in [(1e3 * mass3[j3], true), (0.0, false)] {
        k3.diag[j3] = kd;
        let builds = both_builds(&k3, (&mass3, &active3), &z3, (1.0, 100.0, 0.0));
        for (lane, _) in builds {
            assert_eq!(lane.above, expect);
        }
        let p3 = power_pass(&k3, &mass3, &active3, &mut z3.clone(), 1.0, 100.0, 0.0);
        assert_eq!(p3.expect("valid").diagonal_above, expect);
    }
    let mut z2 = z.clone();
    let p = power_pass(&k2, &mass, &active, &mut z2, 1.0, 100.0, 0.0).expect("valid");
    assert!(p.diagonal_above);
}
