//! The particles a d-dimensional solver starts from, and why a set of them is refused.

use super::MaterialNd;
use crate::grid::Boundary;
use crate::nd::{GridNd, ShapeNd, Vector};
pub use crate::testbench::setup_error::SetupError;

/// Initial particle fields of a d-dimensional run. All vectors have one entry per particle.
#[derive(Clone, Debug, PartialEq)]
pub struct ParticlesNd<const D: usize> {
    /// Positions `x_p`.
    pub x: Vec<Vector<D>>,
    /// Velocities `v_p`.
    pub v: Vec<Vector<D>>,
    /// Masses `m_p`.
    pub mass: Vec<f64>,
    /// Initial volumes `V⁰_p` (density `m_p / V⁰_p`).
    pub volume: Vec<f64>,
    /// GIMP domain lengths per axis (ignored by the other shapes).
    pub domain: Vec<Vector<D>>,
    /// Material of each particle (inclusions and several bodies are per-particle materials).
    pub material: Vec<MaterialNd>,
}

impl<const D: usize> ParticlesNd<D> {
    /// Particles at rest filling the grid uniformly: `per_cell[a]` per axis in every cell,
    /// particle `j` of cell `c` at `(c + (j + ½)/k)·h` per axis, each with the cell volume
    /// shared equally, mass `density · volume`, domain lengths `h_a / k_a`.
    pub fn uniform(
        grid: &GridNd<D>,
        per_cell: [usize; D],
        density: f64,
        material: MaterialNd,
    ) -> Self {
        let counts: [usize; D] = std::array::from_fn(|a| grid.cells[a] * per_cell[a]);
        let n: usize = counts.iter().product();
        let volume = grid.cell_volume() / per_cell.iter().product::<usize>() as f64;
        let domain = Vector::<D>::from_fn(|a, _| grid.h[a] / per_cell[a] as f64);
        let mut x = Vec::with_capacity(n);
        for m in 0..n {
            let mut rest = m;
            x.push(Vector::<D>::from_fn(|a, _| {
                let k = rest % counts[a];
                rest /= counts[a];
                grid.origin[a] + (k as f64 + 0.5) * domain[a]
            }));
        }
        Self {
            v: vec![Vector::<D>::zeros(); n],
            mass: vec![density * volume; n],
            volume: vec![volume; n],
            domain: vec![domain; n],
            material: vec![material; n],
            x,
        }
    }

    /// The particles `[r·n/size, (r+1)·n/size)`: process `r`'s share of a run split over
    /// `size` processes by particle ([`super::SolverNd::new_distributed`]).
    pub fn block(&self, r: usize, size: usize) -> Self {
        let block: Vec<usize> = Self::block_range(self.len(), r, size).collect();
        self.select(&block)
    }

    /// The indices `[r·n/size, (r+1)·n/size)` of process `r`'s block of `n` particles.
    pub(crate) fn block_range(n: usize, r: usize, size: usize) -> std::ops::Range<usize> {
        let size = size.max(1);
        r.min(size) * n / size..(r + 1).min(size) * n / size
    }

    /// The particles at `indices`, in that order.
    pub(crate) fn select(&self, indices: &[usize]) -> Self {
        fn pick<T: Clone>(v: &[T], indices: &[usize]) -> Vec<T> {
            indices.iter().map(|&p| v[p].clone()).collect()
        }
        Self {
            x: pick(&self.x, indices),
            v: pick(&self.v, indices),
            mass: pick(&self.mass, indices),
            volume: pick(&self.volume, indices),
            domain: pick(&self.domain, indices),
            material: pick(&self.material, indices),
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Checks the particles against the grid and shape: equal lengths, finite values,
    /// positive masses, volumes and domain lengths (GIMP: at most one cell), valid
    /// materials, positions inside fixed boxes, quadratic B-splines on periodic axes only.
    pub fn validate(&self, grid: &GridNd<D>, shape: ShapeNd) -> Result<(), SetupError> {
        let n = self.x.len();
        if n == 0 {
            return Err(SetupError::NoParticles);
        }
        for (field, len) in [
            ("v", self.v.len()),
            ("mass", self.mass.len()),
            ("volume", self.volume.len()),
            ("domain", self.domain.len()),
            ("material", self.material.len()),
        ] {
            if len != n {
                return Err(SetupError::Length {
                    field,
                    len,
                    expected: n,
                });
            }
        }
        for a in 0..D {
            if !(grid.cells[a] >= 1 && grid.h[a].is_finite() && grid.h[a] > 0.0) {
                return Err(SetupError::GridAxis { axis: a });
            }
            if shape == ShapeNd::BSpline2 && grid.boundary[a] == Boundary::Fixed {
                return Err(SetupError::BSplineOnFixedAxis { axis: a });
            }
            if shape == ShapeNd::BSpline2 && grid.cells[a] < 3 {
                return Err(SetupError::GridAxis { axis: a });
            }
        }
        for p in 0..n {
            let bad = |field: &'static str, value: f64| SetupError::Invalid {
                field,
                index: p,
                value,
            };
            for a in 0..D {
                let x = self.x[p][a];
                if !x.is_finite() {
                    return Err(bad("x", x));
                }
                if grid.boundary[a] == Boundary::Fixed
                    && !(grid.origin[a]..=grid.origin[a] + grid.length(a)).contains(&x)
                {
                    return Err(SetupError::OutsideBox {
                        index: p,
                        axis: a,
                        x,
                    });
                }
            }
            for a in 0..D {
                if !self.v[p][a].is_finite() {
                    return Err(bad("v", self.v[p][a]));
                }
                let l = self.domain[p][a];
                if shape == ShapeNd::Gimp && !(l.is_finite() && l > 0.0 && l <= grid.h[a]) {
                    return Err(bad("domain", l));
                }
            }
            if !(self.mass[p].is_finite() && self.mass[p] > 0.0) {
                return Err(bad("mass", self.mass[p]));
            }
            if !(self.volume[p].is_finite() && self.volume[p] > 0.0) {
                return Err(bad("volume", self.volume[p]));
            }
            let m = self.material[p];
            let e = m.youngs_modulus();
            if !(e.is_finite() && e > 0.0) {
                return Err(bad("youngs_modulus", e));
            }
            if !m.is_valid() {
                return Err(bad("poisson_ratio", m.poisson_ratio()));
            }
        }
        Ok(())
    }
}
