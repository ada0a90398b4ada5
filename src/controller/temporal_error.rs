//! The temporal local error of the USL step (eqs 20–30) in 1D: the estimator
//! [`RateKernels`] of [`crate::temporal::TemporalError<1>`] ([`TemporalError`] is an
//! alias). What every dimension shares — the deferral, the judged-trial cache, the
//! metrics and verdict, the checkpoint state — is in [`crate::temporal::limit`]; the 1D
//! estimate, its two passes of SIMD kernels ([`super::temporal_kernels`]) and its history of
//! rates are here.
//!
//! Eqs 20, 23 and 28 split each local error into a spatial part and the forward-Euler
//! temporal part
//!
//! ```text
//! le_v,p ≈ dt²/2 · d²v_p/dt²        (eqs 20, 23)
//! le_σ,p ≈ dt²/2 · d²σ_p/dt²        (eq 28)
//! ```
//!
//! This limit estimates the second time derivatives from successive rates of the committed
//! and trial particle fields:
//!
//! * from the second step on, from the previous accepted step (`n−1 → n`, size `dt₋`;
//!   the last checked one when checks were deferred since, below) and the trial
//!   (`n → n+1`, size `dt`):
//!   `d²u/dt² ≈ 2 (r_n − r_{n−1}) / (dt + dt₋)` with `r_n = (u^{n+1} − u^n)/dt` for
//!   `u = v_p` (the particle acceleration of eq 22) and `u = σ_p` (the stress rate of
//!   eq 27);
//! * on the first step (no history) from the rates at both ends of the trial, read from the
//!   views' nodal fields: `a_p = Σ_i S_ip a_i` (eq 21) and `σ̇_p = E_t,p Σ_i D_ip v_i`
//!   (eqs 16, 24), giving `d²u/dt² ≈ (r(t^{n+1}) − r(t^n))/dt`.
//!
//! The errors are scaled SUNDIALS-style into one number
//!
//! ```text
//! dsm = sqrt( 1/(2N) Σ_p [ (le_v,p / w_v,p)² + (le_σ,p / w_σ,p)² ] )     (weighted RMS norm)
//! w_u,p = atol_u + atol_rel · s_u + rtol · max(|u_p^n|, |u_p^{n+1}|)
//! ```
//!
//! where `s_u` is the field's scale: the largest magnitude `‖u‖_∞` over the particles in
//! the committed and trial states, or the last checked step's while this one's has not grown
//! by more than 10 % (the rule of every dimension, [`crate::temporal::scales`]), in
//! *energy-equivalent* units — a vibrating body
//! swaps its energy between `v` and `σ`, so the velocity scale is at least
//! `max_p |σ_p|/(ρc)_p` and the stress scale at least `max_p (ρc)_p |v_p|`, with the
//! acoustic impedance `ρc = √(E_t ρ)`. Without this, a field that starts at zero (the stress
//! of a released standing wave) would be judged relative to its own `O(dt)` size. The
//! weight is never zero at a zero crossing of one particle. `dsm ≤ 1` accepts; the
//! controller's filter turns `dsm` into the next step.
//!
//! **Deferred checks** ([`crate::temporal::deferral`]): while `dsm` stays far below the tolerance
//! (≤ 0.1) the checks of the next trials are deferred (1, 2, 4, up to 8 trials), and the
//! next check's second derivative spans the deferred steps
//! (`span = (dt + dt₋)/2 + gap`). `max_deferred: 0` checks every trial.
//!
//! **The velocity lag** (opt-in, [`TemporalErrorConfig::lag`] = `κ_lag`): the USL step
//! kicks before it drifts (symplectic Euler), so `v_p` lags the synchronised velocity by
//! `dt/2 · a_p` ([`crate::synchronized_velocity`], its (S1)): a first-order error that
//! eqs 20, 23 and 28 do not contain. With the lag on, the velocity sum also holds
//! `(κ_lag dt/2 |a_p| / w_v,p)²`, `a_p = Σ_i S_ip a_i` of the trial state (eq 21, the next
//! kick's; gathered from the nodal field, so that a solver's staggered kick does not
//! change it). The 2D/3D estimator takes `a_p = (v_p^{n+1} − v_p^n)/dt` (eq 22) instead,
//! from the particle arrays it already reads.
//!
//! Interpretations, documented here because the paper leaves them open:
//! * Eq 26 (`F`) is not measured separately: for the elastic laws `σ` is a function of
//!   `F`, so its error is already in `le_σ`.
//! * Eq 30's `dt²/2 · d²x/dt²` term is not included: positions are weighted by the domain
//!   size, which makes this term irrelevant at any useful tolerance, and in a periodic
//!   domain `|x|` depends on where the origin is.
//! * What the estimate does not see is how local errors accumulate. Over many periods the
//!   USL step loses amplitude (its particle→grid→particle projections dissipate energy at
//!   a rate roughly proportional to dt) and drifts in phase (`(ω dt)³/24` per step); on the
//!   standing wave at the stability limit both are comparable to the spatial error after
//!   10⁴ steps while `dsm` stays at a few per cent of the default tolerance (see
//!   `tests/controller_standing_wave.rs`). The defaults are loose on purpose — a temporal
//!   error far below the spatial one buys nothing (Steffen, Kirby & Berzins 2010) — and
//!   `rtol` is the knob for long runs.

