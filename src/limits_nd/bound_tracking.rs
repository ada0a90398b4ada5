//! When the stability limit steps on the element bound instead of a Lanczos value.
//!
//! The element bound `B = max_p λ_p ≥ λmax(M⁻¹K)` ([`super::element_bound`]) is
//! guaranteed (in the frozen-particle sense of eq 56) and costs one pass over the particles
//! — nothing at all when the stepper supplies it from its own pass
//! ([`crate::nd::SummaryNd::element_bound`]). Lanczos gives `λmax` itself but costs several
//! products with `K`, and its value goes stale as particles move. How far apart the two
//! are depends on the scheme and the layout (measured ratios `B/λ` at the refreshes, in
//! `docs/performance.md`): close to 1 for MLS-MPM's gradients, where the bound is exact for
//! every particle on its own and the top mode sits on the few particles of a splash; 1.3–3
//! for GIMP bodies; 3–8 for 3D GIMP and B-spline waves.
//!
//! # The calibrated bound (the default under FLIP, and under APIC on solids)
//!
//! At every Lanczos refresh the bound of the same state is evaluated beside the Lanczos
//! value `λ_L`, `B_L ≥ λ_L`. Until the next refresh the limit proposes from
//!
//! ```text
//! λ ≈ λ_L · max(r, B/B_L),      refreshing when B/B_L leaves [1/(1 + drift), 1 + drift]
//! ```
//!
//! (`drift` = `bound_drift`, 0.5 by default; `r ≥ 1` the moduli's growth factor of the
//! parent module). The element bound sees what moves `λmax` through single particles — a
//! particle's moduli, volume and mass, its place in its cells — at no cost where the
//! stepper supplies it, so the ratio `B/λ` measured by Lanczos is carried to the states
//! after it instead of re-measured whenever particles move half a cell: on a body that
//! translates or deforms smoothly `B` moves little, and the Lanczos value is scaled with
//! it. A rise of `B` raises the estimate in proportion (conservative where the ratio holds;
//! a mode that localises as `B` rises — a splash — makes the ratio fall, and a rise beyond
//! `drift` refreshes); a fall of `B` leaves it where it was (never below `λ_L·r`) until a
//! refresh. Refreshes also come from the parent's mass, diagonal and moduli guards, whose
//! thresholds are raised to `drift` here (their growth scales the estimate up to it).
//! The calibration serves `bound_age` proposals after a refresh (50; SUNDIALS' LSRKStep
//! re-estimates every 25 steps): from then on, until the next refresh, the limit proposes
//! as without it — the cached value times `max(r, s)`, `s` the last calibrated scale
//! `B/B_L` (no longer followed), with the parent's motion guard reading the positions and
//! its thresholds at their own values — and a refresh comes from that guard (a particle
//! moved `refresh_cells`, the moduli or a light node's diagonal grew) or after `max_age`
//! proposals (200). It is not a refresh at `bound_age`: on the 10⁵-particle 2D GIMP wave
//! of `benches/controller_nd.rs` proposal 99 after a refresh still steps on its cached
//! value.
//!
//! **What it assumes.** `B/λ` changes only where `B` changes. That is an interpretation,
//! not a theorem: `λmax` of a uniform layout varies with the particles' offset in their
//! cells (up to 1.49× with GIMP and 1.21× with B-splines within half a cell, in
//! `tests/stability_tracking_nd.rs`) while `B` of many particles hardly does. Measured on
//! that drifting block, the calibrated bound leaves the true `λmax` at most those same
//! factors above the tracked one — the half-cell motion guard gave no better — with 6–7
//! Lanczos runs in 400 steps instead of 17. The growth monitor is the net, as for the
//! motion guard.
//!
//! **Where the stepper supplies `B`** the positions are not read at all (no motion guard);
//! **on the generic path** `B` costs a pass over the weights, so the motion guard stays and
//! calls for `B` instead of Lanczos: within `drift` its positions are re-anchored and the
//! estimate scaled. On a grid split over processes a guard's call refreshes, as before.
//!
//! **Under APIC: on solids only.** The APIC gain is measured on the refresh's top mode;
//! carrying it with a calibrated estimate let the mpm88 fluid grow (22 growth detections
//! at every drift from 0.1 to 0.5, against none for FLIP's analysis of the same scene),
//! and a growth the monitor catches is not undone by a lower safety (measured: switching
//! the calibration off at the first detection does not save the fluid). What the
//! calibration assumes — `B/λ` changes only where `B` does — rests on particles keeping
//! their neighbours, as a solid's do while it translates and deforms; a fluid's particles
//! rearrange freely (no shear stiffness), so the layout that sets `λmax` changes in ways
//! a maximum over single particles does not see. Neither the ratio `B/λ` nor its drift
//! tells the two mpm88 scenes apart (measured at the refreshes: fluid 1.05–1.87, jelly
//! 1.45–2.18), so under APIC the calibrated bound is used while every refresh has found
//! every particle with shear stiffness (`μ_t > 0`), and never again in the run after one
//! that did not ([`BoundTracking::fluid_seen`]); before the first refresh, and after
//! such a one, the raw-bound policy below applies. An interpretation, measured on the two
//! mpm88 scenes (`examples/mls_mpm`, `docs/performance.md`): the jelly takes the same
//! 1 500 steps (0 rejected) with 30 Lanczos runs where the motion guard alone calls 174;
//! the fluid takes the raw-bound policy's steps bit for bit. When a solid turns fluid
//! mid-run the calibration's reference and scale are dropped, so that the raw-bound
//! policy starts clean.
//!
//! **Nor the transfer's gain.** From the same refresh on, a fluid's proposals carry no APIC
//! gain: the step is eq 56's own, `safety·√(2/λ)` ([`crate::limits_nd::transfer`]). The gain
//! `1 + p` is the transfer's share of the frozen layout's top mode; a fluid's layout is
//! not frozen from one step to the next, and on the mpm88 fluid the gain took the
//! controller's mean step to 1.06–1.14× the smallest failing fixed step (taichi and
//! Rust layouts) and its runs into 22 growth detections, ended with `GrowthPersists` at
//! t ≈ 0.26–0.30 on the 200-cell grid and on taichi's layout. Without it the fluid runs to
//! the end on both grids with no rejection (mean step 0.79 of the failure step on the
//! 128-cell grid, `docs/performance.md`). An interpretation measured on one scene on two
//! layouts and two grids; the price is speed (the fluid's mean step falls by about 28 %).
//!
//! **Solids counted as fluids.** The test is on the tangent moduli the view reports: a
//! solid whose tangent shear modulus reaches zero somewhere — `tangent::fixed_corotated`
//! clamps a negative fitted `μ_t` to 0, a neo-Hookean `μ_t = (μ − λ ln J)/J` vanishes at
//! `J = e^{μ/λ}` — switches the calibration off for the rest of the run. That costs
//! Lanczos refreshes (speed), never safety: the raw-bound policy is the stricter one.
//!
//! # The raw-bound policy (`bound_drift < 0`, or APIC)
//!
//! * At every Lanczos refresh the bound of the same state is evaluated too and their
//!   ratio `q = B/λ` recorded. If `q ≤ 1 + bound_slack` the limit enters *bound mode*.
//! * In bound mode every proposal uses the current state's `B` — no motion guard, no
//!   Lanczos — until `bound_age` proposals have passed since the last Lanczos run; then a
//!   refresh measures `q` again. A bound that is not finite (a linear hat with a particle
//!   on a node) ends bound mode at once.
//! * Out of bound mode the tracked Lanczos value and its motion guard work as before;
//!   when the guard calls for a refresh, the bound is evaluated first, and if it is within
//!   `1 + bound_slack` of the cached value the limit enters bound mode without Lanczos.
//!
//! In bound mode the step is `safety·√(2·gain/B)`: at most `1 − 1/√(1 + bound_slack)`
//! shorter than Lanczos' (10.6 % for the default 0.25), never longer than the frozen-particle
//! limit the bound certifies (unlike the cached Lanczos value, which is a margin, not a
//! bound). The APIC gain is the one measured on the Ritz vector of the last refresh — an
//! interpretation, kept to bounds within `1 + bound_slack` of the Lanczos value.
//! `bound_slack < 0` switches the policy off (the Lanczos tracking alone, as before).
//!
//! **Where the stepper supplies the bound** (it costs nothing) and the scheme is FLIP, the
//! threshold also weighs cost: the step shortens by `√(B/λ)` while each step saves the
//! Lanczos products per proposal of the last interval between refreshes (the last warm
//! refresh's products over the proposals until the guard or the bound's age ended it) times
//! `product_cost` bare steps, so the limit steps on `B` while
//! `B/λ ≤ (1 + product_cost·rate)²` ([`BoundTracking::threshold`]). Under APIC it does
//! not (measured on the mpm88 fluid: stepping on bounds up to 1.9× λ with the top mode's
//! gain was stopped by 22 growth detections).
//!
//! **On the generic path** the bound's pass costs about one Lanczos product; where the last
//! ratio was more than [`LOOK_MARGIN`] (1.2) times the threshold it is evaluated again at every
//! [`LOOK_EVERY`]th refresh only ([`BoundTracking::worth_a_look`]).

