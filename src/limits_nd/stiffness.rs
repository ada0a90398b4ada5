//! The eq 56 operator in d dimensions and its largest eigenvalue.
//!
//! Eq 56 says the stress part of the USL step amplifies a perturbation by `I − dt² M⁻¹K`
//! (in 1D `I − E dt²/h² D*F`). In d dimensions (docs/design.md, "Stability in d dimensions") `K` is
//! the nodal stiffness on the `d·n_nodes` nodal velocity space,
//!
//! ```text
//! K = Σ_p V_p B_pᵀ C_p B_p,   (B_p u) = sym(Σ_i u_i ⊗ ∇S_ip),   C_p ε = λ_t tr(ε) I + 2 μ_t ε,
//! ```
//!
//! with `V_p = det(F_p) V⁰_p` and `M` the lumped nodal masses (active nodes only). `M⁻¹K`
//! is similar to the symmetric positive semi-definite `A = M^{-1/2} K M^{-1/2}`, so its
//! eigenvalues are real and `ρ(I − dt² M⁻¹K) ≤ 1 ⇔ dt² λmax ≤ 2`:
//! `dt_eq56 = √(2/λmax)`. [`apply`] computes `A u` matrix-free in one pass over the
//! particles' weights (the cost of about one particle → grid pass); [`lanczos()`] finds
//! `λmax(A)` from a few such products; [`dense`] assembles `A` for small problems.

use crate::nd::ViewNd;

mod blocked;
mod krylov;
mod rows;
#[cfg(all(test, feature = "reference"))]
mod test_layout;
use crate::lanczos::{self, dot, Settle};
use crate::reduce::{Reduce, SingleProcess};
use faer::Mat;
use krylov::{ActiveOperator, ActiveSpace};

/// `M^{-1/2}` on the nodes: `1/√m_i` at active nodes, 0 elsewhere (inactive nodes drop out
/// of the operator).
pub fn inverse_sqrt_mass<const D: usize>(view: &ViewNd<'_, D>) -> Vec<f64> {
    view.node_mass
        .iter()
        .zip(view.node_active)
        .map(|(&m, &a)| if a { 1.0 / m.sqrt() } else { 0.0 })
        .collect()
}

/// `y = A u` with `A = M^{-1/2} K M^{-1/2}` (module docs); `u`, `y` hold `D` components per
/// node, node-major. Inactive nodes read and write zero.
pub fn apply<const D: usize>(view: &ViewNd<'_, D>, u: &[f64], y: &mut [f64]) {
    apply_scaled(view, &inverse_sqrt_mass(view), u, y);
}

/// [`apply`] with `M^{-1/2}` given ([`inverse_sqrt_mass`]), on the calling thread: the
/// particles' parts added in index order. A particle's `(V_p λ_t, V_p μ_t)`,
/// `V_p = det(F_p) V⁰_p`, is formed in the product, as its weight row is: repeated products
/// keep no per-particle array.
pub fn apply_scaled<const D: usize>(
    view: &ViewNd<'_, D>,
    inv_sqrt_m: &[f64],
    u: &[f64],
    y: &mut [f64],
) {
    apply_scaled_on(None, view, inv_sqrt_m, u, y);
}

/// [`apply_scaled`] on `pool` where given and the layout is large and dense enough (at
/// least 16 384 particles and at most half an active node per particle): the particles in
/// 8 fixed ranges, each summed into a vector of its own over the active nodes, the vectors
/// then added in range order: the same bits on any number of threads, round-off away from
/// the one-range sum. The 8 vectors are held for the product (through a whole Lanczos run
/// in [`lanczos_on`]): 32 B per particle on a 2D wave of 2 particles per cell and axis,
/// 24 B in 3D, about as much for bodies in a box (only their active nodes count).
pub fn apply_scaled_on<const D: usize>(
    pool: Option<&rayon::ThreadPool>,
    view: &ViewNd<'_, D>,
    inv_sqrt_m: &[f64],
    u: &[f64],
    y: &mut [f64],
) {
    let mut plan = pool.and_then(|_| blocked::BlockedProduct::plan(view));
    apply_planned(pool.zip(plan.as_mut()), view, inv_sqrt_m, u, y);
}

