//! The phases of [`super::lanczos_on`]: the active components of the nodal vectors and
//! their sums ([`ActiveSpace`]), and the iteration's state ([`Iteration`]).

use super::{apply_planned, blocked, inverse_sqrt_mass, NodalSpace};
use crate::nd::ViewNd;
use crate::reduce::Reduce;
use crate::stability::lambda_max::{dot, top_ritz};

/// `start` with the components of inactive nodes zeroed (the operator ignores them).
pub(super) fn zero_inactive<const D: usize>(view: &ViewNd<'_, D>, start: &[f64]) -> Vec<f64> {
    let mut q: Vec<f64> = start.to_vec();
    for i in 0..view.n_nodes() {
        if !view.node_active[i] {
            for a in 0..D {
                q[i * D + a] = 0.0;
            }
        }
    }
    q
}

/// The active nodes' components of a view's nodal vectors, and the dot products over them.
///
/// The iteration runs on the active components only: every vector vanishes at inactive
/// nodes (the start is zeroed there and `A` reads and writes zero there), so the sums
/// are the full vectors' bit for bit, at the cost of the active part of the grid.
pub(super) struct ActiveSpace<'v, 'a, const D: usize> {
    pub space: NodalSpace<'v, 'a, D>,
    /// Indices `D·i + a` of the active nodes' components, in order.
    pub comps: Vec<usize>,
    /// Whether this process owns each of `comps` (a decomposed grid; else empty).
    owned: Vec<bool>,
}

impl<'v, 'a, const D: usize> ActiveSpace<'v, 'a, D> {
    /// The active components of `view` and its nodal space over `reduce`.
    pub fn new(view: &'v ViewNd<'a, D>, reduce: &'v dyn Reduce) -> Self {
        let space = NodalSpace::new(view, reduce);
        let comps: Vec<usize> = (0..view.n_nodes())
            .filter(|&i| view.node_active[i])
            .flat_map(|i| i * D..(i + 1) * D)
            .collect();
        let owned: Vec<bool> = match &view.split {
            Some(s) => comps.iter().map(|&c| s.owned[c / D]).collect(),
            None => Vec::new(),
        };
        Self {
            space,
            comps,
            owned,
        }
    }

    /// `aᵀb` over the whole grid for each `a` in `left` (one reduction in all).
    pub fn dots(&self, left: &[&[f64]], b: &[f64]) -> Vec<f64> {
        self.space.dots_counting(left, b, |k| self.owned[k])
    }

    /// `√(vᵀv)` over the whole grid.
    pub fn norm(&self, v: &[f64]) -> f64 {
        self.dots(&[v], v)[0].sqrt()
    }

    /// The active components of a full nodal vector.
    pub fn gather(&self, full: &[f64]) -> Vec<f64> {
        self.comps.iter().map(|&c| full[c]).collect()
    }
}

/// The state of a Lanczos run: the basis `q_0…q_k`, the tridiagonal's `α`, `β`, the latest
/// top Ritz pair and how long its value has stayed put.
pub(super) struct Iteration {
    basis: Vec<Vec<f64>>,
    alpha: Vec<f64>,
    beta: Vec<f64>,
    /// (Ritz value, residual bound, coordinates in the basis) of the latest iteration.
    best: (f64, f64, Vec<f64>),
    /// Consecutive iterations in which the Ritz value moved by less than `tol·λ/10`.
    settled_runs: usize,
}