use super::element_bound::element_bound;

/// On the generic path, a bound found far looser than the threshold is evaluated again at
/// every this many refreshes only ([`BoundTracking::worth_a_look`]).
pub const LOOK_EVERY: u32 = 8;

/// On the generic path, the bound is evaluated at every refresh while its last ratio to
/// the Lanczos value was within this factor of the threshold ([`BoundTracking::worth_a_look`]).
pub const LOOK_MARGIN: f64 = 1.2;
use crate::nd::ViewNd;
use crate::reduce::Reduce;

/// Whether the stepper supplies the element bound from its own pass ([`crate::nd::SummaryNd`]).
pub(crate) fn view_supplies_bound<const D: usize>(view: &ViewNd<'_, D>) -> bool {
    view.summary.is_some_and(|s| s.element_bound.is_some())
}

/// State of the policy (module docs).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct BoundTracking {
    /// Whether proposals use the element bound.
    pub active: bool,
    /// `B/λ` at the last refresh (`None` before the first, or where `B` was not finite).
    pub last_ratio: Option<f64>,
    /// Smallest and largest `B/λ` seen at the refreshes, and how many were seen.
    pub ratio_range: Option<(f64, f64, u64)>,
    /// Proposals made from the bound.
    pub bound_proposals: u64,
    /// Bounds evaluated by a pass of the library's own (not supplied by the stepper).
    pub bound_passes: u64,
    /// Lanczos products per proposal over the last interval between refreshes (the last
    /// warm refresh's products over the proposals until the next was due).
    pub lanczos_rate: Option<f64>,
    /// Refreshes since the bound was last evaluated beside one.
    pub refreshes_unlooked: u32,
    /// The calibrated bound's reference: `(B, λ)` of the last Lanczos refresh, when the
    /// calibrated policy is on and `B` was finite there.
    pub reference: Option<(f64, f64)>,
    /// `B/B_ref` at the last re-anchoring of the motion guard on the generic path (1 at a
    /// refresh; 0 before any: the estimate takes `max(r, scale)`, `r ≥ 1`, so 0 and 1 act
    /// alike).
    pub scale: f64,
    /// Proposals made from the calibrated bound.
    pub calibrated_proposals: u64,
    /// Whether some refresh under APIC has met a particle without shear stiffness
    /// (`μ_t ≤ 0`: a fluid, module docs "Under APIC"); the calibrated bound is then off
    /// for the rest of the run.
    pub fluid_seen: bool,
}

