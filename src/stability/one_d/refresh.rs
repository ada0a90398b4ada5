//! When the [`super::Stability`] limit's [`super::Tracking::Lanczos`] mode re-runs its
//! Lanczos update: [`Refresh`] thresholds and the state they are measured from (module docs
//! of [`super`], "When λmax is recomputed").

use crate::stability::error::StabilityError;
use crate::stepper::View;

/// When the [`super::Stability`] limit re-runs its Lanczos update in [`super::Tracking::Lanczos`] mode
/// (module docs of [`super`]). An update happens when any threshold is crossed; the default updates at
/// every proposal.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Refresh {
    /// Most proposals served from one update (default 1: update every step; 10 in
    /// [`Refresh::cached`]).
    pub max_steps: u32,
    /// Largest particle displacement since the update, in cells (default 0.05).
    pub max_displacement: f64,
    /// Largest relative change of an active nodal mass since the update (default 0.05).
    pub max_mass_change: f64,
    /// Largest relative change of a particle's `E_t V` since the update (default 0.05).
    pub max_modulus_change: f64,
}

impl Default for Refresh {
    fn default() -> Self {
        Self::every_step()
    }
}

impl Refresh {
    /// Recompute at every proposal (the default).
    pub fn every_step() -> Self {
        Self {
            max_steps: 1,
            ..Self::cached()
        }
    }

    /// The opt-in cached mode: update after 10 proposals, a displacement of 0.05 cells, or a
    /// 5 % change of a nodal mass or of a particle's `E_t V` (see the module docs of [`super`] for its
    /// known failure on collapsing linear-hat layouts).
    pub fn cached() -> Self {
        Self {
            max_steps: 10,
            max_displacement: 0.05,
            max_mass_change: 0.05,
            max_modulus_change: 0.05,
        }
    }

    pub(super) fn validate(&self) -> Result<(), StabilityError> {
        let checks = [
            ("refresh.max_displacement", self.max_displacement),
            ("refresh.max_mass_change", self.max_mass_change),
            ("refresh.max_modulus_change", self.max_modulus_change),
        ];
        for (field, value) in checks {
            if !(value.is_finite() && value >= 0.0) {
                return Err(StabilityError::InvalidConfig {
                    field,
                    value,
                    reason: "must be non-negative and finite",
                });
            }
        }
        if self.max_steps == 0 {
            return Err(StabilityError::InvalidConfig {
                field: "refresh.max_steps",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        Ok(())
    }
}

/// The state at the last λmax update, against which drift is measured.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct RefreshReference {
    x: Vec<f64>,
    modulus_volume: Vec<f64>,
    node_mass: Vec<f64>,
    node_active: Vec<bool>,
    pub(super) proposals: u32,
}

impl RefreshReference {
    pub(super) fn of(state: &View<'_>) -> Self {
        Self {
            x: state.x.to_vec(),
            modulus_volume: modulus_volume(state).collect(),
            node_mass: state.node_mass.to_vec(),
            node_active: state.node_active.to_vec(),
            proposals: 0,
        }
    }

    /// Whether `state` has drifted past a threshold of `r`.
    pub(super) fn stale(&self, state: &View<'_>, r: &Refresh) -> bool {
        if self.proposals >= r.max_steps
            || self.x.len() != state.x.len()
            || self.node_mass.len() != state.node_mass.len()
            || self.node_active != state.node_active
        {
            return true;
        }
        let nodes_drifted = self
            .node_mass
            .iter()
            .zip(state.node_mass)
            .zip(state.node_active)
            .any(|((&m0, &m), &a)| a && (m - m0).abs() > r.max_mass_change * m0);
        if nodes_drifted {
            return true;
        }
        let grid = state.grid;
        let reach = r.max_displacement * grid.h;
        let moved = self.x.iter().zip(state.x).any(|(&x0, &x)| {
            // Minimum-image displacement on periodic grids.
            grid.offset(0, x - x0 + grid.node_x(0)).abs() > reach
        });
        moved
            || self
                .modulus_volume
                .iter()
                .zip(modulus_volume(state))
                .any(|(&k0, k)| (k - k0).abs() > r.max_modulus_change * k0.abs())
    }
}

/// The per-particle weights `E_t,p F_p V⁰_p` of the operator `B`.
fn modulus_volume<'a>(state: &'a View<'_>) -> impl Iterator<Item = f64> + 'a {
    state
        .tangent_modulus
        .iter()
        .zip(state.f)
        .zip(state.volume0)
        .map(|((&e, &f), &v0)| e * f * v0)
}
