//! Tracking `λmax(B)` of the eq 56 operator by a warm-started Lanczos iteration.
//!
//! `B = diag(√(E V)) Dᵀ M D diag(√(E V))` is symmetric positive semi-definite (see
//! [`super::operator`]), so the Lanczos process on `B` gives Ritz values that increase
//! monotonically towards `λmax(B)` from below. Each iteration costs one application of `B`
//! (`O(nnz)`) plus `O(n)` vector work: the vectors are re-orthogonalised locally (against the
//! last two), not globally — a full re-orthogonalisation costs `O(k² n)`, which at `10⁵`
//! particles and 60 iterations was 100 solver steps. Loss of orthogonality only duplicates
//! converged Ritz values (Paige); the largest still converges to λmax from below. The
//! iteration is the crate's one Lanczos loop (`src/lanczos.rs`), run here with its local
//! recurrence and the stopping rule below.
//!
//! **Stopping rule.** After `k` applications the largest Ritz pair `(θ_k, y)` of the
//! tridiagonal `T_k` has the residual `r_k = ‖B x − θ_k x‖₂ = β_k |y_k|` (Euclidean norm,
//! `x` the unit Ritz vector). We stop when either
//!
//! * `r_k ≤ tol · θ_k`: then some eigenvalue of `B` lies within `tol · θ_k` of `θ_k` (for
//!   symmetric matrices), and — when the top eigenvalue is separated by a gap `g` from the
//!   rest — `0 ≤ λmax − θ_k ≤ r_k²/g`; or
//! * `θ_k − θ_{k−1} ≤ value_tol · θ_k` (`k ≥ 2`): the Ritz value, which increases
//!   monotonically to `λmax`, has stopped moving. This is what makes warm starts cheap: the
//!   top of the spectrum of a jittered layout is a cluster of close eigenvalues whose
//!   eigenvectors rotate as particles move, so the *vector* residual stays large for many
//!   iterations while the *value* — all the step size needs — is already converged.
//!   Stagnation can be premature only if the start vector is nearly orthogonal to the top
//!   eigenvector; the tests compare with dense eigenvalues after every warm update.
//!
//! **Starts.** The first start (and any start after the particle count changed) is the
//! *checkerboard* `x_p = (−1)^{cell(p)}` plus a 10 % deterministic pseudo-random part: the
//! checkerboard is the top mode on uniform layouts (the stress pattern that flips sign
//! from cell to cell), and the random part gives every other mode a non-zero component.
//! Afterwards each update starts from the previous Ritz vector (warm start): when particles
//! move a little, the top eigenvector moves a little and one to three applications suffice.
//!
//! **Level crossings.** On jittered layouts the top of the spectrum is a cluster of modes
//! localised where particles bunch up. As particles move, another member of the cluster can
//! overtake the tracked one; the warm start, close to the old eigenvector, then converges
//! (small residual) to the old mode and under-estimates λmax (measured: up to 0.6 % on a
//! moving jittered GIMP layout with 4 particles per cell). Every `restart_every`-th update
//! therefore also runs a cold (checkerboard) start and keeps the larger Ritz value, bounding
//! how long a crossing can go unnoticed. The `Stability` limit's safety factor covers the rest.
//!
//! No iterative method can *guarantee* the top of the spectrum; a mode with no component in
//! the start vector is invisible to it. [`Eq56Operator::gershgorin_bound`] is a cheap
//! rigorous upper bound that callers can log beside the estimate.

use super::error::StabilityError;
use super::operator::Eq56Operator;
pub(crate) use crate::lanczos::dot;
use lanczos::lanczos;

mod lanczos;

/// A symmetric positive semi-definite operator whose largest eigenvalue a
/// [`LambdaMaxTracker`] follows: the particle form `B` of eq 56 ([`Eq56Operator`], dimension
/// `n_particles`) or its nodal form `C` ([`super::NodalOperator`], dimension `n_nodes`), which
/// share `λmax` (see [`super::nodal`]).
pub trait SymmetricOperator {
    /// Dimension of the vectors it acts on.
    fn dim(&self) -> usize;
    /// `y = op · x`; `work` is scratch the operator may resize.
    fn apply(&self, x: &[f64], y: &mut [f64], work: &mut Vec<f64>);
    /// A cold start that reaches the top mode: the checkerboard of this operator's unknowns
    /// plus a small deterministic pseudo-random part.
    fn checkerboard_start(&self) -> Vec<f64>;
    /// `λ` in the paper's normalisation `λ̂ = h² λ/c²_ref` (4 on uniform GIMP layouts).
    fn normalised(&self, lambda: f64) -> f64;
    /// The largest diagonal entry `(i, op_ii)`, if cheap to get. `op_ii = e_iᵀ op e_i` is a
    /// Rayleigh quotient, hence a rigorous *lower* bound on `λmax`: a Ritz value below it
    /// proves that the iteration missed the top of the spectrum (the tracker then restarts
    /// from `e_i`). The default is `None` (no check).
    fn diagonal_max(&self) -> Option<(usize, f64)> {
        None
    }
}