use super::config::ConfigError;
use super::temporal_kernels::{dispatch_rates, dispatch_sums, lag_sum, Fields, Terms};
use crate::dimension::Dim;
use crate::limit::LimitError;
use crate::stepper::View;
use crate::temporal::deferral::{Deferral, Scheduled};
use crate::temporal::limit::{Estimate, Shared, TemporalDim, TemporalEstimator};
use crate::temporal::scales::weight_scales;
use crate::temporal::TemporalErrorConfig;
pub use crate::temporal::TEMPORAL_ERROR;
use crate::weights::WeightKind;
use serde::{Deserialize, Serialize};

/// Rates of the last checked, accepted step, kept for the next estimate.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct History {
    dt: f64,
    accel: Vec<f64>,
    stress_rate: Vec<f64>,
    v_scale: f64,
    sigma_scale: f64,
    /// The deferral schedule after this step, and the time deferred since
    /// ([`crate::temporal::deferral`]).
    #[serde(default)]
    defer: Deferral,
}

impl Scheduled for History {
    fn schedule(&mut self) -> &mut Deferral {
        &mut self.defer
    }

    fn deferral(&self) -> Deferral {
        self.defer
    }

    fn step(&self) -> f64 {
        self.dt
    }
}

/// The 1D temporal-error limit, `TemporalError<1>`: an alias.
///
/// **Buffers.** The rates of a judged trial become the history when the trial is accepted,
/// and the history they replace is kept as `spare` and refilled by the next judgement, so
/// in a run the two per-particle rate arrays are allocated once, not on every step (at 10⁵
/// particles the freed arrays went back to the OS and were faulted in again each step).
pub type TemporalError = crate::temporal::TemporalError<1>;

impl crate::temporal::TemporalError<1> {
    /// A limit with the given tolerances (validated).
    pub fn new(config: TemporalErrorConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self::with_config(config))
    }
}

/// The 1D estimator of the temporal-error limit (module docs): the two passes of
/// `temporal_kernels` over the particle fields, the history of rates a `History` of
/// plain arrays. It keeps no memory of its own.
#[derive(Clone, Debug, Default)]
pub struct RateKernels;

impl TemporalDim for Dim<1> {
    type Estimator = RateKernels;
}

fn other(message: String) -> LimitError {
    LimitError::Other {
        limit: TEMPORAL_ERROR.to_string(),
        message,
    }
}

impl RateKernels {
    fn check_views(before: &View<'_>, after: &View<'_>) -> Result<(), LimitError> {
        let n = before.n_particles();
        if after.n_particles() != n
            || before.v.len() != n
            || after.v.len() != n
            || before.sigma.len() != n
            || after.sigma.len() != n
        {
            return Err(other(format!(
                "particle counts differ between committed ({n}) and trial ({}) states",
                after.n_particles()
            )));
        }
        Ok(())
    }

    /// Start-of-state rates from the nodal fields: `a_p = Σ S_ip a_i` (eq 21) and
    /// `σ̇_p = E_t,p Σ D_ip v_i` (eqs 16, 24).
    fn nodal_rates(view: &View<'_>) -> Result<(Vec<f64>, Vec<f64>), LimitError> {
        let n = view.n_particles();
        let nodes = view.weights.n_nodes();
        if view.weights.n_particles() != n
            || view.node_acceleration.len() != nodes
            || view.node_velocity.len() != nodes
            || view.tangent_modulus.len() != n
        {
            return Err(other(
                "view's weights, nodal fields and particle fields have inconsistent sizes"
                    .to_string(),
            ));
        }
        let mut accel = vec![0.0; n];
        view.weights
            .gather(WeightKind::S, view.node_acceleration, &mut accel);
        let mut grad = vec![0.0; n];
        view.weights
            .gather(WeightKind::D, view.node_velocity, &mut grad);
        let rate = grad
            .iter()
            .zip(view.tangent_modulus)
            .map(|(l, e)| e * l)
            .collect();
        Ok((accel, rate))
    }

