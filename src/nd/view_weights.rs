//! [`ViewWeightsNd`]: the weights `S_ip`, `∇S_ip` of a [`super::ViewNd`], stored or formed
//! on demand.
//!
//! * **Stored** — a [`WeightsNd`] the stepper keeps (a user's solver with its own kernels,
//!   for instance MLS-MPM's effective gradients): `ViewWeightsNd::from(&weights)`.
//! * **Formed** — the reference solver keeps no weights at all. A particle's row is formed
//!   when a pass reads it, from its position `x_p`, its GIMP domain `l_p`, the grid and the
//!   shape: per axis `a` the 1D stencil `s_a(x_p,a − X_i,a)`, `s'_a` and the storage
//!   offsets of its nodes ([`super::factors`]), then the tensor products
//!   `S_ip = Π_a s_a`, `∂_a S_ip = s'_a Π_{b≠a} s_b` in the fixed order of
//!   [`super::factors`]. The factors are formed by the same function, in the same order, as
//!   the stored rows of [`super::fields::compute_weights`], so a formed row equals the
//!   stored one bit for bit; it costs a few dozen flops per axis and particle in every pass
//!   that reads it, and no memory (a stored 3D quadratic row holds 972 bytes, its per-axis
//!   factors 192).
//!
//! Both forms are read the same way, a row at a time: [`ViewWeightsNd::with_row`] (the row
//! on the stack for the call) and [`ViewWeightsNd::for_each_in_row`] (entry by entry).
//! [`ViewWeightsNd::to_stored`] forms every row into a [`WeightsNd`] for a caller that needs
//! slices (at the memory of the stored form).

use super::factors::{form_row, visit_row, AxisFactors, MAX_FORMED_ROW};
use super::{kernels, GridNd, ShapeNd, Vector, WeightsNd};

/// The weights of a view: stored, or formed on demand from the positions (module docs).
#[derive(Clone, Copy, Debug)]
pub struct ViewWeightsNd<'a, const D: usize>(Source<'a, D>);

#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(feature = "reference"), allow(dead_code))] // used by the reference solvers
enum Source<'a, const D: usize> {
    Stored(&'a WeightsNd<D>),
    Formed(FormedNd<'a, D>),
}

/// What a formed row is formed from.
#[derive(Clone, Copy, Debug)]
struct FormedNd<'a, const D: usize> {
    grid: &'a GridNd<D>,
    shape: ShapeNd,
    x: &'a [Vector<D>],
    domain: &'a [Vector<D>],
    strides: [usize; D],
}

impl<'a, const D: usize> ViewWeightsNd<'a, D> {
    /// Weights a stepper stores.
    pub fn stored(weights: &'a WeightsNd<D>) -> Self {
        Self(Source::Stored(weights))
    }

    /// Weights of `shape` at positions `x` (GIMP domains `domain`) on `grid`, formed when
    /// read. The lengths of `x` and `domain` must match, and every particle's stencil must
    /// lie on stored nodes (the solver checks both when it sets a state up); a particle
    /// whose stencil does not is read as an empty row.
    #[cfg_attr(not(feature = "reference"), allow(dead_code))] // used by the reference solvers
    pub(crate) fn formed(
        grid: &'a GridNd<D>,
        shape: ShapeNd,
        x: &'a [Vector<D>],
        domain: &'a [Vector<D>],
    ) -> Self {
        Self(Source::Formed(FormedNd {
            grid,
            shape,
            x,
            domain,
            strides: std::array::from_fn(|a| grid.stride(a)),
        }))
    }

