//! Proposals of [`super::CertifiedTracker`] between its anchors served on the stepper's
//! element bound, without `K_N` (module docs of [`super`], "Between anchors on the bound").

use super::{estimate, CertifiedEstimate, CertifiedTracker};
use crate::stepper::View;

/// Proposals served on the bound before the next is computed on `K_N`, at the start of a run
/// (then halved after a miss, doubled after a hit, at most `certify_every − 1`).
pub const FIRST_BOUND_RUN: u32 = 4;

/// A proposal on `K_N` whose value exceeds the bound's prediction for its state by more
/// than this relative amount is a miss, which halves the next runs on the bound; any value
/// up to it (or below the prediction) is a hit, which doubles them.
pub const BOUND_MISS: f64 = 0.01;

/// What a proposal computed on `K_N` left for the proposals served on the bound: the element
/// bound of its state, the value it served, and the state's node activity.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BoundReference {
    /// The state's element bound `B_ref` ([`crate::PassSummary::element_bound`]).
    pub bound: f64,
    /// The value served for that state, `λ_ref` (certified at an anchor).
    pub lambda: f64,
    /// The state's active nodes: a change of activity is served on `K_N` again.
    pub active: Vec<bool>,
    /// Proposals served on the bound since.
    pub served: u32,
}

/// The element bound of a view, when finite and positive: the one its trusted summary
/// vouches for, else the library's own from the view's weights (the same value, bit for
/// bit, for the reference solver; `stability/element_bound.rs`).
pub(super) fn trusted_bound(view: &View<'_>) -> Option<f64> {
    view.trusted_summary()
        .and_then(|s| s.element_bound)
        .or_else(|| crate::stability::element_bound::of_view(view))
        .filter(|b| b.is_finite() && *b > 0.0)
}

impl CertifiedTracker {
    /// The proposal served on the bound, `λ̂ = λ_ref max(1, B/B_ref)`, when the view carries no
    /// `K_N`, a trusted bound, the same active nodes as the reference, and no anchor is due;
    /// `None` sends the proposal to the operator. Asks for `K_N` on the next state
    /// ([`Self::wants_nodal_stiffness`]) when the next proposal will be due or `B` has moved
    /// by more than [`super::CertifiedConfig::bound_drift`] either way.
    pub(super) fn serve_on_bound(&mut self, view: &View<'_>) -> Option<CertifiedEstimate> {
        if !self.config.on_bound || view.nodal_stiffness.is_some() {
            return None;
        }
        let bound = trusted_bound(view)?;
        let reference = self.bound_reference.as_ref()?;
        let anchor = self.anchor.as_mut()?;
        let reference_lambda = reference.lambda;
        let every = self.config.certify_every;
        let due = anchor.served.saturating_add(1) >= every;
        if due || reference.served >= self.bound_run || reference.active != view.node_active {
            return None;
        }
        // `max_p E_t/ρ`, the summary's or the scan's (the same bits by the summary's
        // contract), before any state changes: a view the scan refuses goes to the operator.
        let c2_ref = match view.trusted_summary() {
            Some(s) => s.max_wave_speed_sq,
            None => crate::stability::error::check_view_speeds(view).ok()?.c2,
        };
        anchor.served = anchor.served.saturating_add(1);
        let ratio = bound / reference.bound;
        let drift = self.config.bound_drift;
        let drifted = !(ratio <= 1.0 + drift && ratio * (1.0 + drift) >= 1.0);
        let run_over = reference.served.saturating_add(1) >= self.bound_run;
        self.stiffness_next = drifted || run_over || anchor.served.saturating_add(1) >= every;
        let lambda = reference_lambda * ratio.max(1.0);
        if let Some(r) = self.bound_reference.as_mut() {
            r.served += 1;
        }
        tracing::trace!(
            bound,
            ratio,
            lambda,
            "lambda_max served on the element bound"
        );
        Some(CertifiedEstimate {
            estimate: estimate(view.grid.h, c2_ref, lambda, 0),
            rayleigh: anchor.last_rayleigh,
            certified: false,
            factorisations: 0,
        })
    }

    /// Records a proposal computed on the operator (`served`, its value): how well the
    /// bound predicted it after proposals served on the bound (a miss halves the next runs
    /// on the bound, a hit doubles them), the reference of the proposals served on the bound
    /// after it (none without a trusted bound), and whether the next one needs `K_N`.
    pub(super) fn after_operator(&mut self, view: &View<'_>, served: f64) {
        // Only when serving on the bound: the library's own takes a pass over the weights.
        let bound = if self.config.on_bound {
            trusted_bound(view)
        } else {
            None
        };
        let previous = self.bound_reference.take();
        if let (Some(b), Some(r)) = (bound, previous.as_ref().filter(|r| r.served > 0)) {
            let predicted = r.lambda * (b / r.bound).max(1.0);
            let most = self.config.certify_every.saturating_sub(1).max(1);
            self.bound_run = if served > (1.0 + BOUND_MISS) * predicted {
                tracing::debug!(
                    served,
                    predicted,
                    "lambda_max rose past the bound's prediction"
                );
                (self.bound_run / 2).max(1)
            } else {
                self.bound_run.saturating_mul(2).min(most)
            };
        }
        self.bound_reference = bound.map(|bound| {
            let mut active = previous.map(|r| r.active).unwrap_or_default();
            active.clear();
            active.extend_from_slice(view.node_active);
            BoundReference {
                bound,
                lambda: served,
                active,
                served: 0,
            }
        });
        let every = self.config.certify_every;
        let next_due = self
            .anchor
            .as_ref()
            .is_none_or(|a| a.served.saturating_add(1) >= every);
        self.stiffness_next = bound.is_none() || next_due;
    }
}