impl SymmetricOperator for Eq56Operator<'_> {
    fn dim(&self) -> usize {
        Eq56Operator::dim(self)
    }

    fn apply(&self, x: &[f64], y: &mut [f64], work: &mut Vec<f64>) {
        work.resize(self.inv_mass().len(), 0.0);
        Eq56Operator::apply(self, x, y, work);
    }

    fn checkerboard_start(&self) -> Vec<f64> {
        checkerboard_start(self)
    }

    fn normalised(&self, lambda: f64) -> f64 {
        Eq56Operator::normalised(self, lambda)
    }
}

/// Settings of the Lanczos iteration.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LanczosConfig {
    /// Relative residual tolerance `‖Bx − θx‖₂ ≤ tol·θ` (default `1e-3`: some eigenvalue
    /// lies within `10⁻³ θ` — `dt_eq56` to `5·10⁻⁴` — and in practice, measured against
    /// dense eigenvalues on moving jittered layouts, λmax to better than `10⁻⁵`, because the
    /// eigenvalue error is quadratic in the residual).
    pub tol: f64,
    /// Relative change of the Ritz value between two iterations at which it counts as
    /// converged (default `1e-4`; 0 disables this test). On a moving 10⁵-particle GIMP bar the
    /// top of the spectrum is a cluster of eigenvalues within ~0.5 % of each other whose
    /// Ritz values creep up slowly: at `1e-5` the warm updates of a controlled run took 17.7
    /// applications per step on average over 400 steps, at `1e-4` 6.7 (measured with a
    /// throwaway driver of `Controller::standard` on the controller bench's bar, not kept). Any member of that cluster gives `dt_eq56` within 0.25 %,
    /// far inside the `Stability` limit's safety margin, and the tests compare every warm
    /// update with the dense eigenvalue.
    pub value_tol: f64,
    /// Every this many updates, also run a cold start and keep the larger value (default 10;
    /// 0 never restarts). See "Level crossings" in the module docs.
    pub restart_every: usize,
    /// Most applications of `B` of each periodic cold restart (default 20): the restart only
    /// has to notice a larger eigenvalue, not converge it (the warm updates that follow do).
    pub restart_iter: usize,
    /// Most applications of `B` per update (default 60). Reaching it is not an error: the
    /// best Ritz value is returned with `converged = false`.
    pub max_iter: usize,
}

impl Default for LanczosConfig {
    fn default() -> Self {
        Self {
            tol: 1e-3,
            value_tol: 1e-4,
            restart_every: 10,
            restart_iter: 20,
            max_iter: 60,
        }
    }
}

