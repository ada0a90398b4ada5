//! Certified upper bounds on `λmax(C)` of the nodal eq 56 operator: Sylvester's law of inertia.
//!
//! A Lanczos Ritz value or a Rayleigh quotient `θ` is a *lower* bound on `λmax`; nothing in
//! an iteration proves that no eigenvalue lies above it (a level crossing, a mode the start
//! vector does not see). **Sylvester's law of inertia** turns it into a certified bracket:
//! `μI − C` is positive definite ⇔ every eigenvalue of `C` is below `μ`, and positive
//! definiteness is decided by one `LDLᵀ` factorisation without pivoting: all pivots positive.
//! `C` is pentadiagonal (periodic grids add a 2 × 2 corner coupling, handled as a border whose
//! Schur complement is checked last — Haynsworth's inertia additivity), so the test is one
//! `O(n_nodes)` pass ([`below_shift`]). With `μ = (1 + margin) θ` a successful factorisation
//! certifies `θ ≤ λmax(C) < μ`. Its cost is a chain of one division per node (measured:
//! README "Stability").
//!
//! **Rounding.** An `LDLᵀ` (Cholesky) factorisation that completes in floating point is the
//! exact factorisation of `A + ΔA` with `|ΔA_ij| ≤ γ_{k+1} (|L||D||Lᵀ|)_ij`, `k` the length
//! of the inner product that forms entry `(i, j)` and `γ_k = k u/(1 − k u)` (Higham,
//! *Accuracy and Stability of Numerical Algorithms*, Thm 10.5 and §10.4), and for a positive
//! definite `A` Cauchy–Schwarz gives `(|L||D||Lᵀ|)_ij ≤ √(A_ii A_jj) ≤ μ` (for `A = μI − C`,
//! `C_ii ≥ 0`). Inside the band every inner product has at most 3 terms: at most 5 entries
//! per row, `‖ΔA_band‖₂ ≤ 5 γ_3 μ ≈ 15 u μ`. On a periodic grid the border's two columns of
//! `L` are full (the fill of the forward solve): their `2m` entries with the chain of `m`
//! nodes have 3-term inner products (`‖·‖₂ ≤ 2 √m γ_3 μ`), and the border's own `2 × 2`
//! block sums over the whole chain (`γ_{m+2} μ` per entry). In all,
//! `‖ΔA‖₂ ≤ (15 + 6√n + 2n + 4) u μ ≤ (20 + 3n) u μ` for `n` nodes, so a successful test
//! proves `λmax(C) < μ (1 + (20 + 3n) u)`; [`rounding_slack`] adds twice that (and at least
//! `10⁻¹²`) to every certified bound — `3·10⁻¹¹` relative at `5·10⁴` nodes.

use nalgebra::{Cholesky, DMatrix};

/// Relative slack added to a certified bound of an `n`-node operator for the rounding of
/// the factorisation (module docs): `max(10⁻¹², 2 (20 + 3n) u)`, `u = 2⁻⁵³`.
pub fn rounding_slack(n: usize) -> f64 {
    let u = f64::EPSILON / 2.0;
    (2.0 * (20.0 + 3.0 * n as f64) * u).max(1e-12)
}

/// Whether every eigenvalue of the symmetric band matrix `C` is strictly below `mu`, i.e.
/// whether `μI − C` is positive definite (one `LDLᵀ` pass; module docs).
///
/// `diag[i] = C(i, i)` and `off[i] = [C(i, i+1), C(i, i+2)]`, indices wrapped on periodic grids
/// (the storage of [`super::NodalOperator`]). Non-finite entries or `mu` give `false`. Below
/// seven nodes (where periodic couplings can alias) the test runs on the dense matrix.
pub fn below_shift(diag: &[f64], off: &[[f64; 2]], periodic: bool, mu: f64) -> bool {
    let n = diag.len();
    if n == 0 {
        return mu > 0.0;
    }
    if off.len() != n || !mu.is_finite() {
        return false;
    }
    if n < 7 {
        return below_shift_dense(diag, off, periodic, mu);
    }
    positive_definite(n, periodic, |k| mu - diag[k], |k, j| off[k][j])
}

