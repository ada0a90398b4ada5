//! The per-particle pass of [`super::temporal_error::RateSweeps`] (module docs there): the history it
//! keeps, how trial particles find their committed state and history, and the sweep that
//! forms the rates, the field-scale maxima and the sums of the scaled errors.

use super::stress_rates::{StressRates, StressRatesMut};
use crate::nd::{Tensor, Vector, ViewNd, ViewWeightsNd};
use crate::temporal::deferral::{Deferral, Scheduled};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// No partner (a particle absent from the other state).
pub(super) const NONE: u32 = u32::MAX;

/// The history id of a particle left out of its trial's estimate (it has no rates).
pub(super) const LEFT_OUT: u64 = u64::MAX;

/// Rates of the last checked, accepted step, kept for the next estimate.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct History<const D: usize> {
    /// The step the rates were formed over.
    pub(super) dt: f64,
    /// `(v^{n+1} − v^n)/dt` per particle.
    pub(super) accel: Vec<Vector<D>>,
    /// `(σ^{n+1} − σ^n)/dt` per particle (packed while symmetric, [`StressRates`]).
    pub(super) stress_rate: StressRates<D>,
    /// Run-wide particle ids, on a grid-decomposed run (else empty: the index is the id).
    pub(super) ids: Vec<u64>,
    /// `‖v‖_∞` of the step (module docs of [`super::temporal_error::RateSweeps`]).
    pub(super) v_scale: f64,
    /// `‖σ‖_∞` of the step.
    pub(super) sigma_scale: f64,
    /// The deferral schedule after this step, and the time deferred since.
    #[serde(default)]
    pub(super) defer: Deferral,
}

/// How trial particles find their committed state and their history.
pub(super) struct Pairing<'h, const D: usize> {
    /// On a grid-decomposed run where particles changed process in the trial, the trial's
    /// run-wide ids (partners through the id table); `None` when trial particle `p` is
    /// committed particle `p`.
    pub moved: Option<&'h [u64]>,
    /// Run-wide id → committed index, filled when particles moved ([`NONE`]: absent).
    pub slot_before: &'h [u32],
    /// The committed state's run-wide ids on a grid-decomposed run.
    pub before_ids: Option<&'h [u64]>,
    /// The history, when it describes these particles: its entries follow the committed
    /// order (it was the trial that became the committed state).
    pub history: Option<&'h History<D>>,
}

impl<const D: usize> Scheduled for History<D> {
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

impl<const D: usize> History<D> {
    /// The arrays belong together: one rate pair per particle, ids for all or none, a
    /// positive finite step, a finite non-negative gap and a non-negative checked `dsm`
    /// (what a restored state must satisfy
    /// before it is indexed).
    pub fn consistent(&self) -> bool {
        self.accel.len() == self.stress_rate.len()
            && (self.ids.is_empty() || self.ids.len() == self.accel.len())
            && self.dt.is_finite()
            && self.dt > 0.0
            && self.defer.consistent()
    }
}

impl<const D: usize> History<D> {
    /// Where a sweep writes the rates of every particle.
    fn rates_out(&mut self) -> RatesOut<'_, D> {
        RatesOut {
            start: 0,
            accel: &mut self.accel,
            stress_rate: self.stress_rate.as_mut(),
            ids: &mut self.ids,
            needs_full: false,
        }
    }

    /// Where the chunks of a threaded sweep write their rates (chunks of `chunk`
    /// particles; the ids are written only on a grid-decomposed run, never threaded).
    fn rates_out_chunks(&mut self, chunk: usize) -> Vec<RatesOut<'_, D>> {
        self.accel
            .chunks_mut(chunk)
            .zip(self.stress_rate.chunks_mut(chunk))
            .enumerate()
            .map(|(k, (accel, stress_rate))| RatesOut {
                start: k * chunk,
                accel,
                stress_rate,
                ids: &mut [],
                needs_full: false,
            })
            .collect()
    }

    /// Bytes of its arrays (their capacities).
    pub fn heap_bytes(&self) -> usize {
        self.accel.capacity() * std::mem::size_of::<Vector<D>>()
            + self.stress_rate.heap_bytes()
            + self.ids.capacity() * std::mem::size_of::<u64>()
    }
}

