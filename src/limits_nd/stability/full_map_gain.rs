//! The stability limit on the whole linearised FLIP step
//! ([`super::StabilityNdConfig::full_map`]).
//!
//! Eq 56 analyses the stress part of the step, `I − dt² M⁻¹K` on the nodal velocities. The
//! whole frozen-particle step also carries the particle velocity update `v_p' = v_p +
//! dt Σ_i S_ip a_i`, which feeds the next step's nodal velocity through the consistent
//! mass `Q = Sᵀ diag(m_p) S`; its critical step is `√(2/λ*)`, `λ* = λmax(A_s(I − Q_s/2))`
//! ([`crate::stability::nodal_full_map`]), between eq 56's and `√2` times it, and equal to
//! the empirical blow-up step of real runs within 0.25 % on the scenarios where that was
//! measured (docs/design.md, "The full map from the nodes").
//!
//! At a refresh the limit has eq 56's Lanczos value `θ` and Ritz vector; a second Lanczos
//! run, in the `I − Q_s/2` inner product and warm-started from that vector, gives the
//! Ritz value `θ*` of `A_s(I − Q_s/2)`, and the limit keeps `gain = θ/θ*` (clamped to
//! `[0.5, 2]`: `λ*` lies in `[λmax/2, λmax]`). The proposal `safety·√(2·gain/λ)` is then
//! `safety·√(2/(θ*(1 + tol)·margin))` at the refresh, and between refreshes `λ` is tracked
//! as before (the calibrated bound, the moduli's growth) with the gain held. `θ*` is a
//! Ritz value, a lower bound on `λ*` that its `(1 + tol)` covers as for eq 56's value.
//!
//! Products: each iteration of the second run is one product with `K` and one with `Q`
//! (about as costly: both form every particle's weight row). `lanczos_applications`
//! counts the `K` products of both runs.

use super::StabilityNd;
use crate::limits_nd::nodal_full_map::NodalPencilNd;
use crate::limits_nd::stiffness::LanczosResult;
use crate::nd::ViewNd;
use crate::stability::nodal_full_map::{nodal_critical_dt_from, NodalLanczos};

impl<const D: usize> StabilityNd<D> {
    /// `gain = θ/θ*` of the state `view` at a refresh whose eq 56 Lanczos gave `r` (module
    /// docs); 1 (eq 56) on a decomposed grid or when the second run finds no value.
    pub(super) fn full_map_gain(&mut self, view: &ViewNd<'_, D>, r: &LanczosResult) -> f64 {
        if view.split.is_some() {
            return 1.0;
        }
        let settings = NodalLanczos {
            tol: self.config.tol,
            settle: 0.1 * self.config.tol,
            max_iter: self.config.max_iter,
        };
        let pencil = NodalPencilNd::new(view);
        match nodal_critical_dt_from(&pencil, Some(&r.vector), settings) {
            Some(c) if c.lambda > 0.0 && r.lambda > 0.0 => {
                self.applications += c.products as u64;
                (r.lambda / c.lambda).clamp(0.5, 2.0)
            }
            _ => 1.0,
        }
    }
}
