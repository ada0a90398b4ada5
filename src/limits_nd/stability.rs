//! [`StabilityNd`]: the eq 56 stability limit in d dimensions, `dt = safety · √(2/λmax)`
//! with `λmax = λmax(M⁻¹K)` ([`super::stiffness`]) tracked on the evolving state.
//!
//! # What is recomputed, and when
//!
//! `λmax` moves only as particles move against the grid (weights and nodal masses change)
//! or their tangent moduli and volumes change. So the limit recomputes it by Lanczos,
//! warm-started from the previous Ritz vector, only when
//!
//! * some particle has moved more than `refresh_cells` of a cell on some axis since the
//!   last refresh, or
//! * the smallest active nodal mass fell by more than `refresh_mass` (relative): nearly
//!   empty nodes set `λmax` on small-mass layouts, or
//! * some particle's `V (λ_t + 2μ_t)` has changed by more than `refresh_modulus`
//!   (relative), or
//! * `max_age` proposals have passed, or the node count changed;
//!
//! and between refreshes proposes from the cached value. The per-step guard is one pass over
//! the particles (positions and moduli against their values at the refresh): O(n), no
//! weights read. A Lanczos Ritz value is a lower bound on `λmax` that converges fast; the
//! cached value is the Ritz value times `(1 + tol)·margin` — a margin, not a rigorous bound
//! (the residual bound would be one for the nearest eigenvalue, but in the clustered top of
//! a uniform layout's spectrum it stays large long after the value has settled).
//!
//! # What this guarantees, and what it does not
//!
//! Between refreshes the proposal is for a state within `refresh_cells` of the analysed
//! one; it is not a certificate (the 1D tracker's `LDLᵀ` certificate is not carried over
//! yet). Frozen-particle analysis itself overestimates the true limit when particles move
//! (docs/design.md: with quadratic B-splines by about a fifth). The controller's growth monitor
//! ([`super::GrowthNd`]) is the guard that catches both: it rejects a step whose energy
//! grows and lowers this limit's safety for the rest of the run
//! ([`StepLimit::scale_safety`]).

use super::stiffness::lanczos;
use crate::dimension::{Dim, Dimension};
use crate::limit::{LimitError, Metrics, Proposal, StepLimit};
use crate::nd::{Vector, ViewNd};
use serde::{Deserialize, Serialize};

/// Name in logs: `"stability"`.
pub const STABILITY: &str = "stability";

/// Settings of [`StabilityNd`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StabilityNdConfig {
    /// Fraction of `dt_eq56` proposed (default 0.9, as in 1D).
    pub safety: f64,
    /// Refresh when a particle moved this many cells on some axis (default 0.5).
    pub refresh_cells: f64,
    /// Refresh when the smallest active nodal mass fell by this much, relative (default 0.1).
    pub refresh_mass: f64,
    /// Refresh when some `V(λ_t + 2μ_t)` changed by this much, relative (default 0.02).
    pub refresh_modulus: f64,
    /// Refresh at least every this many proposals (default 200).
    pub max_age: u32,
    /// Lanczos tolerance (default 1e-2): residual below `tol·λ` or the value settled to
    /// `tol·λ/10` in one iteration; the Ritz value is raised by this fraction.
    pub tol: f64,
    /// Lanczos products per refresh at most (default 40).
    pub max_iter: usize,
    /// Multiplier on the refreshed `λmax` bound (default 1.0).
    pub margin: f64,
}

impl Default for StabilityNdConfig {
    fn default() -> Self {
        Self {
            safety: 0.9,
            refresh_cells: 0.5,
            refresh_mass: 0.1,
            refresh_modulus: 0.02,
            max_age: 200,
            tol: 1e-2,
            max_iter: 40,
            margin: 1.0,
        }
    }
}

/// The tracked eq 56 limit in d dimensions (module docs).
#[derive(Clone, Debug)]
pub struct StabilityNd<const D: usize> {
    config: StabilityNdConfig,
    safety: f64,
    lambda: Option<f64>,
    ritz: Vec<f64>,
    x_ref: Vec<Vector<D>>,
    stiff_ref: Vec<f64>,
    /// Smallest active nodal mass and active node count at the refresh.
    mass_ref: (f64, usize),
    age: u32,
    refreshes: u64,
    applications: u64,
}

impl<const D: usize> StabilityNd<D> {
    /// A limit with `config`.
    pub fn new(config: StabilityNdConfig) -> Self {
        Self {
            safety: config.safety,
            config,
            lambda: None,
            ritz: Vec::new(),
            x_ref: Vec::new(),
            stiff_ref: Vec::new(),
            mass_ref: (0.0, 0),
            age: 0,
            refreshes: 0,
            applications: 0,
        }
    }

    /// The tracked bound on `λmax(M⁻¹K)`, once computed.
    pub fn lambda_max(&self) -> Option<f64> {
        self.lambda
    }