/// Writes the rates `(v^{n+1} − v^n)/dt`, `(σ^{n+1} − σ^n)/dt` of a step whose trial keeps
/// its particles in their committed order into `out`, with the same operations as
/// [`sweep`] (so the same values, bit for bit), and the trial's run-wide ids. On `pool`
/// in chunks of [`SWEEP_CHUNK`] particles in parallel (the same values: each is its own).
pub(super) fn rates_into<const D: usize>(
    pool: Option<&rayon::ThreadPool>,
    before: &ViewNd<'_, D>,
    after: &ViewNd<'_, D>,
    dt: f64,
    out: &mut History<D>,
) {
    let n = after.n_particles().min(before.n_particles());
    out.accel.clear();
    out.accel.resize(n, Vector::<D>::zeros());
    out.stress_rate.reset(n);
    let (b, a) = (SweepFields::of(before), SweepFields::of(after));
    loop {
        let needs_full = match pool {
            Some(pool) if n > SWEEP_CHUNK => pool.install(|| {
                out.rates_out_chunks(SWEEP_CHUNK)
                    .into_par_iter()
                    .map(|mut r| rates_range(&b, &a, dt, &mut r))
                    .reduce(|| false, |x, y| x | y)
            }),
            _ => rates_range(&b, &a, dt, &mut out.rates_out()),
        };
        if !needs_full {
            break;
        }
        out.stress_rate.unpack();
    }
    out.ids.clear();
    if let Some(split) = after.split {
        out.ids.extend_from_slice(split.particle_id);
    }
}

/// [`rates_into`] for the particles `out` covers; whether a stress rate could not be
/// stored packed ([`RatesOut::needs_full`]).
fn rates_range<const D: usize>(
    before: &SweepFields<'_, D>,
    after: &SweepFields<'_, D>,
    dt: f64,
    out: &mut RatesOut<'_, D>,
) -> bool {
    let inv_dt = 1.0 / dt;
    for k in 0..out.accel.len() {
        let p = out.start + k;
        out.accel[k] = (after.v[p] - before.v[p]) * inv_dt;
        out.needs_full |= !out
            .stress_rate
            .set(k, (after.sigma[p] - before.sigma[p]) * inv_dt);
    }
    out.needs_full
}

/// Stamps a history with the step it was formed over and the step's field scales.
pub(super) fn stamp<const D: usize>(out: &mut History<D>, dt: f64, v_scale: f64, sigma_scale: f64) {
    out.dt = dt;
    out.v_scale = v_scale;
    out.sigma_scale = sigma_scale;
}

/// What one sweep over the particles gives.
pub(super) struct Sweep {
    /// `Σ (le_v/w_v)²`, `Σ (le_σ/w_σ)²`.
    pub sums: [f64; 2],
    /// Particles in the sums (`N`).
    pub count: usize,
    /// `max v̂²`, `max σ̂²`, `max σ̂²/z²`, `max v̂² z²`.
    pub maxima: [f64; 4],
    /// Every rate formed was finite.
    pub finite: bool,
}

/// What a sweep reads of one state: the view's particle and nodal fields, apart from its
/// process-split part (which is not shared between threads).
#[derive(Clone, Copy)]
pub(super) struct SweepFields<'a, const D: usize> {
    v: &'a [Vector<D>],
    sigma: &'a [Tensor<D>],
    density: &'a [f64],
    lame_lambda: &'a [f64],
    lame_mu: &'a [f64],
    weights: ViewWeightsNd<'a, D>,
    node_velocity: &'a [Vector<D>],
    node_acceleration: &'a [Vector<D>],
}

impl<'a, const D: usize> SweepFields<'a, D> {
    /// The fields of `view`.
    pub fn of(view: &ViewNd<'a, D>) -> Self {
        Self {
            v: view.v,
            sigma: view.sigma,
            density: view.density,
            lame_lambda: view.lame_lambda,
            lame_mu: view.lame_mu,
            weights: view.weights,
            node_velocity: view.node_velocity,
            node_acceleration: view.node_acceleration,
        }
    }

    /// Particles of the state.
    pub fn n_particles(&self) -> usize {
        self.v.len()
    }
}

/// The rates `(a_p, σ̇_p)` of particle `p` at the start of a step from the state's nodal
/// fields (eqs 21, 16, 24).
fn nodal_rates<const D: usize>(view: &SweepFields<'_, D>, p: usize) -> (Vector<D>, Tensor<D>) {
    let (a, l) = view.weights.with_row(p, |nodes, s, grad| {
        let mut a = Vector::<D>::zeros();
        let mut l = Tensor::<D>::zeros();
        for ((&i, &s), g) in nodes.iter().zip(s).zip(grad) {
            let i = i as usize;
            a += view.node_acceleration[i] * s;
            l += view.node_velocity[i] * g.transpose();
        }
        (a, l)
    });
    let e = (l + l.transpose()) * 0.5;
    let rate =
        Tensor::<D>::identity() * (view.lame_lambda[p] * e.trace()) + e * (2.0 * view.lame_mu[p]);
    (a, rate)
}

