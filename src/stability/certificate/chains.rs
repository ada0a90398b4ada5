//! The `LDLᵀ` positivity test of [`super::positive_definite`] as `C` chains eliminated side by
//! side ([`positive_definite_chains`]): the chains' layout, their forward elimination and
//! the positivity of the borders' Schur complement.

use super::Chain;

/// A missing border (before the first chain or after the last on a fixed grid).
const NONE: usize = usize::MAX;

/// [`super::positive_definite`] as `C` chains eliminated side by side. Borders of two nodes
/// cut the node lattice into `C` chains that do not couple to each other (the half-bandwidth
/// is 2): on a periodic grid `C` borders, the last `{n−2, n−1}`, each following its chain; on
/// a fixed grid the `C − 1` borders between the chains. Every chain is eliminated forward, all
/// in one loop, so their chains of dependent divisions overlap. A chain meets the border
/// before it at its first two nodes and the border after it at its last two, so its forward
/// solve carries two border columns along and two more at its end ([`Chain`]). The test is
/// then the positivity of the borders' Schur complement `S = Q − Σ_chains Σ y yᵀ/d`
/// (`2C × 2C` periodic, `2(C−1)` fixed) — Haynsworth: `inertia(A) = inertia(⊕ chains) +
/// inertia(S)`, and a failed pivot in a chain is a leading principal submatrix (of a
/// symmetric permutation of `A`) that is not positive definite. The same matrix, reordered:
/// the rounding analysis of the module docs of [`super`] holds with the borders' sums over
/// their chains.
/// Needs chains of at least two nodes (`n ≥ 4C` is plenty).
#[inline(always)]
pub(super) fn positive_definite_chains<const C: usize>(
    n: usize,
    periodic: bool,
    a: impl Fn(usize) -> f64,
    o: impl Fn(usize, usize) -> f64,
) -> bool {
    let layout = Layout::<C>::new(n, periodic);
    let Some(chains) = layout.eliminate(&a, &o) else {
        return false;
    };
    let q = layout.border_schur(&chains, &a, &o);
    dense_cholesky_positive(&q, 2 * layout.borders)
}

/// How [`positive_definite_chains`] cuts `n` nodes into `C` chains and the two-node borders
/// after them.
struct Layout<const C: usize> {
    n: usize,
    periodic: bool,
    /// The number of borders: `C` periodic, `C − 1` fixed.
    borders: usize,
    /// Chain `k`: `start[k] .. start[k] + len[k]`; border `k`: the two nodes after chain `k`.
    start: [usize; C],
    len: [usize; C],
}

impl<const C: usize> Layout<C> {
    /// The `n − 2·borders` chain nodes split evenly, the first `in_chains % C` chains one
    /// node longer, each chain followed by its border.
    #[inline(always)]
    fn new(n: usize, periodic: bool) -> Self {
        let borders = if periodic { C } else { C - 1 };
        let in_chains = n - 2 * borders;
        let mut start = [0usize; C];
        let mut len = [0usize; C];
        let mut at = 0;
        for k in 0..C {
            start[k] = at;
            len[k] = in_chains / C + usize::from(k < in_chains % C);
            at += len[k] + 2;
        }
        Layout {
            n,
            periodic,
            borders,
            start,
            len,
        }
    }

    /// Node `t` (0 or 1) of border `b`.
    #[inline(always)]
    fn border_node(&self, b: usize, t: usize) -> usize {
        self.start[b] + self.len[b] + t
    }

    /// The border before chain `k` ([`NONE`] at a fixed grid's start).
    #[inline(always)]
    fn before(&self, k: usize) -> usize {
        if k > 0 {
            k - 1
        } else if self.periodic {
            C - 1
        } else {
            NONE
        }
    }

    /// The border after chain `k` ([`NONE`] at a fixed grid's end).
    #[inline(always)]
    fn after(&self, k: usize) -> usize {
        if k + 1 < C || self.periodic {
            k
        } else {
            NONE
        }
    }

    /// The off-diagonal `A(i, j) = −o(lo, d − 1)` for nodes `d ≤ 2` apart (wrapped on
    /// periodic grids), 0 otherwise.
    #[inline(always)]
    fn coupling(&self, o: &impl Fn(usize, usize) -> f64, i: usize, j: usize) -> f64 {
        let (lo, hi) = if i < j { (i, j) } else { (j, i) };
        let d = hi - lo;
        if d <= 2 {
            -o(lo, d - 1)
        } else if self.periodic && self.n - d <= 2 {
            -o(hi, self.n - d - 1)
        } else {
            0.0
        }
    }

    /// The couplings of node `i` of chain `k` to its border columns
    /// `[before 0, before 1, after 0, after 1]` (0 where a border is missing).
    #[inline(always)]
    fn columns(&self, o: &impl Fn(usize, usize) -> f64, i: usize, k: usize) -> [f64; 4] {
        let mut b = [0.0; 4];
        for (c, border) in [self.before(k), self.after(k)].into_iter().enumerate() {
            if border != NONE {
                b[2 * c] = self.coupling(o, i, self.border_node(border, 0));
                b[2 * c + 1] = self.coupling(o, i, self.border_node(border, 1));
            }
        }
        b
    }