impl BoundTracking {
    /// The element bound of `view`: the stepper's own ([`crate::nd::SummaryNd`]) when it
    /// supplies one, else a pass over the weights; the largest over the processes of a
    /// split run either way (one scalar reduction).
    pub fn bound_of<const D: usize>(&mut self, view: &ViewNd<'_, D>, reduce: &dyn Reduce) -> f64 {
        match view.summary.and_then(|s| s.element_bound) {
            Some(b) => {
                let mine = if b.is_nan() { 0.0 } else { b };
                let (neg, any_nan) = reduce.min_and_any(-mine, b.is_nan());
                if any_nan {
                    f64::NAN
                } else {
                    -neg
                }
            }
            None => {
                self.bound_passes += 1;
                element_bound(view, reduce).lambda
            }
        }
    }

    /// The largest `B/λ` worth stepping on (module docs): `1 + slack` on the generic
    /// path; where the stepper supplies the bound from its own pass (it costs nothing),
    /// also more where the Lanczos tracking is dear — the step shortens by `√(B/λ)` while
    /// each step saves `product_cost · rate` bare steps of Lanczos products (`rate`
    /// products per proposal over the last interval between refreshes).
    pub fn threshold(&self, slack: f64, product_cost: f64, supplied: bool) -> f64 {
        if slack < 0.0 {
            return f64::NAN;
        }
        if !supplied {
            return 1.0 + slack;
        }
        let saving = 1.0 + product_cost * self.lanczos_rate.unwrap_or(0.0);
        (1.0 + slack).max(saving * saving)
    }