impl Iteration {
    /// The iterations from the unit active vector `qc` (`n` the full vectors' length), with
    /// the products on `pool` ([`super::apply_scaled_on`]): `w = A q_k`, `α_k = q_kᵀw`,
    /// `q_{k+1} = w/β_k` with `w` fully reorthogonalised, until a stopping test is met.
    pub fn run<const D: usize>(
        pool: Option<&rayon::ThreadPool>,
        view: &ViewNd<'_, D>,
        active: &ActiveSpace<'_, '_, D>,
        mut qc: Vec<f64>,
        n: usize,
        tol: f64,
        max_iter: usize,
    ) -> Self {
        let mut qf = vec![0.0; n];
        let mut wf = vec![0.0; n];
        let inv_sqrt_m = inverse_sqrt_mass(view);
        // The blocked products' plan (slots, range vectors), formed once for the run.
        let mut plan = pool.and_then(|_| blocked::BlockedProduct::plan(view));
        let mut it = Self {
            basis: Vec::new(),
            alpha: Vec::new(),
            beta: Vec::new(),
            best: (0.0, f64::INFINITY, vec![1.0]),
            settled_runs: 0,
        };
        for k in 0..max_iter.max(1) {
            for (&c, &v) in active.comps.iter().zip(&qc) {
                qf[c] = v;
            }
            apply_planned(pool.zip(plan.as_mut()), view, &inv_sqrt_m, &qf, &mut wf);
            active.space.complete(&mut wf);
            let mut w = active.gather(&wf);
            let a = active.dots(&[&qc], &w)[0];
            it.basis.push(std::mem::take(&mut qc));
            it.alpha.push(a);
            it.reorthogonalise(view.split.is_some(), active, &mut w);
            let bnorm = active.norm(&w);
            if it.ritz_step(k, bnorm, tol, max_iter) {
                break;
            }
            it.beta.push(bnorm);
            qc = w.iter().map(|v| v / bnorm).collect();
        }
        it
    }

    /// `w ← w − Σ_j (q_jᵀw) q_j` over the basis, twice (full reorthogonalisation).
    fn reorthogonalise<const D: usize>(
        &self,
        decomposed: bool,
        active: &ActiveSpace<'_, '_, D>,
        w: &mut [f64],
    ) {
        // Full reorthogonalisation (twice is enough): modified Gram–Schmidt on an
        // undivided grid; classical (one reduction per pass) on a decomposed one.
        for _ in 0..2 {
            if decomposed {
                let refs: Vec<&[f64]> = self.basis.iter().map(|b| b.as_slice()).collect();
                let cs = active.dots(&refs, w);
                for (b, c) in self.basis.iter().zip(cs) {
                    w.iter_mut().zip(b).for_each(|(x, y)| *x -= c * y);
                }
            } else {
                for b in &self.basis {
                    let c = dot(b, w);
                    w.iter_mut().zip(b).for_each(|(x, y)| *x -= c * y);
                }
            }
        }
    }

    /// Records the top Ritz pair `(θ, y)` of the tridiagonal and its residual bound
    /// `β_k |y_k|`; whether iteration `k` is the last.
    fn ritz_step(&mut self, k: usize, bnorm: f64, tol: f64, max_iter: usize) -> bool {
        let (theta, y) = top_ritz(&self.alpha, &self.beta);
        let residual = bnorm * y.last().copied().unwrap_or(0.0).abs();
        let settled = (theta - self.best.0).abs() <= 0.1 * tol * theta.abs();
        self.settled_runs = if settled { self.settled_runs + 1 } else { 0 };
        self.best = (theta, residual, y);
        residual <= tol * theta.abs()
            || (k >= 2 && self.settled_runs >= 2)
            || bnorm <= 1e-14 * theta.abs()
            || k + 1 == max_iter
    }

    /// The latest Ritz value and its residual bound.
    pub fn value(&self) -> (f64, f64) {
        (self.best.0, self.best.1)
    }

    /// Products with `A` used.
    pub fn applications(&self) -> usize {
        self.alpha.len()
    }

    /// The Ritz vector `Σ_j y_j q_j`, normalised, back on the whole window of nodes (`n`
    /// entries).
    pub fn ritz_vector<const D: usize>(
        &self,
        active: &ActiveSpace<'_, '_, D>,
        n: usize,
    ) -> Vec<f64> {
        let mut v = vec![0.0; active.comps.len()];
        for (b, &c) in self.basis.iter().zip(&self.best.2) {
            v.iter_mut().zip(b).for_each(|(x, z)| *x += c * z);
        }
        let norm = active.norm(&v);
        if norm > 0.0 {
            v.iter_mut().for_each(|x| *x /= norm);
        }
        let mut vector = vec![0.0; n];
        for (&c, &x) in active.comps.iter().zip(&v) {
            vector[c] = x;
        }
        vector
    }
}
