//! The weights `S_ip` and gradients `∇S_ip` of a d-dimensional solver, as **stored rows**
//! (ELLPACK, as the 1D [`crate::Weights`]): for particle `p` the node indices
//! `nodes[p·w .. p·w + w]`, the weights `s[..]` and the gradients `grad[..]`, `w` the
//! stencil's node count (`3^d` for GIMP and quadratic B-splines, `2^d` for the linear hat);
//! padding slots carry weight and gradient zero and a valid node index. A user's solver
//! fills this from its own kernels (for instance the effective gradients of MLS-MPM) with
//! [`WeightsNd::from_rows`] or [`WeightsNd::storage_mut`], and hands it to its view as
//! [`super::ViewWeightsNd::stored`]. The reference solver stores none: its views form each
//! row when a pass reads it ([`super::ViewWeightsNd`]). A 3D quadratic row holds
//! `27 × (4 + 8 + 24) = 972` bytes.

use super::Vector;
use crate::weights::WeightsError;

/// `S` and `∇S` of every particle as stored rows (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WeightsNd<const D: usize> {
    n_nodes: usize,
    width: usize,
    nodes: Vec<u32>,
    s: Vec<f64>,
    grad: Vec<Vector<D>>,
}

impl<const D: usize> WeightsNd<D> {
    /// Empty weights of rows `width` wide over `n_nodes` nodes (no particles).
    pub fn new(n_nodes: usize, width: usize) -> Self {
        Self {
            n_nodes,
            width,
            ..Self::default()
        }
    }

    /// Weights from whole arrays of `width` entries per particle, checked.
    pub fn from_rows(
        n_nodes: usize,
        width: usize,
        nodes: Vec<u32>,
        s: Vec<f64>,
        grad: Vec<Vector<D>>,
    ) -> Result<Self, WeightsError> {
        let n = nodes.len().checked_div(width).unwrap_or(0);
        let expected = n * width;
        for (what, len) in [("nodes", nodes.len()), ("s", s.len()), ("grad", grad.len())] {
            if len != expected || width == 0 && len != 0 {
                return Err(WeightsError::Length {
                    what,
                    len,
                    expected,
                    width,
                });
            }
        }
        for (k, &node) in nodes.iter().enumerate() {
            if node as usize >= n_nodes {
                return Err(WeightsError::NodeOutOfRange {
                    particle: k / width,
                    node: node as usize,
                    n_nodes,
                });
            }
            if !s[k].is_finite() || grad[k].iter().any(|g| !g.is_finite()) {
                return Err(WeightsError::NonFinite {
                    particle: k / width,
                });
            }
        }
        Ok(Self {
            n_nodes,
            width,
            nodes,
            s,
            grad,
        })
    }

    /// Mutable access to the three arrays for an in-place refill of `n_particles` rows (a
    /// solver's hot path; entries must stay in range, which the caller ensures).
    pub fn storage_mut(
        &mut self,
        n_particles: usize,
    ) -> (&mut Vec<u32>, &mut Vec<f64>, &mut Vec<Vector<D>>) {
        let len = n_particles * self.width;
        self.nodes.resize(len, 0);
        self.s.resize(len, 0.0);
        self.grad.resize(len, Vector::<D>::zeros());
        (&mut self.nodes, &mut self.s, &mut self.grad)
    }

    /// Calls `f` with particle `p`'s row (node indices, weights, gradients).
    #[inline]
    pub fn with_row<T>(&self, p: usize, f: impl FnOnce(&[u32], &[f64], &[Vector<D>]) -> T) -> T {
        let r = p * self.width..(p + 1) * self.width;
        f(&self.nodes[r.clone()], &self.s[r.clone()], &self.grad[r])
    }

    /// Calls `visit(node, S_ip, ∇S_ip)` for each entry of particle `p`'s row, in row order.
    #[inline(always)]
    pub fn for_each_in_row(&self, p: usize, mut visit: impl FnMut(usize, f64, &Vector<D>)) {
        let r = p * self.width..(p + 1) * self.width;
        for ((&i, &s), g) in self.nodes[r.clone()]
            .iter()
            .zip(&self.s[r.clone()])
            .zip(&self.grad[r])
        {
            visit(i as usize, s, g);
        }
    }

    /// Bytes this holds per particle (the arrays' lengths, not their capacities):
    /// `width × (4 + 8 + 8·D)`.
    pub fn bytes_per_particle(&self) -> usize {
        self.width
            * (std::mem::size_of::<u32>()
                + std::mem::size_of::<f64>()
                + std::mem::size_of::<Vector<D>>())
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Number of particles (rows).
    pub fn n_particles(&self) -> usize {
        self.nodes.len().checked_div(self.width).unwrap_or(0)
    }

    /// Entries per particle.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Node indices of particle `p`'s row.
    #[inline]
    pub fn nodes_of(&self, p: usize) -> &[u32] {
        &self.nodes[p * self.width..(p + 1) * self.width]
    }

    /// Weights `S_ip` of particle `p`'s row.
    #[inline]
    pub fn s_of(&self, p: usize) -> &[f64] {
        &self.s[p * self.width..(p + 1) * self.width]
    }

    /// Gradients `∇S_ip` of particle `p`'s row.
    #[inline]
    pub fn grad_of(&self, p: usize) -> &[Vector<D>] {
        &self.grad[p * self.width..(p + 1) * self.width]
    }
}
