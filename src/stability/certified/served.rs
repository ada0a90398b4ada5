//! The served pass of [`super::CertifiedTracker`] (module docs of [`super`]): a generalised
//! Rayleigh quotient and a power step on the last anchor's mode, served unless an anchor is
//! due or a detector fires.

use super::{diagonal_above, estimate, CertifiedEstimate, CertifiedTracker};
use crate::stability::nodal::NodalOperator;
use crate::stability::power_pass::{active_masses_positive, power_pass, FLUSH_RELATIVE};
use crate::stepper::View;

/// What the served pass left: a served estimate, or an anchor to make.
pub(super) enum Served {
    Estimate(CertifiedEstimate),
    Anchor {
        hint: Option<f64>,
        recertify: Option<f64>,
    },
}

impl CertifiedTracker {
    /// The served pass (module docs): a quotient and a power step on the last anchor's mode,
    /// served unless an anchor is due or a detector fires; then the quotient to start the
    /// anchor from (`hint`) and the served ratio to re-certify (`recertify`, module docs,
    /// "Certification"). No anchor yet, or a pass that cannot run: an anchor from nothing.
    pub(super) fn served_pass(&mut self, view: &View<'_>, op: &NodalOperator) -> Served {
        const FROM_NOTHING: Served = Served::Anchor {
            hint: None,
            recertify: None,
        };
        let margin = self.config.margin;
        let Some(anchor) = self.anchor.as_mut() else {
            return FROM_NOTHING;
        };
        let k = view.nodal_stiffness.unwrap_or(op.stiffness());
        // Below every value served without a `dropped` trigger (`r ρ ≥ r (1 − drop_tol)
        // ρ_anchor`), so the pass's diagonal test is conservative; a hit is re-checked
        // exactly against the served value below.
        let lambda_floor = anchor.ratio * (1.0 - self.config.drop_tol) * anchor.rayleigh;
        // The pass assumes positive active masses: vouched for by a trusted summary,
        // scanned otherwise (a failure anchors, whose validation reports it).
        let masses_ok = view.trusted_summary().is_some()
            || active_masses_positive(view.node_mass, view.node_active);
        let pass = masses_ok
            .then(|| {
                power_pass(
                    k,
                    view.node_mass,
                    view.node_active,
                    &mut anchor.z,
                    anchor.last_rayleigh,
                    lambda_floor,
                    anchor.flush_below,
                )
            })
            .flatten();
        let Some(p) = pass else {
            return FROM_NOTHING;
        };
        anchor.flush_below = FLUSH_RELATIVE * p.max_abs;
        let due = anchor.served.saturating_add(1) >= self.config.certify_every;
        let dropped = p.rayleigh < (1.0 - self.config.drop_tol) * anchor.rayleigh;
        let served = anchor.ratio * p.rayleigh;
        let above =
            p.diagonal_above && diagonal_above(&k.diag, view.node_mass, view.node_active, served);
        // A mode served with a large certified ratio that has since improved would
        // overstate λmax by that improvement: re-certify it (usually one
        // factorisation, after which the ratio is 1 + margin again).
        let loose = 1.0 + 2.0 * margin;
        let rose = anchor.ratio > loose && p.rayleigh > loose * anchor.rayleigh;
        if !(due || dropped || above || rose) {
            anchor.served = anchor.served.saturating_add(1);
            anchor.last_rayleigh = p.rayleigh;
            return Served::Estimate(CertifiedEstimate {
                estimate: estimate(view.grid.h, k.c2_ref, served, 0),
                rayleigh: p.rayleigh,
                certified: false,
                factorisations: 0,
            });
        }
        tracing::trace!(due, dropped, above, rose, "lambda_max: anchoring");
        // A stale mode (its quotient dropped) or a diagonal entry above the served value:
        // the served value itself is in doubt, so the anchor skips its re-certification
        // and the shift growth and tries (1 + margin) ρ directly. The power step (already
        // in `z`) can only improve the mode the anchor certifies.
        Served::Anchor {
            hint: Some(p.rayleigh),
            recertify: (!(dropped || above)).then_some(anchor.ratio),
        }
    }
}
