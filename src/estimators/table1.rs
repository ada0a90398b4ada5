//! The experiment of the paper's Section 5 and Table 1, as a library function shared by the
//! tests and `examples/table1.rs`.
//!
//! No time stepping: particles are laid out on `[0, 1]`, `ppc` per cell at
//! `x_p = (c + (k + ½ + j ξ_p)/ppc) h` (uniform for jitter `j = 0`; `ξ_p` uniform in
//! `[−½, ½]` from a seeded SplitMix64 stream otherwise), with GIMP widths and volumes
//! `h/ppc` and masses `ρ h/ppc` (eq 7), `E = ρ = 1`, `C = √(E/ρ) = 1`. The analytic standing
//! wave is sampled at particles and nodes, pushed through one MPM map, and compared with the
//! exact result; the estimate of the same error is computed from the mapped data alone
//! (never from the exact derivatives). Norms are L∞ (eq 48) over the compared points; the
//! index is `‖estimate‖∞ / ‖error‖∞` (eq 48).
//!
//! # Fields
//!
//! * [`Field::Phase`] (default): `v = C sin 2πx cos 2πCt`, `σ = E cos 2πx sin 2πCt` at
//!   `t = 1/8` (phase π/4). The paper's printed norms match this field.
//! * [`Field::Eq45`]: eq 45 literally, `v = C sin 2πx cos Cπt`, at `t = π/4`, with the stress
//!   `σ = E ∂u/∂x`, `u = ∫₀ᵗ v`, i.e. `σ = 2E cos 2πx sin Cπt`. (This pair does not solve
//!   eqs 1–2 — eq 45's `cos Cπt` should be `cos 2πCt`, see [`crate::problems`] — but Table 1
//!   only samples fields, so any smooth pair serves.)
//!
//! # Cases (what each compares — the paper is terse; these choices reproduce its norms)
//!
//! 1. **eq 17**: particle velocities → nodal velocities; error `v(X_i) − v_i` at active
//!    nodes; estimate eq 34.
//! 2. **eq 18**: particle stresses → nodal accelerations; error `∂σ/∂x(X_i)/ρ_i − a_i` at
//!    active nodes; estimate eq 33.
//! 3. **eq 21**: exact nodal values `v(X_i)` interpolated to the particles; error
//!    `v(x_p) − Σ_i S_ip v(X_i)`; estimate eq 37 with eq 40. (Eq 21 maps accelerations; the
//!    paper's printed norms are those of the velocity field, so the velocity is used.)
//! 4. **eq 24**: exact nodal velocities differentiated at the particles; error
//!    `∂v/∂x(x_p) − Σ_i D_ip v(X_i)`; estimate eq 41.
//! 5. **D then Dᵀ**: particle velocities → nodal derivative (eq 18's operator) → second
//!    derivative at the particles (eq 24's); error `∂²v/∂x²(x_p) − s_p`; estimate
//!    [`second_derivative_error`].
//!
//! Cases 1, 2 and 5 need nodal derivatives of particle fields, obtained by the configured
//! [`Recovery`]. Cases 3 and 4 difference the exact nodal values (eqs 42/43).

use super::derivatives::nodal_derivatives;
use super::layout::Layout;
use super::node_to_particle::{
    gradient_error, interpolation_error, second_derivative, second_derivative_error,
};
use super::particle_to_node::{stress_divergence_error_from, value_mapping_error};
use super::recovery::Recovery;
use super::{linf, EstimatorError};
use crate::grid::{Boundary, Grid};
use crate::shape::Shape;
use crate::weights::{WeightKind, Weights};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Cell counts of the paper's Table 1 (it prints them as 21, 41, 81, 161: the node counts).
pub const CELLS: [usize; 4] = [20, 40, 80, 160];
/// Particles per cell: the paper's 1, 2, 4, 8 and 16.
pub const PPC: [usize; 5] = [1, 2, 4, 8, 16];
/// Case numbers 1–5.
pub const CASES: [u8; 5] = [1, 2, 3, 4, 5];

/// Which analytic field is sampled (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Field {
    /// Standing wave at phase π/4 (`t = 1/8`): the field of the paper's printed norms.
    #[default]
    Phase,
    /// Eq 45 literally at `t = π/4`.
    Eq45,
}

