//! The fixed background grid of the 1D method (eqs 3–4).
//!
//! Nodes are equally spaced, `X_i = a + i h`. Two boundaries are supported:
//!
//! * [`Boundary::Periodic`] (eq 5): `cells` nodes at `X_i = a + i h`, `i = 0 … N−1`; node `N`
//!   is node `0`. Node indices wrap modulo `N`.
//! * [`Boundary::Fixed`]: the `N + 1` nodes `X_0 … X_N` plus one *ghost* node on each side,
//!   `N + 3` nodes stored at `X = a + (i − 1) h`. A GIMP particle domain of width
//!   `l_p ≤ h` whose particle lies in `[a, b]` reaches at most one cell past either end, so one
//!   ghost per side keeps `Σ_i S_ip = 1` exact. The two end nodes and the ghosts are
//!   *constrained*: their velocity and acceleration are held at zero (a clamped bar).

use serde::{Deserialize, Serialize};

/// Boundary condition of the 1D domain's ends, or of one axis of a 2D/3D grid
/// ([`crate::nd::GridNd`], one per axis; its module docs give the node numbering of each
/// kind: a periodic axis stores `cells` nodes, a fixed one `cells + 3` with a ghost node
/// past each wall, and the nodes on or past a wall are held at zero velocity).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Boundary {
    /// Periodic ends (eq 5): the domain is a ring of length `L`.
    Periodic,
    /// Both ends clamped: velocity and acceleration are zero at `X_0` and `X_N`.
    Fixed,
}

/// A uniform 1D grid on `[origin, origin + cells·h]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Boundary condition.
    pub boundary: Boundary,
    /// Number of cells `N` (intervals of eq 3).
    pub cells: usize,
    /// Node spacing `h` (eq 4).
    pub h: f64,
    /// Left end `a` of the domain.
    pub origin: f64,
}

impl Grid {
    /// A grid of `cells` cells on `[0, length]`. The caller validates the arguments
    /// (see [`crate::scenario`]); here `cells ≥ 1` and `length > 0` are assumed.
    pub fn new(boundary: Boundary, cells: usize, length: f64) -> Self {
        Self {
            boundary,
            cells,
            h: length / cells as f64,
            origin: 0.0,
        }
    }

    /// Length `L = N h` of the domain.
    pub fn length(&self) -> f64 {
        self.cells as f64 * self.h
    }

    /// Number of stored nodes: `N` (periodic) or `N + 3` (fixed, with two ghosts).
    pub fn n_nodes(&self) -> usize {
        match self.boundary {
            Boundary::Periodic => self.cells,
            Boundary::Fixed => self.cells + 3,
        }
    }

    /// Storage index of the node with *lattice* index `j` (node at `origin + j h`).
    /// Periodic grids wrap `j` modulo `N`; fixed grids shift by the left ghost and
    /// return `None` outside the stored range.
    #[inline]
    pub fn storage_index(&self, j: i64) -> Option<usize> {
        match self.boundary {
            Boundary::Periodic => Some(j.rem_euclid(self.cells as i64) as usize),
            Boundary::Fixed => {
                let k = j + 1;
                (k >= 0 && (k as usize) < self.cells + 3).then_some(k as usize)
            }
        }
    }

    /// Position `X_i` of stored node `i` (in `[origin, origin + L)` for periodic grids).
    #[inline]
    pub fn node_x(&self, i: usize) -> f64 {
        match self.boundary {
            Boundary::Periodic => self.origin + i as f64 * self.h,
            Boundary::Fixed => self.origin + (i as f64 - 1.0) * self.h,
        }
    }

    /// All node positions, in storage order.
    pub fn node_positions(&self) -> Vec<f64> {
        (0..self.n_nodes()).map(|i| self.node_x(i)).collect()
    }

    /// Whether stored node `i` is constrained (velocity and acceleration held at zero):
    /// the two end nodes and the ghosts of a fixed grid; none for periodic grids.
    pub fn is_constrained(&self, i: usize) -> bool {
        match self.boundary {
            Boundary::Periodic => false,
            Boundary::Fixed => i <= 1 || i + 2 >= self.cells + 3,
        }
    }

    /// Signed offset `X_i − x` from a point `x` to stored node `i`, taking the nearest
    /// periodic image on periodic grids (the offset the Taylor expansions of eqs 31 and
    /// 35 need).
    #[inline]
    pub fn offset(&self, i: usize, x: f64) -> f64 {
        let d = self.node_x(i) - x;
        match self.boundary {
            Boundary::Periodic => {
                let l = self.length();
                d - l * (d / l).round()
            }
            Boundary::Fixed => d,
        }
    }

    /// Wraps a position into `[origin, origin + L)` on periodic grids; identity otherwise.
    #[inline]
    pub fn wrap(&self, x: f64) -> f64 {
        match self.boundary {
            Boundary::Periodic => {
                let l = self.length();
                let mut y = x - self.origin;
                if !(0.0..l).contains(&y) {
                    y = y.rem_euclid(l);
                    if y >= l {
                        y = 0.0;
                    }
                }
                self.origin + y
            }
            Boundary::Fixed => x,
        }
    }
}
