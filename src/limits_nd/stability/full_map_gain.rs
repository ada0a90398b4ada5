//! The stability limit on the whole linearised FLIP step
//! ([`super::StabilityNdConfig::full_map`]).
//!
//! Eq 56 analyses the stress part of the step, `I − dt² M⁻¹K` on the nodal velocities. The
//! whole frozen-particle step also carries the particle velocity update `v_p' = v_p +
//! dt Σ_i S_ip a_i`, which feeds the next step's nodal velocity through the consistent
//! mass `Q = Sᵀ diag(m_p) S`; its critical step is `√(2/λ*)`, `λ* = λmax(A_s(I − Q_s/2))`
//! ([`crate::stability::nodal_full_map`]), between eq 56's and `√2` times it, and equal to
//! the empirical blow-up step of real runs within 0.23 % below it on the scenarios where
//! that was measured, except a light node's 2D layout (0.57 % above; docs/design.md, "The
//! full map from the nodes").
//!
//! At a refresh the limit has eq 56's Lanczos value `θ` and Ritz vector; a second Lanczos
//! run, in the `I − Q_s/2` inner product and warm-started from that vector, gives the
//! Ritz value `θ*` of `A_s(I − Q_s/2)`, and the limit keeps `gain = θ/θ*` (at most 2:
//! `λ*` ≥ `λmax/2`; below 1 where the second run found a mode above eq 56's Ritz value,
//! which then shortens the step). The proposal `safety·√(2·gain/λ)` is then
//! `safety·√(2/(θ*(1 + tol)·margin))` at the refresh. `θ*` is a Ritz value, a lower bound
//! on `λ*` that its `(1 + tol)` covers as for eq 56's value; a second run that does not
//! converge within `max_iter` leaves the gain at 1 (eq 56).
//!
//! **Between refreshes** the tracked `λ` is scaled as before (the calibrated bound's rise,
//! the moduli's growth, the light-node diagonal) with the gain held — an interpretation,
//! as for the APIC gain: a new top mode with a smaller ratio (a light node, whose
//! consistent mass is small, has a ratio near 1) is stepped on with the old gain until the
//! next refresh, and the growth monitor is the net. Proposals on the raw element bound
//! (bound mode) do not take the gain: `B ≥ λmax` certifies eq 56's step, not the full
//! map's.
//!
//! Products: each iteration of the second run is one product with `K` and one with `Q`
//! (about as costly: both form every particle's weight row). `lanczos_applications`
//! counts the `K` products of both runs.

use super::GuardedEq56;
use crate::limits_nd::nodal_full_map::NodalPencilNd;
use crate::limits_nd::stiffness::LanczosResult;
use crate::nd::ViewNd;
use crate::stability::nodal_full_map::{nodal_critical_dt_from, NodalLanczos};

impl<const D: usize> GuardedEq56<D> {
    /// `gain = θ/θ*` of the state `view` at a refresh whose eq 56 Lanczos gave `r` (module
    /// docs); 1 (eq 56) on a run over several processes or when the second run finds no converged
    /// value. Also the second run's cost in eq 56's products (each iteration about two),
    /// for the bound's cost model ([`crate::limits_nd::bound_tracking`]).
    pub(super) fn full_map_gain(&mut self, view: &ViewNd<'_, D>, r: &LanczosResult) -> (f64, u64) {
        // The reduction's products are one process's: on a run over several processes
        // (a decomposed grid, or particles split over a shared grid) eq 56 stays.
        if view.split.is_some() || self.reduce.size() > 1 {
            return (1.0, 0);
        }
        let settings = NodalLanczos {
            tol: self.config.tol,
            settle: 0.1 * self.config.tol,
            max_iter: self.config.max_iter,
        };
        let pencil = NodalPencilNd::new(view);
        match nodal_critical_dt_from(&pencil, Some(&r.vector), settings) {
            Some(c) => {
                self.tracked.applications += c.products as u64;
                let gain = match c.converged && c.lambda > 0.0 && r.lambda > 0.0 {
                    true => (r.lambda / c.lambda).min(2.0),
                    false => 1.0,
                };
                (gain, 2 * c.products as u64)
            }
            None => (1.0, 0),
        }
    }

    /// The gain a proposal takes: the held one, except that a proposal on the raw element
    /// bound takes at most 1 under the full map (the bound certifies eq 56's step, not the
    /// full map's; module docs). The APIC gain is taken on the bound as before.
    pub(super) fn proposal_gain(&self, on_bound: bool) -> f64 {
        match on_bound && self.config.full_map {
            true => self.tracked.gain.min(1.0),
            false => self.tracked.gain,
        }
    }
}