/// Set-up of one Table 1 run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Config {
    /// The analytic field. Default [`Field::Phase`].
    pub field: Field,
    /// Periodic (the paper) or fixed ends. Default periodic.
    pub boundary: Boundary,
    /// Jitter amplitude `j ∈ [0, 1]` as a fraction of the particle spacing `h/ppc`
    /// (0 = the paper's uniform layout). Default 0.
    pub jitter: f64,
    /// Seed of the jitter stream. Default 1.
    pub seed: u64,
    /// How nodal derivatives of particle fields are obtained. Default [`Recovery::Mapped`]
    /// (the paper's).
    pub recovery: Recovery,
    /// Jitter the particle *domains* instead of the positions: the cut points between
    /// neighbouring GIMP domains move by up to `j/4` of the spacing, and each particle sits at
    /// the centre of its domain with width and volume equal to the domain's length, so the
    /// domains still tile the bar (no overlaps or gaps, `Σ_p D_ip V_p = 0`). Needs `ppc ≥ 2`
    /// when `j > 0` (GIMP widths must not exceed `h`). Default false.
    #[serde(default)]
    pub tiling: bool,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            field: Field::Phase,
            boundary: Boundary::Periodic,
            jitter: 0.0,
            seed: 1,
            recovery: Recovery::Mapped,
            tiling: false,
        }
    }
}

/// One entry of the table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Case 1–5.
    pub case: u8,
    /// Number of cells `N`.
    pub cells: usize,
    /// Particles per cell.
    pub ppc: usize,
    /// `‖e‖∞` of the true error.
    pub error_norm: f64,
    /// `‖e_st‖∞` of the estimate.
    pub estimate_norm: f64,
    /// Error index `‖e_st‖∞ / ‖e‖∞` (eq 48).
    pub index: f64,
}

/// The standing wave `v = A sin kx`, `σ = B cos kx`, `k = 2π`.
#[derive(Clone, Copy, Debug)]
struct Wave {
    a: f64,
    b: f64,
}

const K: f64 = 2.0 * PI;

impl Wave {
    fn new(field: Field) -> Self {
        match field {
            Field::Phase => Self {
                a: (PI / 4.0).cos(),
                b: (PI / 4.0).sin(),
            },
            Field::Eq45 => {
                let t = PI / 4.0;
                Self {
                    a: (PI * t).cos(),
                    b: 2.0 * (PI * t).sin(),
                }
            }
        }
    }
    fn v(&self, x: f64) -> f64 {
        self.a * (K * x).sin()
    }
    fn dv(&self, x: f64) -> f64 {
        self.a * K * (K * x).cos()
    }
    fn d2v(&self, x: f64) -> f64 {
        -self.a * K * K * (K * x).sin()
    }
    fn sigma(&self, x: f64) -> f64 {
        self.b * (K * x).cos()
    }
    fn dsigma(&self, x: f64) -> f64 {
        -self.b * K * (K * x).sin()
    }
}

/// SplitMix64: a tiny seeded generator so the library needs no RNG dependency.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Particle positions of the layout described in the module docs.
pub fn positions(cells: usize, ppc: usize, jitter: f64, seed: u64) -> Vec<f64> {
    let h = 1.0 / cells as f64;
    let mut rng = SplitMix64(seed);
    let mut x = Vec::with_capacity(cells * ppc);
    for c in 0..cells {
        for k in 0..ppc {
            let xi = if jitter > 0.0 {
                rng.next_unit() - 0.5
            } else {
                0.0
            };
            x.push((c as f64 + (k as f64 + 0.5 + jitter * xi) / ppc as f64) * h);
        }
    }
    x
}

/// Particle positions and widths of the tiling layout (see [`Config::tiling`]): domain cut
/// points `c_j = (j + j_amp ξ_j / 4) h/ppc` (ends fixed), particles at the domain centres.
pub fn tiling_layout(cells: usize, ppc: usize, jitter: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let n = cells * ppc;
    let dx = 1.0 / n as f64;
    let mut rng = SplitMix64(seed);
    let cuts: Vec<f64> = (0..=n)
        .map(|j| {
            if j == 0 || j == n || jitter == 0.0 {
                j as f64 * dx
            } else {
                (j as f64 + 0.5 * jitter * (rng.next_unit() - 0.5)) * dx
            }
        })
        .collect();
    cuts.windows(2)
        .map(|w| (0.5 * (w[0] + w[1]), w[1] - w[0]))
        .unzip()
}