impl LanczosConfig {
    /// Checks `0 < tol < 1` and `max_iter ≥ 1`.
    pub fn validate(&self) -> Result<(), StabilityError> {
        if !(self.tol > 0.0 && self.tol < 1.0) {
            return Err(StabilityError::InvalidConfig {
                field: "tol",
                value: self.tol,
                reason: "must be in (0, 1)",
            });
        }
        if !(self.value_tol >= 0.0 && self.value_tol < 1.0) {
            return Err(StabilityError::InvalidConfig {
                field: "value_tol",
                value: self.value_tol,
                reason: "must be in [0, 1)",
            });
        }
        if self.max_iter == 0 {
            return Err(StabilityError::InvalidConfig {
                field: "max_iter",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        Ok(())
    }
}

/// The result of one λmax update.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LambdaEstimate {
    /// `λmax(B)` estimate (the largest Ritz value; a lower bound on the true value).
    pub lambda_b: f64,
    /// The same in the paper's normalisation `λ̂ = h² λmax(B)/c²_ref` (4 on uniform GIMP).
    pub lambda_hat: f64,
    /// The eq 56 critical step `√(2/λmax(B))`.
    pub dt_eq56: f64,
    /// Relative residual `‖Bx − θx‖₂/θ` of the returned Ritz pair.
    pub residual: f64,
    /// Applications of `B` this update used.
    pub applications: usize,
    /// Whether the residual met the tolerance.
    pub converged: bool,
    /// Whether this update started from the previous eigenvector.
    pub warm: bool,
}

/// The checkpointable part of a [`LambdaMaxTracker`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackerState {
    /// The warm-start vector.
    pub vector: Vec<f64>,
    /// The last estimate.
    pub last: Option<LambdaEstimate>,
    /// Updates so far (for the periodic restarts).
    pub updates: usize,
}

/// Follows `λmax(B)` from step to step, keeping the last eigenvector as the next start.
#[derive(Clone, Debug)]
pub struct LambdaMaxTracker {
    config: LanczosConfig,
    vector: Vec<f64>,
    last: Option<LambdaEstimate>,
    updates: usize,
    work: Work,
}

/// Reused allocations of the Lanczos iteration (basis vectors, scratch). Scratch only: a
/// clone starts empty.
#[derive(Debug, Default)]
struct Work {
    lanczos: crate::lanczos::Work,
    nodes: Vec<f64>,
    /// A cold start of the last dimension seen, blended into warm starts (any vector with a
    /// component on every mode serves; regenerating it costs about one application).
    cold: Vec<f64>,
}

impl Clone for Work {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl LambdaMaxTracker {
    /// A tracker with the given settings.
    pub fn new(config: LanczosConfig) -> Result<Self, StabilityError> {
        config.validate()?;
        Ok(Self {
            config,
            vector: Vec::new(),
            last: None,
            updates: 0,
            work: Work::default(),
        })
    }

    /// A tracker with the default settings.
    pub fn default_tracker() -> Self {
        Self {
            config: LanczosConfig::default(),
            vector: Vec::new(),
            last: None,
            updates: 0,
            work: Work::default(),
        }
    }

    /// The settings.
    pub fn config(&self) -> LanczosConfig {
        self.config
    }

    /// Replaces the settings (crate-internal: callers validate them first).
    pub(crate) fn set_config(&mut self, config: LanczosConfig) {
        self.config = config;
    }

    /// The last estimate, if any.
    pub fn last(&self) -> Option<LambdaEstimate> {
        self.last
    }

    /// The current eigenvector estimate (empty before the first update).
    pub fn vector(&self) -> &[f64] {
        &self.vector
    }

    /// The warm-start state (for checkpoints): restoring it with [`Self::restore`] makes the
    /// next updates bit-identical.
    pub fn state(&self) -> TrackerState {
        TrackerState {
            vector: self.vector.clone(),
            last: self.last,
            updates: self.updates,
        }
    }

    /// Restores a state from [`Self::state`].
    pub fn restore(&mut self, state: TrackerState) {
        self.vector = state.vector;
        self.last = state.last;
        self.updates = state.updates;
    }

    /// Forgets the warm start (the next update starts from the checkerboard).
    pub fn reset(&mut self) {
        self.vector.clear();
        self.last = None;
    }

    /// Updates the estimate for operator `op` (warm if the dimension is unchanged).
    pub fn update<O: SymmetricOperator + ?Sized>(
        &mut self,
        op: &O,
    ) -> Result<LambdaEstimate, StabilityError> {
        self.update_with(op, self.config)
    }

