//! [`ViewWeights`]: the `S`, `D` weights of a [`crate::View`], ready or computed on first use.
//!
//! Building the weights of a state costs about as much as a whole reference solver step
//! (one stencil evaluation per particle and node, written to `3 n_p` slots). Most steps of a
//! controlled run never read them: the stability limit works from the nodal stiffness the
//! stepper accumulates in its own particle pass ([`crate::NodalStiffness`]) and the other
//! limits read particle and nodal fields only. So a view may carry its weights *deferred*: the
//! recipe (grid, shape, positions, widths) and a per-state [`WeightsCache`] that computes them
//! the first time someone dereferences [`ViewWeights`], and keeps them for every later view of
//! the same state.
//!
//! A user's stepper that stores its weights anyway passes them ready:
//! `ViewWeights::from(&weights)`.
//!
//! `ViewWeights` dereferences to [`Weights`], so `view.weights.nodes_of(p)` reads as before;
//! where a `&Weights` must outlive the view expression, use [`ViewWeights::get`]. A view with
//! deferred weights holds a `&`[`WeightsCache`], which is not `Sync`: such a view stays on the
//! thread of its stepper.

use crate::grid::Grid;
use crate::recycled::Recycled;
use crate::shape::Shape;
use crate::weights::Weights;

/// Per-state storage for weights computed on first use, reusing the allocation of the
/// previous state's weights after [`WeightsCache::invalidate`] (`Recycled`, crate-internal). A clone keeps
/// computed weights but not the spare storage.
#[derive(Clone, Default)]
pub struct WeightsCache(Recycled<Weights>);

impl WeightsCache {
    /// Forgets the weights (call when the positions change); their storage is kept for the
    /// next computation.
    pub fn invalidate(&mut self) {
        self.0.invalidate();
    }

    /// The weights of particles at `x` with widths `widths` on `grid`, computed on the first
    /// call after [`WeightsCache::invalidate`] ([`Weights::compute_into`]).
    pub fn get_or_compute(&self, grid: &Grid, shape: Shape, x: &[f64], widths: &[f64]) -> &Weights {
        self.0.get_or_init_with(|spare| {
            let mut w = spare.unwrap_or_default();
            w.compute_into(grid, shape, x, widths);
            w
        })
    }

    /// Whether the weights are computed.
    pub fn is_computed(&self) -> bool {
        self.0.is_computed()
    }
}

impl std::fmt::Debug for WeightsCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WeightsCache")
            .field("computed", &self.is_computed())
            .finish()
    }
}

/// The weights of a view: ready, or computed on first use (module docs).
#[derive(Clone, Copy, Debug)]
pub struct ViewWeights<'a>(Source<'a>);

#[derive(Clone, Copy, Debug)]
enum Source<'a> {
    Ready(&'a Weights),
    Deferred {
        cache: &'a WeightsCache,
        grid: &'a Grid,
        shape: Shape,
        x: &'a [f64],
        widths: &'a [f64],
    },
}

impl<'a> ViewWeights<'a> {
    /// Weights already computed.
    pub fn ready(weights: &'a Weights) -> Self {
        Self(Source::Ready(weights))
    }

    /// Weights of particles at `x` with widths `widths` on `grid`, computed into `cache` on
    /// first use.
    pub fn deferred(
        cache: &'a WeightsCache,
        grid: &'a Grid,
        shape: Shape,
        x: &'a [f64],
        widths: &'a [f64],
    ) -> Self {
        Self(Source::Deferred {
            cache,
            grid,
            shape,
            x,
            widths,
        })
    }

    /// Number of particles (columns), without computing deferred weights.
    pub fn n_particles(&self) -> usize {
        match self.0 {
            Source::Ready(w) => w.n_particles(),
            Source::Deferred { x, widths, .. } => x.len().min(widths.len()),
        }
    }

    /// Number of nodes (rows), without computing deferred weights.
    pub fn n_nodes(&self) -> usize {
        match self.0 {
            Source::Ready(w) => w.n_nodes(),
            Source::Deferred { grid, .. } => grid.n_nodes(),
        }
    }

    /// The shape of weights the library computes (deferred), `None` for weights handed over
    /// ready.
    pub fn shape(&self) -> Option<Shape> {
        match self.0 {
            Source::Ready(_) => None,
            Source::Deferred { shape, .. } => Some(shape),
        }
    }

    /// The weights (computing them if deferred and not yet computed).
    pub fn get(&self) -> &'a Weights {
        match self.0 {
            Source::Ready(w) => w,
            Source::Deferred {
                cache,
                grid,
                shape,
                x,
                widths,
            } => cache.get_or_compute(grid, shape, x, widths),
        }
    }
}

impl<'a> From<&'a Weights> for ViewWeights<'a> {
    fn from(weights: &'a Weights) -> Self {
        Self::ready(weights)
    }
}

impl std::ops::Deref for ViewWeights<'_> {
    type Target = Weights;

    fn deref(&self) -> &Weights {
        self.get()
    }
}