fn validate(cells: usize, ppc: usize, config: &Config) -> Result<(), EstimatorError> {
    if cells < 6 {
        return Err(EstimatorError::Argument {
            name: "cells",
            value: cells as f64,
            reason: "at least 6 cells are needed for the difference stencils",
        });
    }
    if ppc == 0 {
        return Err(EstimatorError::Argument {
            name: "ppc",
            value: 0.0,
            reason: "at least one particle per cell",
        });
    }
    if !(0.0..=1.0).contains(&config.jitter) {
        return Err(EstimatorError::Argument {
            name: "jitter",
            value: config.jitter,
            reason: "must lie in [0, 1]",
        });
    }
    if config.tiling && config.jitter > 0.0 && ppc < 2 {
        return Err(EstimatorError::Argument {
            name: "ppc",
            value: ppc as f64,
            reason: "a jittered tiling layout needs at least 2 particles per cell",
        });
    }
    Ok(())
}

fn row(case: u8, cells: usize, ppc: usize, err: &[f64], est: &[f64]) -> Row {
    let error_norm = linf(err);
    let estimate_norm = linf(est);
    Row {
        case,
        cells,
        ppc,
        error_norm,
        estimate_norm,
        index: estimate_norm / error_norm,
    }
}

/// Runs one case of Table 1 on `cells` cells with `ppc` particles per cell.
pub fn run_case(
    config: &Config,
    case: u8,
    cells: usize,
    ppc: usize,
) -> Result<Row, EstimatorError> {
    validate(cells, ppc, config)?;
    let wave = Wave::new(config.field);
    let grid = Grid::new(config.boundary, cells, 1.0);
    let (x, width) = particle_layout(config, cells, ppc, grid.h);
    let weights = Weights::compute(&grid, Shape::Gimp, &x, &width);
    let mass = width.clone(); // ρ = 1
    let mut layout = Layout::new(&grid, &weights, &x, &mass, &width)?;
    let nodes = grid.node_positions();
    let v_p: Vec<f64> = x.iter().map(|&x| wave.v(x)).collect();
    let (err, est) = match case {
        1 => case_velocity_to_nodes(config, &wave, &layout, &nodes, &v_p)?,
        2 => case_stress_to_nodes(config, &wave, &layout, &nodes)?,
        3 | 4 => case_nodes_to_particles(case, &wave, &layout, &nodes)?,
        5 => case_second_derivative(config, &wave, &mut layout, &v_p)?,
        _ => {
            return Err(EstimatorError::Argument {
                name: "case",
                value: case as f64,
                reason: "Table 1 has cases 1 to 5",
            })
        }
    };
    Ok(row(case, cells, ppc, &err, &est))
}

/// Pointwise errors and estimates of one case, over the points it compares.
type Compared = (Vec<f64>, Vec<f64>);

/// Particle positions and GIMP widths of the configured layout (tiling or per-cell).
fn particle_layout(config: &Config, cells: usize, ppc: usize, h: f64) -> (Vec<f64>, Vec<f64>) {
    if config.tiling {
        tiling_layout(cells, ppc, config.jitter, config.seed)
    } else {
        let x = positions(cells, ppc, config.jitter, config.seed);
        let width = vec![h / ppc as f64; x.len()];
        (x, width)
    }
}

/// Case 1 (eq 17): particle velocities mapped to the active nodes, estimate eq 34.
fn case_velocity_to_nodes(
    config: &Config,
    wave: &Wave,
    layout: &Layout<'_>,
    nodes: &[f64],
    v_p: &[f64],
) -> Result<Compared, EstimatorError> {
    let nn = layout.grid.n_nodes();
    let v_i = layout.map_to_nodes(v_p);
    let d = config.recovery.nodal_derivatives(layout, v_p)?;
    let est = value_mapping_error(layout, &d)?;
    Ok((0..nn)
        .filter(|&i| layout.node_active[i])
        .map(|i| (wave.v(nodes[i]) - v_i[i], est[i]))
        .unzip())
}