    /// [`Self::update`] with other settings for this update only.
    pub fn update_with<O: SymmetricOperator + ?Sized>(
        &mut self,
        op: &O,
        config: LanczosConfig,
    ) -> Result<LambdaEstimate, StabilityError> {
        config.validate()?;
        let n = op.dim();
        let warm = self.vector.len() == n && self.vector.iter().any(|&v| v != 0.0);
        let start = if warm {
            let mut start = std::mem::take(&mut self.vector);
            if self.work.cold.len() != n {
                self.work.cold = op.checkerboard_start();
            }
            blend(&mut start, &self.work.cold, WARM_BLEND);
            start
        } else {
            op.checkerboard_start()
        };
        let (mut est, mut vec) = lanczos(op, start, config, warm, &mut self.work)?;
        self.updates += 1;
        if let Some((i, diag)) = op.diagonal_max() {
            if est.lambda_b < diag {
                // A rigorous lower bound beats the Ritz value: the start vector had (almost)
                // no component on the top mode, localised near node i. Restart from e_i.
                let mut start = vec![0.0; n];
                start[i] = 1.0;
                if self.work.cold.len() != n {
                    self.work.cold = op.checkerboard_start();
                }
                blend(&mut start, &self.work.cold, WARM_BLEND);
                let (local, local_vec) = lanczos(op, start, config, false, &mut self.work)?;
                tracing::debug!(
                    missed = est.lambda_hat,
                    found = local.lambda_hat,
                    node = i,
                    "lambda_max: Ritz value below the largest diagonal entry; restarted there"
                );
                let applications = est.applications + local.applications;
                if local.lambda_b > est.lambda_b {
                    est = local;
                    vec = local_vec;
                }
                est.applications = applications;
            }
        }
        if warm && config.restart_every > 0 && self.updates.is_multiple_of(config.restart_every) {
            let restart = LanczosConfig {
                max_iter: config.restart_iter.clamp(1, config.max_iter),
                ..config
            };
            let (cold, cold_vec) =
                lanczos(op, op.checkerboard_start(), restart, false, &mut self.work)?;
            let applications = est.applications + cold.applications;
            if cold.lambda_b > est.lambda_b {
                tracing::debug!(
                    warm = est.lambda_hat,
                    cold = cold.lambda_hat,
                    "lambda_max: cold restart found a larger eigenvalue"
                );
                est = cold;
                vec = cold_vec;
            }
            est.applications = applications;
        }
        self.vector = vec;
        self.last = Some(est);
        tracing::debug!(
            lambda_hat = est.lambda_hat,
            dt_eq56 = est.dt_eq56,
            applications = est.applications,
            residual = est.residual,
            warm,
            "lambda_max update"
        );
        Ok(est)
    }
}

/// Weight of the cold start blended into every warm start (relative to the unit warm vector).
///
/// A warm start alone can be blind: after a nodal mass collapses and recovers (linear hats,
/// particles crossing a node), the previous eigenvector is localised at that node, the Krylov
/// space of a banded operator grows by two nodes per application, and the Ritz value stagnates
/// at a local eigenvalue far below `λmax`. Seen on `scenarios/suite/linear_small_mass.json`
/// with the nodal operator: λ̂ = 4.4 tracked while the true value was ≈ 15, and the run blew
/// up. Two guards: the rigorous lower bound of [`SymmetricOperator::diagonal_max`] (a restart
/// from the node it names — measured, this alone fixes that run), and this small global
/// component, which lets the iteration pick up a much larger mode that the warm vector does not
/// see. At `10⁻³` it cost no extra application in the tests (at `10⁻²` a repeated update of
/// an unchanged state took 3 applications instead of 1).
pub const WARM_BLEND: f64 = 1e-3;

/// `start ← start/‖start‖ + weight · other/‖other‖` (unchanged parts if a norm is zero).
fn blend(start: &mut [f64], other: &[f64], weight: f64) {
    let ns = dot(start, start).sqrt();
    let no = dot(other, other).sqrt();
    if !(ns > 0.0 && no > 0.0 && ns.is_finite() && no.is_finite()) {
        return;
    }
    for (s, o) in start.iter_mut().zip(other) {
        *s = *s / ns + weight * o / no;
    }
}

/// The cold start of the particle form `B`: `(−1)^{cell(p)}` plus a deterministic
/// pseudo-random 10 % part.
pub fn checkerboard_start(op: &Eq56Operator<'_>) -> Vec<f64> {
    let w = op.weights();
    checkerboard_with_noise(op.dim(), |p| {
        // The parity of the first node of the particle's stencil with non-zero D.
        w.nodes_of(p)
            .iter()
            .zip(w.d_of(p))
            .find(|(_, &d)| d != 0.0)
            .map(|(&i, _)| i as u64)
            .unwrap_or(0)
    })
}

/// `x_k = (−1)^{parity(k)} + 0.2 r_k` with `r_k ∈ [−½, ½)` from a fixed splitmix64 sequence:
/// the checkerboard, with every other mode given a non-zero component.
pub(crate) fn checkerboard_with_noise(n: usize, parity: impl Fn(usize) -> u64) -> Vec<f64> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|k| {
            let sign = if parity(k).is_multiple_of(2) {
                1.0
            } else {
                -1.0
            };
            // splitmix64
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            let r = (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            sign + 0.2 * r
        })
        .collect()
}

impl Default for LambdaMaxTracker {
    fn default() -> Self {
        Self::default_tracker()
    }
}