/// Whether every eigenvalue of `C = M^{1/2} K_N M^{1/2}` is strictly below `mu`, tested on
/// the pencil without forming `C`: `μI − C` is congruent, on the active nodes, to
/// `A = μ diag(m) − K_N` (`A = D (μI − C) D` with `D = diag(√m_i)`), so by Sylvester's law of
/// inertia one is positive definite exactly when the other is. Inactive nodes, where `C`
/// has zero rows and `μI − C` the pivot `μ`, get the row of the identity. One `LDLᵀ` pass, no
/// square root and no operator build — what an anchor needs when the stepper provides `K_N`.
///
/// **Rounding.** A completed factorisation is exact for `A + ΔA` with
/// `|ΔA_ij| ≤ γ_3 (|L| D |Lᵀ|)_ij ≤ γ_3 √(A_ii A_jj) ≤ γ_3 μ √(m_i m_j)` (Higham Thm 10.5;
/// Cauchy–Schwarz for the positive definite `A`; `A_ii ≤ μ m_i` since `K_ii ≥ 0`), so
/// `D⁻¹ΔA D⁻¹` has entries at most `γ_3 μ`, five per row, and the test proves
/// `λmax(C) < μ (1 + 15u)` inside the band, and the border adds what it adds to
/// [`below_shift`]: [`rounding_slack`] covers both.
///
/// `None` when the inputs do not fit (sizes; under seven nodes, where [`below_shift`] on the
/// assembled `C` runs instead); `Some(false)` for non-finite or non-positive values.
pub fn below_shift_pencil(
    k: &crate::NodalStiffness,
    mass: &[f64],
    active: &[bool],
    periodic: bool,
    mu: f64,
) -> Option<bool> {
    let n = k.diag.len();
    if n < 7 || k.off.len() != n || mass.len() != n || active.len() != n {
        return None;
    }
    if !mu.is_finite() {
        return Some(false);
    }
    let (kd, ko) = (&k.diag, &k.off);
    // An active node's neighbour j + 1 places on: wrapped (periodic), or past the end where
    // the storage holds zeros anyway (fixed).
    let coupled = |i: usize, j: usize| {
        let w = i + j + 1;
        active[i] && active[if w >= n { w - n } else { w }]
    };
    Some(positive_definite(
        n,
        periodic,
        |i| {
            if active[i] {
                mu * mass[i] - kd[i]
            } else {
                1.0
            }
        },
        |i, j| if coupled(i, j) { ko[i][j] } else { 0.0 },
    ))
}

/// The `LDLᵀ` positivity test of the symmetric pentadiagonal `A` with `A(k, k) = a(k)` and
/// `A(k, k+j+1) = −o(k, j)` (`j = 0, 1`, indices wrapped on periodic grids; `n ≥ 7`).
#[inline(always)]
fn positive_definite(
    n: usize,
    periodic: bool,
    a: impl Fn(usize) -> f64,
    o: impl Fn(usize, usize) -> f64,
) -> bool {
    // Leading block P: every node on a fixed grid; nodes 0..n−2 on a periodic one, whose two
    // last nodes form the border Q (they carry every wrapped coupling).
    let m = if periodic { n - 2 } else { n };
    let border = |k: usize| -> [f64; 2] {
        if !periodic {
            return [0.0; 2];
        }
        // A(n−2, k) and A(n−1, k) for k < n − 2.
        let mut b = [0.0; 2];
        if k == n - 4 {
            b[0] = -o(n - 4, 1);
        }
        if k == n - 3 {
            b[0] = -o(n - 3, 0);
            b[1] = -o(n - 3, 1);
        }
        if k == 0 {
            b[0] += -o(n - 2, 1);
            b[1] += -o(n - 1, 0);
        }
        if k == 1 {
            b[1] += -o(n - 1, 1);
        }
        b
    };
    // LDLᵀ of the pentadiagonal P (A(k,k−1) = e_k, A(k,k−2) = f_k), with r = 1/d:
    //   g_k = e_k − f_k l_{k−1},  l_k = g_k r_{k−1}  (= L(k,k−1)),
    //   d_k = a_k − g_k l_k − f_k² r_{k−2},
    // and the forward solve y_k = b_k − L(k,k−1) y_{k−1} − L(k,k−2) y_{k−2} of the border,
    // whose Schur complement is S = Q − Σ_k y_k y_kᵀ r_k (Haynsworth: inertia(A) =
    // inertia(P) + inertia(S)).
    let (mut r1, mut r2) = (0.0_f64, 0.0_f64); // r_{k−1}, r_{k−2}
    let mut l1 = 0.0_f64; // L(k−1, k−2)
    let (mut y1, mut y2) = ([0.0_f64; 2], [0.0_f64; 2]);
    let mut s = [0.0_f64; 3]; // Σ y yᵀ r: (0,0), (0,1), (1,1)
    for k in 0..m {
        let a = a(k);
        let e = if k >= 1 { -o(k - 1, 0) } else { 0.0 };
        let f = if k >= 2 { -o(k - 2, 1) } else { 0.0 };
        let g = e - f * l1;
        let l = g * r1;
        let d = a - g * l - f * f * r2;
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let r = 1.0 / d;
        if periodic {
            let lf = f * r2; // L(k, k−2)
            let b = border(k);
            let y = [b[0] - l * y1[0] - lf * y2[0], b[1] - l * y1[1] - lf * y2[1]];
            s[0] += y[0] * y[0] * r;
            s[1] += y[0] * y[1] * r;
            s[2] += y[1] * y[1] * r;
            y2 = y1;
            y1 = y;
        }
        r2 = r1;
        r1 = r;
        l1 = l;
    }
    if !periodic {
        return true;
    }
    let q00 = a(n - 2) - s[0];
    let q01 = -o(n - 2, 0) - s[1];
    let q11 = a(n - 1) - s[2];
    q00 > 0.0 && q00 * q11 - q01 * q01 > 0.0 && q11.is_finite()
}

