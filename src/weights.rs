//! The particle–node weight matrices `S` (eqs 7, 12, 17, 21) and `D` (eqs 6, 14, 18, 24).
//!
//! Both are `n_nodes × n_particles` matrices with entries `S_ip`, `D_ip`; the paper writes
//! the particle→node use (`S_pi`, `D_pi`) and the node→particle use (`S_ip`, `D_ip`) of the
//! same numbers. Particle→node is a *scatter* (`y_i = Σ_p S_ip u_p`), node→particle a
//! *gather* (`u_p = Σ_i S_ip y_i`).
//!
//! # Storage: fixed-width rows per particle (ELLPACK), not faer's CSC
//!
//! Every particle touches the same small number of nodes (3 in 1D GIMP, `3^d` in d
//! dimensions), so the matrices are stored particle-major with a fixed width `w`: for particle
//! `p`, the node indices `nodes[p·w .. p·w + w]` and the values `s[..]`, `d[..]`. Compared with
//! a general compressed-column matrix this needs no column pointers, lets the gather be a
//! straight loop over contiguous memory, keeps `S` and `D` sharing one index array, and is the
//! layout MPM codes already use — so a user's solver can fill it directly. Padding slots carry
//! weight 0 (and a valid node index). [`Weights::to_faer`] converts to a
//! `faer::sparse::SparseColMat` when general sparse algebra is wanted.

use crate::grid::{Boundary, Grid};
use crate::shape::{ParticleStencil, Shape, MAX_NODES};
use crate::stencil;
use faer::sparse::{SparseColMat, Triplet};

/// `S` and `D` in fixed-width particle-major storage (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Weights {
    n_nodes: usize,
    width: usize,
    nodes: Vec<u32>,
    s: Vec<f64>,
    d: Vec<f64>,
}

/// Which of the two weight matrices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeightKind {
    /// The mapping weights `S_ip`.
    S,
    /// The gradient weights `D_ip`.
    D,
}

/// Why a set of weight rows could not be stored, in any dimension ([`Weights::push_row`]
/// in 1D, [`crate::nd::WeightsNd::from_rows`] in 2D/3D).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WeightsError {
    /// An array does not hold `width` entries per particle (2D/3D whole arrays).
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
    /// A row has a different number of entries than the width.
    #[error("weights: particle {particle}: row has {len} entries, width is {width}")]
    RowLength {
        /// Particle index.
        particle: usize,
        /// Entries given.
        len: usize,
        /// Expected width.
        width: usize,
    },
    /// A node index is out of range.
    #[error("weights: particle {particle} refers to node {node} (n_nodes = {n_nodes})")]
    NodeOutOfRange {
        /// Particle index.
        particle: usize,
        /// Offending node index.
        node: usize,
        /// Number of nodes.
        n_nodes: usize,
    },
    /// A weight or gradient is NaN or infinite.
    #[error("weights: non-finite weight or gradient at particle {particle}")]
    NonFinite {
        /// Particle index.
        particle: usize,
    },
}

impl Weights {
    /// Empty weights for `n_nodes` nodes and rows of `width` entries.
    pub fn new(n_nodes: usize, width: usize) -> Self {
        Self {
            n_nodes,
            width,
            ..Self::default()
        }
    }

    /// Appends particle rows: `(node, S_ip, D_ip)` triples, exactly `width` of them
    /// (pad with weight-0 entries). This is how a user's solver fills the view.
    pub fn push_row(&mut self, row: &[(usize, f64, f64)]) -> Result<(), WeightsError> {
        let particle = self.n_particles();
        if row.len() != self.width {
            return Err(WeightsError::RowLength {
                particle,
                len: row.len(),
                width: self.width,
            });
        }
        for &(node, s, d) in row {
            if node >= self.n_nodes || node > u32::MAX as usize {
                return Err(WeightsError::NodeOutOfRange {
                    particle,
                    node,
                    n_nodes: self.n_nodes,
                });
            }
            if !(s.is_finite() && d.is_finite()) {
                return Err(WeightsError::NonFinite { particle });
            }
        }
        for &(node, s, d) in row {
            self.nodes.push(node as u32);
            self.s.push(s);
            self.d.push(d);
        }
        Ok(())
    }

