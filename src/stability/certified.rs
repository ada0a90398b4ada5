//! [`CertifiedTracker`]: `λmax` of the nodal eq 56 operator for the price of one pass over
//! the nodes per step, certified by Sylvester's law of inertia every few steps.
//!
//! ```text
//! every step (served):   ρ = zᵀ K_N z / zᵀ M z,  z ← M⁻¹ K_N z   (one pass: quotient, power step)
//!                        λ̂ = r ρ                          (what dt_eq56 uses)
//! anchor (re-certify):   LDLᵀ(μ₁ diag(m) − K_N) ≻ 0 with μ₁ = r ρ (the served value)
//!                        ⇒ λmax(C) < μ₁; bisect [ρ, μ₁] to the margin on the same pencil
//!                        on failure: Lanczos (warm), certified brackets (see `anchor_at`)
//! ```
//!
//! `C = M^{1/2} K_N M^{1/2}` ([`NodalOperator`], `M = diag(1/m_i)` over active nodes) and
//! `C u = λ u` ⇔ `K_N z = λ diag(m) z` with `z = M^{1/2} u`. For any `z` that vanishes at
//! inactive nodes, the generalised Rayleigh quotient `ρ(z) = zᵀK_N z / Σ m_i z_i²` is the
//! Rayleigh quotient of `C` at `u = M^{−1/2} z`, hence a rigorous *lower* bound on `λmax(C)`;
//! with `z` the last anchor's eigenvector it is second-order accurate in the eigenvector's
//! change. It reads the stepper's `K_N` bands and nodal masses in one fused pass — no square
//! roots, no operator build, no eigenvalue iteration (measured: README "Stability").
//!
//! **Certification.** Every `certify_every` proposals, and whenever a served step looks
//! suspicious, the tracker tests `μI − C ≻ 0` by one `LDLᵀ` pass ([`super::certificate`]);
//! with the stepper's `K_N` it tests the congruent pencil `μ diag(m) − K_N` instead, which
//! needs no operator build ([`super::certificate::below_shift_pencil`], bands prepared once
//! per anchor by [`Pencil`]). A scheduled anchor (`due`, or the rise trigger below) first
//! re-certifies **the value being served**, `μ₁ = r ρ`: success proves
//! that value was an upper bound, and the bracket `[ρ, μ₁]` is then bisected on the same
//! operator, starting at `(1 + margin) ρ`, until `hi ≤ (1 + margin) lo` — usually one or
//! three more factorisations, no Lanczos. Failure means an eigenvalue lies above the served
//! value (a level crossing, a mode that `z` does not see, or simply a served value a little
//! low): the shift then grows on the same operator, `r ρ (1 + 2^k margin)` for `k = 1 … 4`
//! (0.2 % … 1.6 % above), and the bracket found is bisected as above. Only when that fails
//! too does the tracker build `C`, run a warm Lanczos update (with its diagonal guard),
//! certify `(1 + margin) θ`, then a cold, tight Lanczos and finally a bisection between the
//! failed shift and the rigorous Gershgorin bound. An anchor triggered by a dropped quotient or a diagonal entry
//! (below) skips the re-certification of the served value, which is in doubt there, and
//! tries `(1 + margin) ρ` directly (on the pencil when it can), then the same fall-back. How often
//! each path runs in a 10⁵-particle controller run: README "Stability".
//!
//! **Localised modes.** A Lanczos vector is non-zero everywhere, and the served pass costs
//! in proportion to its mode's support (it skips blocks where the mode is zero). So before a
//! Lanczos vector is served it is tapered to a window of 512 nodes around its largest
//! component (`stability/localise.rs`, `CertifiedConfig::localise`), kept only when that loses
//! at most `margin / 10` of its quotient; the anchor then uses the window's quotient. The
//! certificate is unchanged (it tests the operator, not the mode).
//!
//! Suspicious served steps, which trigger an anchor at once:
//!
//! * `ρ` dropped by more than `drop_tol` relative since the anchor — `z` may be going stale
//!   (a drop of `ρ` is the only symptom a stale `z` can show, since `ρ ≤ λmax` always);
//! * some active node has `K_N(i,i)/m_i > λ̂` — a diagonal entry of `C` is itself a Rayleigh
//!   quotient, so a mode localised at a light node is above the tracked value (linear hats,
//!   particles crossing a node);
//! * the anchor certified a ratio `r` above `1 + 2·margin` (its mode was far below the top)
//!   and `ρ` has since risen by more than `2·margin`: served values `r ρ` would overstate
//!   λmax by that rise;
//! * the nodes changed (count, activity), or a value the pass multiplies is not finite (the
//!   anchor's full validation then reports it as a typed error; a non-finite `K_N` entry in
//!   a zero block of the mode is not multiplied, and waits for the next scheduled anchor:
//!   `power_pass`, "Zero blocks").
//!
//! **Between anchors on the bound (opt-in).** A stepper that takes the element bound in its
//! own pass ([`crate::PassSummary::element_bound`], `B = max_p (E_t,p V_p/m_p) Σ_i
//! D_ip²/S_ip ≥ λmax(C)`, the element eigenvalue inequality with particles as elements) need
//! not accumulate `K_N` on every state. With [`CertifiedConfig::on_bound`] the tracker
//! serves the proposals between anchors as
//!
//! ```text
//! λ̂ = λ_ref · max(1, B/B_ref)
//! ```
//!
//! `λ_ref` and `B_ref` being the value served and the bound of the last state whose proposal
//! was computed on `K_N` (an anchor, or a served pass), and asks the stepper for `K_N`
//! ([`crate::Stepper::provide_nodal_stiffness_on_trials`], through
//! [`CertifiedTracker::wants_nodal_stiffness`]) only for the state of the next anchor
//! (`certify_every`), after `B` has moved by more than [`CertifiedConfig::bound_drift`]
//! either way, or after a run of proposals on the bound: 4 at first, doubled after each
//! proposal on `K_N` whose value was at most [`BOUND_MISS`] (1 %) above the bound's
//! prediction, halved after one above it, at most `certify_every − 1`. A view without the stepper's bound has it taken
//! from its own weights when they are the library's GIMP weights (`stability::element_bound`,
//! the same value bit for bit: a restored run continues as it would have); a view whose
//! active nodes differ from the
//! reference's, or without `K_N` when it is needed, is served on `K_N` assembled from its
//! weights.
//!
//! Like the served quotient, `λ̂` between anchors is not a proof, and it is less tight:
//! `λmax` can rise without `B` moving (the bound is loose by a factor `B/λmax` of about 2.3
//! on uniform 2-per-cell GIMP layouts, and its maximum sits on the particle with the worst
//! stencil, not where the top mode is), which the next anchor finds and certifies; a falling
//! `λmax` is served at `λ_ref` until then (a smaller step than the quotient's). Measured
//! against a tracker on `K_N` at every step, state by state (`tests/solver_summary.rs`):
//! within 1 % below and 2 % above on small-amplitude waves, but 10 % below to 14 % above
//! on a neo-Hookean wave at 20 % strain, where `λmax` moves by up to 16 % in three steps
//! while `B` stays within 2 % — a `dt` up to 5.4 % above the quotient's, inside the
//! [`super::Stability`] safety factor but not within the quotient's 1 %. Hence opt-in. What it
//! saves is the accumulation of `K_N` (six products and three scattered adds per particle
//! in the stepper's pass) and the served pass on most steps, against one division per
//! particle for `B`: on the 10⁵-particle 1D wave with the reference solver about 5 % of a
//! controlled step (`perf` samples; below the wall-clock noise here), with a stepper that
//! hands over no `K_N` (assembled from the weights on every state otherwise) 19–23 %
//! (docs/performance.md). On those steps the decision's
//! `lambda_rayleigh` metric is the last quotient computed, on the reference state.
//!
//! **What is and is not guaranteed.** At an anchor the step uses a certified upper bound.
//! Between anchors (at most `certify_every − 1` proposals) `λ̂` is a Rayleigh quotient times
//! the anchor's certified ratio `r` (`1 + margin` when the served mode certified first time),
//! with the detectors above — not a proof. Measured against dense eigenvalues
//! (`tests/stability_certified.rs`): served values between 2.0 % below (a stale mode within
//! `drop_tol`) and 0.16 % above the true λmax, i.e. `dt_eq56` at most 1 % high, inside the
//! `Stability` safety factor. The previous default (a Lanczos update per step with periodic
//! cold restarts) gave no proof at any step; `certify_every = 1` gives one at every step, at about
//! a fifth of a solver step each (the `LDLᵀ` pass is a chain of divisions).

