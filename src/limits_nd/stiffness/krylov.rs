//! The operator of [`super::lanczos_on`] for the crate's Lanczos iteration
//! (`src/lanczos.rs`): the active components of the nodal vectors and their sums
//! ([`ActiveSpace`]), and the products `A u` on them ([`ActiveOperator`]).

use super::rows::FormedRows;
use super::{apply_planned, blocked, inverse_sqrt_mass, NodalSpace};
use crate::lanczos::{self, Inner};
use crate::nd::ViewNd;
use crate::reduce::Reduce;

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

    /// The inner product of active vectors: over the whole grid, so on a decomposed grid
    /// over the owned components, summed over its processes.
    pub fn inner(&self) -> Inner<'_> {
        match self.space.view.split {
            Some(_) => Inner::over(self.space.reduce, &self.owned),
            None => Inner::local(),
        }
    }

    /// The active components of a full nodal vector.
    pub fn gather(&self, full: &[f64]) -> Vec<f64> {
        self.comps.iter().map(|&c| full[c]).collect()
    }

    /// The full nodal vector (`n` entries) of active components `v`.
    pub fn scatter(&self, v: &[f64], n: usize) -> Vec<f64> {
        let mut full = vec![0.0; n];
        for (&c, &x) in self.comps.iter().zip(v) {
            full[c] = x;
        }
        full
    }
}

/// `A u` on the active components (`n` the full vectors' length), with the products on
/// `pool` ([`super::apply_scaled_on`]) and completed over the processes.
pub(super) struct ActiveOperator<'s, 'v, 'a, const D: usize> {
    pool: Option<&'s rayon::ThreadPool>,
    view: &'v ViewNd<'a, D>,
    active: &'s ActiveSpace<'v, 'a, D>,
    inv_sqrt_m: Vec<f64>,
    /// The blocked products' plan (slots, range vectors), formed once for the run.
    plan: Option<blocked::BlockedProduct>,
    /// Without a plan, the rows the first product forms, kept for the others.
    rows: Option<FormedRows<D>>,
    qf: Vec<f64>,
    wf: Vec<f64>,
}

impl<'s, 'v, 'a, const D: usize> ActiveOperator<'s, 'v, 'a, D> {
    /// The operator of `view` on `active`'s components.
    pub fn new(
        pool: Option<&'s rayon::ThreadPool>,
        view: &'v ViewNd<'a, D>,
        active: &'s ActiveSpace<'v, 'a, D>,
        n: usize,
    ) -> Self {
        let plan = pool.and_then(|_| blocked::BlockedProduct::plan(view));
        // Otherwise the rows the first product forms, kept for the others (`super::rows`).
        let rows = plan.is_none().then(|| FormedRows::for_view(view)).flatten();
        Self {
            pool,
            view,
            active,
            inv_sqrt_m: inverse_sqrt_mass(view),
            plan,
            rows,
            qf: vec![0.0; n],
            wf: vec![0.0; n],
        }
    }
}

impl<const D: usize> lanczos::Operator for ActiveOperator<'_, '_, '_, D> {
    fn inner(&self) -> Inner<'_> {
        self.active.inner()
    }

    fn apply(&mut self, x: &[f64], _bx: &[f64], y: &mut [f64]) {
        let comps = &self.active.comps;
        for (&c, &v) in comps.iter().zip(x) {
            self.qf[c] = v;
        }
        match self.rows.as_mut() {
            Some(rows) if rows.is_kept() => rows.add(&self.inv_sqrt_m, &self.qf, &mut self.wf),
            Some(rows) => rows.record_and_add(self.view, &self.inv_sqrt_m, &self.qf, &mut self.wf),
            None => {
                let blocked = self.pool.zip(self.plan.as_mut());
                apply_planned(blocked, self.view, &self.inv_sqrt_m, &self.qf, &mut self.wf);
            }
        }
        self.active.space.complete(&mut self.wf);
        for (y, &c) in y.iter_mut().zip(comps) {
            *y = self.wf[c];
        }
    }
}
