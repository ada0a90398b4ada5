//! The Cartesian background grid in `D` dimensions: its own cell size per axis, periodic or
//! fixed walls per axis.
//!
//! Per axis `a` the lattice nodes sit at `X = origin_a + j h_a`. Storage follows the 1D
//! grid ([`crate::Grid`]): a periodic axis stores `cells_a` nodes (lattice index modulo
//! `cells_a`); a fixed axis stores `cells_a + 3`, the `cells_a + 1` nodes of `[0, L_a]` plus
//! one ghost each side, at storage index `k = j + 1`. Nodes are numbered axis 0 fastest:
//! `i = Σ_a k_a · stride_a`, `stride_0 = 1`, `stride_{a+1} = stride_a · n_a`.
//!
//! A node is *constrained* (velocity and acceleration held at zero, every component) when
//! it lies on or beyond a fixed wall: lattice index `j ≤ 0` or `j ≥ cells_a` on a fixed
//! axis.

use super::Vector;
use crate::grid::Boundary;
use serde::{Deserialize, Serialize};

/// A uniform Cartesian grid on `Π_a [origin_a, origin_a + cells_a h_a]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridNd<const D: usize> {
    /// Boundary condition per axis.
    #[serde(with = "serde_arrays")]
    pub boundary: [Boundary; D],
    /// Number of cells per axis.
    #[serde(with = "serde_arrays")]
    pub cells: [usize; D],
    /// Cell size `h_a` per axis.
    #[serde(with = "serde_arrays")]
    pub h: [f64; D],
    /// Lower corner of the domain.
    #[serde(with = "serde_arrays")]
    pub origin: [f64; D],
}

impl<const D: usize> GridNd<D> {
    /// A grid of `cells[a]` cells of length `length[a] / cells[a]` on `[0, length[a]]` per
    /// axis. The caller validates (`cells ≥ 1`, `length > 0`, finite).
    pub fn new(boundary: [Boundary; D], cells: [usize; D], length: [f64; D]) -> Self {
        Self {
            boundary,
            cells,
            h: std::array::from_fn(|a| length[a] / cells[a] as f64),
            origin: [0.0; D],
        }
    }

    /// Domain length `L_a = cells_a h_a` of axis `a`.
    pub fn length(&self, a: usize) -> f64 {
        self.cells[a] as f64 * self.h[a]
    }

    /// The first axis along which `x` lies outside the box `[origin, origin + length]`,
    /// if any (where a particle whose stencil left the stored nodes went).
    pub fn axis_outside(&self, x: &Vector<D>) -> Option<usize> {
        (0..D).find(|&a| !(self.origin[a]..=self.origin[a] + self.length(a)).contains(&x[a]))
    }

    /// Smallest cell size over the axes.
    pub fn h_min(&self) -> f64 {
        self.h.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Volume of one cell, `Π_a h_a`.
    pub fn cell_volume(&self) -> f64 {
        self.h.iter().product()
    }

    /// Stored nodes along axis `a`: `cells_a` (periodic) or `cells_a + 3` (fixed).
    pub fn nodes_along(&self, a: usize) -> usize {
        match self.boundary[a] {
            Boundary::Periodic => self.cells[a],
            Boundary::Fixed => self.cells[a] + 3,
        }
    }

    /// Number of stored nodes, `Π_a nodes_along(a)`.
    pub fn n_nodes(&self) -> usize {
        (0..D).map(|a| self.nodes_along(a)).product()
    }

    /// Stride of axis `a` in the flat node numbering.
    pub fn stride(&self, a: usize) -> usize {
        (0..a).map(|b| self.nodes_along(b)).product()
    }

    /// Storage index along axis `a` of lattice index `j` (periodic axes wrap; fixed axes
    /// shift by the ghost and return `None` outside the stored range).
    #[inline]
    pub fn storage_along(&self, a: usize, j: i64) -> Option<usize> {
        match self.boundary[a] {
            Boundary::Periodic => Some(j.rem_euclid(self.cells[a] as i64) as usize),
            Boundary::Fixed => {
                let k = j + 1;
                (k >= 0 && (k as usize) < self.cells[a] + 3).then_some(k as usize)
            }
        }
    }

    /// Flat index of the node with lattice indices `j`, if stored.
    pub fn flat_index(&self, j: [i64; D]) -> Option<usize> {
        let mut i = 0;
        let mut stride = 1;
        for (a, &ja) in j.iter().enumerate() {
            i += self.storage_along(a, ja)? * stride;
            stride *= self.nodes_along(a);
        }
        Some(i)
    }

    /// Lattice indices of stored node `i` (periodic axes in `0..cells_a`).
    pub fn lattice_of(&self, i: usize) -> [i64; D] {
        let mut rest = i;
        std::array::from_fn(|a| {
            let n = self.nodes_along(a);
            let k = rest % n;
            rest /= n;
            match self.boundary[a] {
                Boundary::Periodic => k as i64,
                Boundary::Fixed => k as i64 - 1,
            }
        })
    }

    /// Position `X_i` of stored node `i`.
    pub fn node_position(&self, i: usize) -> Vector<D> {
        let j = self.lattice_of(i);
        Vector::<D>::from_fn(|a, _| self.origin[a] + j[a] as f64 * self.h[a])
    }

    /// Whether node `i` is on or beyond a fixed wall (held at zero velocity).
    pub fn is_constrained(&self, i: usize) -> bool {
        let j = self.lattice_of(i);
        (0..D).any(|a| {
            self.boundary[a] == Boundary::Fixed && (j[a] <= 0 || j[a] >= self.cells[a] as i64)
        })
    }
}

/// serde for `[T; D]` with a const `D` (serde implements arrays only up to fixed sizes
/// through its derive; this writes them as sequences).
mod serde_arrays {
    use serde::de::Error;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer, T: Serialize, const D: usize>(
        a: &[T; D],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        a.as_slice().serialize(s)
    }

    pub fn deserialize<'de, De: Deserializer<'de>, T: Deserialize<'de>, const D: usize>(
        d: De,
    ) -> Result<[T; D], De::Error> {
        let v = Vec::<T>::deserialize(d)?;
        let n = v.len();
        v.try_into()
            .map_err(|_| De::Error::custom(format!("expected {D} values, got {n}")))
    }
}