    /// The trial state's particle accelerations `a_p = Σ_i S_ip a_i` at `xⁿ⁺¹` (eq 21):
    /// the next kick's, whose half step is the state's velocity lag. Read from the nodal
    /// field, not from `(vⁿ⁺¹ − vⁿ)/dt`, so that it does not depend on how the solver
    /// kicked (a staggered kick spans `(dt₋ + dt)/2`).
    fn next_kick(after: &View<'_>) -> Result<Vec<f64>, LimitError> {
        let n = after.n_particles();
        if after.weights.n_particles() != n
            || after.node_acceleration.len() != after.weights.n_nodes()
        {
            return Err(other("lag: inconsistent view sizes".to_string()));
        }
        let mut a = vec![0.0; n];
        after
            .weights
            .gather(WeightKind::S, after.node_acceleration, &mut a);
        Ok(a)
    }

    /// Spatial local errors of a step of size `dt` from `view`, per particle:
    /// `dt |Σ_i S_ip Ea_i|` (eqs 20, 23 with eq 33) and `|leσ_p|` (eq 44).
    fn spatial(view: &View<'_>, dt: f64) -> Result<(Vec<f64>, Vec<f64>), LimitError> {
        use crate::estimators::{
            local_stress::local_stress_error, stress_divergence_error, Recovery,
        };
        let err = |e: crate::estimators::EstimatorError| other(format!("balance: {e}"));
        let ea = stress_divergence_error(view).map_err(err)?;
        let mut ea_p = vec![0.0; view.n_particles()];
        if ea.len() != view.weights.n_nodes() || view.weights.n_particles() != ea_p.len() {
            return Err(other("balance: inconsistent view sizes".to_string()));
        }
        view.weights.gather(WeightKind::S, &ea, &mut ea_p);
        let sv = ea_p.iter().map(|e| dt * e.abs()).collect();
        let ss = local_stress_error(view, dt, Recovery::default())
            .map_err(err)?
            .into_iter()
            .map(f64::abs)
            .collect();
        Ok((sv, ss))
    }

    /// Computes `(dsm, dsm_v, dsm_sigma)` of a trial and writes the rates to remember into
    /// `out` (its arrays are overwritten, their old contents unused).
    ///
    /// Two passes over the particles ([`super::temporal_kernels`]), with the arithmetic of
    /// the plain per-quantity loops: the first computes the rates and every scale (maxima,
    /// which do not depend on the order; `f64::max` ignores NaN in any order), the second
    /// the weights and the two sums, in particle order. The second derivatives are formed
    /// on the fly, not stored. The scales are `‖v‖_∞ = max(max_p v̂_p, √(max_p σ̂_p²/z_p²))`
    /// and `‖σ‖_∞ = max(max_p σ̂_p, √(max_p v̂_p² z_p²))` (√ is monotone: one square root
    /// per step instead of one per particle; equal to the per-particle forms to within an
    /// ulp, and the scales only set tolerances).
    fn estimate_into(
        shared: Shared<'_, History>,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
        out: &mut History,
    ) -> Result<Estimate, LimitError> {
        Self::check_views(before, after)?;
        let n = before.n_particles();
        let (v0, v1) = (&before.v[..n], &after.v[..n]);
        let (s0, s1) = (&before.sigma[..n], &after.sigma[..n]);
        let (et, rho) = (before.tangent_modulus, before.density);
        out.accel.resize(n, 0.0);
        out.stress_rate.resize(n, 0.0);
        let nz = n.min(et.len()).min(rho.len());
        // Pass 1: rates r = (u^{n+1} − u^n)/dt and the scales (`temporal_kernels::rates_and_scales`).
        let sc = dispatch_rates(
            Fields {
                v0,
                v1,
                s0,
                s1,
                et: &et[..nz],
                rho: &rho[..nz],
            },
            1.0 / dt,
            &mut out.accel[..n],
            &mut out.stress_rate[..n],
        );
        let v_scale = sc.v.max(sc.v_from_s2.sqrt());
        let sigma_scale = sc.sigma.max(sc.s_from_v2.sqrt());
        let (accel, stress_rate) = (&out.accel[..n], &out.stress_rate[..n]);
        let nodal; // Second time derivatives d²u/dt² = (x_p − y_p)/span.
        let (xv, yv, xs, ys, span): (&[f64], &[f64], &[f64], &[f64], f64) = match shared.history {
            Some(h) if h.accel.len() == n && h.stress_rate.len() == n => (
                accel,
                &h.accel,
                stress_rate,
                &h.stress_rate,
                // The rates sit at the midpoints of their steps, `gap` apart.
                0.5 * (dt + h.dt) + h.defer.gap,
            ),
            _ => {
                nodal = (Self::nodal_rates(before)?, Self::nodal_rates(after)?);
                let ((a0, r0), (a1, r1)) = &nodal;
                (a1, a0, r1, r0, dt)
            }
        };
        // The weights' field scales: the rule of every dimension (`crate::temporal::scales`).
        let prev = shared.history.map(|h| (h.v_scale, h.sigma_scale));
        let (weight_v, weight_s) = weight_scales((v_scale, sigma_scale), prev);
        let c = shared.config;
        let spatial = match c.balance {
            Some(kappa) => {
                let (mut sv, mut ss) = Self::spatial(before, dt)?;
                sv.iter_mut().for_each(|e| *e *= kappa);
                ss.iter_mut().for_each(|e| *e *= kappa);
                Some((sv, ss))
            }
            None => None,
        };
        // Pass 2: the weighted sums of the local errors dt²/2 · d²u/dt² (`temporal_kernels::sums`),
        // then the velocity lag κ_lag·dt/2·|a_p| (`TemporalErrorConfig::lag`) when it is on.
        let terms = Terms {
            xv,
            yv,
            xs,
            ys,
            v0,
            v1,
            s0,
            s1,
            spatial: spatial.as_ref().map(|(sv, ss)| (&sv[..], &ss[..])),
            c_span: 0.5 * dt * dt / span,
            atol_v: c.atol_v,
            atol_sigma: c.atol_sigma,
            abs_v: c.atol_rel() * weight_v,
            abs_s: c.atol_rel() * weight_s,
            rtol: c.rtol,
        };
        let (mut sum_v, sum_s) = dispatch_sums(&terms, n);
        if let Some(kappa) = c.lag {
            sum_v += lag_sum(&terms, &Self::next_kick(after)?, kappa * 0.5 * dt, n);
        }
        let nf = n.max(1) as f64;
        let dsm = ((sum_v + sum_s) / (2.0 * nf)).sqrt();
        let dsm_v = (sum_v / nf).sqrt();
        let dsm_s = (sum_s / nf).sqrt();
        out.dt = dt;
        out.v_scale = v_scale;
        out.sigma_scale = sigma_scale;
        Ok(Estimate {
            dsm,
            dsm_v,
            dsm_sigma: dsm_s,
            count: None,
            v_scale,
            sigma_scale,
        })
    }
}

