//! [`GuardedEq56<D>`]: the rule of the eq 56 stability limit in two and three dimensions,
//! [`Stability<D>`](crate::stability::limit::Stability) ([`super::StabilityNd<D>`]),
//! `dt = safety · √(2/λmax)` with `λmax = λmax(M⁻¹K)` ([`super::stiffness`]) tracked on the
//! evolving state. The limit itself — the safety, its lowering after growth, the proposal
//! and the checkpoint framing — is the one of every dimension ([`crate::stability::limit`]);
//! this rule tracks `λmax` and accepts every trial.
//!
//! # What is recomputed, and when
//!
//! `λmax` moves only as particles move against the grid (weights and nodal masses change)
//! or their tangent moduli and volumes change. So the limit recomputes it by Lanczos,
//! warm-started from the previous Ritz vector, only when
//!
//! * some particle has moved more than `refresh_cells` of a cell on some axis since the
//!   last refresh, or
//! * the smallest active nodal mass fell by more than `refresh_mass` (relative) *and* the
//!   largest diagonal entry of `M^{-1/2} K M^{-1/2}` grew by more than `refresh_diagonal`
//!   since the refresh (below), or
//! * some particle's moduli grew by more than `refresh_modulus` (relative, 10 % by default, below), or
//! * `max_age` proposals have passed, or the node count changed;
//!
//! and between refreshes proposes from the cached value, scaled for the moduli's growth.
//!
//! **The calibrated bound** (the default under FLIP, and under APIC on solids). At every
//! refresh the element bound `B ≥ λmax` ([`super::element_bound`]) of the same state is
//! evaluated too, and between refreshes the proposal is the Lanczos value scaled by `B`'s
//! rise since then,
//! `λ_L·max(r, B/B_L)`, until `B` has drifted by `bound_drift` or `bound_age` proposals
//! have passed; the motion guard is then not read where the stepper supplies `B`, and on
//! the generic path it calls for `B` instead of Lanczos ([`super::bound_tracking`]).
//!
//! Under APIC the calibrated bound is used on solids only: while every refresh has found
//! every particle with shear stiffness (`μ_t > 0`; [`super::bound_tracking`] "Under APIC").
//!
//! **Bound mode** (with `bound_drift < 0`, and under APIC otherwise). At every refresh the
//! element bound `B ≥ λmax` ([`super::element_bound`]) of the same state is evaluated
//! too. Where it is close to the Lanczos value (within `1 + bound_slack`; where the
//! stepper supplies `B` from its own
//! pass, also wherever the Lanczos products it saves outweigh the shorter step), the next
//! proposals step on the current state's `B` instead — guaranteed in the frozen-particle
//! sense, no motion guard, no Lanczos — until `bound_age` proposals have passed; and a
//! refresh the guard calls for is skipped where `B` is that close to the cached value
//! ([`super::bound_tracking`]).
//!
//! **Moduli between refreshes.** On symmetric tensors the isotropic `V_p C_p` has two
//! eigenvalues, `V(dλ_t + 2μ_t)` (volumetric) and `2Vμ_t` (deviatoric). If each grew at
//! most by the factor `r_p` since the refresh then `V'_p C'_p ⪯ r_p V_p C_p`, so with the
//! weights unchanged `K' ⪯ (max_p r_p) K` in the Loewner order and
//! `λmax(M⁻¹K') ≤ (max_p r_p) λmax(M⁻¹K)`: the cached value times `max(1, max_p r_p)` is
//! a bound for the new moduli, exact in the frozen-weight sense. A collision, where `J`
//! and the tangent moduli change every step, thus costs no Lanczos run until some
//! particle's moduli grew by `refresh_modulus`; then the factor is reset by a refresh
//! (which also wins back the step when moduli fall).
//!
//! **Light nodes.** Nearly empty nodes set `λmax` on linear-hat layouts: a node with mass
//! `m_i → 0` keeps a stiffness row of order one, and the Rayleigh quotient of a unit
//! velocity there, the diagonal entry `K_ii/m_i`, grows without bound. With GIMP and
//! B-spline weights the stiffness row vanishes with the mass (weight gradients vanish where
//! the weights do) and a node's mass falling as a body slides over it is harmless. So when
//! the smallest nodal mass falls, the limit computes `max diag(A)` (one pass over the weight
//! gradients, [`super::stiffness::diagonal_argmax`]): if it grew by more than
//! `refresh_diagonal`, `λmax` is recomputed; else the cached value is multiplied by that
//! growth (≥ 1) until the next refresh — a heuristic scaling, not a bound, since the
//! diagonal only bounds `λmax` from below. The per-step guard is one pass over
//! the particles (positions and moduli against their values at the refresh): O(n), no
//! weights read. A Lanczos Ritz value is a lower bound on `λmax` that converges fast; the
//! cached value is the Ritz value times `(1 + tol)·margin` — a margin, not a rigorous bound
//! (the residual bound would be one for the nearest eigenvalue, but in the clustered top of
//! a uniform layout's spectrum it stays large long after the value has settled).
//!
//! # What this guarantees, and what it does not
//!
//! Between refreshes the proposal is for a state within `refresh_cells` of the analysed
//! one; it is not a certificate (the 1D tracker's `LDLᵀ` certificate is not carried over).
//! The frozen-particle `λmax` is a rough function of the positions: on a jittered block
//! drifting across a periodic grid (`tests/stability_tracking_nd.rs`) the true value rose
//! up to 1.09× (linear hat), 1.49× (GIMP) and 1.21× (B-spline) above the tracked one
//! within half a cell of motion (refreshing every eighth of a cell still left 1.34× with
//! GIMP, measured with a Lanczos tolerance of 10⁻³) — so a step of `0.9·√(2/λ)` can exceed
//! the frozen critical step by up to about 10 % for a few steps. A refreshed value is the Lanczos Ritz value, which is the
//! top eigenvalue unless a new mode far from the warm start has just risen above the old
//! one (measured: at worst 3 % low). Frozen-particle analysis itself
//! overestimates the true limit when particles move (docs/design.md: with quadratic
//! B-splines by about a fifth). The controller's growth monitor ([`super::GrowthNd`]) is
//! the guard that catches all three: it rejects a step whose energy grows and lowers this
//! limit's safety for the rest of the run ([`StepLimit::scale_safety`]).

