//! The tensor-product form of a particle's weights: per axis `a`, the storage offsets
//! `k_a · stride_a` of its `n` stencil nodes along the axis and their 1D weights `s_a` and
//! derivatives `s'_a`. The row of the `n^D` stencil nodes is formed from them on demand:
//! node `i = Σ_a offset_a[k_a]`, `S_ip = Π_a s_a[k_a]`, `∂_a S_ip = s'_a[k_a] Π_{b≠a} s_b[k_b]`,
//! walked as an odometer over the axes, axis 0 fastest.
//!
//! A 3D quadratic particle holds `3 × (3·4 + 3·8 + 3·8) = 180` bytes this way (192 with the
//! alignment of the factors) instead of the
//! `27 × (4 + 8 + 24) = 972` bytes of its stored row. The products are formed in one fixed
//! order (the factors multiplied axis by axis, `((s_0 s_1) s_2)`, and for `∂_a` the
//! derivative first, then the other axes in increasing order), so a formed row is the same,
//! bit for bit, wherever it is formed.

use super::Vector;

/// Most stencil nodes a formed row holds: `3^3` (quadratic stencils in 3D).
pub const MAX_FORMED_ROW: usize = 27;

/// One particle's factors on one axis (module docs). Slots past the shape's
/// `nodes_per_axis` are unused.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisFactors {
    /// Storage offset `k · stride` of each node along the axis.
    pub offset: [u32; 3],
    /// 1D weights of the nodes.
    pub s: [f64; 3],
    /// 1D derivatives of the weights with respect to the particle position.
    pub d: [f64; 3],
}

/// What a walk over a formed row does at each entry `m` (node `node`, weight `S`,
/// gradient `∇S`). A pass whose work per entry is more than a line implements it on a
/// struct with an `#[inline(always)]` method: a closure called from the unrolled stencil
/// loop is not inlined once its body is large, and then costs a call per node.
pub trait RowVisitor<const D: usize> {
    /// Visits entry `m` of the row.
    fn visit(&mut self, m: usize, node: usize, s: f64, grad: Vector<D>);
}

impl<const D: usize, F: FnMut(usize, usize, f64, Vector<D>)> RowVisitor<D> for F {
    #[inline(always)]
    fn visit(&mut self, m: usize, node: usize, s: f64, grad: Vector<D>) {
        self(m, node, s, grad)
    }
}

/// Writes the row of `n^D` entries formed from `f` (module docs) into the first `n^D`
/// slots of `nodes`, `s` and `grad` (`n` = 2 or 3; any other `n` writes nothing).
#[inline(always)]
pub fn form_row<const D: usize>(
    f: &[AxisFactors; D],
    n: usize,
    nodes: &mut [u32],
    s: &mut [f64],
    grad: &mut [Vector<D>],
) {
    visit_row(f, n, |m, node, w, g| {
        nodes[m] = node as u32;
        s[m] = w;
        grad[m] = g;
    });
}

/// Calls `visit(m, node, S, ∇S)` for the `n^D` entries `m` of the row formed from `f`, in
/// row order (`n` = 2 or 3; any other `n` visits nothing).
#[inline(always)]
pub fn visit_row<const D: usize>(f: &[AxisFactors; D], n: usize, mut visit: impl RowVisitor<D>) {
    visit_row_with(f, n, &mut visit);
}

/// [`visit_row`] with a visitor the caller keeps (its totals read afterwards).
#[inline(always)]
pub fn visit_row_with<const D: usize, V: RowVisitor<D>>(
    f: &[AxisFactors; D],
    n: usize,
    visit: &mut V,
) {
    // A constant node count per axis lets the compiler unroll the odometer and share the
    // partial products between nodes (the values are the same: only the loop is constant).
    match n {
        2 => visit_row_n::<D, 2, V>(f, visit),
        3 => visit_row_n::<D, 3, V>(f, visit),
        _ => {}
    }
}

