//! [`SlabNd`]: a d-dimensional grid decomposed into slabs along its last axis, one slab per
//! process, with ghost layers and the exchanges a particle → grid pass and a moving particle
//! need ([`super::SolverNd::new_slab`]).
//!
//! # The decomposition
//!
//! The `C` cells of the last axis (`y` in 2D, `z` in 3D: its node planes are contiguous in
//! the flat numbering, axis 0 fastest) are split into `size` runs of consecutive cells,
//! process `r` owning cells `[c₀, c₁) = [r·C/size, (r+1)·C/size)`, at least
//! [`MIN_CELLS`] each. A process owns
//!
//! * the particles with `y ∈ [origin + c₀h, origin + c₁h)` (the first and last slab of a
//!   fixed axis also those on and beyond the walls), and
//! * the node planes of lattice index `c₀ ≤ J < c₁` (the first and last slab of a fixed
//!   axis also the wall and ghost planes beyond them).
//!
//! Its *window* is the node planes `c₀ − 2 ≤ J < c₁ + 2` (clipped to the stored planes on a
//! fixed axis): every node the stencil of an owned particle reaches (GIMP with particle
//! domains up to a cell, quadratic B-splines: `J ∈ [c₀ − 1, c₁ + 1]`; linear hats less).
//! Two neighbouring windows share the four planes `c₁ − 2 ≤ J < c₁ + 2` (on a periodic
//! axis the first and last slab are neighbours); with slabs of at least four cells no node
//! is in three windows.
//!
//! # The exchanges
//!
//! * **Nodal sums** ([`SlabNd::complete`]): after a particle → grid pass each process sends
//!   its partial sums on the shared planes to the neighbour and adds the neighbour's. Both
//!   copies then hold `a + b` (IEEE addition is commutative: bit for bit the same), so the
//!   grid update — a function of the node's sums only — is the same at every copy.
//! * **Migration** ([`SlabNd::migrate`]): after a grid → particle pass, a particle whose
//!   new `y` left the owned range goes to the neighbour that owns it, with every field
//!   that describes it (a record of `3D + 2D² + 9` numbers, `nd::migration`). A step moves a particle much
//!   less than a slab (four cells); a particle that jumps past the neighbour fails the
//!   trial.
//!
//! Both are two shifts ([`crate::reduce::Reduce::exchange`]): to the upper neighbour and
//! from the lower one, then the reverse.

use super::SetupError;
use crate::grid::Boundary;
use crate::nd::{GridNd, NodalHalo, Vector};
use crate::reduce::Reduce;
use std::ops::Range;
use std::rc::Rc;

/// Fewest cells along the decomposed axis per process.
pub const MIN_CELLS: usize = 4;
/// Ghost planes each side of the owned planes.
const GHOST: i64 = 2;
/// Planes two neighbouring windows share.
const SHARED: usize = 2 * GHOST as usize;
const TAG_SUMS_UP: u16 = 11;
const TAG_SUMS_DOWN: u16 = 12;
const TAG_MOVE_UP: u16 = 21;
const TAG_MOVE_DOWN: u16 = 22;

/// One process's slab of a decomposed grid (module docs).
#[derive(Clone, Debug)]
pub struct SlabNd<const D: usize> {
    whole: GridNd<D>,
    local: GridNd<D>,
    plane_len: usize,
    global_node: Vec<u32>,
    owned: Vec<bool>,
    down: Option<usize>,
    up: Option<usize>,
    reduce: Rc<dyn Reduce>,
}