    /// The forward `LDLᵀ` elimination of every chain, node `j` of all chains in turn
    /// ([`Chain::step`] with `A(i, i−1) = e`, `A(i, i−2) = f`): the chains' final states, or
    /// `None` on a non-positive or non-finite pivot.
    #[inline(always)]
    fn eliminate(
        &self,
        a: &impl Fn(usize) -> f64,
        o: &impl Fn(usize, usize) -> f64,
    ) -> Option<[Chain; C]> {
        let mut chains = [Chain::START; C];
        // Node j of chain k (a macro rather than a closure so that the chain states can stay
        // in registers when the loop over the chains unrolls).
        macro_rules! step {
            ($k:expr, $j:expr) => {{
                let (k, j) = ($k, $j);
                let i = self.start[k] + j;
                let e = if j >= 1 { -o(i - 1, 0) } else { 0.0 };
                let f = if j >= 2 { -o(i - 2, 1) } else { 0.0 };
                let c = &mut chains[k];
                // Within two of the chain's end first: a short chain's node can be among the
                // first two and the last two, and then needs all four columns.
                if j + 2 >= self.len[k] {
                    c.step::<4>(a(i), e, f, self.columns(o, i, k))
                } else if j < 2 {
                    c.step::<2>(a(i), e, f, self.columns(o, i, k))
                } else {
                    c.step::<2>(a(i), e, f, [0.0; 4])
                }
            }};
        }
        // Every chain has at least `len[C − 1]` nodes; the first `in_chains % C` one more.
        let shortest = self.len[C - 1];
        for j in 0..shortest {
            let mut ok = true;
            for k in 0..C {
                ok &= step!(k, j);
            }
            if !ok {
                return None;
            }
        }
        for k in 0..C {
            if self.len[k] > shortest && !step!(k, shortest) {
                return None;
            }
        }
        Some(chains)
    }

    /// The borders' Schur complement `S = Q − Σ_chains Σ y yᵀ/d` (node `2b + t` for node `t`
    /// of border `b`; the leading `2·borders` rows and columns).
    #[inline(always)]
    fn border_schur(
        &self,
        chains: &[Chain; C],
        a: &impl Fn(usize) -> f64,
        o: &impl Fn(usize, usize) -> f64,
    ) -> [[f64; 2 * MAX_CHAINS]; 2 * MAX_CHAINS] {
        let m = 2 * self.borders;
        let mut q = [[0.0_f64; 2 * MAX_CHAINS]; 2 * MAX_CHAINS];
        let node = |x: usize| self.border_node(x / 2, x % 2);
        for (x, row) in q.iter_mut().enumerate().take(m) {
            for (y, entry) in row.iter_mut().enumerate().take(m) {
                *entry = if x == y {
                    a(node(x))
                } else {
                    self.coupling(o, node(x), node(y))
                };
            }
        }
        for (k, chain) in chains.iter().enumerate() {
            self.subtract_chain(&mut q, k, chain);
        }
        q
    }

    /// `Q −= Σ y yᵀ/d` of chain `k` ([`Chain`]'s `s`), scattered to its borders' rows and
    /// columns (both triangles).
    #[inline(always)]
    fn subtract_chain(
        &self,
        q: &mut [[f64; 2 * MAX_CHAINS]; 2 * MAX_CHAINS],
        k: usize,
        chain: &Chain,
    ) {
        // The chain's columns: [before 0, before 1, after 0, after 1].
        let slot = |c: usize| {
            let border = if c < 2 { self.before(k) } else { self.after(k) };
            (border != NONE).then(|| 2 * border + c % 2)
        };
        let mut idx = 0;
        for ci in 0..4 {
            for cj in ci..4 {
                if let (Some(x), Some(y)) = (slot(ci), slot(cj)) {
                    q[x][y] -= chain.s[idx];
                    if x != y {
                        q[y][x] -= chain.s[idx];
                    }
                }
                idx += 1;
            }
        }
    }
}

/// The most chains [`positive_definite_chains`] runs.
const MAX_CHAINS: usize = 4;

/// Whether the symmetric `q[..m][..m]` is positive definite (Cholesky by hand: every pivot
/// positive and finite).
fn dense_cholesky_positive(q: &[[f64; 2 * MAX_CHAINS]; 2 * MAX_CHAINS], m: usize) -> bool {
    let mut l = [[0.0_f64; 2 * MAX_CHAINS]; 2 * MAX_CHAINS];
    for i in 0..m {
        for j in 0..=i {
            let sum = (0..j).fold(q[i][j], |sum, k| sum - l[i][k] * l[j][k]);
            if i == j {
                if !(sum > 0.0 && sum.is_finite()) {
                    return false;
                }
                l[i][i] = sum.sqrt();
            } else {
                l[i][j] = sum / l[j][j];
            }
        }
    }
    true
}
