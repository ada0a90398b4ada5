//! The input every estimator reads: where the particles are and what they weigh.
//!
//! A [`Layout`] gathers the grid, the weights `S_ip`, `D_ip` at the particle positions, the
//! particle masses `m_p` and current volumes `V_p = F_p V_p⁰` (eq 8), and derives the nodal
//! masses `m_i = Σ_p S_ip m_p` (eq 7), nodal volumes `V_i = Σ_p S_ip V_p` and nodal densities
//! `ρ_i = m_i / V_i`. `ρ_i` is the density that turns the divergence `∂σ/∂x` into the
//! acceleration of eq 2; it equals `ρ` exactly when every particle has `m_p = ρ V_p`.

use super::EstimatorError;
use crate::grid::Grid;
use crate::stepper::View;
use crate::weights::{WeightKind, Weights};

/// Particle layout and nodal masses for the estimators (see the module docs).
#[derive(Clone, Debug)]
pub struct Layout<'a> {
    /// The background grid.
    pub grid: &'a Grid,
    /// `S_ip`, `D_ip` at `x`.
    pub weights: &'a Weights,
    /// Particle positions `x_p`.
    pub x: &'a [f64],
    /// Particle masses `m_p`.
    pub mass: Vec<f64>,
    /// Current particle volumes `V_p = F_p V_p⁰`.
    pub volume: Vec<f64>,
    /// Nodal masses `m_i = Σ_p S_ip m_p` (eq 7).
    pub node_mass: Vec<f64>,
    /// Nodal volumes `V_i = Σ_p S_ip V_p`.
    pub node_volume: Vec<f64>,
    /// Whether node `i` takes part: positive mass and not constrained by the grid.
    pub node_active: Vec<bool>,
}

fn check(
    field: &'static str,
    v: &[f64],
    expected: usize,
    positive: bool,
) -> Result<(), EstimatorError> {
    if v.len() != expected {
        return Err(EstimatorError::Length {
            field,
            len: v.len(),
            expected,
        });
    }
    for (index, &value) in v.iter().enumerate() {
        if !value.is_finite() || (positive && value <= 0.0) {
            return Err(EstimatorError::InvalidValue {
                field,
                index,
                value,
            });
        }
    }
    Ok(())
}

impl<'a> Layout<'a> {
    /// A layout from positions, masses and current volumes. A node is active when its mass
    /// exceeds `1e-12` of the mean nodal mass and the grid does not constrain it.
    pub fn new(
        grid: &'a Grid,
        weights: &'a Weights,
        x: &'a [f64],
        mass: &[f64],
        volume: &[f64],
    ) -> Result<Self, EstimatorError> {
        let np = x.len();
        if weights.n_particles() != np {
            return Err(EstimatorError::Length {
                field: "weights (particles)",
                len: weights.n_particles(),
                expected: np,
            });
        }
        if weights.n_nodes() != grid.n_nodes() {
            return Err(EstimatorError::Length {
                field: "weights (nodes)",
                len: weights.n_nodes(),
                expected: grid.n_nodes(),
            });
        }
        check("x", x, np, false)?;
        check("mass", mass, np, true)?;
        check("volume", volume, np, true)?;
        let nn = grid.n_nodes();
        let mut node_mass = vec![0.0; nn];
        let mut node_volume = vec![0.0; nn];
        weights.scatter(WeightKind::S, mass, &mut node_mass);
        weights.scatter(WeightKind::S, volume, &mut node_volume);
        let mean = node_mass.iter().sum::<f64>() / nn.max(1) as f64;
        let node_active = (0..nn)
            .map(|i| node_mass[i] > 1e-12 * mean && !grid.is_constrained(i))
            .collect();
        Ok(Self {
            grid,
            weights,
            x,
            mass: mass.to_vec(),
            volume: volume.to_vec(),
            node_mass,
            node_volume,
            node_active,
        })
    }

    /// The layout of a solver's state: volumes `F_p V_p⁰`, the view's masses, and the view's
    /// active-node flags (the solver's own choice of which nodes take part).
    pub fn from_view(view: &View<'a>) -> Result<Self, EstimatorError> {
        let np = view.x.len();
        check("f", view.f, np, true)?;
        check("volume0", view.volume0, np, true)?;
        let volume: Vec<f64> = view
            .f
            .iter()
            .zip(view.volume0)
            .map(|(f, v)| f * v)
            .collect();
        let mut layout = Self::new(view.grid, view.weights.get(), view.x, view.mass, &volume)?;
        if view.node_active.len() != layout.node_active.len() {
            return Err(EstimatorError::Length {
                field: "node_active",
                len: view.node_active.len(),
                expected: layout.node_active.len(),
            });
        }
        for (mine, &theirs) in layout.node_active.iter_mut().zip(view.node_active) {
            *mine = *mine && theirs;
        }
        Ok(layout)
    }

    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.x.len()
    }

    /// Number of stored nodes.
    pub fn n_nodes(&self) -> usize {
        self.node_mass.len()
    }

    /// `x_p − X_i` for stored node `i` (periodic minimum image): the offset of eq 31.
    #[inline]
    pub fn dx_from_node(&self, i: usize, p: usize) -> f64 {
        -self.grid.offset(i, self.x[p])
    }

    /// Nodal density `ρ_i = m_i / V_i` (0 where `V_i = 0`).
    pub fn node_density(&self, i: usize) -> f64 {
        if self.node_volume[i] > 0.0 {
            self.node_mass[i] / self.node_volume[i]
        } else {
            0.0
        }
    }

    /// The eq 17 particle→node map of a particle field: `u_i = Σ_p S_ip m_p u_p / m_i` on
    /// active nodes, 0 elsewhere.
    pub fn map_to_nodes(&self, u: &[f64]) -> Vec<f64> {
        let mu: Vec<f64> = u.iter().zip(&self.mass).map(|(u, m)| u * m).collect();
        let mut out = vec![0.0; self.n_nodes()];
        self.weights.scatter(WeightKind::S, &mu, &mut out);
        for (i, o) in out.iter_mut().enumerate() {
            *o = if self.node_active[i] {
                *o / self.node_mass[i]
            } else {
                0.0
            };
        }
        out
    }

    /// The eq 18 particle→node derivative of a particle field, in gradient units:
    /// `G_i[u] = −(1/V_i) Σ_p D_ip V_p u_p` on active nodes, 0 elsewhere. For `u = σ` this is
    /// `ρ_i a_i`.
    pub fn derivative_to_nodes(&self, u: &[f64]) -> Vec<f64> {
        let vu: Vec<f64> = u.iter().zip(&self.volume).map(|(u, v)| u * v).collect();
        let mut out = vec![0.0; self.n_nodes()];
        self.weights.scatter(WeightKind::D, &vu, &mut out);
        for (i, o) in out.iter_mut().enumerate() {
            *o = if self.node_active[i] {
                -*o / self.node_volume[i]
            } else {
                0.0
            };
        }
        out
    }
}