use super::certificate::{below_shift, Pencil};
use super::error::StabilityError;
use super::lambda_max::{LambdaEstimate, LambdaMaxTracker, LanczosConfig};
use super::nodal::NodalOperator;
use super::operator::Eq56Operator;
use crate::stepper::View;
use bracket::{Bracket, GROWTH_STEPS};
use served::Served;

mod anchor;
mod bracket;
mod config;
mod on_bound;
mod served;

pub use config::CertifiedConfig;

pub use on_bound::{BoundReference, BOUND_MISS, FIRST_BOUND_RUN};

/// The result of one [`CertifiedTracker::update`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CertifiedEstimate {
    /// The value the step size uses, `λ̂ = (1 + margin) ρ` (certified, rounding slack
    /// included, when `certified`), with its critical step `√(2/λ̂)` and normalised value
    /// (`applications` counts this update's applications of `C`: 0 unless Lanczos ran).
    pub estimate: LambdaEstimate,
    /// The Rayleigh quotient `ρ`, a rigorous lower bound on `λmax(C)` (up to rounding).
    pub rayleigh: f64,
    /// Whether this update certified `λmax(C) < λ̂` by an `LDLᵀ` factorisation.
    pub certified: bool,
    /// `LDLᵀ` factorisations this update ran.
    pub factorisations: usize,
}