    /// The stored weights, if they are stored.
    pub fn as_stored(&self) -> Option<&'a WeightsNd<D>> {
        match self.0 {
            Source::Stored(w) => Some(w),
            Source::Formed(_) => None,
        }
    }

    /// Whether the rows are formed on demand (nothing stored per particle).
    pub fn is_formed(&self) -> bool {
        matches!(self.0, Source::Formed(_))
    }

    /// Number of particles (rows).
    pub fn n_particles(&self) -> usize {
        match self.0 {
            Source::Stored(w) => w.n_particles(),
            Source::Formed(f) => f.x.len().min(f.domain.len()),
        }
    }

    /// Number of nodes the rows are over.
    pub fn n_nodes(&self) -> usize {
        match self.0 {
            Source::Stored(w) => w.n_nodes(),
            Source::Formed(f) => f.grid.n_nodes(),
        }
    }

    /// Entries per row.
    pub fn width(&self) -> usize {
        match self.0 {
            Source::Stored(w) => w.width(),
            Source::Formed(f) => f.shape.width(D),
        }
    }

    /// Bytes held per particle: the stored rows' ([`WeightsNd::bytes_per_particle`]), 0
    /// for formed ones.
    pub fn bytes_per_particle(&self) -> usize {
        match self.0 {
            Source::Stored(w) => w.bytes_per_particle(),
            Source::Formed(_) => 0,
        }
    }

    /// Calls `f` with particle `p`'s row (node indices, weights, gradients). A formed row
    /// lives on the stack for the call.
    #[inline]
    pub fn with_row<T>(&self, p: usize, f: impl FnOnce(&[u32], &[f64], &[Vector<D>]) -> T) -> T {
        self.with_row_and_factors(p, |_, nodes, s, grad| f(nodes, s, grad))
    }

    /// [`Self::with_row`], also handing `f` the per-axis factors the row was formed from
    /// (`None` for stored weights or a row that could not be formed), for a pass that reads
    /// more than the row from them (the reference solver's element bound).
    #[inline]
    pub(crate) fn with_row_and_factors<T>(
        &self,
        p: usize,
        f: impl FnOnce(Option<(&[AxisFactors; D], usize)>, &[u32], &[f64], &[Vector<D>]) -> T,
    ) -> T {
        let formed = match self.0 {
            Source::Stored(w) => return w.with_row(p, |nodes, s, grad| f(None, nodes, s, grad)),
            Source::Formed(formed) => formed,
        };
        let mut nodes = [0u32; MAX_FORMED_ROW];
        let mut s = [0.0; MAX_FORMED_ROW];
        let mut grad = [Vector::<D>::zeros(); MAX_FORMED_ROW];
        match formed.factors(p) {
            Some((factors, n)) => {
                form_row(&factors, n, &mut nodes, &mut s, &mut grad);
                let w = formed.shape.width(D).min(MAX_FORMED_ROW);
                f(Some((&factors, n)), &nodes[..w], &s[..w], &grad[..w])
            }
            None => f(None, &[], &[], &[]),
        }
    }

    /// Calls `visit(node, S_ip, ∇S_ip)` for each entry of particle `p`'s row, in row order.
    #[inline(always)]
    pub fn for_each_in_row(&self, p: usize, mut visit: impl FnMut(usize, f64, &Vector<D>)) {
        match self.0 {
            Source::Stored(w) => w.for_each_in_row(p, visit),
            Source::Formed(formed) => {
                if let Some((factors, n)) = formed.factors(p) {
                    visit_row(&factors, n, |_, i, s, g| visit(i, s, &g));
                }
            }
        }
    }

    /// Every row formed into stored weights (the memory of the stored form: 972 bytes per
    /// 3D quadratic particle); a copy of stored ones.
    pub fn to_stored(&self) -> WeightsNd<D> {
        if let Source::Stored(w) = self.0 {
            return w.clone();
        }
        let (n, width) = (self.n_particles(), self.width());
        let (mut nodes, mut s, mut grad) = (
            Vec::with_capacity(n * width),
            Vec::with_capacity(n * width),
            Vec::with_capacity(n * width),
        );
        for p in 0..n {
            self.with_row(p, |rn, rs, rg| {
                // A row that could not be formed is padded (weight and gradient zero).
                let pad = width - rn.len();
                nodes.extend(rn.iter().copied().chain(std::iter::repeat_n(0, pad)));
                s.extend(rs.iter().copied().chain(std::iter::repeat_n(0.0, pad)));
                grad.extend(
                    rg.iter()
                        .copied()
                        .chain(std::iter::repeat_n(Vector::<D>::zeros(), pad)),
                );
            });
        }
        let mut w = WeightsNd::new(self.n_nodes(), width);
        let (wn, ws, wg) = w.storage_mut(n);
        *wn = nodes;
        *ws = s;
        *wg = grad;
        w
    }
}

impl<const D: usize> FormedNd<'_, D> {
    /// Particle `p`'s per-axis factors and nodes per axis; `None` if its stencil leaves the
    /// stored nodes or `p` is out of range.
    #[inline(always)]
    fn factors(&self, p: usize) -> Option<([AxisFactors; D], usize)> {
        let (x, l) = (self.x.get(p)?, self.domain.get(p)?);
        let f = kernels::axis_factors(self.grid, self.shape, &self.strides, x, l)?;
        Some((f, self.shape.nodes_per_axis()))
    }
}

impl<'a, const D: usize> From<&'a WeightsNd<D>> for ViewWeightsNd<'a, D> {
    fn from(weights: &'a WeightsNd<D>) -> Self {
        Self::stored(weights)
    }
}