impl<const D: usize> SlabNd<D> {
    /// This process's slab of `whole` over the processes of `reduce`.
    pub fn new(whole: GridNd<D>, reduce: Rc<dyn Reduce>) -> Result<Self, SetupError> {
        let axis = D - 1;
        let (rank, size) = (reduce.rank(), reduce.size().max(1));
        if whole.n_nodes() > u32::MAX as usize {
            // Node indices are stored as u32 (the weights' format).
            return Err(SetupError::GridAxis { axis });
        }
        let n_cells = whole.cells[axis];
        if size > 1 && n_cells < MIN_CELLS * size {
            return Err(SetupError::Decomposition {
                cells: n_cells,
                processes: size,
                min_cells: MIN_CELLS,
            });
        }
        if size == 1 {
            // One process: the whole grid, its own periodic wrap, no neighbours.
            let n = whole.n_nodes();
            return Ok(Self {
                local: whole.clone(),
                plane_len: whole.stride(axis),
                global_node: (0..n as u32).collect(),
                owned: vec![true; n],
                down: None,
                up: None,
                whole,
                reduce,
            });
        }
        let start = |r: usize| r * n_cells / size;
        let (c0, c1) = (start(rank), start(rank + 1));
        let periodic = whole.boundary[axis] == Boundary::Periodic;
        let (lo, hi) = if periodic {
            (c0 as i64 - GHOST, c1 as i64 + GHOST)
        } else {
            // Stored lattice planes of a fixed axis: −1 ..= C + 1.
            (
                (c0 as i64 - GHOST).max(-1),
                (c1 as i64 + GHOST).min(n_cells as i64 + 2),
            )
        };
        let planes = (hi - lo) as usize;
        let mut local = whole.clone();
        local.boundary[axis] = Boundary::Fixed;
        local.cells[axis] = planes - 3;
        local.origin[axis] = whole.origin[axis] + (lo + 1) as f64 * whole.h[axis];
        let plane_len = whole.stride(axis);
        let last = rank + 1 == size;
        let mut global_node = Vec::with_capacity(planes * plane_len);
        let mut owned = Vec::with_capacity(planes * plane_len);
        for k in 0..planes {
            let j = lo + k as i64;
            let g = whole
                .storage_along(axis, j)
                .expect("window planes are stored planes");
            let own = (j >= c0 as i64 || (!periodic && rank == 0))
                && (j < c1 as i64 || (!periodic && last));
            for rest in 0..plane_len {
                global_node.push((g * plane_len + rest) as u32);
                owned.push(own);
            }
        }
        let (down, up) = if size == 1 {
            (None, None)
        } else if periodic {
            (Some((rank + size - 1) % size), Some((rank + 1) % size))
        } else {
            ((rank > 0).then(|| rank - 1), (!last).then_some(rank + 1))
        };
        Ok(Self {
            whole,
            local,
            plane_len,
            global_node,
            owned,
            down,
            up,
            reduce,
        })
    }

    /// The run's reductions and exchanges.
    pub fn reduce(&self) -> &dyn Reduce {
        &*self.reduce
    }

    /// The whole grid.
    pub fn whole(&self) -> &GridNd<D> {
        &self.whole
    }

    /// The window's grid: the local node numbering (a fixed axis of `planes − 3` cells
    /// along the last axis; which nodes are walls is the whole grid's business).
    pub fn local(&self) -> &GridNd<D> {
        &self.local
    }

    /// Index in the whole grid of each local node.
    pub fn global_node(&self) -> &[u32] {
        &self.global_node
    }

    /// Whether this process owns each local node.
    pub fn owned(&self) -> &[bool] {
        &self.owned
    }

    /// The process that owns a particle at `y` on the last axis.
    pub fn owner_of(&self, y: f64) -> usize {
        let axis = D - 1;
        let n_cells = self.whole.cells[axis];
        let size = self.reduce.size().max(1);
        let c = ((y - self.whole.origin[axis]) / self.whole.h[axis]).floor();
        let c = if c.is_nan() {
            0
        } else {
            c.clamp(0.0, (n_cells - 1) as f64) as usize
        };
        let mut r = (c * size / n_cells).min(size - 1);
        while r + 1 < size && (r + 1) * n_cells / size <= c {
            r += 1;
        }
        while r > 0 && r * n_cells / size > c {
            r -= 1;
        }
        r
    }

    /// Whether this process owns a particle at `y`.
    pub fn owns(&self, y: f64) -> bool {
        self.owner_of(y) == self.reduce.rank()
    }

