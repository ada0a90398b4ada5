//! The door check of a d-dimensional view ([`ViewNd`]; module docs of [`super`]).

use super::rows::{check_rows, Rows};
use super::{check_counts, finite, ViewError};
use crate::grid::Boundary;
use crate::nd::{GridNd, Vector, ViewNd};

impl<const D: usize> ViewNd<'_, D> {
    /// The O(1) part of the door check: every particle array has the particle count as
    /// length, every nodal array the grid's node count (module docs of
    /// [`crate::view_check`]). Returns the particle count.
    pub fn check_shape(&self) -> Result<usize, ViewError> {
        let w = self.weights;
        let mut particle = vec![
            ("x", self.x.len()),
            ("v", self.v.len()),
            ("sigma", self.sigma.len()),
            ("F", self.f.len()),
            ("volume0", self.volume0.len()),
            ("mass", self.mass.len()),
            ("lame_lambda", self.lame_lambda.len()),
            ("lame_mu", self.lame_mu.len()),
            ("density", self.density.len()),
            ("weights", w.n_particles()),
        ];
        let mut nodal = vec![
            ("node_mass", self.node_mass.len()),
            ("node_velocity", self.node_velocity.len()),
            ("node_acceleration", self.node_acceleration.len()),
            ("node_active", self.node_active.len()),
            ("weights.n_nodes", w.n_nodes()),
        ];
        if let Some(s) = self.split {
            particle.push(("split.particle_id", s.particle_id.len()));
            nodal.push(("split.global_node", s.global_node.len()));
            nodal.push(("split.owned", s.owned.len()));
        }
        check_counts(&particle, &nodal, self.grid.n_nodes(), &self.grid.cells)
    }

    /// The O(particles × stencil + nodes) part of the door check: a finite state, weight
    /// rows over stored nodes, a partition of unity with complete gradients (module docs
    /// of [`crate::view_check`]). Assumes [`ViewNd::check_shape`] passed.
    pub fn check_contents(&self) -> Result<(), ViewError> {
        finite_nd("x", self.x, |m| m.as_slice())?;
        finite_nd("v", self.v, |m| m.as_slice())?;
        finite_nd("sigma", self.sigma, |m| m.as_slice())?;
        finite_nd("F", self.f, |m| m.as_slice())?;
        for (array, values) in [
            ("volume0", self.volume0),
            ("mass", self.mass),
            ("lame_lambda", self.lame_lambda),
            ("lame_mu", self.lame_mu),
            ("density", self.density),
            ("node_mass", self.node_mass),
        ] {
            finite(array, values, 1)?;
        }
        finite_nd("node_velocity", self.node_velocity, |m| m.as_slice())?;
        finite_nd("node_acceleration", self.node_acceleration, |m| {
            m.as_slice()
        })?;
        if let Some(s) = self.split {
            let whole = s.whole.n_nodes();
            if let Some((i, &g)) = s
                .global_node
                .iter()
                .enumerate()
                .find(|(_, &g)| g as usize >= whole)
            {
                return Err(ViewError::NodeOutOfRange {
                    array: "split.global_node",
                    index: i,
                    node: g as usize,
                    n_nodes: whole,
                });
            }
        }
        check_rows(&NdRows::new(self))
    }

    /// The whole door check: [`ViewNd::check_shape`], then [`ViewNd::check_contents`]. A
    /// solver's own tests can call it on the views it builds.
    pub fn check(&self) -> Result<(), ViewError> {
        self.check_shape()?;
        self.check_contents()
    }
}

/// The first non-finite component of `values` (each element's components by `comps`).
/// A branch-free pass confirms the normal case; only a failing array is searched.
fn finite_nd<M>(
    array: &'static str,
    values: &[M],
    comps: impl Fn(&M) -> &[f64],
) -> Result<(), ViewError> {
    let mut bad = 0.0;
    for m in values {
        for &c in comps(m) {
            bad += c * 0.0;
        }
    }
    if bad == 0.0 {
        return Ok(());
    }
    for (index, m) in values.iter().enumerate() {
        if let Some(&value) = comps(m).iter().find(|c| !c.is_finite()) {
            return Err(ViewError::NonFinite {
                array,
                index,
                value,
            });
        }
    }
    Ok(())
}

/// A d-dimensional view's rows for [`check_rows`], with the node positions computed once.
struct NdRows<'v, 'a, const D: usize> {
    view: &'v ViewNd<'a, D>,
    /// `X_i` of every node of the view's grid.
    position: Vec<[f64; D]>,
    /// The period of each periodic axis (of the whole grid, for a split view).
    period: [Option<f64>; D],
    /// Axes along which completeness is checked.
    complete: [bool; D],
}

impl<'v, 'a, const D: usize> NdRows<'v, 'a, D> {
    fn new(view: &'v ViewNd<'a, D>) -> Self {
        let grid: &GridNd<D> = view.grid;
        // A grid-decomposed view's window is unwrapped along the split axis; the whole
        // grid says which axes wrap.
        let whole = view.split.map_or(grid, |s| s.whole);
        let periodic = |a: usize| whole.boundary[a] == Boundary::Periodic;
        Self {
            view,
            position: (0..grid.n_nodes())
                .map(|i| grid.node_position(i).into())
                .collect(),
            period: std::array::from_fn(|a| periodic(a).then(|| whole.length(a))),
            complete: std::array::from_fn(|a| !periodic(a) || whole.cells[a] >= 3),
        }
    }
}

impl<const D: usize> Rows<D> for NdRows<'_, '_, D> {
    type Grad = Vector<D>;

    fn n_particles(&self) -> usize {
        self.view.weights.n_particles()
    }

    fn n_nodes(&self) -> usize {
        self.position.len()
    }

    #[inline]
    fn with_row<T>(&self, p: usize, f: impl FnOnce(&[u32], &[f64], &[Vector<D>]) -> T) -> T {
        self.view.weights.with_row(p, f)
    }

    #[inline]
    fn components(g: Vector<D>) -> [f64; D] {
        g.into()
    }

    #[inline]
    fn node(&self, i: usize) -> [f64; D] {
        self.position[i]
    }

    #[inline]
    fn particle(&self, p: usize) -> [f64; D] {
        self.view.x[p].into()
    }

    fn period(&self) -> [Option<f64>; D] {
        self.period
    }

    fn complete_along(&self, a: usize) -> bool {
        self.complete[a]
    }
}
