//! The anchors of [`super::CertifiedTracker`]: a certified bracket of `λmax` on the
//! operator at hand, by `LDLᵀ` inertia tests and, when the served mode fails, Lanczos
//! (module docs of [`super`], "Certification").

use super::bracket::{shift, Bracket};
use super::{estimate, Anchor, CertifiedEstimate, CertifiedTracker, Scale};
use crate::stability::certificate::{below_shift, rounding_slack};
use crate::stability::error::StabilityError;
use crate::stability::lambda_max::{LanczosConfig, SymmetricOperator};
use crate::stability::localise::{self, localised};
use crate::stability::nodal::NodalOperator;
use crate::stability::power_pass::FLUSH_RELATIVE;

impl CertifiedTracker {
    /// A new anchor on `op` (module docs of [`super`]): a certified bracket `lo ≤ λmax(C) < hi`, narrowed
    /// to `hi ≤ (1 + margin) lo`. Every failed certificate at `μ` proves `λmax ≥ μ` up to
    /// the factorisation's rounding (a non-positive pivot makes a leading principal
    /// submatrix of a symmetric permutation of `μI − C` — or the Schur complement of a
    /// border — not positive definite, so by Cauchy interlacing, Haynsworth for the border,
    /// `μI − C` is not positive definite either). `hi` always comes from a test that passed
    /// (or from Gershgorin), so the served upper bound is rigorous; `lo` only steers the
    /// search:
    ///
    /// 1. the served quotient `ρ` of the power-stepped `z` is tried first: `μ = (1 + margin) ρ`;
    /// 2. else a warm Lanczos update (with the tracker's diagonal guard) gives the mode `z`
    ///    to serve next and `θ`, and `μ = (1 + margin) max(θ, lo)` is tried;
    /// 3. else the shift grows geometrically, `lo (1 + 2^k margin)` for `k = 1 … 6` (a top
    ///    cluster the Lanczos value has not converged into);
    /// 4. else a cold, tight Lanczos, and finally the rigorous Gershgorin bound;
    /// 5. the bracket is then bisected until `hi ≤ (1 + margin) lo`.
    ///
    /// Served values are then `hi/ρ_anchor` times their quotient. (Converging the served
    /// mode further at the anchor, to bring that ratio down, was tried and dropped: on a
    /// 10⁵-particle bar the top of the spectrum is a cluster of nearly equal eigenvalues, a
    /// converged Lanczos vector is a localised member of it whose quotient fell by 1 % in the
    /// next step, and every step then re-anchored.)
    ///
    /// `proven_above` is a shift whose certificate the caller already saw fail (so step 1 is
    /// skipped: `λmax ≥` it), and `factorisations` the caller's count.
    pub(super) fn anchor_at(
        &mut self,
        op: &NodalOperator,
        hint: Option<f64>,
        proven_above: Option<f64>,
        factorisations: usize,
    ) -> Result<CertifiedEstimate, StabilityError> {
        let (diag, off) = op.bands();
        let periodic = op.is_periodic();
        let margin = self.config.margin;
        let test = |mu: f64| below_shift(diag, off, periodic, mu);
        let lower = op.diagonal_max().map_or(0.0, |(_, d)| d);
        let mut bracket = Bracket::new(test, margin, lower);
        bracket.factorisations = factorisations;
        let mut hi = None;
        let mut applications = 0;
        // 1. The served quotient (its z is kept when it certifies).
        let mut vector_ritz = None;
        if let Some(known) = proven_above {
            bracket.lo = bracket.lo.max(known);
        } else if let Some(rho) = hint.filter(|&r| r >= bracket.lo && self.anchor.is_some()) {
            bracket.lo = bracket.lo.max(rho);
            hi = bracket.try_at(shift(rho, 1.0 + margin));
            if hi.is_some() {
                vector_ritz = Some(rho);
            }
        }
        // 2. A warm Lanczos update.
        if hi.is_none() {
            let est = self.tracker.update(op)?;
            applications += est.applications;
            let (rho, extra) = self.set_vector(op, est.lambda_b);
            vector_ritz = Some(rho);
            applications += extra;
            bracket.lo = bracket.lo.max(est.lambda_b);
            hi = bracket.try_at(shift(bracket.lo, 1.0 + margin));
        }
        // 3. Geometric growth of the shift.
        if hi.is_none() {
            hi = bracket.grow(bracket.lo, 1..=6);
        }
        // 4. A cold, tight Lanczos (a mode far above the warm one), then Gershgorin.
        if hi.is_none() {
            let tight = LanczosConfig {
                tol: 1e-8,
                value_tol: 0.0,
                restart_every: 0,
                max_iter: self.tracker.config().max_iter.max(200),
                ..self.tracker.config()
            };
            self.tracker.reset();
            let cold = self.tracker.update_with(op, tight)?;
            applications += cold.applications;
            tracing::debug!(
                lo = bracket.lo,
                cold = cold.lambda_b,
                "lambda_max certificate failed: cold Lanczos retried"
            );
            if cold.lambda_b > bracket.lo {
                let (rho, extra) = self.set_vector(op, cold.lambda_b);
                vector_ritz = Some(rho);
                applications += extra;
                bracket.lo = cold.lambda_b;
                hi = bracket.try_at(shift(bracket.lo, 1.0 + margin));
            }
        }
        let hi = match hi {
            Some(hi) => hi,
            None => {
                let g = op.gershgorin_bound() * (1.0 + 1e-12);
                if g > bracket.lo {
                    g
                } else {
                    2.0 * bracket.lo
                }
            }
        };
        // 5. Bisection down to the margin.
        let hi = bracket.bisect(hi, None);
        let (lo, factorisations) = (bracket.lo, bracket.factorisations);
        if !hi.is_finite() {
            return Err(StabilityError::InvalidField {
                field: "lambda_max",
                index: 0,
                value: hi,
            });
        }
        let rho = vector_ritz.unwrap_or(lo);
        tracing::debug!(rayleigh = rho, lower = lo, "lambda_max bracket narrowed");
        let scale = Scale {
            n_nodes: diag.len(),
            h: op.h(),
            c2_ref: op.c2_ref(),
        };
        Ok(self.anchored(scale, rho, hi, applications, factorisations))
    }

