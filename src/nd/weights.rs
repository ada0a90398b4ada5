//! The weights `S_ip` and gradients `∇S_ip` of a d-dimensional solver, in one of two forms:
//!
//! * **stored rows** (ELLPACK, as the 1D [`crate::Weights`]): for particle `p` the node
//!   indices `nodes[p·w .. p·w + w]`, the weights `s[..]` and the gradients `grad[..]`,
//!   `w` the stencil's node count (`3^d` for GIMP and quadratic B-splines, `2^d` for the
//!   linear hat); padding slots carry weight and gradient zero and a valid node index. A
//!   user's solver fills this from its own kernels (for instance the effective gradients of
//!   MLS-MPM) with [`WeightsNd::from_rows`] or [`WeightsNd::storage_mut`];
//! * **per-axis factors** (the tensor-product form of [`super::factors`]): per particle and
//!   axis the offsets, weights and derivatives of its nodes along the axis, from which a row
//!   is formed when it is read. The reference solver hands its weights over this way: a 3D
//!   quadratic particle holds 192 bytes instead of 972.
//!
//! Read a row in either form with [`WeightsNd::with_row`]; the library's own passes do. The
//! slice accessors [`WeightsNd::nodes_of`], [`WeightsNd::s_of`], [`WeightsNd::grad_of`]
//! return the stored rows; on per-axis factors they form every row once, on first use, and
//! keep them (the memory of the stored form).

use super::factors::{form_row, visit_row, AxisFactors, MAX_FORMED_ROW};
use super::Vector;
use std::sync::OnceLock;

/// `S` and `∇S` of every particle, as stored rows or as per-axis factors (module docs).
#[derive(Clone, Debug, Default)]
pub struct WeightsNd<const D: usize> {
    n_nodes: usize,
    width: usize,
    nodes: Vec<u32>,
    s: Vec<f64>,
    grad: Vec<Vector<D>>,
    /// The tensor-product form: per particle, its factors on each axis (empty for rows).
    factors: Vec<[AxisFactors; D]>,
    /// Nodes per axis of the tensor-product form; 0 for stored rows.
    per_axis: usize,
    /// The rows formed from the factors, for [`Self::nodes_of`] and company (on demand).
    formed: OnceLock<Rows<D>>,
}

/// Stored rows formed from factors.
#[derive(Clone, Debug, Default)]
struct Rows<const D: usize> {
    nodes: Vec<u32>,
    s: Vec<f64>,
    grad: Vec<Vector<D>>,
}

impl<const D: usize> PartialEq for WeightsNd<D> {
    /// The same form, sizes and values (rows formed on demand do not count).
    fn eq(&self, other: &Self) -> bool {
        self.n_nodes == other.n_nodes
            && self.width == other.width
            && self.per_axis == other.per_axis
            && self.nodes == other.nodes
            && self.s == other.s
            && self.grad == other.grad
            && self.factors == other.factors
    }
}