/// The tracked mode and the state of the last anchor.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Anchor {
    /// The generalised eigenvector `z = M^{1/2} u` (zero at inactive nodes).
    pub z: Vec<f64>,
    /// The Rayleigh quotient at the anchor.
    pub rayleigh: f64,
    /// The Rayleigh quotient of the last served step (scales the power step).
    pub last_rayleigh: f64,
    /// Proposals served since the anchor.
    pub served: u32,
    /// Power-step values below this are stored as zero: `10⁻¹⁵` times the largest component
    /// of the mode the last pass started from (the served pass's "flushed tails": a long
    /// run's localised mode otherwise decays into subnormal numbers, which slowed the pass
    /// 1.2–1.4×). `0` (a checkpoint from before this field) flushes nothing until the next
    /// pass sets it.
    #[serde(default)]
    pub flush_below: f64,
    /// The certified upper bound over the anchor's Rayleigh quotient (`1 + margin` when the
    /// first certificate passed): served values are this ratio times their quotient.
    pub ratio: f64,
}

/// The checkpointable part of a [`CertifiedTracker`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CertifiedState {
    /// The Lanczos tracker's warm start.
    pub tracker: super::lambda_max::TrackerState,
    /// The last anchor.
    pub anchor: Option<Anchor>,
    /// The reference of the proposals served on the element bound.
    #[serde(default)]
    pub bound_reference: Option<BoundReference>,
    /// Whether the next proposal reads `K_N` ([`CertifiedTracker::wants_nodal_stiffness`]).
    #[serde(default = "yes")]
    pub stiffness_next: bool,
    /// Proposals served on the bound before the next on `K_N`.
    #[serde(default = "first_bound_run")]
    pub bound_run: u32,
}

fn first_bound_run() -> u32 {
    on_bound::FIRST_BOUND_RUN
}

fn yes() -> bool {
    true
}

/// `λmax` of the nodal eq 56 operator by a Rayleigh quotient per step, certified at anchors
/// (module docs).
#[derive(Clone, Debug)]
pub struct CertifiedTracker {
    config: CertifiedConfig,
    tracker: LambdaMaxTracker,
    anchor: Option<Anchor>,
    /// Scratch: the pencil bands of an anchor's state (from the stepper's `K_N`).
    pencil: Pencil,
    /// The reference of the proposals served on the element bound (`on_bound.rs`).
    bound_reference: Option<BoundReference>,
    /// Whether the next proposal reads `K_N` ([`Self::wants_nodal_stiffness`]).
    stiffness_next: bool,
    /// Proposals served on the bound before the next on `K_N` (`on_bound.rs`).
    bound_run: u32,
}

