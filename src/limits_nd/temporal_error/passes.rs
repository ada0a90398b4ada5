//! The phases of the estimate of [`RateSweeps`]: the trial's particles paired with the
//! committed ones, and the sweeps over them with the weights of the field scales (the
//! parent module's docs, "One pass").

use super::{other, RateSweeps};
use crate::limit::LimitError;
use crate::limits_nd::temporal_sweep::{sweep, History, Pairing, Sweep, Weights};
use crate::nd::{Vector, ViewNd};
use crate::temporal::limit::{Estimate, Shared};
use crate::temporal::scales::weight_scales;
use crate::temporal::TemporalErrorConfig;

/// The sums of an estimate's last sweep, with what its first sweep found: whether every
/// rate was finite, and the trial's field scales `‖v‖_∞`, `‖σ‖_∞`.
pub(super) struct Passes {
    sweep: Sweep,
    finite: bool,
    pub v_scale: f64,
    pub sigma_scale: f64,
}

/// The trial's run-wide ids and, where particles changed process, the ids to match by.
type Partners<'a> = (Option<&'a [u64]>, Option<&'a [u64]>);

impl<const D: usize> RateSweeps<D> {
    /// The trial's run-wide ids (`split`) and, where particles changed process, the same
    /// ids as `moved`, to be matched through `slot_before` (filled here).
    pub(super) fn partners<'a>(
        &mut self,
        before: &ViewNd<'_, D>,
        after: &ViewNd<'a, D>,
    ) -> Result<Partners<'a>, LimitError> {
        let n = after.n_particles();
        match (before.split, after.split) {
            (Some(b), Some(a)) if a.particle_id == b.particle_id => Ok((Some(a.particle_id), None)),
            (Some(b), Some(a)) => {
                let total = b.n_particles_total.max(a.n_particles_total);
                Self::index_ids(&mut self.slot_before, b.particle_id, total)?;
                Ok((Some(a.particle_id), Some(a.particle_id)))
            }
            (None, None) if before.n_particles() == n => Ok((None, None)),
            _ => Err(other(format!(
                "committed ({}) and trial ({n}) particles cannot be matched",
                before.n_particles()
            ))),
        }
    }

    /// The history when it describes the committed particles: consistent, as many, and
    /// with run-wide ids exactly when `before` is grid-decomposed.
    pub(super) fn usable_history<'h>(
        history: Option<&'h History<D>>,
        before: &ViewNd<'_, D>,
    ) -> Option<&'h History<D>> {
        let before_ids = before.split.map(|b| b.particle_id);
        let n_before = before.n_particles();
        history.filter(|h| {
            h.consistent()
                && h.accel.len() == n_before
                && match before_ids {
                    None => h.ids.is_empty(),
                    Some(_) => !h.ids.is_empty(),
                }
        })
    }

    /// Sizes `out` for the `n` trial particles, with their run-wide ids `split`.
    pub(super) fn prepare(out: &mut History<D>, n: usize, split: Option<&[u64]>) {
        out.accel.resize(n, Vector::<D>::zeros());
        out.stress_rate.reset(n);
        out.ids.clear();
        if let Some(ids) = split {
            out.ids.extend_from_slice(ids);
        }
    }

    /// The weights `w_u = atol_u + atol_rel · s_u + rtol · û_p` for the field scales
    /// `(s_v, s_σ) = (sv, ss)`.
    fn weights(c: &TemporalErrorConfig, sv: f64, ss: f64, dt: f64) -> Option<Weights> {
        Some(Weights {
            lag: c.lag.map_or(0.0, |k| k * 0.5 * dt),
            rtol: c.rtol,
            abs: (
                c.atol_v + c.atol_rel() * sv,
                c.atol_sigma + c.atol_rel() * ss,
            ),
        })
    }

    /// The sweeps of an estimate: the first with the previous step's scales (writing the
    /// rates into `out`), a second with the scales of [`weight_scales`] when a scale grew
    /// by more than its slack.
    pub(super) fn passes(
        shared: &Shared<'_, History<D>>,
        before: &ViewNd<'_, D>,
        after: &ViewNd<'_, D>,
        dt: f64,
        pair: &Pairing<'_, D>,
        out: Option<&mut History<D>>,
    ) -> Passes {
        // The weights need this trial's field scales, known only after a pass: the first
        // sweep uses the previous step's, and a second sweep, writing nothing, redoes the
        // sums with `max(new, previous)` only when a scale grew by more than the slack of
        // `crate::temporal::scales` (a run gaining energy).
        let pool = shared.pool;
        let (prev_v, prev_s) = match shared.history {
            Some(h) => (h.v_scale, h.sigma_scale),
            // No previous scales (the first step, or a history lost): the scales from a
            // pass over the fields alone, so that the sums are taken once, with this
            // step's own scales, as a second sweep would take them.
            None => field_scales(sweep(pool, before, after, dt, pair, None, None).maxima),
        };
        let first = sweep(
            pool,
            before,
            after,
            dt,
            pair,
            Self::weights(shared.config, prev_v, prev_s, dt),
            out,
        );
        let finite = first.finite;
        let (v_scale, sigma_scale) = field_scales(first.maxima);
        let (sv, ss) = weight_scales((v_scale, sigma_scale), Some((prev_v, prev_s)));
        let sweep = if sv.to_bits() == prev_v.to_bits() && ss.to_bits() == prev_s.to_bits() {
            first
        } else {
            sweep(
                pool,
                before,
                after,
                dt,
                pair,
                Self::weights(shared.config, sv, ss, dt),
                None,
            )
        };
        Passes {
            sweep,
            finite,
            v_scale,
            sigma_scale,
        }
    }
}

/// `(‖v‖_∞, ‖σ‖_∞)` of a sweep's maxima (the impedance-scaled ones included).
fn field_scales([vm, sm, vs2, sv2]: [f64; 4]) -> (f64, f64) {
    (vm.max(vs2).sqrt(), sm.max(sv2).sqrt())
}

impl Passes {
    /// The estimate: `dsm = sqrt((Σ_v + Σ_σ)/(2N))` (NaN when a rate was not finite),
    /// `dsm_u = sqrt(Σ_u/N)`.
    pub(super) fn estimate(&self) -> Estimate {
        let [sum_v, sum_s] = self.sweep.sums;
        let nf = self.sweep.count.max(1) as f64;
        // A non-finite rate is a non-finite trial: `dsm` NaN rejects it (the maxima and
        // the first step's nodal form would not carry the NaN).
        let dsm = if self.finite {
            ((sum_v + sum_s) / (2.0 * nf)).sqrt()
        } else {
            f64::NAN
        };
        Estimate {
            dsm,
            dsm_v: (sum_v / nf).sqrt(),
            dsm_sigma: (sum_s / nf).sqrt(),
            count: Some(self.sweep.count),
            v_scale: self.v_scale,
            sigma_scale: self.sigma_scale,
        }
    }
}