mod checkpoint;
mod full_map_gain;
mod guard;
mod guard_scan;
pub mod on_summary;
mod policy;
mod rule;
pub use on_summary::SUMMARY_CHECK_EVERY;

use super::bound_tracking::view_supplies_bound;
use super::stability_config::StabilityNdConfig;
use super::start::checkerboard_start;
use super::stiffness::{diagonal_argmax, lanczos_on, NodalSpace};
use super::transfer::{apic_gain, TransferNd};
#[cfg(doc)]
use crate::limit::StepLimit;
use crate::limit::{LimitError, Metrics};
use crate::nd::ViewNd;
use crate::reduce::{Reduce, SingleProcess};
pub use crate::stability::limit::{StabilityNd, STABILITY};
pub use checkpoint::TrackedNd;
use guard::Staleness;
use std::rc::Rc;

/// The rule of the 2D/3D stability limit,
/// [`Stability<D>`](crate::stability::limit::Stability) ([`super::StabilityNd<D>`]): how
/// `λmax` is tracked, refreshed and checked is in the [module docs](self).
///
/// # Memory
///
/// Per particle (O(particles)): its position (in single precision) and the two moduli of
/// `V_p C_p` at the refresh, the motion guard's references, `4D + 16` bytes (28 in 3D, 24
/// in 2D; on a decomposed grid for every particle of the run). Per node (O(nodes)): the Ritz vector,
/// `D·8` bytes; during a refresh also the Lanczos basis, `D·8` bytes per active node and
/// iteration, released after it. Products with `K` form each particle's weight row and
/// moduli as they go; within one refresh the first product keeps them for the others
/// where the weights are formed and the rows have at most 2²⁰ entries (`4 + 8·D` bytes
/// per entry at an active node and 20 per particle, released with the basis; the
/// products' bits are the same, [`super::stiffness::lanczos_on`]).
/// [`StepLimit::memory_bytes`] sums what is held between calls.
#[derive(Clone, Debug)]
pub struct GuardedEq56<const D: usize> {
    /// The settings; their safety is the configured one, the largest a restored
    /// checkpoint may carry (the limit holds the current one).
    config: StabilityNdConfig,
    /// What the limit tracks between proposals, and a checkpoint saves ([`TrackedNd`]).
    tracked: TrackedNd<D>,
    /// The run's reductions ([`StepLimit::set_reduce`]).
    reduce: Rc<dyn Reduce>,
    /// Threads for the layout guard's pass ([`StepLimit::set_threads`]).
    pool: Option<std::sync::Arc<rayon::ThreadPool>>,
}

