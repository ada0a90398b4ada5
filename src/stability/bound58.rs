//! The eq 58 "lower bound" on the norm of the amplification matrix, from the eq 33 estimate.
//!
//! ```text
//! Ea_i ≈ (−1/m̃_i) Σ_p D_ip [ (x_p−X_i)²/2 σ''(X_i) + (x_p−X_i)³/6 σ'''(X_i) ]      (eq 33)
//! E dt²/h² D*F Δσ = dt² E Σ_i D_ip Ea_i                                             (eq 57)
//! ‖I − E dt²/h² D*F‖ ≥ |Δσ − dt² E Σ_i D_ip Ea_i| / |Δσ|                             (eq 58)
//! ```
//!
//! with `Δσ` "the term in [...] of eq 33". The bracket is the Taylor remainder of the stress
//! at particle `p` about node `i`: it depends on the pair `(p, i)`, so "the vector `Δσ`" needs
//! a reading. Both readings implemented here share these choices:
//!
//! * nodal stress `σ_i = Σ_p S_ip m_p σ_p / m_i` (the eq 17 projection) at nodes with mass;
//!   `σ''(X_i)` by eq 42, `σ'''(X_i)` by the central difference
//!   `(σ_{i+2} − 2σ_{i+1} + 2σ_{i−1} − σ_{i−2})/(2h³)` (eq 43 as printed is not a difference
//!   formula); both are 0 where the 5-point stencil leaves the massive nodes (no estimate);
//! * the volume `V_p = F_p V_p⁰` of eq 18 weights each term, and `Ea_i` carries the sign of
//!   eq 20, `Ea = a_true − a_computed = +(1/m_i) Σ_p D_ip V_p [...]` (eq 33 as printed has the
//!   opposite sign, computed − true; with it eq 58's numerator would be `(I + …)Δσ`, not `AΔσ`);
//! * `Δσ_p` is the bracket of particle `p` about its **nearest** node.
//!
//! The readings differ in `Ea`:
//!
//! * [`Bound58Reading::Paper`]: `Ea_i` by eq 33 with every particle's bracket about node `i`.
//!   Eq 57 then holds only approximately and the ratio is **not** a lower bound in general
//!   (it exceeds `‖A‖₂` on jittered layouts; tested).
//! * [`Bound58Reading::Consistent`]: `Ea_i = (1/m_i) Σ_q D_iq V_q Δσ_q`, i.e. eq 33 applied to
//!   the vector `Δσ`, so that eq 57 holds exactly and the numerator is `‖AΔσ‖`. Then the ratio
//!   is a true lower bound: `≤ ‖A‖₂` in the Euclidean norm and `≤ ρ(A)` in the strain-energy
//!   norm `‖δσ‖_W = (Σ V_p δσ_p²/E_p)^{1/2}`, in which `A` is normal. But it stays near 1
//!   while `‖A‖` grows: `Δσ` is smooth (a Taylor remainder of a smooth field) and the
//!   unstable mode is the checkerboard, so `AΔσ ≈ Δσ − O(dt² h² …)`.
//!
//! Both norms are reported: `value` in the Euclidean 2-norm over particles (compare with the
//! spectral norm `‖A‖₂`), `value_energy` in the strain-energy norm (compare with `ρ(A)`).

use super::error::{check_dt, check_view, StabilityError};
use crate::grid::Boundary;
use crate::stepper::View;
use crate::weights::WeightKind;

/// Which reading of eqs 57–58 (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Bound58Reading {
    /// `Ea_i` by eq 33 (all brackets about node `i`); not a lower bound in general.
    Paper,
    /// `Ea_i` from the vector `Δσ` so that eq 57 holds exactly; a true lower bound.
    Consistent,
}

/// The eq 58 ratio in two norms.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Bound58 {
    /// `‖Δσ − dt² E Dᵀ Ea‖₂ / ‖Δσ‖₂` (Euclidean norm over particles).
    pub value: f64,
    /// The same ratio in the strain-energy norm `(Σ V_p x_p²/E_p)^{1/2}`.
    pub value_energy: f64,
    /// `‖Δσ‖₂`, the size of the estimate (0 means no information).
    pub delta_sigma_norm: f64,
}