impl Default for CertifiedTracker {
    /// The default settings (as [`Self::new`] builds them).
    fn default() -> Self {
        Self {
            config: CertifiedConfig::default(),
            tracker: Self::anchor_tracker(LanczosConfig::default()),
            anchor: None,
            pencil: Pencil::default(),
            bound_reference: None,
            stiffness_next: true,
            bound_run: on_bound::FIRST_BOUND_RUN,
        }
    }
}

impl CertifiedTracker {
    /// The Lanczos tracker of the anchors: no periodic cold restarts, since the certificate
    /// catches what they were for.
    fn anchor_tracker(lanczos: LanczosConfig) -> LambdaMaxTracker {
        let mut tracker = LambdaMaxTracker::default_tracker();
        tracker.set_config(LanczosConfig {
            restart_every: 0,
            ..lanczos
        });
        tracker
    }

    /// A tracker with the given settings and the Lanczos settings of its anchors (validated).
    pub fn new(config: CertifiedConfig, lanczos: LanczosConfig) -> Result<Self, StabilityError> {
        config.validate()?;
        lanczos.validate()?;
        Ok(Self {
            config,
            tracker: Self::anchor_tracker(lanczos),
            anchor: None,
            pencil: Pencil::default(),
            bound_reference: None,
            stiffness_next: true,
            bound_run: on_bound::FIRST_BOUND_RUN,
        })
    }

    /// The settings.
    pub fn config(&self) -> CertifiedConfig {
        self.config
    }

    /// The Lanczos tracker of the anchors.
    pub fn lanczos(&self) -> &LambdaMaxTracker {
        &self.tracker
    }

    /// The last anchor, if any.
    pub fn anchor(&self) -> Option<&Anchor> {
        self.anchor.as_ref()
    }

    /// The checkpointable state.
    pub fn state(&self) -> CertifiedState {
        CertifiedState {
            tracker: self.tracker.state(),
            anchor: self.anchor.clone(),
            bound_reference: self.bound_reference.clone(),
            stiffness_next: self.stiffness_next,
            bound_run: self.bound_run,
        }
    }

    /// Whether the next proposal reads `K_N` from the stepper: always, unless proposals
    /// are being served on the element bound and the next is neither due for an anchor nor
    /// after a drift of the bound (`on_bound.rs`). The [`super::Stability`] limit passes it
    /// on to the controller ([`crate::StepLimit::reads_nodal_stiffness`]).
    pub fn wants_nodal_stiffness(&self) -> bool {
        !self.config.on_bound || self.stiffness_next
    }

    /// Restores a state from [`Self::state`]: the next updates are bit-identical.
    pub fn restore(&mut self, state: CertifiedState) {
        self.tracker.restore(state.tracker);
        self.anchor = state.anchor;
        self.bound_reference = state.bound_reference;
        self.stiffness_next = state.stiffness_next;
        self.bound_run = state.bound_run;
    }

    /// `λmax` of the nodal operator of `view` (module docs). `op` is scratch: it is rebuilt
    /// from `view` only when the view carries no `K_N` or an anchor falls back to Lanczos
    /// (and then holds `C` of `view`); anchors on the pencil leave it as it was.
    pub fn update(
        &mut self,
        view: &View<'_>,
        op: &mut NodalOperator,
    ) -> Result<CertifiedEstimate, StabilityError> {
        if let Some(served) = self.serve_on_bound(view) {
            return Ok(served);
        }
        let result = self.update_on_operator(view, op)?;
        self.after_operator(view, result.estimate.lambda_b);
        Ok(result)
    }

    /// [`Self::update`] on `K_N` (the stepper's, or assembled from the view's weights): the
    /// served pass, or an anchor when it is due or the pass looks suspicious.
    fn update_on_operator(
        &mut self,
        view: &View<'_>,
        op: &mut NodalOperator,
    ) -> Result<CertifiedEstimate, StabilityError> {
        // Without the stepper's K_N the operator is assembled now (and then already built).
        let built = view.nodal_stiffness.is_none();
        if built {
            op.rebuild(view)?;
        }
        let (hint, recertify) = match self.served_pass(view, op) {
            Served::Estimate(estimate) => return Ok(estimate),
            Served::Anchor { hint, recertify } => (hint, recertify),
        };
        self.anchor_on_operator(view, op, built, hint, recertify)
    }

