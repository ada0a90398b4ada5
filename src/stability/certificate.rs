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
//! **Rounding.** A Cholesky (`LDLᵀ`) factorisation that completes in floating point is the
//! exact factorisation of `A + ΔA` with `|ΔA| ≤ γ_{w+1} |L||Lᵀ|` (Higham, *Accuracy and
//! Stability of Numerical Algorithms*, Thm 10.5, `w = 2` the half-bandwidth, `γ_k ≈ k u`),
//! and for a positive definite `A` the entries of `|L||Lᵀ|` are at most `max_i A_ii`; with at
//! most 5 non-zeros per row `‖ΔA‖₂ ≤ 15 u μ`. A successful test therefore proves
//! `λmax(C) < μ (1 + 15u)`; [`ROUNDING`] adds that slack to every certified bound.

use nalgebra::{Cholesky, DMatrix};

/// Relative slack added to a certified bound for the rounding of the factorisation (module
/// docs: `15 u ≈ 3.3·10⁻¹⁵`, rounded up generously).
pub const ROUNDING: f64 = 1e-12;

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
    // Leading block P: every node on a fixed grid; nodes 0..n−2 on a periodic one, whose two
    // last nodes form the border Q (they carry every wrapped coupling).
    let m = if periodic { n - 2 } else { n };
    let border = |k: usize| -> [f64; 2] {
        if !periodic {
            return [0.0; 2];
        }
        // A(n−2, k) and A(n−1, k) of A = μI − C for k < n − 2.
        let mut b = [0.0; 2];
        if k == n - 4 {
            b[0] = -off[n - 4][1];
        }
        if k == n - 3 {
            b[0] = -off[n - 3][0];
            b[1] = -off[n - 3][1];
        }
        if k == 0 {
            b[0] += -off[n - 2][1];
            b[1] += -off[n - 1][0];
        }
        if k == 1 {
            b[1] += -off[n - 1][1];
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
        let a = mu - diag[k];
        let e = if k >= 1 { -off[k - 1][0] } else { 0.0 };
        let f = if k >= 2 { -off[k - 2][1] } else { 0.0 };
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
    let q00 = mu - diag[n - 2] - s[0];
    let q01 = -off[n - 2][0] - s[1];
    let q11 = mu - diag[n - 1] - s[2];
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
    fn non_finite_input_is_never_certified() {
        let diag = vec![1.0; 10];
        let mut off = vec![[0.1, 0.0]; 10];
        assert!(below_shift(&diag, &off, true, 2.0));
        off[4][0] = f64::NAN;
        assert!(!below_shift(&diag, &off, true, 2.0));
        assert!(!below_shift(&diag, &[[0.0; 2]; 10], true, f64::INFINITY));
    }
}