/// [`apply_scaled_on`] with the blocked product's plan formed by the caller (once per
/// Lanczos run), or on the calling thread without one.
fn apply_planned<const D: usize>(
    blocked: Option<(&rayon::ThreadPool, &mut blocked::BlockedProduct)>,
    view: &ViewNd<'_, D>,
    inv_sqrt_m: &[f64],
    u: &[f64],
    y: &mut [f64],
) {
    let nn = view.n_nodes();
    debug_assert!(u.len() == nn * D && y.len() == nn * D && inv_sqrt_m.len() == nn);
    match blocked {
        Some((pool, plan)) => plan.apply(pool, view, inv_sqrt_m, u, y),
        _ => {
            y.fill(0.0);
            let fields = blocked::ProductFields::of(view);
            blocked::add_range(&fields, inv_sqrt_m, u, 0..view.n_particles(), y, None);
        }
    }
}

/// `max_{i,a} A_(ia),(ia)`, the largest diagonal entry of `A` (module docs): the Rayleigh
/// quotient of a unit velocity at one node, a lower bound on `λmax(A)` that carries the
/// small-nodal-mass mechanism (a light node's row). For the isotropic `C_p`, with
/// `g = ∇S_ip`,
///
/// ```text
/// K_(ia),(ia) = Σ_p V_p [(λ_t + μ_t) g_a² + μ_t |g|²],   A_(ia),(ia) = K_(ia),(ia) / m_i.
/// ```
///
/// One pass over the particles' weight gradients, about a third of an [`apply`]. Returns
/// the largest entry and where it is: the index `D·i + a` of node `i`, component `a` (0
/// when no node is active). In a run split over processes ([`crate::reduce`]) the view
/// holds this process's particles and the global nodal masses; the diagonal sums are
/// completed with `reduce`, so every process returns the same (pass
/// [`SingleProcess`] otherwise).
pub fn diagonal_argmax<const D: usize>(view: &ViewNd<'_, D>, reduce: &dyn Reduce) -> (f64, usize) {
    let space = NodalSpace::new(view, reduce);
    let mut diag = vec![0.0; view.n_nodes() * D];
    let w = &view.weights;
    for p in 0..view.n_particles() {
        let vol = view.volume(p);
        let (l, m) = (view.lame_lambda[p], view.lame_mu[p]);
        // Entry by entry, in row order: no row is laid out on the stack.
        w.for_each_in_row(p, |i, _, g| {
            let g2 = g.norm_squared();
            for a in 0..D {
                diag[i * D + a] += vol * ((l + m) * g[a] * g[a] + m * g2);
            }
        });
    }
    space.complete(&mut diag);
    // The largest entry over the whole grid, then the lowest whole-grid index among the
    // entries within `NEAR_TIE` of it: sums completed in another order (a split run)
    // differ in the last bits, and uniform layouts have many equal entries, so a strict
    // argmax would pick a different node on a different split.
    let entry = |i: usize, a: usize| diag[i * D + a] / view.node_mass[i];
    let counted = |i: usize| view.node_active[i] && space.owns(i);
    let mut largest = 0.0f64;
    for i in (0..view.n_nodes()).filter(|&i| counted(i)) {
        for a in 0..D {
            let d = entry(i, a);
            // A NaN is picked up and then kept, so that it propagates.
            if d.is_nan() || (!largest.is_nan() && d > largest) {
                largest = d;
            }
        }
    }
    let largest = space.agree_on_max(largest);
    let mut at = usize::MAX;
    for i in (0..view.n_nodes()).filter(|&i| counted(i)) {
        for a in 0..D {
            let d = entry(i, a);
            let near = if largest.is_nan() {
                d.is_nan()
            } else {
                d >= largest * (1.0 - NEAR_TIE)
            };
            if near {
                at = at.min(space.global(i) * D + a);
            }
        }
    }
    (largest, space.agree_on_min_index(at))
}

/// Relative closeness below which two diagonal entries count as tied
/// ([`diagonal_argmax`]).
const NEAR_TIE: f64 = 1e-9;

/// How the nodal vectors of a view are completed and contracted when the run is split
/// over processes ([`crate::reduce`]): by the view's halo and over owned nodes when the
/// grid is decomposed ([`ViewNd::split`]); by a sum over the processes of whole-grid
/// vectors when the particles are split and the grid is not; trivially on one process.
pub struct NodalSpace<'v, 'a, const D: usize> {
    view: &'v ViewNd<'a, D>,
    reduce: &'v dyn Reduce,
}

impl<'v, 'a, const D: usize> NodalSpace<'v, 'a, D> {
    /// The nodal space of `view` over the processes of `reduce` — on a decomposed grid
    /// ([`ViewNd::split`]) over the split's own processes, whatever `reduce` says.
    pub fn new(view: &'v ViewNd<'a, D>, reduce: &'v dyn Reduce) -> Self {
        let reduce = match &view.split {
            Some(s) => s.halo.reduce(),
            None => reduce,
        };
        Self { view, reduce }
    }