    /// Local node ranges shared with the lower and the upper neighbour.
    fn shared(&self) -> (Option<Range<usize>>, Option<Range<usize>>) {
        let planes = self.global_node.len() / self.plane_len;
        let nodes = |p0: usize| p0 * self.plane_len..(p0 + SHARED) * self.plane_len;
        (
            self.down.map(|_| nodes(0)),
            self.up.map(|_| nodes(planes - SHARED)),
        )
    }

    /// The two shifts every exchange makes: `to_up` to the upper neighbour while the lower
    /// one's arrives, then `to_down` to the lower neighbour while the upper one's arrives.
    /// Returns `(from below, from above)`.
    fn shifts(
        &self,
        tags: (u16, u16),
        to_up: &[f64],
        to_down: &[f64],
    ) -> (Option<Vec<f64>>, Option<Vec<f64>>) {
        let from_down = self.reduce.exchange(self.up, self.down, tags.0, to_up);
        let from_up = self.reduce.exchange(self.down, self.up, tags.1, to_down);
        (from_down, from_up)
    }

    /// A halo swap: `pack(range)` the values this process sends for a shared range of
    /// local nodes; returns each shared range with what the neighbour sent for it.
    fn swap(
        &self,
        mut pack: impl FnMut(Range<usize>) -> Vec<f64>,
    ) -> Vec<(Range<usize>, Vec<f64>)> {
        let (down, up) = self.shared();
        let to_up = up.clone().map(&mut pack).unwrap_or_default();
        let to_down = down.clone().map(&mut pack).unwrap_or_default();
        let (from_down, from_up) = self.shifts((TAG_SUMS_UP, TAG_SUMS_DOWN), &to_up, &to_down);
        [down.zip(from_down), up.zip(from_up)]
            .into_iter()
            .flatten()
            .collect()
    }

    /// Completes the nodal sums `Σ S m`, `Σ S m v`, `−Σ V σ ∇S` of a particle → grid pass
    /// on the shared planes (module docs).
    pub fn complete_nodal(
        &self,
        node_mass: &mut [f64],
        node_v: &mut [Vector<D>],
        node_a: &mut [Vector<D>],
    ) {
        let w = 1 + 2 * D;
        let received = self.swap(|r| {
            let mut buf = Vec::with_capacity(r.len() * w);
            for i in r {
                buf.push(node_mass[i]);
                buf.extend(node_v[i].iter());
                buf.extend(node_a[i].iter());
            }
            buf
        });
        for (r, v) in received {
            if v.len() != r.len() * w {
                continue;
            }
            for (k, i) in r.enumerate() {
                let b = &v[k * w..(k + 1) * w];
                node_mass[i] += b[0];
                for a in 0..D {
                    node_v[i][a] += b[1 + a];
                    node_a[i][a] += b[1 + D + a];
                }
            }
        }
    }

    /// Sends the records ([`super::migration::ParticleRecord`]) of the particles that left
    /// the owned range up and down to the neighbours that own them (module docs) and
    /// returns the records that arrive, from below, then from above. Collective between
    /// neighbours.
    pub fn migrate(&self, up_going: &[f64], down_going: &[f64]) -> Vec<f64> {
        let (from_down, from_up) = self.shifts((TAG_MOVE_UP, TAG_MOVE_DOWN), up_going, down_going);
        [from_down, from_up]
            .into_iter()
            .flatten()
            .flatten()
            .collect()
    }

    /// Where a particle at `y` that this process no longer owns goes: `Some(true)` up,
    /// `Some(false)` down, `None` when neither neighbour owns it (it jumped past a slab).
    pub fn direction(&self, y: f64) -> Option<bool> {
        let owner = self.owner_of(y);
        if Some(owner) == self.up {
            Some(true)
        } else if Some(owner) == self.down {
            Some(false)
        } else {
            None
        }
    }
}

impl<const D: usize> NodalHalo for SlabNd<D> {
    fn reduce(&self) -> &dyn Reduce {
        &*self.reduce
    }