/// The weights `w = abs + rtol·û` of a sweep's sums: `abs = (atol_v + atol_rel ‖v‖_∞,
/// atol_σ + atol_rel ‖σ‖_∞)`.
#[derive(Clone, Copy)]
pub(super) struct Weights {
    pub rtol: f64,
    pub abs: (f64, f64),
    /// `κ_lag dt/2` of the velocity lag (`TemporalErrorConfig::lag`), 0 when off.
    pub lag: f64,
}

/// Where a sweep writes the rates of particles `start..start + accel.len()`.
pub(super) struct RatesOut<'o, const D: usize> {
    /// The first particle written.
    pub start: usize,
    pub accel: &'o mut [Vector<D>],
    pub stress_rate: StressRatesMut<'o, D>,
    /// The history ids, on a grid-decomposed run (`LEFT_OUT` marks an arrival).
    pub ids: &'o mut [u64],
    /// A stress rate was not symmetric while the rates were packed: the rates written are
    /// incomplete (the caller unpacks them and sweeps again).
    pub needs_full: bool,
}

/// One pass over the trial's particles: the maxima behind the field scales and, with
/// `weights`, their rates (written into `out` when given) and the sums of `(le/w)²`
/// (without, the sums are 0 and `finite` true: the fields' scales only). On `pool` (and a
/// run not decomposed over processes) the particles are taken in chunks of
/// [`SWEEP_CHUNK`] in parallel ([`sweep_chunked`]).
pub(super) fn sweep<const D: usize>(
    pool: Option<&rayon::ThreadPool>,
    before: &ViewNd<'_, D>,
    after: &ViewNd<'_, D>,
    dt: f64,
    pair: &Pairing<'_, D>,
    weights: Option<Weights>,
    mut out: Option<&mut History<D>>,
) -> Sweep {
    let (b, a) = (SweepFields::of(before), SweepFields::of(after));
    loop {
        // A grid-decomposed run (`before_ids`) sums in one chunk, on every step alike.
        let split = pair.before_ids.is_some();
        let (found, needs_full) = match (pool, pair.moved) {
            (Some(pool), None) if !split && a.n_particles() > SWEEP_CHUNK => {
                pool.install(|| sweep_chunked(&b, &a, dt, pair, weights, out.as_deref_mut()))
            }
            _ => {
                let mut rates = out.as_deref_mut().map(History::rates_out);
                let n = a.n_particles();
                let found = sweep_range(&b, &a, dt, pair, weights, 0..n, rates.as_mut());
                (found, rates.is_some_and(|r| r.needs_full))
            }
        };
        match out.as_deref_mut() {
            // A non-symmetric stress rate met while packed: unpack and sweep again.
            Some(hist) if needs_full => hist.stress_rate.unpack(),
            _ => return found,
        }
    }
}

/// The particles of a sweep in chunks of [`SWEEP_CHUNK`] on the current thread pool; the
/// chunks' sums are added in chunk order, so the result does not depend on the number of
/// threads (it differs from the one-chunk sum of [`sweep_range`] by round-off). Returns
/// whether a chunk met a non-symmetric stress rate while packed.
fn sweep_chunked<const D: usize>(
    before: &SweepFields<'_, D>,
    after: &SweepFields<'_, D>,
    dt: f64,
    pair: &Pairing<'_, D>,
    weights: Option<Weights>,
    out: Option<&mut History<D>>,
) -> (Sweep, bool) {
    let n = after.n_particles();
    let ranges: Vec<_> = (0..n.div_ceil(SWEEP_CHUNK))
        .map(|k| k * SWEEP_CHUNK..((k + 1) * SWEEP_CHUNK).min(n))
        .collect();
    let parts: Vec<(Sweep, bool)> = match out {
        Some(hist) => hist
            .rates_out_chunks(SWEEP_CHUNK)
            .into_par_iter()
            .zip(ranges)
            .map(|(mut rates, r)| {
                let found = sweep_range(before, after, dt, pair, weights, r, Some(&mut rates));
                (found, rates.needs_full)
            })
            .collect(),
        None => ranges
            .into_par_iter()
            .map(|r| {
                (
                    sweep_range(before, after, dt, pair, weights, r, None),
                    false,
                )
            })
            .collect(),
    };
    let mut total = Sweep::empty();
    let mut needs_full = false;
    for (part, full) in parts {
        total.merge(&part);
        needs_full |= full;
    }
    (total, needs_full)
}

/// Particles per chunk of a threaded sweep: fixed, so that the sums' order depends on the
/// particle count only.
pub(super) const SWEEP_CHUNK: usize = 8192;

impl Sweep {
    /// A sweep over no particles.
    fn empty() -> Self {
        Sweep {
            sums: [0.0; 2],
            count: 0,
            maxima: [0.0; 4],
            finite: true,
        }
    }