    /// Completes a sum of this process's particles' contributions (`D` per node).
    pub fn complete(&self, y: &mut [f64]) {
        match &self.view.split {
            Some(s) => s.halo.complete(y, D),
            None => self.reduce.sum(y),
        }
    }

    /// Whether this process counts local node `i` in sums over nodes.
    pub fn owns(&self, i: usize) -> bool {
        self.view.split.as_ref().is_none_or(|s| s.owned[i])
    }

    /// Index in the whole grid of local node `i`.
    pub fn global(&self, i: usize) -> usize {
        self.view
            .split
            .as_ref()
            .map_or(i, |s| s.global_node[i] as usize)
    }

    /// Number of nodes of the whole grid.
    pub fn global_nodes(&self) -> usize {
        self.view
            .split
            .as_ref()
            .map_or(self.view.n_nodes(), |s| s.whole.n_nodes())
    }

    /// `aᵀb` over the whole grid, for each `a` in `left` (one reduction in all).
    pub fn dots(&self, left: &[&[f64]], b: &[f64]) -> Vec<f64> {
        self.dots_counting(left, b, |c| {
            self.view.split.as_ref().is_none_or(|s| s.owned[c / D])
        })
    }

    /// `aᵀb` for each `a` in `left`, over entries `k` with `counted(k)` — this process's
    /// owned entries, of vectors laid out as it likes — then over the processes of a
    /// decomposed grid (one reduction in all). On an undivided grid every entry counts and
    /// `counted` is not asked.
    pub fn dots_counting(
        &self,
        left: &[&[f64]],
        b: &[f64],
        counted: impl Fn(usize) -> bool,
    ) -> Vec<f64> {
        if self.view.split.is_none() {
            return left.iter().map(|a| dot(a, b)).collect();
        }
        lanczos::reduced_dots(left, b, counted, self.reduce)
    }

    /// `aᵀb` over the whole grid.
    pub fn dot(&self, a: &[f64], b: &[f64]) -> f64 {
        self.dots(&[a], b)[0]
    }

    /// The largest of the processes' values (a NaN anywhere wins); the same on every
    /// process.
    fn agree_on_max(&self, mine: f64) -> f64 {
        if self.view.split.is_none() {
            return mine;
        }
        let (neg, nan) = self
            .reduce
            .min_and_any(if mine.is_nan() { 0.0 } else { -mine }, mine.is_nan());
        if nan {
            f64::NAN
        } else {
            -neg
        }
    }

    /// The smallest of the processes' indices (`usize::MAX` for none; 0 when no process
    /// has one).
    fn agree_on_min_index(&self, mine: usize) -> usize {
        let value = if mine == usize::MAX {
            f64::INFINITY
        } else {
            mine as f64
        };
        let (at, _) = match self.view.split {
            Some(_) => self.reduce.min_and_any(value, false),
            None => (value, false),
        };
        if at.is_finite() {
            at as usize
        } else {
            0
        }
    }
}

/// The dense `A` (module docs), `d·n_nodes` square, for small problems and tests.
pub fn dense<const D: usize>(view: &ViewNd<'_, D>) -> Mat<f64> {
    let n = view.n_nodes() * D;
    let mut a = Mat::<f64>::zeros(n, n);
    let mut e = vec![0.0; n];
    let mut col = vec![0.0; n];
    let inv_sqrt_m = inverse_sqrt_mass(view);
    for j in 0..n {
        e.fill(0.0);
        e[j] = 1.0;
        apply_scaled(view, &inv_sqrt_m, &e, &mut col);
        for (i, &c) in col.iter().enumerate() {
            a[(i, j)] = c;
        }
    }
    a
}

/// The largest eigenvalue of the dense `A` (faer's symmetric eigen solver).
pub fn dense_lambda_max<const D: usize>(view: &ViewNd<'_, D>) -> Option<f64> {
    let a = dense(view);
    let eig = a.self_adjoint_eigenvalues(faer::Side::Lower).ok()?;
    eig.into_iter()
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
}

/// Result of a Lanczos run.
#[derive(Clone, Debug)]
pub struct LanczosResult {
    /// The largest Ritz value (a lower bound on `λmax(A)`).
    pub lambda: f64,
    /// Its residual bound `β_k |y_k|` (the distance to an eigenvalue is at most this).
    pub residual: f64,
    /// The Ritz vector (unit 2-norm), a warm start for the next run.
    pub vector: Vec<f64>,
    /// Products with `A` used.
    pub applications: usize,
}