    /// Lanczos refreshes so far.
    pub fn refreshes(&self) -> u64 {
        self.refreshes
    }

    fn stiffness(view: &ViewNd<'_, D>, p: usize) -> f64 {
        crate::nd::det(&view.f[p]) * view.volume0[p] * (view.lame_lambda[p] + 2.0 * view.lame_mu[p])
    }

    /// Smallest active nodal mass and the number of active nodes.
    fn node_mass_summary(view: &ViewNd<'_, D>) -> (f64, usize) {
        view.node_mass
            .iter()
            .zip(view.node_active)
            .filter(|(_, &a)| a)
            .fold((f64::INFINITY, 0), |(m, n), (&mi, _)| (m.min(mi), n + 1))
    }

    fn stale(&self, view: &ViewNd<'_, D>) -> bool {
        if self.lambda.is_none()
            || self.age >= self.config.max_age
            || self.x_ref.len() != view.n_particles()
            || self.ritz.len() != view.n_nodes() * D
        {
            return true;
        }
        let (m_min, active) = Self::node_mass_summary(view);
        if active == 0 || m_min < (1.0 - self.config.refresh_mass) * self.mass_ref.0 {
            return true;
        }
        let h = view.grid.h;
        let lim = self.config.refresh_cells;
        for p in 0..view.n_particles() {
            let dx = view.x[p] - self.x_ref[p];
            for a in 0..D {
                // A periodic wrap shows as a jump of a whole box: also a refresh.
                if dx[a].abs() > lim * h[a] {
                    return true;
                }
            }
            let s = Self::stiffness(view, p);
            if (s - self.stiff_ref[p]).abs() > self.config.refresh_modulus * self.stiff_ref[p] {
                return true;
            }
        }
        false
    }

    fn refresh(&mut self, view: &ViewNd<'_, D>) -> Result<f64, LimitError> {
        let n = view.n_nodes() * D;
        let start: Vec<f64> = if self.ritz.len() == n {
            // Warm start, nudged so that it is never orthogonal to a new top mode.
            self.ritz
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v + 1e-3 * (((i * 7919) % 97) as f64 / 97.0 - 0.5) / (n as f64).sqrt()
                })
                .collect()
        } else {
            checkerboard_start(view)
        };
        let r = lanczos(view, &start, self.config.tol, self.config.max_iter);
        let lambda = r.lambda * (1.0 + self.config.tol) * self.config.margin;
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(LimitError::Other {
                limit: STABILITY.into(),
                message: format!(
                    "λmax estimate {lambda:e} is not a positive number at t = {}",
                    view.t
                ),
            });
        }
        self.ritz = r.vector;
        self.x_ref = view.x.to_vec();
        self.stiff_ref = (0..view.n_particles())
            .map(|p| Self::stiffness(view, p))
            .collect();
        self.mass_ref = Self::node_mass_summary(view);
        self.age = 0;
        self.refreshes += 1;
        self.applications += r.applications as u64;
        self.lambda = Some(lambda);
        Ok(lambda)
    }
}

/// A cold start close to the top of the spectrum: the nodal checkerboard
/// `(−1)^(Σ_a j_a)` in every component (the highest-wavenumber mode, which carries `λmax` on
/// uniform layouts), plus a small seeded perturbation so that no mode is missed.
fn checkerboard_start<const D: usize>(view: &ViewNd<'_, D>) -> Vec<f64> {
    let n = view.n_nodes();
    let mut out = Vec::with_capacity(n * D);
    for i in 0..n {
        let j = view.grid.lattice_of(i);
        let sign = if j.iter().sum::<i64>().rem_euclid(2) == 0 {
            1.0
        } else {
            -1.0
        };
        for a in 0..D {
            let noise = ((i * D + a) * 7919 % 101) as f64 / 101.0 - 0.5;
            out.push(sign + 0.1 * noise);
        }
    }
    out
}

impl<const D: usize> StepLimit<D> for StabilityNd<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    fn name(&self) -> &str {
        STABILITY
    }

    fn propose(&mut self, state: &ViewNd<'_, D>) -> Result<Proposal, LimitError> {
        let mut metrics = Metrics::new();
        let lambda = if self.stale(state) {
            let l = self.refresh(state)?;
            metrics.insert("refreshes".into(), self.refreshes as f64);
            metrics.insert("lanczos_applications".into(), self.applications as f64);
            l
        } else {
            self.lambda.unwrap_or(f64::INFINITY)
        };
        self.age += 1;
        metrics.insert(crate::controller::metric::LAMBDA_MAX.into(), lambda);
        Ok(Proposal {
            dt: self.safety * (2.0 / lambda).sqrt(),
            metrics,
        })
    }

    fn scale_safety(&mut self, factor: f64) {
        if factor.is_finite() && factor > 0.0 {
            self.safety *= factor;
        }
    }
}
