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
//! block sums over the whole chain (`γ_{m+2} μ` per entry). In all, for one chain of `n`
//! nodes, `‖ΔA‖₂ ≤ (19 + 6√n + 2n) u μ`. The elimination in `C ≤ 4` chains side by side used
//! from 16 nodes on adds borders: their `2C` columns (the fill of each chain's forward solve,
//! 3-term inner products) have Frobenius norm at most `3 √(2Cn) u μ`, and the `2C × 2C`
//! border block, whose entries sum over at most two chains (`≤ 2n/C + 8` terms with its own
//! Cholesky), at most `(4n + 16C) u μ`: `(79 + 8.5√n + 4n) u μ` in all. Each bound is at most
//! `2 (20 + 3n) u μ` from `n = 50` on, and below 1500 nodes the floor `10⁻¹²` (about `9000 u`)
//! is larger still, so a successful test proves `λmax(C) < μ (1 + slack)` with
//! [`rounding_slack`] `= max(10⁻¹², 2 (20 + 3n) u)` added to every certified bound —
//! `3·10⁻¹¹` relative at `5·10⁴` nodes. A *failed* test proves `λmax ≥ μ` only up to the
//! same rounding; the trackers use failures to steer a search, never as a bound they serve.

use nalgebra::{Cholesky, DMatrix};

mod chains;

use chains::positive_definite_chains;

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
/// Forming `A_ii = μ m_i − K_ii` rounds twice, `|ΔA_ii| ≤ 2u (μ m_i + K_ii) ≤ 4u μ m_i`
/// (`K_ii < μ m_i` when `A` is positive definite): `4u` more, also inside the slack.
///
/// `None` when the inputs do not fit (sizes; under seven nodes, where [`below_shift`] on the
/// assembled `C` runs instead); `Some(false)` for non-finite or non-positive values. Several
/// shifts on one state: [`Pencil`] prepares the bands once.
pub fn below_shift_pencil(
    k: &crate::NodalStiffness,
    mass: &[f64],
    active: &[bool],
    periodic: bool,
    mu: f64,
) -> Option<bool> {
    let mut pencil = Pencil::default();
    pencil
        .prepare(k, mass, active, periodic)
        .then(|| pencil.below_shift(mu))
}

/// The bands of the pencil `μ diag(m) − K_N` of [`below_shift_pencil`] with the node activity
/// folded in, prepared once per state for any number of shifts: `A_ii = μ m'_i − k'_i` with
/// `(m'_i, k'_i) = (m_i, K_ii)` at active nodes and `(0, −1)` at inactive ones (so the pivot
/// there is exactly 1), couplings zero unless both nodes are active. One pass over the nodes;
/// each [`Self::below_shift`] is then the same `LDLᵀ` pass as [`below_shift`] on `C`.
#[derive(Clone, Debug, Default)]
pub struct Pencil {
    mass: Vec<f64>,
    diag: Vec<f64>,
    off: Vec<[f64; 2]>,
    periodic: bool,
}

impl Pencil {
    /// Prepares the bands of one state; `false` (and nothing to test) when the sizes do not
    /// fit or there are under seven nodes.
    pub fn prepare(
        &mut self,
        k: &crate::NodalStiffness,
        mass: &[f64],
        active: &[bool],
        periodic: bool,
    ) -> bool {
        let n = k.diag.len();
        self.mass.clear();
        self.diag.clear();
        self.off.clear();
        if n < 7 || !k.has_len(n) || mass.len() != n || active.len() != n {
            return false;
        }
        self.periodic = periodic;
        let select = |a: bool, x: f64, otherwise: f64| if a { x } else { otherwise };
        self.mass
            .extend(mass.iter().zip(active).map(|(&m, &a)| select(a, m, 0.0)));
        self.diag
            .extend(k.diag.iter().zip(active).map(|(&d, &a)| select(a, d, -1.0)));
        // Node i couples to i + 1 and i + 2 (wrapped; past a fixed grid's end the storage
        // holds zeros anyway).
        let at = |w: usize| active[if w >= n { w - n } else { w }];
        let uppers = k.upper1.iter().zip(&k.upper2);
        self.off.extend(uppers.enumerate().map(|(i, (&u1, &u2))| {
            let a = active[i];
            [
                select(a && at(i + 1), u1, 0.0),
                select(a && at(i + 2), u2, 0.0),
            ]
        }));
        true
    }

    /// Whether every eigenvalue of `C` of the prepared state is strictly below `mu` (see
    /// [`below_shift_pencil`]); `false` when nothing is prepared or for non-finite values.
    pub fn below_shift(&self, mu: f64) -> bool {
        let n = self.diag.len();
        if n < 7 || !mu.is_finite() {
            return false;
        }
        let (m, d, o) = (&self.mass[..n], &self.diag[..n], &self.off[..n]);
        positive_definite(n, self.periodic, |k| mu * m[k] - d[k], |k, j| o[k][j])
    }
}