/// The eq 58 ratio of state `view` at step `dt`. `Ok(None)` when `Δσ = 0` (e.g. a stress
/// field that is zero or linear): the ratio carries no information then.
pub fn bound58(
    view: &View<'_>,
    dt: f64,
    reading: Bound58Reading,
) -> Result<Option<Bound58>, StabilityError> {
    check_view(view)?;
    check_dt(dt)?;
    let has_mass: Vec<bool> = view.node_mass.iter().map(|&m| m > 0.0).collect();
    let sig = nodal_stress(view, &has_mass);
    let taylor = Taylor::new(view, &sig, &has_mass);
    let delta = taylor.delta_sigma(view);
    let volume: Vec<f64> = view
        .f
        .iter()
        .zip(view.volume0)
        .map(|(f, v)| f * v)
        .collect();
    let ea = error_acceleration(view, reading, &taylor, &delta, &volume);
    let num = numerator(view, dt, &delta, &ea);
    Ok(ratios(view, &volume, &delta, &num))
}

/// Nodal stress by the eq 17 projection, `σ_i = Σ_p S_ip m_p σ_p / m_i`, at nodes with mass
/// (0 elsewhere).
fn nodal_stress(view: &View<'_>, has_mass: &[bool]) -> Vec<f64> {
    let nn = view.grid.n_nodes();
    let ms: Vec<f64> = view
        .mass
        .iter()
        .zip(view.sigma)
        .map(|(m, s)| m * s)
        .collect();
    let mut sig = vec![0.0; nn];
    view.weights.scatter(WeightKind::S, &ms, &mut sig);
    for i in 0..nn {
        sig[i] = if has_mass[i] {
            sig[i] / view.node_mass[i]
        } else {
            0.0
        };
    }
    sig
}

/// The nodal derivatives in the eq 33 Taylor bracket: `σ''(X_i)` (eq 42) and `σ'''(X_i)`
/// (central difference), 0 where the 5-point stencil leaves the massive nodes.
struct Taylor {
    d2: Vec<f64>,
    d3: Vec<f64>,
}

impl Taylor {
    /// `σ''_i = (σ_{i+1} − 2σ_i + σ_{i−1})/h²` (eq 42) and
    /// `σ'''_i = (σ_{i+2} − 2σ_{i+1} + 2σ_{i−1} − σ_{i−2})/(2h³)` from the nodal stress `sig`.
    fn new(view: &View<'_>, sig: &[f64], has_mass: &[bool]) -> Self {
        let grid = view.grid;
        let nn = grid.n_nodes();
        let h = grid.h;
        let neighbour = |i: usize, k: i64| -> Option<usize> {
            let j = i as i64 + k;
            match grid.boundary {
                Boundary::Periodic => Some(j.rem_euclid(nn as i64) as usize),
                Boundary::Fixed => (j >= 0 && (j as usize) < nn).then_some(j as usize),
            }
            .filter(|&j| has_mass[j])
        };
        let mut d2 = vec![0.0; nn];
        let mut d3 = vec![0.0; nn];
        for i in 0..nn {
            if !has_mass[i] {
                continue;
            }
            // The five-node stencil, all with mass (an array: this loop used to allocate a
            // vector per node, measured in the controller's profile).
            let mut st = [0usize; 5];
            let mut complete = true;
            for (slot, k) in st.iter_mut().zip(-2..=2) {
                match neighbour(i, k) {
                    Some(j) => *slot = j,
                    None => complete = false,
                }
            }
            if complete {
                let s = |k: usize| sig[st[k]];
                d2[i] = (s(3) - 2.0 * s(2) + s(1)) / (h * h);
                d3[i] = (s(4) - 2.0 * s(3) + 2.0 * s(1) - s(0)) / (2.0 * h * h * h);
            }
        }
        Taylor { d2, d3 }
    }