/// Case 2 (eq 18): particle stresses mapped to nodal accelerations, estimate eq 33.
fn case_stress_to_nodes(
    config: &Config,
    wave: &Wave,
    layout: &Layout<'_>,
    nodes: &[f64],
) -> Result<Compared, EstimatorError> {
    let nn = layout.grid.n_nodes();
    let s_p: Vec<f64> = layout.x.iter().map(|&x| wave.sigma(x)).collect();
    let g = layout.derivative_to_nodes(&s_p);
    let d = config.recovery.nodal_derivatives(layout, &s_p)?;
    let est = stress_divergence_error_from(layout, &d)?;
    Ok((0..nn)
        .filter(|&i| layout.node_active[i])
        .map(|i| {
            let rho = layout.node_density(i);
            ((wave.dsigma(nodes[i]) - g[i]) / rho, est[i])
        })
        .unzip())
}

/// Cases 3 (eq 21) and 4 (eq 24): exact nodal velocities interpolated or differentiated
/// at the particles, estimates eq 37 and eq 41.
fn case_nodes_to_particles(
    case: u8,
    wave: &Wave,
    layout: &Layout<'_>,
    nodes: &[f64],
) -> Result<Compared, EstimatorError> {
    let nn = layout.grid.n_nodes();
    let x = layout.x;
    let v_i: Vec<f64> = nodes.iter().map(|&x| wave.v(x)).collect();
    let d = nodal_derivatives(layout.grid, &v_i, &vec![true; nn])?;
    let mut computed = vec![0.0; x.len()];
    let (kind, est) = if case == 3 {
        (WeightKind::S, interpolation_error(layout, &d)?)
    } else {
        (WeightKind::D, gradient_error(layout, &d)?)
    };
    layout.weights.gather(kind, &v_i, &mut computed);
    let err: Vec<f64> = x
        .iter()
        .zip(&computed)
        .map(|(&x, c)| if case == 3 { wave.v(x) } else { wave.dv(x) } - c)
        .collect();
    Ok((err, est))
}

/// Case 5: particle velocities to a nodal derivative and back to a second derivative at
/// the particles, estimate [`second_derivative_error`].
fn case_second_derivative(
    config: &Config,
    wave: &Wave,
    layout: &mut Layout<'_>,
    v_p: &[f64],
) -> Result<Compared, EstimatorError> {
    let nn = layout.grid.n_nodes();
    if config.boundary == Boundary::Fixed {
        // The wall nodes take part in the derivative map: v = 0 there, so the
        // boundary term of the integration by parts behind eq 18 vanishes.
        let mean = layout.node_mass.iter().sum::<f64>() / nn as f64;
        for i in [1, nn - 2] {
            layout.node_active[i] = layout.node_mass[i] > 1e-12 * mean;
        }
    }
    let (g, s) = second_derivative(layout, v_p);
    // At clamped walls the velocity is known, v = 0. The `c_0 v_i / V_i` defect term
    // of the first map there is the boundary term of the integration by parts,
    // `O(1/h)` times the wall velocity, so the estimate must use the known value;
    // pinning it also steadies the one-sided fits next to the wall.
    let pins: Vec<(usize, f64)> = match config.boundary {
        Boundary::Fixed => vec![(1, 0.0), (nn - 2, 0.0)],
        Boundary::Periodic => vec![],
    };
    let dv = config
        .recovery
        .nodal_derivatives_pinned(layout, v_p, &pins)?;
    let dvx = match config.recovery {
        Recovery::Mapped => nodal_derivatives(layout.grid, &g, &layout.node_active)?,
        Recovery::LeastSquares => dv.shifted(),
    };
    let est = second_derivative_error(layout, &dv, &dvx)?;
    let err: Vec<f64> = layout
        .x
        .iter()
        .zip(&s)
        .map(|(&x, s)| wave.d2v(x) - s)
        .collect();
    Ok((err, est))
}

/// The whole table: every case of [`CASES`], cell count of [`CELLS`] and ppc of [`PPC`],
/// ordered by case, then ppc, then cells (ppc 1 is left out of a jittered tiling layout,
/// which it cannot form).
pub fn run(config: &Config) -> Result<Vec<Row>, EstimatorError> {
    let mut rows = Vec::with_capacity(CASES.len() * CELLS.len() * PPC.len());
    for case in CASES {
        for ppc in PPC {
            if config.tiling && config.jitter > 0.0 && ppc < 2 {
                continue;
            }
            for cells in CELLS {
                rows.push(run_case(config, case, cells, ppc)?);
            }
        }
    }
    Ok(rows)
}