    /// Records the anchor of the mode with quotient `rho` certified below `hi` (the rounding
    /// slack added here) and returns its estimate.
    pub(super) fn anchored(
        &mut self,
        scale: Scale,
        rho: f64,
        hi: f64,
        applications: usize,
        factorisations: usize,
    ) -> CertifiedEstimate {
        let Scale { n_nodes, h, c2_ref } = scale;
        let upper = hi * (1.0 + rounding_slack(n_nodes));
        let margin = self.config.margin;
        let anchor = self.anchor.get_or_insert_with(Anchor::default);
        anchor.rayleigh = rho;
        anchor.last_rayleigh = rho;
        anchor.served = 0;
        anchor.ratio = if rho > 0.0 { upper / rho } else { 1.0 + margin };
        tracing::debug!(
            rayleigh = rho,
            upper,
            applications,
            factorisations,
            "lambda_max anchored"
        );
        CertifiedEstimate {
            estimate: estimate(h, c2_ref, upper, applications),
            rayleigh: rho,
            certified: true,
            factorisations,
        }
    }

    /// The tracked mode `z = M^{1/2} u` from the Lanczos tracker's vector `u` (Ritz value
    /// `theta`), tapered to a window around its largest component when that loses at most
    /// `margin / 10` of the quotient (`stability/localise.rs`: the served pass then skips the
    /// rest of the nodes from the first step). Returns the mode's quotient (`theta` without
    /// the window) and the applications of `C` this took (1 when a window was tried). The
    /// Lanczos tracker keeps `u` itself for its next warm start.
    fn set_vector(&mut self, op: &NodalOperator, theta: f64) -> (f64, usize) {
        let u = self.tracker.vector();
        let tried =
            self.config.localise && u.len() == op.dim() && localise::worth_trying(u.len(), theta);
        let windowed = if tried {
            localised(op, u, theta, self.config.margin / 10.0)
        } else {
            None
        };
        let (mode, rho) = match &windowed {
            Some((w, rho)) => (w.as_slice(), *rho),
            None => (u, theta),
        };
        let anchor = self.anchor.get_or_insert_with(Anchor::default);
        anchor.z.clear();
        anchor
            .z
            .extend(mode.iter().zip(op.scale()).map(|(u, s)| u * s));
        anchor.flush_below = FLUSH_RELATIVE * anchor.z.iter().fold(0.0_f64, |m, z| m.max(z.abs()));
        tracing::debug!(
            theta,
            rho,
            windowed = windowed.is_some(),
            "lambda_max: Lanczos mode set"
        );
        (rho, usize::from(tried))
    }
}