    /// The weights of `shape` for particles at `x` with GIMP widths `widths` on `grid`.
    /// Positions must lie in the grid's domain (the reference solver guarantees it).
    ///
    /// The values are the reference solver's own branch-free stencils (`crate::stencil`),
    /// which agree with [`Shape::stencil`] to round-off: the weights a reference step from
    /// these positions uses, bit for bit. [`Weights::compute_into`] does the same
    /// into existing storage.
    pub fn compute(grid: &Grid, shape: Shape, x: &[f64], widths: &[f64]) -> Self {
        let mut w = Self::default();
        w.compute_into(grid, shape, x, widths);
        w
    }

    /// [`Weights::compute`] into `self`, reusing its allocations: `self` becomes the
    /// weights of `shape` for particles at `x` with widths `widths` on `grid`, bit for bit
    /// what [`Weights::compute`] returns.
    pub fn compute_into(&mut self, grid: &Grid, shape: Shape, x: &[f64], widths: &[f64]) {
        let n = x.len().min(widths.len());
        self.n_nodes = grid.n_nodes();
        self.width = MAX_NODES;
        self.nodes.resize(n * MAX_NODES, 0);
        self.s.resize(n * MAX_NODES, 0.0);
        self.d.resize(n * MAX_NODES, 0.0);
        let (x, widths) = (&x[..n], &widths[..n]);
        let out = (&mut self.nodes[..], &mut self.s[..], &mut self.d[..]);
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2() {
            // SAFETY: `fill_avx2` only requires AVX2, which `has_avx2` detected on this CPU.
            unsafe { fill_avx2(grid, shape, x, widths, out) };
            return;
        }
        fill_shape::<false>(grid, shape, x, widths, out);
    }

    /// Number of nodes (rows of `S` and `D`).
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Number of particles (columns of `S` and `D`).
    pub fn n_particles(&self) -> usize {
        self.nodes.len().checked_div(self.width).unwrap_or(0)
    }

    /// Entries per particle (stored non-zeros and padding).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Node indices of particle `p`.
    #[inline]
    pub fn nodes_of(&self, p: usize) -> &[u32] {
        &self.nodes[p * self.width..(p + 1) * self.width]
    }

    /// `S_ip` for the nodes of particle `p`.
    #[inline]
    pub fn s_of(&self, p: usize) -> &[f64] {
        &self.s[p * self.width..(p + 1) * self.width]
    }

    /// `D_ip` for the nodes of particle `p`.
    #[inline]
    pub fn d_of(&self, p: usize) -> &[f64] {
        &self.d[p * self.width..(p + 1) * self.width]
    }

    /// Iterator over the stored `(node, S_ip, D_ip)` of particle `p` (padding included).
    pub fn row(&self, p: usize) -> impl Iterator<Item = (usize, f64, f64)> + '_ {
        let r = p * self.width..(p + 1) * self.width;
        self.nodes[r.clone()]
            .iter()
            .zip(&self.s[r.clone()])
            .zip(&self.d[r])
            .map(|((&i, &s), &d)| (i as usize, s, d))
    }

    fn values(&self, kind: WeightKind) -> &[f64] {
        match kind {
            WeightKind::S => &self.s,
            WeightKind::D => &self.d,
        }
    }

    /// Particle→node map: `out_i = Σ_p W_ip u_p` (overwrites `out`, length `n_nodes`).
    pub fn scatter(&self, kind: WeightKind, u: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        let vals = self.values(kind);
        for (p, &up) in u.iter().enumerate() {
            let r = p * self.width..(p + 1) * self.width;
            for (&i, &w) in self.nodes[r.clone()].iter().zip(&vals[r]) {
                out[i as usize] += w * up;
            }
        }
    }

    /// Node→particle map: `out_p = Σ_i W_ip y_i` (overwrites `out`, length `n_particles`).
    pub fn gather(&self, kind: WeightKind, y: &[f64], out: &mut [f64]) {
        let vals = self.values(kind);
        for (p, o) in out.iter_mut().enumerate() {
            let r = p * self.width..(p + 1) * self.width;
            *o = self.nodes[r.clone()]
                .iter()
                .zip(&vals[r])
                .map(|(&i, &w)| w * y[i as usize])
                .sum();
        }
    }

    /// The `n_nodes × n_particles` matrix as a faer sparse matrix (duplicate entries, e.g.
    /// a particle touching the same node twice on a tiny periodic grid, are summed).
    pub fn to_faer(&self, kind: WeightKind) -> SparseColMat<usize, f64> {
        let vals = self.values(kind);
        let trip: Vec<Triplet<usize, usize, f64>> = (0..self.n_particles())
            .flat_map(|p| {
                let r = p * self.width..(p + 1) * self.width;
                self.nodes[r.clone()]
                    .iter()
                    .zip(&vals[r])
                    .filter(|(_, &w)| w != 0.0)
                    .map(move |(&i, &w)| Triplet::new(i as usize, p, w))
                    .collect::<Vec<_>>()
            })
            .collect();
        SparseColMat::try_new_from_triplets(self.n_nodes, self.n_particles(), &trip)
            .expect("indices were validated on insertion")
    }
}