    /// The common anchor on `op` or the stepper's `K_N`, from the served pass's `hint` and
    /// `recertify` (`built`: `op` already holds the view's assembled operator).
    fn anchor_on_operator(
        &mut self,
        view: &View<'_>,
        op: &mut NodalOperator,
        built: bool,
        hint: Option<f64>,
        recertify: Option<f64>,
    ) -> Result<CertifiedEstimate, StabilityError> {
        let margin = self.config.margin;
        // The common anchor, on the operator at hand — the pencil `μ diag(m) − K_N` of the
        // stepper's K_N ([`below_shift_pencil`], no operator build) or the assembled `C`.
        let mut proven_above = None;
        let mut factorisations = 0;
        let rho_hint = hint.filter(|&r| r > 0.0);
        let periodic = matches!(view.grid.boundary, crate::Boundary::Periodic);
        let stiffness = view.nodal_stiffness;
        let on_pencil = rho_hint.is_some()
            && stiffness.is_some_and(|k| {
                self.pencil
                    .prepare(k, view.node_mass, view.node_active, periodic)
            });
        // A K_N the pencil cannot take (under 7 nodes, sizes that do not fit) leaves no
        // operator to test here: straight to the fall-back.
        if let Some(rho) = rho_hint.filter(|_| stiffness.is_none() || on_pencil) {
            let pencil = &self.pencil;
            let test = |mu: f64| {
                if on_pencil {
                    pencil.below_shift(mu)
                } else {
                    let (diag, off) = op.bands();
                    below_shift(diag, off, op.is_periodic(), mu)
                }
            };
            let tight = (1.0 + margin) * rho;
            let first = recertify.map_or(tight, |ratio| (ratio * rho).max(tight));
            // A served value that failed: the top is usually just above it (served values
            // are measured within 2 % of λmax), so the shift grows on the same operator,
            // 0.2 % … 1.6 % above it, before the Lanczos fall-back. After a dropped quotient
            // or a high diagonal entry the mode itself is in doubt: straight to the fall-back.
            let growth = if recertify.is_some() { GROWTH_STEPS } else { 0 };
            let mut bracket = Bracket::new(test, margin, rho);
            let certified = bracket.grow(first, 0..=growth).map(|hi| {
                // Bisect to the margin on the same operator, from the tight shift when it
                // lies inside the bracket.
                let start = (bracket.lo < tight && tight < hi).then_some(tight);
                bracket.bisect(hi, start)
            });
            let (lo, count) = (bracket.lo, bracket.factorisations);
            if let Some(hi) = certified {
                let scale = Scale {
                    n_nodes: view.node_mass.len(),
                    h: view.grid.h,
                    c2_ref: stiffness.unwrap_or(op.stiffness()).c2_ref,
                };
                return Ok(self.anchored(scale, rho, hi, 0, count));
            }
            factorisations = count;
            if lo > rho {
                proven_above = Some(lo);
            }
        }
        if !built {
            op.rebuild(view)?;
        }
        self.anchor_at(op, hint, proven_above, factorisations)
    }
}

/// Whether some active node has `K_N(i,i) > λ m_i`, i.e. a diagonal entry of `C` (itself a
/// Rayleigh quotient) above `λ` (the exact re-check of [`power_pass`]'s conservative flag).
fn diagonal_above(kd: &[f64], mass: &[f64], active: &[bool], lambda: f64) -> bool {
    kd.iter()
        .zip(mass)
        .zip(active)
        .any(|((&k, &m), &a)| a && k > lambda * m)
}

/// What turns a certified `λmax(C)` into an estimate: the node count (for the rounding
/// slack), the grid spacing and the reference wave speed².
#[derive(Clone, Copy)]
struct Scale {
    n_nodes: usize,
    h: f64,
    c2_ref: f64,
}

/// The [`LambdaEstimate`] of the value `lambda` on a grid of spacing `h` with reference wave
/// speed² `c2_ref` (`residual` 0: not an eigenpair residual; `warm` when no application of `C`
/// was needed).
fn estimate(h: f64, c2_ref: f64, lambda: f64, applications: usize) -> LambdaEstimate {
    LambdaEstimate {
        lambda_b: lambda,
        lambda_hat: h * h * lambda / c2_ref,
        dt_eq56: Eq56Operator::critical_dt(lambda),
        residual: 0.0,
        applications,
        converged: true,
        warm: applications == 0,
    }
}
