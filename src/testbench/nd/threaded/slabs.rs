//! The slabs of the threaded step: the grid cut across its last axis into a multiple of
//! [`COLOURS`] slabs, so that slabs of one colour scatter at once without sharing a node.

use super::{COLOURS, MAX_SLABS, MIN_SLAB_CELLS};
use crate::nd::GridNd;

/// The slabs of a grid across its last axis: cell boundaries `bounds[s] … bounds[s + 1]`.
pub(super) struct Slabs {
    origin: f64,
    inv_h: f64,
    cells: usize,
    bounds: Vec<usize>,
}

impl Slabs {
    /// A multiple of [`COLOURS`] slabs of at least [`MIN_SLAB_CELLS`] cells, or one slab
    /// where the last axis is too short for that.
    pub fn of<const D: usize>(grid: &GridNd<D>) -> Self {
        let cells = grid.cells[D - 1];
        let count = (cells / MIN_SLAB_CELLS).min(MAX_SLABS) / COLOURS * COLOURS;
        let count = count.max(1);
        Self {
            origin: grid.origin[D - 1],
            inv_h: 1.0 / grid.h[D - 1],
            cells,
            bounds: (0..=count).map(|s| s * cells / count).collect(),
        }
    }

    pub fn count(&self) -> usize {
        self.bounds.len() - 1
    }

    /// The slab of a particle at `x_last` along the last axis (clamped into the grid).
    #[inline]
    pub fn slab_of(&self, x_last: f64) -> u32 {
        let c = crate::shape::floor((x_last - self.origin) * self.inv_h);
        let c = if c > 0.0 {
            (c as usize).min(self.cells - 1)
        } else {
            0
        };
        let count = self.count();
        let mut s = c * count / self.cells;
        while s + 1 < count && self.bounds[s + 1] <= c {
            s += 1;
        }
        while self.bounds[s] > c {
            s -= 1;
        }
        s as u32
    }
}
