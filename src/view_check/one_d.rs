//! The door check of a 1D view ([`View`]; module docs of [`super`]), and the non-finite
//! scan of 1D trials.

use super::rows::{check_rows, Rows};
use super::{check_counts, finite, ViewError};
use crate::grid::Boundary;
use crate::view::View;
use crate::weights::Weights;

/// The first non-finite value of the trial's `x`, `v`, `σ`, `F` (in that order), if any.
///
/// Runs on every trial: a trusted pass summary is the stepper's guarantee that the trial is
/// finite (`crate::pass_summary`); else a vectorised pass per field confirms the normal
/// case (all finite) and only a failing field is searched element by element for the first
/// bad index.
pub(crate) fn first_nonfinite(view: &View<'_>) -> Option<(&'static str, usize, f64)> {
    if view.trusted_summary().is_some() {
        return None;
    }
    if [view.x, view.v, view.sigma, view.f]
        .into_iter()
        .all(super::all_finite)
    {
        return None;
    }
    for (name, field) in [
        ("x", view.x),
        ("v", view.v),
        ("sigma", view.sigma),
        ("F", view.f),
    ] {
        if let Some((i, &v)) = field.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Some((name, i, v));
        }
    }
    None
}

impl View<'_> {
    /// The O(1) part of the door check: every particle array has the particle count as
    /// length, every nodal array (and `K_N`, when provided) the grid's node count (module
    /// docs of [`crate::view_check`]). Deferred weights are not computed. Returns the
    /// particle count.
    pub fn check_shape(&self) -> Result<usize, ViewError> {
        let particle = [
            ("x", self.x.len()),
            ("v", self.v.len()),
            ("sigma", self.sigma.len()),
            ("F", self.f.len()),
            ("volume0", self.volume0.len()),
            ("mass", self.mass.len()),
            ("tangent_modulus", self.tangent_modulus.len()),
            ("density", self.density.len()),
            ("weights", self.weights.n_particles()),
        ];
        let mut nodal = vec![
            ("node_mass", self.node_mass.len()),
            ("node_velocity", self.node_velocity.len()),
            ("node_acceleration", self.node_acceleration.len()),
            ("node_active", self.node_active.len()),
            ("weights.n_nodes", self.weights.n_nodes()),
        ];
        if let Some(k) = self.nodal_stiffness {
            let bands = [k.diag.len(), k.upper1.len(), k.upper2.len()];
            let odd = bands.iter().copied().find(|&l| l != k.n_nodes());
            nodal.push(("nodal_stiffness", odd.unwrap_or(k.n_nodes())));
        }
        check_counts(&particle, &nodal, self.grid.n_nodes(), &[self.grid.cells])
    }

    /// The O(particles × stencil + nodes) part of the door check: a finite state, weight
    /// rows over stored nodes, a partition of unity with complete gradients (module docs
    /// of [`crate::view_check`]). Computes deferred weights. Assumes [`View::check_shape`]
    /// passed.
    pub fn check_contents(&self) -> Result<(), ViewError> {
        for (array, values) in [
            ("x", self.x),
            ("v", self.v),
            ("sigma", self.sigma),
            ("F", self.f),
            ("volume0", self.volume0),
            ("mass", self.mass),
            ("tangent_modulus", self.tangent_modulus),
            ("density", self.density),
            ("node_mass", self.node_mass),
            ("node_velocity", self.node_velocity),
            ("node_acceleration", self.node_acceleration),
        ] {
            finite(array, values, 1)?;
        }
        check_rows(&OneDRows {
            view: self,
            weights: self.weights.get(),
        })
    }

    /// The whole door check: [`View::check_shape`], then [`View::check_contents`]. A
    /// solver's own tests can call it on the views it builds.
    pub fn check(&self) -> Result<(), ViewError> {
        self.check_shape()?;
        self.check_contents()
    }
}

/// A 1D view's rows for [`check_rows`].
struct OneDRows<'v, 'a> {
    view: &'v View<'a>,
    weights: &'a Weights,
}

impl Rows<1> for OneDRows<'_, '_> {
    type Grad = f64;

    fn n_particles(&self) -> usize {
        self.weights.n_particles()
    }

    fn n_nodes(&self) -> usize {
        self.weights.n_nodes()
    }

    #[inline]
    fn with_row<T>(&self, p: usize, f: impl FnOnce(&[u32], &[f64], &[f64]) -> T) -> T {
        let w = self.weights;
        f(w.nodes_of(p), w.s_of(p), w.d_of(p))
    }

    #[inline]
    fn components(g: f64) -> [f64; 1] {
        [g]
    }

    #[inline]
    fn node(&self, i: usize) -> [f64; 1] {
        [self.view.grid.node_x(i)]
    }

    #[inline]
    fn particle(&self, p: usize) -> [f64; 1] {
        [self.view.x[p]]
    }

    fn period(&self) -> [Option<f64>; 1] {
        let g = self.view.grid;
        [(g.boundary == Boundary::Periodic).then(|| g.length())]
    }

    fn complete_along(&self, _: usize) -> bool {
        self.view.grid.boundary == Boundary::Fixed || self.view.grid.cells >= 3
    }
}