/// The `LDLᵀ` positivity test of the symmetric pentadiagonal `A` with `A(k, k) = a(k)` and
/// `A(k, k+j+1) = −o(k, j)` (`j = 0, 1`, indices wrapped on periodic grids; `n ≥ 7`): from
/// [`SPLIT_MIN`] nodes on as two chains eliminated side by side
/// ([`positive_definite_chains`]), below that as one ([`positive_definite_chain`]). Two
/// chains run 2.06× faster than one on 5·10⁴ nodes (308 against 634 µs, one run); three and
/// four measured slower than two (814 µs and 460–700 µs against 365 µs in one loaded run):
/// their chain states no longer fit the registers.
#[inline(always)]
fn positive_definite(
    n: usize,
    periodic: bool,
    a: impl Fn(usize) -> f64,
    o: impl Fn(usize, usize) -> f64,
) -> bool {
    if n >= SPLIT_MIN {
        positive_definite_chains::<2>(n, periodic, a, o)
    } else {
        positive_definite_chain(n, periodic, a, o)
    }
}

/// Nodes from which [`positive_definite`] splits the elimination into chains.
const SPLIT_MIN: usize = 16;

/// One chain of an `LDLᵀ` elimination in progress: the last two reciprocal pivots and
/// multiplier, and the forward solve `y` of the border columns (`[B1₀, B1₁, B2₀, B2₁]`) with
/// the Schur complement's accumulated `Σ y yᵀ/d` (upper triangle of 4 × 4, row by row).
#[derive(Clone, Copy)]
struct Chain {
    r1: f64,
    r2: f64,
    l1: f64,
    y1: [f64; 4],
    y2: [f64; 4],
    s: [f64; 10],
}

impl Chain {
    const START: Chain = Chain {
        r1: 0.0,
        r2: 0.0,
        l1: 0.0,
        y1: [0.0; 4],
        y2: [0.0; 4],
        s: [0.0; 10],
    };

    /// Eliminates the next node: its diagonal `a`, its couplings `e`, `f` to the previous two
    /// nodes of the chain, and its border couplings `b`; `BORDER` = how many of the border
    /// columns can be non-zero from here on (0: none, 2: `B1` only, 4: both). `false` on a
    /// non-positive or non-finite pivot.
    #[inline(always)]
    fn step<const BORDER: usize>(&mut self, a: f64, e: f64, f: f64, b: [f64; 4]) -> bool {
        let g = e - f * self.l1;
        let l = g * self.r1;
        let d = a - g * l - f * f * self.r2;
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let r = 1.0 / d;
        let lf = f * self.r2;
        let mut y = [0.0; 4];
        for c in 0..BORDER {
            y[c] = b[c] - l * self.y1[c] - lf * self.y2[c];
        }
        let mut idx = 0;
        for i in 0..BORDER {
            for j in i..4 {
                if j < BORDER {
                    self.s[idx] += y[i] * y[j] * r;
                }
                idx += 1;
            }
        }
        self.y2 = self.y1;
        self.y1 = y;
        self.r2 = self.r1;
        self.r1 = r;
        self.l1 = l;
        true
    }
}

/// [`positive_definite`] as one chain (the nodes in order, the periodic border last).
#[inline(always)]
fn positive_definite_chain(
    n: usize,
    periodic: bool,
    a: impl Fn(usize) -> f64,
    o: impl Fn(usize, usize) -> f64,
) -> bool {
    // Leading block P: every node on a fixed grid; nodes 0..n−2 on a periodic one, whose two
    // last nodes form the border Q (they carry every wrapped coupling).
    let m = if periodic { n - 2 } else { n };
    // Called on periodic grids only.
    let border = |k: usize| -> [f64; 2] {
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
    // LDLᵀ of the pentadiagonal P by [`Chain::step`] (A(k,k−1) = e_k, A(k,k−2) = f_k), with
    // the forward solve of the two border columns on a periodic grid, whose Schur complement
    // is S = Q − Σ_k y_k y_kᵀ r_k (Haynsworth: inertia(A) = inertia(P) + inertia(S)).
    let mut chain = Chain::START;
    for k in 0..m {
        let e = if k >= 1 { -o(k - 1, 0) } else { 0.0 };
        let f = if k >= 2 { -o(k - 2, 1) } else { 0.0 };
        let ok = if periodic {
            let [b0, b1] = border(k);
            chain.step::<2>(a(k), e, f, [b0, b1, 0.0, 0.0])
        } else {
            chain.step::<0>(a(k), e, f, [0.0; 4])
        };
        if !ok {
            return false;
        }
    }
    if !periodic {
        return true;
    }
    // Σ y yᵀ r of the two columns: entries (0,0), (0,1), (1,1) of `Chain::s`.
    let q00 = a(n - 2) - chain.s[0];
    let q01 = -o(n - 2, 0) - chain.s[1];
    let q11 = a(n - 1) - chain.s[4];
    q00 > 0.0 && q00.is_finite() && q00 * q11 - q01 * q01 > 0.0 && q11.is_finite()
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
mod tests;