/// Lanczos with full reorthogonalisation for `λmax(A)` (the crate's Lanczos iteration,
/// `src/lanczos.rs`, in the Euclidean inner product of the active components), from `start`
/// (any non-zero vector; a previous Ritz vector makes it fast). Its value is a Ritz value, a
/// lower bound on `λmax(A)` that rises to it as the Krylov space grows. Stops when the residual bound of the largest Ritz
/// value is below `tol · λ`, or when the Ritz value changed by less than `tol · λ / 10` in two
/// iterations running (it converges much faster than the vector when the top of the spectrum is a
/// cluster, as on uniform layouts), or after `max_iter` products.
pub fn lanczos<const D: usize>(
    view: &ViewNd<'_, D>,
    start: &[f64],
    tol: f64,
    max_iter: usize,
) -> LanczosResult {
    lanczos_reduced(view, start, tol, max_iter, &SingleProcess)
}

/// [`lanczos()`] for a run split over processes ([`crate::reduce`]): each product `A u` is
/// this process's particles' part, completed over the processes ([`NodalSpace`]: a sum of
/// whole-grid vectors when the grid is not decomposed, the view's halo when it is, with
/// dot products over owned nodes). Every scalar of the iteration is then the same on every
/// process, so its stopping test and its result are too (every process must call it
/// together).
pub fn lanczos_reduced<const D: usize>(
    view: &ViewNd<'_, D>,
    start: &[f64],
    tol: f64,
    max_iter: usize,
    reduce: &dyn Reduce,
) -> LanczosResult {
    lanczos_on(None, view, start, tol, max_iter, reduce)
}

/// [`lanczos_reduced`] with its products on `pool` ([`apply_scaled_on`]): the same result
/// bit for bit on any number of the pool's threads.
///
/// Where a product runs on the calling thread (no pool, or a layout too small to block)
/// and the view's weights are formed, the first product keeps the rows and moduli it
/// forms for the others, up to 2²⁰ row entries (`4 + 8·D` bytes an entry at an active
/// node, 20 a particle, freed at the end of the run): each product is
/// [`apply_scaled`]'s bit for bit, at about half its cost on a small GIMP layout.
pub fn lanczos_on<const D: usize>(
    pool: Option<&rayon::ThreadPool>,
    view: &ViewNd<'_, D>,
    start: &[f64],
    tol: f64,
    max_iter: usize,
    reduce: &dyn Reduce,
) -> LanczosResult {
    let n = start.len();
    let q = krylov::zero_inactive(view, start);
    let active = ActiveSpace::new(view, reduce);
    let qc = active.gather(&q);
    let mut op = ActiveOperator::new(pool, view, &active, n);
    let norm = lanczos::norm(&mut op, &qc, &mut Vec::new());
    if !(norm > 0.0 && norm.is_finite()) {
        return LanczosResult {
            lambda: 0.0,
            residual: 0.0,
            vector: q,
            applications: 0,
        };
    }
    let mut work = lanczos::Work::default();
    work.start(qc.len(), &qc, None, norm);
    // Settled: within `tol/10` in two evaluations running, from the third iteration on.
    let mut rule = Settle::new(tol, 0.1 * tol, (2, 2), 1e-14, 0.0);
    let full = lanczos::Orthogonalise::Full;
    let Ok(top) = lanczos::run(
        &mut op,
        &mut work,
        qc.len(),
        max_iter.max(1),
        full,
        &mut rule,
    ) else {
        unreachable!("no metric, and this rule takes any value");
    };
    let vector = work.ritz_vector(&top.y, active.inner(), Vec::new(), qc.len());
    LanczosResult {
        lambda: top.theta,
        residual: top.residual,
        vector: active.scatter(&vector, n),
        applications: top.applications,
    }
}

/// `λmax(M⁻¹K)` of a view by Lanczos to a relative residual of `1e-10`, from the
/// stability limit's cold start (checkerboards with seeded noise), in at most 150
/// products — 60 above 10⁵ unknowns, where the fully reorthogonalised basis would cost
/// seconds and a gigabyte (the value has settled far below the limits' tolerance by then;
/// the residual of a clustered top converges much more slowly than the value).
pub fn lambda_max<const D: usize>(view: &ViewNd<'_, D>) -> f64 {
    let n = view.n_nodes() * D;
    let space = NodalSpace::new(view, &crate::reduce::SingleProcess);
    let start = super::start::checkerboard_start(view, &space);
    let max_iter = if n > 100_000 { 60 } else { 150 };
    let r = lanczos(view, &start, 1e-10, max_iter.min(n.max(1)));
    r.lambda
}