/// Why a set of weight rows could not be stored.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WeightsNdError {
    /// The arrays do not hold `width` entries per particle.
    #[error("weights: {what} has {len} entries, expected {expected} (width {width})")]
    Length {
        /// Which array.
        what: &'static str,
        /// Its length.
        len: usize,
        /// The expected length.
        expected: usize,
        /// The row width.
        width: usize,
    },
    /// A node index is out of range.
    #[error("weights: particle {particle} refers to node {node} (n_nodes = {n_nodes})")]
    NodeOutOfRange {
        /// Particle index.
        particle: usize,
        /// The node index.
        node: usize,
        /// Number of nodes.
        n_nodes: usize,
    },
    /// A weight or gradient is not finite.
    #[error("weights: non-finite value at particle {particle}")]
    NonFinite {
        /// Particle index.
        particle: usize,
    },
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
    ) -> Result<Self, WeightsNdError> {
        let n = nodes.len().checked_div(width).unwrap_or(0);
        let expected = n * width;
        for (what, len) in [("nodes", nodes.len()), ("s", s.len()), ("grad", grad.len())] {
            if len != expected || width == 0 && len != 0 {
                return Err(WeightsNdError::Length {
                    what,
                    len,
                    expected,
                    width,
                });
            }
        }
        for (k, &node) in nodes.iter().enumerate() {
            if node as usize >= n_nodes {
                return Err(WeightsNdError::NodeOutOfRange {
                    particle: k / width,
                    node: node as usize,
                    n_nodes,
                });
            }
            if !s[k].is_finite() || grad[k].iter().any(|g| !g.is_finite()) {
                return Err(WeightsNdError::NonFinite {
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
            ..Self::default()
        })
    }

    /// Mutable access to the three arrays for an in-place refill of `n_particles` rows (a
    /// solver's hot path; entries must stay in range, which the caller ensures). Weights
    /// held as per-axis factors are first turned into stored rows, so that a caller that
    /// rewrites only some of the arrays (the gradients, say) keeps the others.
    pub fn storage_mut(
        &mut self,
        n_particles: usize,
    ) -> (&mut Vec<u32>, &mut Vec<f64>, &mut Vec<Vector<D>>) {
        if self.per_axis != 0 {
            let rows = self.take_formed();
            self.nodes = rows.nodes;
            self.s = rows.s;
            self.grad = rows.grad;
            self.factors = Vec::new();
            self.per_axis = 0;
        }
        self.formed = OnceLock::new();
        let len = n_particles * self.width;
        self.nodes.resize(len, 0);
        self.s.resize(len, 0.0);
        self.grad.resize(len, Vector::<D>::zeros());
        (&mut self.nodes, &mut self.s, &mut self.grad)
    }

    /// Mutable access to the per-axis factors of `n_particles` particles with `per_axis`
    /// nodes per axis, for an in-place refill; the stored rows are dropped. `None` (and
    /// nothing changed) unless `per_axis` is 2 or 3 and the row width is `per_axis^D ≤ 27`
    /// (the form covers the stencils of 2 or 3 nodes per axis in at most 3 dimensions).
    pub(crate) fn factors_mut(
        &mut self,
        n_particles: usize,
        per_axis: usize,
    ) -> Option<&mut Vec<[AxisFactors; D]>> {
        if !(2..=3).contains(&per_axis)
            || per_axis.checked_pow(D as u32) != Some(self.width)
            || self.width > MAX_FORMED_ROW
        {
            return None;
        }
        if self.per_axis == 0 {
            self.nodes = Vec::new();
            self.s = Vec::new();
            self.grad = Vec::new();
        }
        self.per_axis = per_axis;
        self.formed = OnceLock::new();
        self.factors
            .resize(n_particles, [AxisFactors::default(); D]);
        Some(&mut self.factors)
    }

    /// The per-axis factors and the nodes per axis, if the weights are held in that form.
    #[inline]
    pub fn factors(&self) -> Option<(&[[AxisFactors; D]], usize)> {
        (self.per_axis != 0).then_some((&self.factors, self.per_axis))
    }

    /// Calls `f` with particle `p`'s row (node indices, weights, gradients), in either form.
    /// A row formed from factors lives on the stack for the call.
    #[inline]
    pub fn with_row<T>(&self, p: usize, f: impl FnOnce(&[u32], &[f64], &[Vector<D>]) -> T) -> T {
        if self.per_axis == 0 {
            let r = p * self.width..(p + 1) * self.width;
            return f(&self.nodes[r.clone()], &self.s[r.clone()], &self.grad[r]);
        }
        let mut nodes = [0u32; MAX_FORMED_ROW];
        let mut s = [0.0; MAX_FORMED_ROW];
        let mut grad = [Vector::<D>::zeros(); MAX_FORMED_ROW];
        let w = self.width;
        form_row(
            &self.factors[p],
            self.per_axis,
            &mut nodes,
            &mut s,
            &mut grad,
        );
        f(&nodes[..w], &s[..w], &grad[..w])
    }

    /// Calls `visit(node, S_ip, ∇S_ip)` for each entry of particle `p`'s row, in row order,
    /// in either form — on factors without forming the row first (the hot passes' way).
    #[inline(always)]
    pub fn for_each_in_row(&self, p: usize, mut visit: impl FnMut(usize, f64, &Vector<D>)) {
        if self.per_axis == 0 {
            let r = p * self.width..(p + 1) * self.width;
            for ((&i, &s), g) in self.nodes[r.clone()]
                .iter()
                .zip(&self.s[r.clone()])
                .zip(&self.grad[r])
            {
                visit(i as usize, s, g);
            }
        } else {
            visit_row(&self.factors[p], self.per_axis, |_, i, s, g| {
                visit(i, s, &g)
            });
        }
    }

    /// Bytes this holds per particle (the arrays' lengths, not their capacities; rows
    /// formed on demand included).
    pub fn bytes_per_particle(&self) -> usize {
        let row = std::mem::size_of::<u32>()
            + std::mem::size_of::<f64>()
            + std::mem::size_of::<Vector<D>>();
        let formed = self.formed.get().map_or(0, |_| self.width * row);
        if self.per_axis == 0 {
            self.width * row
        } else {
            std::mem::size_of::<[AxisFactors; D]>() + formed
        }
    }

    /// The stored rows formed from the factors (once, kept until the next refill).
    fn formed_rows(&self) -> &Rows<D> {
        self.formed.get_or_init(|| self.form_all())
    }

    /// The rows formed from the factors, taken out of the cache (or formed now).
    fn take_formed(&mut self) -> Rows<D> {
        self.formed.take().unwrap_or_else(|| self.form_all())
    }

    fn form_all(&self) -> Rows<D> {
        let (n, w) = (self.factors.len(), self.width);
        let mut rows = Rows {
            nodes: vec![0; n * w],
            s: vec![0.0; n * w],
            grad: vec![Vector::<D>::zeros(); n * w],
        };
        for (p, f) in self.factors.iter().enumerate() {
            let r = p * w..(p + 1) * w;
            form_row(
                f,
                self.per_axis,
                &mut rows.nodes[r.clone()],
                &mut rows.s[r.clone()],
                &mut rows.grad[r],
            );
        }
        rows
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Number of particles (rows).
    pub fn n_particles(&self) -> usize {
        if self.per_axis != 0 {
            return self.factors.len();
        }
        self.nodes.len().checked_div(self.width).unwrap_or(0)
    }

    /// Entries per particle.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Node indices of particle `p`'s row. On per-axis factors this forms and keeps every
    /// row on first use (module docs); [`Self::with_row`] does not.
    #[inline]
    pub fn nodes_of(&self, p: usize) -> &[u32] {
        let r = p * self.width..(p + 1) * self.width;
        if self.per_axis == 0 {
            &self.nodes[r]
        } else {
            &self.formed_rows().nodes[r]
        }
    }

    /// Weights `S_ip` of particle `p`'s row (as [`Self::nodes_of`]).
    #[inline]
    pub fn s_of(&self, p: usize) -> &[f64] {
        let r = p * self.width..(p + 1) * self.width;
        if self.per_axis == 0 {
            &self.s[r]
        } else {
            &self.formed_rows().s[r]
        }
    }

    /// Gradients `∇S_ip` of particle `p`'s row (as [`Self::nodes_of`]).
    #[inline]
    pub fn grad_of(&self, p: usize) -> &[Vector<D>] {
        let r = p * self.width..(p + 1) * self.width;
        if self.per_axis == 0 {
            &self.grad[r]
        } else {
            &self.formed_rows().grad[r]
        }
    }
}