    /// The eq 33 bracket of particle `p` about node `i`:
    /// `(x_p−X_i)²/2 σ''(X_i) + (x_p−X_i)³/6 σ'''(X_i)`.
    fn bracket(&self, view: &View<'_>, p: usize, i: usize) -> f64 {
        let r = -view.grid.offset(i, view.x[p]); // x_p − X_i
        r * r / 2.0 * self.d2[i] + r * r * r / 6.0 * self.d3[i]
    }

    /// `Δσ_p`: the bracket of each particle about its nearest stencil node (0 without one).
    fn delta_sigma(&self, view: &View<'_>) -> Vec<f64> {
        let grid = view.grid;
        let w = view.weights;
        (0..view.n_particles())
            .map(|p| {
                let nearest = w
                    .nodes_of(p)
                    .iter()
                    .zip(w.s_of(p))
                    .filter(|(_, &s)| s != 0.0)
                    .map(|(&i, _)| i as usize)
                    .min_by(|&a, &b| {
                        grid.offset(a, view.x[p])
                            .abs()
                            .total_cmp(&grid.offset(b, view.x[p]).abs())
                    });
                nearest.map_or(0.0, |i| self.bracket(view, p, i))
            })
            .collect()
    }
}

/// `Ea_i = (1/m_i) Σ_p D_ip V_p b_ip` at active nodes, 0 elsewhere (eq 33 with the sign of
/// eq 20, true − computed), `b_ip` the bracket about node `i` ([`Bound58Reading::Paper`]) or
/// `Δσ_p` ([`Bound58Reading::Consistent`]).
fn error_acceleration(
    view: &View<'_>,
    reading: Bound58Reading,
    taylor: &Taylor,
    delta: &[f64],
    volume: &[f64],
) -> Vec<f64> {
    let w = view.weights;
    let mut ea = vec![0.0; view.grid.n_nodes()];
    for p in 0..view.n_particles() {
        for (&i, &d) in w.nodes_of(p).iter().zip(w.d_of(p)) {
            let i = i as usize;
            let b = match reading {
                Bound58Reading::Paper => taylor.bracket(view, p, i),
                Bound58Reading::Consistent => delta[p],
            };
            ea[i] += d * volume[p] * b;
        }
    }
    for ((e, &active), &m) in ea.iter_mut().zip(view.node_active).zip(view.node_mass) {
        *e = if active { *e / m } else { 0.0 };
    }
    ea
}

/// The eq 58 numerator per particle, `Δσ_p − dt² E_p Σ_i D_ip Ea_i` (eq 57).
fn numerator(view: &View<'_>, dt: f64, delta: &[f64], ea: &[f64]) -> Vec<f64> {
    let n = view.n_particles();
    let mut dea = vec![0.0; n];
    view.weights.gather(WeightKind::D, ea, &mut dea);
    (0..n)
        .map(|p| delta[p] - dt * dt * view.tangent_modulus[p] * dea[p])
        .collect()
}

/// The eq 58 ratios `‖num‖/‖Δσ‖` in the Euclidean norm and in the strain-energy norm
/// `(Σ V_p x_p²/E_p)^{1/2}`; `None` when `‖Δσ‖₂` is 0 or not finite.
fn ratios(view: &View<'_>, volume: &[f64], delta: &[f64], num: &[f64]) -> Option<Bound58> {
    let norm2 = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>().sqrt();
    let norm_w = |x: &[f64]| {
        x.iter()
            .enumerate()
            .map(|(p, v)| volume[p] * v * v / view.tangent_modulus[p])
            .sum::<f64>()
            .sqrt()
    };
    let dn = norm2(delta);
    if dn == 0.0 || !dn.is_finite() {
        return None;
    }
    Some(Bound58 {
        value: norm2(num) / dn,
        value_energy: norm_w(num) / norm_w(delta),
        delta_sigma_norm: dn,
    })
}