    /// Whether to evaluate the bound at a refresh: always when the stepper supplies it
    /// (free), else unless the last ratio was above the threshold by more than
    /// [`LOOK_MARGIN`], and then at every [`LOOK_EVERY`]th refresh only — on the generic
    /// path the bound's pass costs about a Lanczos product (measured on the B-spline FLIP
    /// block: 1.8 % of the run against 11 % for its 3 207 products), wasted where the
    /// bound is loose (1.5–8× on the jelly, GIMP and B-spline layouts).
    pub fn worth_a_look(&self, threshold: f64, supplied: bool) -> bool {
        supplied
            || self.last_ratio.is_none_or(|q| q <= LOOK_MARGIN * threshold)
            || self.refreshes_unlooked + 1 >= LOOK_EVERY
    }

    /// Counts a refresh at which the bound was not evaluated; bound mode stays off.
    pub fn skipped_refresh(&mut self) {
        self.refreshes_unlooked += 1;
        self.active = false;
    }

    /// Records a refresh's Lanczos value `lambda` beside the same state's `bound`, and
    /// decides whether the next proposals use the bound; `rate` is the refresh's products
    /// per proposal since the previous one when the motion guard called for it.
    pub fn after_refresh(&mut self, lambda: f64, bound: f64, threshold: f64) {
        self.refreshes_unlooked = 0;
        let ratio = bound / lambda;
        if ratio.is_finite() {
            self.last_ratio = Some(ratio);
            self.ratio_range = Some(match self.ratio_range {
                None => (ratio, ratio, 1),
                Some((lo, hi, n)) => (lo.min(ratio), hi.max(ratio), n + 1),
            });
        } else {
            self.last_ratio = None;
        }
        self.active = ratio.is_finite() && ratio <= threshold;
    }

    /// The calibrated estimate `λ ≈ λ_L · B/B_L` (module docs) for the current `bound`,
    /// `None` where `B` drifted by more than `drift` (relative, either way) from its value
    /// at the refresh, or there is no reference (a refresh follows).
    pub fn calibrated_scale(&self, bound: f64, drift: f64) -> Option<f64> {
        let (b_ref, _) = self.reference?;
        let s = bound / b_ref;
        (s.is_finite() && s > 0.0 && s <= 1.0 + drift && s * (1.0 + drift) >= 1.0).then_some(s)
    }

    /// Records the reference of the calibrated bound at a refresh: `bound` beside the
    /// Lanczos value `lambda`, or none where the bound is not a positive number.
    pub fn calibrate(&mut self, lambda: f64, bound: f64) {
        self.scale = 1.0;
        self.active = false;
        self.reference = (bound.is_finite() && bound > 0.0).then_some((bound, lambda));
    }

    /// Whether a bound met where the cached value `cached` went stale is tight enough to
    /// step on (module docs); enters bound mode if so.
    pub fn take_instead_of_refresh(&mut self, bound: f64, cached: f64, threshold: f64) -> bool {
        self.active = bound.is_finite() && bound > 0.0 && bound <= threshold * cached;
        self.active
    }
}