#[inline(always)]
fn visit_row_n<const D: usize, const N: usize, V: RowVisitor<D>>(
    f: &[AxisFactors; D],
    visit: &mut V,
) {
    match D {
        2 => visit_2d::<D, N, V>(f, visit),
        3 => visit_3d::<D, N, V>(f, visit),
        _ => visit_any::<D, N, V>(f, visit),
    }
}

/// [`visit_row`] in 2D: `S = s_0 s_1`, `∇S = (s'_0 s_1, s'_1 s_0)`.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // k0, k1 index both axes' factors
fn visit_2d<const D: usize, const N: usize, V: RowVisitor<D>>(f: &[AxisFactors; D], visit: &mut V) {
    let (f0, f1) = (&f[0], &f[1]);
    for k1 in 0..N {
        for k0 in 0..N {
            let node = f0.offset[k0] as usize + f1.offset[k1] as usize;
            let g = [f0.d[k0] * f1.s[k1], f1.d[k1] * f0.s[k0]];
            visit.visit(
                k0 + N * k1,
                node,
                f0.s[k0] * f1.s[k1],
                Vector::<D>::from_fn(|a, _| g[a]),
            );
        }
    }
}

/// [`visit_row`] in 3D: the products of two axes formed once per pair of nodes, then
/// multiplied by the third factor in the order of the module docs.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // k0, k1, k2 index several tables each
fn visit_3d<const D: usize, const N: usize, V: RowVisitor<D>>(f: &[AxisFactors; D], visit: &mut V) {
    let (f0, f1, f2) = (&f[0], &f[1], &f[2]);
    // [k1][k0]: s_0 s_1, s'_0 s_1, s'_1 s_0; [k2][k0]: s'_2 s_0.
    let s01: [[f64; N]; N] =
        std::array::from_fn(|k1| std::array::from_fn(|k0| f0.s[k0] * f1.s[k1]));
    let d0s1: [[f64; N]; N] =
        std::array::from_fn(|k1| std::array::from_fn(|k0| f0.d[k0] * f1.s[k1]));
    let d1s0: [[f64; N]; N] =
        std::array::from_fn(|k1| std::array::from_fn(|k0| f1.d[k1] * f0.s[k0]));
    let d2s0: [[f64; N]; N] =
        std::array::from_fn(|k2| std::array::from_fn(|k0| f2.d[k2] * f0.s[k0]));
    for k2 in 0..N {
        for k1 in 0..N {
            for k0 in 0..N {
                let node = f0.offset[k0] as usize + f1.offset[k1] as usize + f2.offset[k2] as usize;
                let g = [
                    d0s1[k1][k0] * f2.s[k2],
                    d1s0[k1][k0] * f2.s[k2],
                    d2s0[k2][k0] * f1.s[k1],
                ];
                visit.visit(
                    k0 + N * (k1 + N * k2),
                    node,
                    s01[k1][k0] * f2.s[k2],
                    Vector::<D>::from_fn(|a, _| g[a]),
                );
            }
        }
    }
}

/// [`visit_row`] in any dimension: the odometer over the axes.
#[inline(always)]
fn visit_any<const D: usize, const N: usize, V: RowVisitor<D>>(
    f: &[AxisFactors; D],
    visit: &mut V,
) {
    let width = N.pow(D as u32);
    let mut ks = [0usize; D];
    for m in 0..width {
        let mut node = 0usize;
        let mut w = 1.0;
        for a in 0..D {
            node += f[a].offset[ks[a]] as usize;
            w *= f[a].s[ks[a]];
        }
        let g = Vector::<D>::from_fn(|a, _| {
            let mut v = f[a].d[ks[a]];
            for b in 0..D {
                if b != a {
                    v *= f[b].s[ks[b]];
                }
            }
            v
        });
        visit.visit(m, node, w, g);
        for k in ks.iter_mut() {
            *k += 1;
            if *k < N {
                break;
            }
            *k = 0;
        }
    }
}