impl<const D: usize> GuardedEq56<D> {
    /// A rule with `config` not checked.
    fn unchecked(config: StabilityNdConfig) -> Self {
        Self {
            config,
            tracked: TrackedNd::default(),
            reduce: Rc::new(SingleProcess),
            pool: None,
        }
    }

    /// The reductions the processes agree with: a decomposed view's own
    /// ([`crate::nd::NodalHalo::reduce`]), so that a limit the run forgot to give its
    /// reducer ([`StepLimit::set_reduce`]) still takes part in every collective; else
    /// `own`.
    fn agreement<'r>(own: &'r dyn Reduce, view: &ViewNd<'r, D>) -> &'r dyn Reduce {
        match &view.split {
            Some(s) => s.halo.reduce(),
            None => own,
        }
    }

    /// `m_min` is the view's [`Self::smallest_node_mass`], `diag` its [`diagonal_argmax`]
    /// when [`Self::staleness`] computed it, `bound` its element bound when
    /// [`Self::tracked_lambda`] evaluated it just before (not evaluated twice).
    fn refresh(
        &mut self,
        view: &ViewNd<'_, D>,
        m_min: f64,
        diag: Option<(f64, usize)>,
        bound: Option<f64>,
    ) -> Result<f64, LimitError> {
        self.note_fluid(view); // Before the gain: under APIC a fluid steps on eq 56.
        let n = view.n_nodes() * D;
        let space = NodalSpace::new(view, &*self.reduce);
        // Component `c` of the local vectors is component `global(c)` of the whole grid's:
        // starts are functions of the latter, the same however the grid is split.
        let global = |c: usize| space.global(c / D) * D + c % D;
        let n_global = (space.global_nodes() * D) as f64;
        let (diag_max, diag_at) = diag.unwrap_or_else(|| diagonal_argmax(view, &*self.reduce));
        let warm = self.tracked.ritz.len() == n;
        let mut start: Vec<f64> = if warm {
            // Warm start, nudged so that it is never orthogonal to a new top mode.
            self.tracked
                .ritz
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v + 0.1 * (((global(i) * 7919) % 97) as f64 / 97.0 - 0.5) / n_global.sqrt()
                })
                .collect()
        } else {
            checkerboard_start(view, &space)
        };
        // A warm start plus the unit velocity at the stiffest node for its mass: a mode
        // localised on a light node, far from the previous top mode, is then in the Krylov
        // space from the first product. (Not on a cold start: there it dilutes the
        // checkerboards and costs products — measured 2 against 20 on the 3D GIMP wave, 4
        // against 11 on the linear-hat small-mass layout, with equal or higher values.)
        let scale = space.dot(&start, &start).sqrt();
        if warm && scale > 0.0 {
            for (c, value) in start.iter_mut().enumerate() {
                if global(c) == diag_at {
                    *value += scale;
                }
            }
        }
        let r = lanczos_on(
            self.pool.as_deref(),
            view,
            &start,
            self.config.tol,
            self.config.max_iter,
            &*self.reduce,
        );
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
        let (gain, extra_products) = match self.config.transfer {
            TransferNd::Flip if self.config.full_map => self.full_map_gain(view, &r),
            TransferNd::Flip => (1.0, 0),
            // A fluid under APIC steps on eq 56 itself (`policy`, "fluids").
            TransferNd::Apic { .. } if self.tracked.tracking.fluid_seen => (1.0, 0),
            TransferNd::Apic { inertia } => (apic_gain(view, &space, &r.vector, inertia), 0),
        };
        self.tracked.gain = gain;
        self.tracked.ritz = r.vector;
        self.store_references(view);
        self.tracked.mass_ref = m_min;
        self.tracked.diag_ref = diag_max;
        self.tracked.diag_growth = 1.0;
        self.tracked.age = 0;
        self.tracked.refreshes += 1;
        self.tracked.applications += r.applications as u64;
        self.tracked.last_products = warm.then_some(r.applications as u64 + extra_products);
        self.tracked.lambda = Some(lambda);
        self.bound_after_refresh(view, lambda, bound);
        Ok(lambda)
    }

    /// `λmax` out of bound mode: the cached Lanczos value while the motion guard holds,
    /// the element bound where it is tight enough when the guard calls for a refresh,
    /// else a refresh (module docs, [`super::bound_tracking`]). Returns it and whether
    /// Lanczos ran.
    fn tracked_lambda(&mut self, state: &ViewNd<'_, D>) -> Result<(f64, bool), LimitError> {
        // The smallest nodal mass first: a reduction every process makes, on every step.
        let m_min = self.smallest_node_mass(state);
        let mut diag = None;
        let supplied = view_supplies_bound(state);
        let calibrated = self.calibrating()
            && self.tracked.tracking.reference.is_some()
            && self.tracked.age < self.config.bound_age;
        // With the bound supplied every step, the calibrated bound watches the layout and
        // the positions are not read; on the generic path a particle's motion calls for
        // the bound's pass, and on a split grid for a refresh, as before.
        let local = self.staleness(
            state,
            m_min,
            &mut diag,
            !(calibrated && supplied),
            calibrated,
        );
        let (growth, moved) = match local {
            Staleness::Fresh(g) => (Some(g), false),
            Staleness::Moved(g) => (Some(g), true),
            Staleness::Stale => (None, false),
        };
        let moved_is_stale = moved && !(calibrated && state.split.is_none());
        // The processes of a split run agree: any stale part refreshes everywhere, and
        // the moduli growth is the largest of all (`crate::reduce`).
        let (neg_growth, stale) = Self::agreement(&*self.reduce, state)
            .min_and_any(-growth.unwrap_or(1.0), growth.is_none() || moved_is_stale);
        let agreed = (!stale).then_some(-neg_growth);
        self.tracked.on_summary.checked(agreed.unwrap_or(1.0));
        let mut looked = None;
        if let (Some(growth), Some(cached)) = (agreed, self.tracked.lambda) {
            if !(calibrated && (supplied || moved)) {
                self.tracked.tracking.calibrated_proposals += u64::from(calibrated);
                return Ok((cached * growth.max(self.tracked.tracking.scale), false));
            }
            let bound = self
                .tracked
                .tracking
                .bound_of(state, Self::agreement(&*self.reduce, state));
            if let Some(s) = self
                .tracked
                .tracking
                .calibrated_scale(bound, self.config.bound_drift)
            {
                if moved {
                    self.reanchor_positions(state);
                    self.tracked.tracking.scale = s;
                }
                self.tracked.tracking.calibrated_proposals += 1;
                return Ok((cached * growth.max(s), false));
            }
            looked = Some(bound);
        }
        if looked.is_some() {
            return Ok((self.refresh(state, m_min, diag, looked)?, true));
        }
        if let Some(products) = self.tracked.last_products.filter(|_| self.tracked.age > 0) {
            // An interval between refreshes ended: what its refresh cost per proposal.
            self.tracked.tracking.lanczos_rate =
                Some(products as f64 / f64::from(self.tracked.age));
        }
        let threshold = self.bound_threshold(state);
        let look = self.tracked.age < self.config.bound_age
            && !self.calibrating()
            && self.config.bound_slack >= 0.0
            && self
                .tracked
                .tracking
                .worth_a_look(threshold, view_supplies_bound(state));
        if let Some(cached) = self.tracked.lambda.filter(|_| look) {
            let bound = self
                .tracked
                .tracking
                .bound_of(state, Self::agreement(&*self.reduce, state));
            if self
                .tracked
                .tracking
                .take_instead_of_refresh(bound, cached, threshold)
            {
                self.tracked.tracking.bound_proposals += 1;
                return Ok((bound, false));
            }
            looked = Some(bound);
        }
        Ok((self.refresh(state, m_min, diag, looked)?, true))
    }

    /// The metrics of a proposal: `λmax` used, and how it was obtained.
    fn proposal_metrics(&self, lambda: f64, refreshed: bool) -> Metrics {
        let mut metrics = Metrics::new();
        if refreshed {
            metrics.insert("refreshes".into(), self.tracked.refreshes as f64);
            metrics.insert(
                "lanczos_applications".into(),
                self.tracked.applications as f64,
            );
            if let Some(r) = self.tracked.tracking.last_ratio {
                metrics.insert("bound_ratio".into(), r);
            }
        }
        if self.tracked.tracking.active {
            metrics.insert(
                "bound_proposals".into(),
                self.tracked.tracking.bound_proposals as f64,
            );
        }
        if self.tracked.tracking.calibrated_proposals > 0 {
            metrics.insert(
                "calibrated_proposals".into(),
                self.tracked.tracking.calibrated_proposals as f64,
            );
        }
        metrics.insert(crate::limit::metric::LAMBDA_MAX.into(), lambda);
        if self.config.transfer != TransferNd::Flip || self.config.full_map {
            metrics.insert("transfer_gain".into(), self.tracked.gain);
        }
        metrics
    }
}