/// [`below_shift`] on the assembled dense matrix (small grids, where periodic couplings of
/// distance 1 and 2 can land on the same pair of nodes and add up).
fn below_shift_dense(diag: &[f64], off: &[[f64; 2]], periodic: bool, mu: f64) -> bool {
    let n = diag.len();
    let a = DMatrix::<f64>::identity(n, n) * mu - band_to_dense(diag, off, periodic);
    a.iter().all(|v| v.is_finite()) && Cholesky::new(a).is_some()
}

/// The dense symmetric matrix of the band storage of [`below_shift`] (aliased couplings of a
/// small periodic grid added up).
fn band_to_dense(diag: &[f64], off: &[[f64; 2]], periodic: bool) -> DMatrix<f64> {
    let n = diag.len();
    let mut c = DMatrix::<f64>::zeros(n, n);
    for i in 0..n {
        c[(i, i)] += diag[i];
        for (o, &v) in off[i].iter().enumerate() {
            let j = i + o + 1;
            let j = if j < n {
                j
            } else if periodic {
                j % n
            } else {
                continue;
            };
            if j == i {
                // A self-coupling through the wrap (n ≤ 2): a diagonal contribution.
                c[(i, i)] += 2.0 * v;
            } else {
                c[(i, j)] += v;
                c[(j, i)] += v;
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
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
                    off: vec![[0.0; 2]; n],
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
                            k.off[(base + a) % n][b - a - 1] += kp * d[a] * d[b];
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
                    .map(|i| [1, 2].map(|j| k.off[i][j - 1] * s[i] * s[(i + j) % n]))
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
            off: vec![[0.0; 2]; 6],
            c2_ref: 1.0,
        };
        assert_eq!(
            below_shift_pencil(&k, &[1.0; 6], &[true; 6], true, 2.0),
            None
        );
        let mut k = crate::NodalStiffness {
            diag: vec![1.0; 9],
            off: vec![[0.1, 0.0]; 9],
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
        k.off[4][0] = f64::NAN;
        assert_eq!(
            below_shift_pencil(&k, &[1.0; 9], &[true; 9], true, 2.0),
            Some(false)
        );
    }

    #[test]
    fn non_finite_input_is_never_certified() {
        let diag = vec![1.0; 10];
        let mut off = vec![[0.1, 0.0]; 10];
        assert!(below_shift(&diag, &off, true, 2.0));
        off[4][0] = f64::NAN;
        assert!(!below_shift(&diag, &off, true, 2.0));
        assert!(!below_shift(&diag, &[[0.0; 2]; 10], true, f64::INFINITY));
    }
}