/// The stored rows `(nodes, S, D)` that [`Weights::compute_into`] fills.
type Rows<'a> = (&'a mut [u32], &'a mut [f64], &'a mut [f64]);

/// [`fill_shape`] compiled for AVX2, where `⌊·⌋` is one instruction (the same exact result
/// as the baseline's truncation and correction, see `crate::stencil`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn fill_avx2(grid: &Grid, shape: Shape, x: &[f64], widths: &[f64], out: Rows<'_>) {
    fill_shape::<true>(grid, shape, x, widths, out);
}

/// [`fill`] with the reference solver's branch-free stencil of `shape` (`crate::stencil`),
/// `⌊·⌋` by rounding instruction if `ROUND`: the view's weights are exactly those the
/// solver's step uses.
#[inline(always)]
fn fill_shape<const ROUND: bool>(
    grid: &Grid,
    shape: Shape,
    x: &[f64],
    widths: &[f64],
    out: Rows<'_>,
) {
    match shape {
        Shape::Gimp => fill(grid, x, widths, out, stencil::gimp::<ROUND>),
        Shape::Linear => fill(grid, x, widths, out, |x, _, inv_h| {
            stencil::linear::<ROUND>(x, inv_h)
        }),
    }
}

/// Fills the rows of [`Weights::compute_into`] (all slices sized for `x.len()` particles)
/// with `stencil(x − origin, l_p, 1/h)`. A stencil whose three nodes are consecutive stored
/// nodes — every particle but those whose stencil crosses the periodic wrap or a fixed
/// grid's end — is stored directly; the others go through [`Grid::storage_index`].
#[inline(always)]
fn fill(
    grid: &Grid,
    x: &[f64],
    widths: &[f64],
    (nodes, s, d): Rows<'_>,
    stencil: impl Fn(f64, f64, f64) -> ParticleStencil,
) {
    let (origin, inv_h) = (grid.origin, 1.0 / grid.h);
    // Storage index of lattice node j is j + shift when it is in range.
    let shift = match grid.boundary {
        Boundary::Periodic => 0,
        Boundary::Fixed => 1,
    };
    let last_first = grid.n_nodes() as i64 - MAX_NODES as i64;
    let rows = nodes
        .chunks_exact_mut(MAX_NODES)
        .zip(s.chunks_exact_mut(MAX_NODES))
        .zip(d.chunks_exact_mut(MAX_NODES));
    for ((&xp, &lp), ((nodes, s), d)) in x.iter().zip(widths).zip(rows) {
        let st = stencil(xp - origin, lp, inv_h);
        let k0 = st.first.saturating_add(shift);
        if (0..=last_first).contains(&k0) {
            for (k, node) in nodes.iter_mut().enumerate() {
                *node = (k0 + k as i64) as u32;
            }
            s.copy_from_slice(&st.s);
            d.copy_from_slice(&st.d);
        } else {
            for k in 0..MAX_NODES {
                // A slot outside a fixed grid can only carry weight 0 for in-domain
                // particles; park it on a valid node.
                (nodes[k], s[k], d[k]) = match grid.storage_index(st.first + k as i64) {
                    Some(i) => (i as u32, st.s[k], st.d[k]),
                    None => (0, 0.0, 0.0),
                };
            }
        }
    }
}