impl TemporalEstimator<Dim<1>> for RateKernels {
    type History = History;

    const INCONSISTENT: &'static str =
        "cannot restore state: rates, step, gap and schedule do not belong together";

    /// The 1D steppers hand over every array: the trait's default.
    const ON_DEMAND: bool = false;

    fn deferrable(history: &History, before: &View<'_>, after: &View<'_>) -> bool {
        let n = after.n_particles();
        history.accel.len() == n && before.n_particles() == n
    }

    /// Always: the judged trial's rates become the history when it is accepted.
    fn keeps_rates(_before: &View<'_>, _after: &View<'_>) -> bool {
        true
    }

    fn estimate(
        &mut self,
        shared: Shared<'_, History>,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
        out: Option<&mut History>,
    ) -> Result<Estimate, LimitError> {
        let mut own = History::default();
        Self::estimate_into(shared, before, after, dt, out.unwrap_or(&mut own))
    }

    /// The first pass of `temporal_kernels` alone (the limit keeps every judged
    /// trial's rates, so this is not called in a run).
    fn rates_into(
        _pool: Option<&rayon::ThreadPool>,
        before: &View<'_>,
        after: &View<'_>,
        dt: f64,
        e: &Estimate,
        out: &mut History,
    ) {
        let n = before.n_particles().min(after.n_particles());
        let n = n.min(before.v.len()).min(after.v.len());
        let n = n.min(before.sigma.len()).min(after.sigma.len());
        let (et, rho) = (before.tangent_modulus, before.density);
        let nz = n.min(et.len()).min(rho.len());
        out.accel.resize(n, 0.0);
        out.stress_rate.resize(n, 0.0);
        dispatch_rates(
            Fields {
                v0: &before.v[..n],
                v1: &after.v[..n],
                s0: &before.sigma[..n],
                s1: &after.sigma[..n],
                et: &et[..nz],
                rho: &rho[..nz],
            },
            1.0 / dt,
            &mut out.accel[..n],
            &mut out.stress_rate[..n],
        );
        out.dt = dt;
        out.v_scale = e.v_scale;
        out.sigma_scale = e.sigma_scale;
    }

    fn consistent(h: &History) -> bool {
        h.accel.len() == h.stress_rate.len()
            && h.dt.is_finite()
            && h.dt > 0.0
            && h.defer.consistent()
    }

    /// None: the 1D limit has never counted its arrays (its [`StepLimit::memory_bytes`] is
    /// 0, as before the limits were unified).
    ///
    /// [`StepLimit::memory_bytes`]: crate::limit::StepLimit::memory_bytes
    fn history_bytes(_history: &History) -> usize {
        0
    }
}