    /// Takes in a sweep over the particles that follow.
    fn merge(&mut self, other: &Sweep) {
        self.sums[0] += other.sums[0];
        self.sums[1] += other.sums[1];
        self.count += other.count;
        for (m, o) in self.maxima.iter_mut().zip(other.maxima) {
            *m = m.max(o);
        }
        self.finite &= other.finite;
    }
}

/// [`sweep`] over the trial particles `range`, their rates written into `out` (which starts
/// at `range.start`).
#[allow(clippy::too_many_arguments)]
fn sweep_range<const D: usize>(
    before: &SweepFields<'_, D>,
    after: &SweepFields<'_, D>,
    dt: f64,
    pair: &Pairing<'_, D>,
    weights: Option<Weights>,
    range: std::ops::Range<usize>,
    mut out: Option<&mut RatesOut<'_, D>>,
) -> Sweep {
    let inv_dt = 1.0 / dt;
    // `(le/w)²` with `le² = (dt²/2)² |d²u/dt²|²`; 0 when `le = 0`, whatever `w`.
    let half_dt2 = 0.5 * dt * dt;
    let c2 = half_dt2 * half_dt2;
    let term = |d2: f64, w: f64| {
        let r = c2 * d2 / (w * w).max(f64::MIN_POSITIVE);
        if d2 == 0.0 {
            0.0
        } else {
            r
        }
    };
    let mut acc = Sweep::empty();
    for p in range {
        let q = match pair.moved {
            None => p,
            Some(ids) => match pair.slot_before.get(ids[p] as usize) {
                Some(&q) if q != NONE => q as usize,
                _ => {
                    // Arrived in this trial: left out (module docs), and without rates
                    // for the next step.
                    if let Some(out) = out.as_deref_mut() {
                        out.ids[p - out.start] = LEFT_OUT;
                    }
                    continue;
                }
            },
        };
        let (v0, v1) = (before.v[q], after.v[p]);
        let (s0, s1) = (before.sigma[q], after.sigma[p]);
        // Squares throughout: one square root per field and particle.
        let v_hat2 = v0.norm_squared().max(v1.norm_squared());
        let s_hat2 = s0.norm_squared().max(s1.norm_squared());
        if let Some(Weights {
            rtol,
            abs: (abs_v, abs_s),
            lag,
        }) = weights
        {
            let accel = (v1 - v0) * inv_dt;
            let stress_rate = (s1 - s0) * inv_dt;
            acc.finite &= (accel.norm_squared() + stress_rate.norm_squared()).is_finite();
            if let Some(out) = out.as_deref_mut() {
                out.accel[p - out.start] = accel;
                out.needs_full |= !out.stress_rate.set(p - out.start, stress_rate);
            }
            // The history of committed particle `q`, unless it was left out.
            let hist = pair.history.filter(|hist| match pair.before_ids {
                None => true,
                Some(ids) => hist.ids[q] == ids[q],
            });
            let (d2v, d2s) = match hist {
                Some(hist) => {
                    // The rates sit at the midpoints of their steps, `gap` apart.
                    let inv_span = 2.0 / (dt + hist.dt + 2.0 * hist.defer.gap);
                    (
                        (accel - hist.accel[q]) * inv_span,
                        (stress_rate - hist.stress_rate.get(q)) * inv_span,
                    )
                }
                None => {
                    let (a0, r0) = nodal_rates(before, q);
                    let (a1, r1) = nodal_rates(after, p);
                    ((a1 - a0) * inv_dt, (r1 - r0) * inv_dt)
                }
            };
            let w_v = abs_v + rtol * v_hat2.sqrt();
            acc.sums[0] += term(d2v.norm_squared(), w_v);
            if lag > 0.0 {
                // The velocity lag (κ_lag dt/2 |a_p| / w_v)², in the velocity part.
                let a2 = accel.norm_squared();
                let r = lag * lag * a2 / (w_v * w_v).max(f64::MIN_POSITIVE);
                acc.sums[0] += if a2 == 0.0 { 0.0 } else { r };
            }
            acc.sums[1] += term(d2s.norm_squared(), abs_s + rtol * s_hat2.sqrt());
        }
        acc.count += 1;
        let m = &mut acc.maxima;
        m[0] = m[0].max(v_hat2);
        m[1] = m[1].max(s_hat2);
        let z2 = before.density[q] * (before.lame_lambda[q] + 2.0 * before.lame_mu[q]);
        if z2.is_finite() && z2 > 0.0 {
            m[2] = m[2].max(s_hat2 / z2);
            m[3] = m[3].max(v_hat2 * z2);
        }
    }
    acc
}
