//! One particle's share of a step's nodal work over its formed row: the gather of
//! grid → particle (`Σ S a_i`, `Σ v_iⁿ⁺¹ ⊗ ∇S`) and the scatter of particle → grid
//! (`S m`, `S m v`, `−V σ ∇S`), each in row order.
//!
//! The nodes of a row are `Σ_a offset_a[k_a]` ([`crate::nd::factors`]), so none exceeds
//! [`row_max_node`], the sum of each axis's largest offset. Both visits check that bound
//! once per row against the nodal arrays' length and then index them unchecked, instead of
//! a bounds check per stencil node (2 in the gather, 3 in the scatter: 45 per particle in
//! 2D, 135 in 3D), a measurable share of the step's instructions. The sums are the same,
//! bit for bit.

use crate::nd::factors::{visit_row_with, AxisFactors, RowVisitor};
use crate::nd::{Tensor, Vector};

/// The largest node index of the row formed from `f` with `n` nodes per axis:
/// `Σ_a max_{k<n} offset_a[k]` (every node of the row is at most this). The sum saturates,
/// so on any target it is at least every node's index (a saturated sum fails the caller's
/// length check).
#[inline(always)]
fn row_max_node<const D: usize>(f: &[AxisFactors; D], n: usize) -> usize {
    f.iter()
        .map(|fa| fa.offset[..n.min(3)].iter().copied().max().unwrap_or(0) as usize)
        .fold(0, usize::saturating_add)
}

/// The gather of grid → particle: `Σ S a_i` and `Σ v_iⁿ⁺¹ ⊗ ∇S`, in row order.
pub(super) struct Gather<'a, const D: usize> {
    node_a: &'a [Vector<D>],
    node_v1: &'a [Vector<D>],
    /// `Σ S a_i`.
    pub acc: Vector<D>,
    /// `Σ v_iⁿ⁺¹ ⊗ ∇S`.
    pub l: Tensor<D>,
}

impl<'a, const D: usize> Gather<'a, D> {
    /// Zero sums over the nodal accelerations `node_a` and velocities `node_v1`.
    #[inline(always)]
    pub fn new(node_a: &'a [Vector<D>], node_v1: &'a [Vector<D>]) -> Self {
        Gather {
            node_a,
            node_v1,
            acc: Vector::<D>::zeros(),
            l: Tensor::<D>::zeros(),
        }
    }

    /// Adds the row formed from `f` (`n` nodes per axis). Panics if a node of it lies past
    /// the nodal arrays, as indexing them would.
    #[inline(always)]
    pub fn add_row(&mut self, f: &[AxisFactors; D], n: usize) {
        let len = self.node_a.len().min(self.node_v1.len());
        assert!(row_max_node(f, n) < len, "a stencil node past the grid");
        visit_row_with(f, n, &mut CheckedGather(self));
    }
}

/// [`Gather`] visiting a row whose nodes [`Gather::add_row`] checked.
struct CheckedGather<'g, 'a, const D: usize>(&'g mut Gather<'a, D>);

impl<const D: usize> RowVisitor<D> for CheckedGather<'_, '_, D> {
    #[inline(always)]
    fn visit(&mut self, _: usize, i: usize, w: f64, g: Vector<D>) {
        let s = &mut *self.0;
        // SAFETY: only `Gather::add_row` visits with this type, after checking that every
        // node of the row (at most `row_max_node`) is below both arrays' length.
        let (a, v1) = unsafe { (s.node_a.get_unchecked(i), s.node_v1.get_unchecked(i)) };
        s.acc += *a * w;
        s.l += *v1 * g.transpose();
    }
}

/// One particle's share of particle → grid: `S m`, `S m v` and `−V σ ∇S` = `vs ∇S` added
/// into the nodal sums.
pub(super) struct Scatter<'a, const D: usize> {
    mass: &'a mut [f64],
    momentum: &'a mut [Vector<D>],
    force: &'a mut [Vector<D>],
}

impl<'a, const D: usize> Scatter<'a, D> {
    /// A scatter into the nodal sums `Σ S m`, `Σ S m v`, `−Σ V σ ∇S`.
    #[inline(always)]
    pub fn new(
        mass: &'a mut [f64],
        momentum: &'a mut [Vector<D>],
        force: &'a mut [Vector<D>],
    ) -> Self {
        Scatter {
            mass,
            momentum,
            force,
        }
    }

    /// Adds the row formed from `f` (`n` nodes per axis) of a particle of mass `mp`,
    /// momentum `mv` and `vs = −V σ`. Panics if a node of it lies past the nodal arrays,
    /// as indexing them would.
    #[inline(always)]
    pub fn add_row(
        &mut self,
        f: &[AxisFactors; D],
        n: usize,
        mp: f64,
        mv: Vector<D>,
        vs: Tensor<D>,
    ) {
        let len = self
            .mass
            .len()
            .min(self.momentum.len())
            .min(self.force.len());
        assert!(row_max_node(f, n) < len, "a stencil node past the grid");
        let mut row = CheckedScatter {
            to: self,
            mp,
            mv,
            vs,
        };
        visit_row_with(f, n, &mut row);
    }
}

/// [`Scatter`] of one particle visiting a row whose nodes [`Scatter::add_row`] checked.
struct CheckedScatter<'s, 'a, const D: usize> {
    to: &'s mut Scatter<'a, D>,
    mp: f64,
    mv: Vector<D>,
    vs: Tensor<D>,
}

impl<const D: usize> RowVisitor<D> for CheckedScatter<'_, '_, D> {
    #[inline(always)]
    fn visit(&mut self, _: usize, i: usize, w: f64, g: Vector<D>) {
        let to = &mut *self.to;
        // SAFETY: only `Scatter::add_row` visits with this type, after checking that every
        // node of the row (at most `row_max_node`) is below the three arrays' length.
        unsafe {
            *to.mass.get_unchecked_mut(i) += w * self.mp;
            *to.momentum.get_unchecked_mut(i) += self.mv * w;
            *to.force.get_unchecked_mut(i) += self.vs * g;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bound is the largest node a row visits, for 2 and 3 nodes per axis.
    #[test]
    fn row_max_node_bounds_every_node_of_the_row() {
        let f = [
            AxisFactors {
                offset: [7, 0, 1],
                s: [0.2, 0.5, 0.3],
                d: [1.0, 0.0, -1.0],
            },
            AxisFactors {
                offset: [40, 50, 30],
                s: [0.1, 0.6, 0.3],
                d: [1.0, 0.0, -1.0],
            },
        ];
        for n in [2, 3] {
            let mut most = 0;
            visit_row_with(&f, n, &mut |_: usize, i: usize, _: f64, _: Vector<2>| {
                most = most.max(i)
            });
            assert_eq!(row_max_node(&f, n), most, "n {n}");
        }
    }
}