    fn complete(&self, values: &mut [f64], width: usize) {
        let received = self.swap(|r| values[r.start * width..r.end * width].to_vec());
        for (r, v) in received {
            let dst = &mut values[r.start * width..r.end * width];
            if v.len() == dst.len() {
                dst.iter_mut().zip(&v).for_each(|(a, b)| *a += b);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reduce::SingleProcess;

    #[test]
    fn one_process_owns_the_whole_grid_and_slabs_are_checked() {
        let grid = GridNd::<2>::new([Boundary::Fixed; 2], [6, 10], [0.6, 1.0]);
        let slab = SlabNd::new(grid.clone(), Rc::new(SingleProcess)).expect("slab");
        assert_eq!(slab.local().n_nodes(), grid.n_nodes());
        assert!(slab.owned().iter().all(|&o| o));
        let global: Vec<u32> = (0..grid.n_nodes() as u32).collect();
        assert_eq!(slab.global_node(), &global[..]);
        assert!(slab.owns(1.0) && slab.owns(-0.01) && slab.owns(0.55));
        let small = GridNd::<2>::new([Boundary::Periodic; 2], [6, 7], [0.6, 0.7]);
        assert!(SlabNd::new(small.clone(), Rc::new(SingleProcess)).is_ok());
        assert!(matches!(
            SlabNd::new(small, Rc::new(TwoOf(0))),
            Err(SetupError::Decomposition { cells: 7, .. })
        ));
    }

    /// Rank `.0` of two processes, for the layout only (no exchange is made).
    #[derive(Debug)]
    struct TwoOf(usize);

    impl Reduce for TwoOf {
        fn rank(&self) -> usize {
            self.0
        }
        fn size(&self) -> usize {
            2
        }
        fn min_and_any(&self, v: f64, f: bool) -> (f64, bool) {
            (v, f)
        }
        fn any_flags(&self, _: &mut [bool]) {}
        fn sum(&self, _: &mut [f64]) {}
        fn exchange(
            &self,
            _: Option<usize>,
            _: Option<usize>,
            _: u16,
            _: &[f64],
        ) -> Option<Vec<f64>> {
            None
        }
    }

    #[test]
    fn two_slabs_own_every_node_once_and_share_four_planes() {
        for boundary in [Boundary::Periodic, Boundary::Fixed] {
            let grid = GridNd::<2>::new([boundary; 2], [5, 9], [0.5, 0.9]);
            let slabs: Vec<SlabNd<2>> = (0..2)
                .map(|r| SlabNd::new(grid.clone(), Rc::new(TwoOf(r))).expect("slab"))
                .collect();
            let mut owners = vec![0; grid.n_nodes()];
            let mut copies = vec![0; grid.n_nodes()];
            for s in &slabs {
                assert_eq!(s.local().n_nodes(), s.global_node().len());
                for (&g, &o) in s.global_node().iter().zip(s.owned()) {
                    copies[g as usize] += 1;
                    owners[g as usize] += usize::from(o);
                }
                // Local node positions are the whole grid's.
                for (i, &g) in s.global_node().iter().enumerate() {
                    let (a, b) = (s.local().node_position(i), grid.node_position(g as usize));
                    let period = if boundary == Boundary::Periodic {
                        0.9
                    } else {
                        f64::INFINITY
                    };
                    let dy = (a[1] - b[1]).abs();
                    assert!(
                        (a[0] - b[0]).abs() < 1e-12 && (dy < 1e-12 || (dy - period).abs() < 1e-12),
                        "{boundary:?}: node {i} at {a:?}, global {g} at {b:?}"
                    );
                }
            }
            assert!(owners.iter().all(|&o| o == 1), "{boundary:?}: {owners:?}");
            let shared = copies.iter().filter(|&&c| c == 2).count();
            let expected_planes = if boundary == Boundary::Periodic { 8 } else { 4 };
            assert_eq!(shared, expected_planes * grid.stride(1), "{boundary:?}");
            // Ownership of particles: the split is at cell 4 (y = 0.4).
            assert!(slabs[0].owns(0.39) && slabs[1].owns(0.41));
            assert_eq!(slabs[0].direction(0.41), Some(true));
        }
    }
}
