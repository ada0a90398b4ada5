//! The temporal local error of the USL step (eqs 20–30) in `d` dimensions: the estimator
//! [`RateSweeps<D>`] of [`crate::temporal::TemporalError<D>`] ([`TemporalErrorNd<D>`] is an
//! alias), with the same settings ([`TemporalErrorConfig`]) and the same scaled
//! norm as the 1D one. What every dimension shares — the deferral, the judged-trial cache,
//! the metrics and verdict, the checkpoint state — is in [`crate::temporal::limit`]; the
//! sweeps over the particles, their pairing across processes and the history of rates are
//! here and in `temporal_sweep`.
//!
//! Per particle, the forward-Euler local errors of eqs 20/23 (velocity) and eq 28 (stress)
//! are `le_v,p = dt²/2 · |d²v_p/dt²|` and `le_σ,p = dt²/2 · ‖d²σ_p/dt²‖`, with `|·|` the
//! Euclidean norm of the velocity vector and `‖·‖` the Frobenius norm of the stress tensor
//! (in 1D both are the absolute value, so the 1D limit is the case `d = 1`). The second
//! derivatives come from successive rates of the committed and trial fields:
//!
//! ```text
//! r_p = (u_p^{n+1} − u_p^n)/dt                     u = v (eq 22), u = σ (eq 27)
//! d²u_p/dt² ≈ 2 (r_p − r_p^{prev}) / (dt + dt₋)    from the previous accepted step
//! d²u_p/dt² ≈ (ṙ_p(t^{n+1}) − ṙ_p(t^n)) / dt       without one (first step)
//! ```
//!
//! where the rates at the ends of the first step are read from the views' nodal fields:
//! `a_p = Σ_i S_ip a_i` (eq 21) and `σ̇_p = λ_t tr(ε̇) I + 2μ_t ε̇`,
//! `ε̇ = sym(Σ_i v_i ⊗ ∇S_ip)` (eqs 16, 24 with the tangent moduli of [`ViewNd`]). The
//! scaled norm, the tolerances and the energy-equivalent field scales are the 1D limit's
//! (`dsm ≤ 1` accepts; module docs of [`crate::controller::TemporalError`]): with
//! `v̂_p = max(|v_p^n|, |v_p^{n+1}|)`, `σ̂_p` likewise and the squared P-wave impedance
//! `z_p² = ρ_p (λ_t + 2μ_t)`,
//!
//! ```text
//! dsm = sqrt( 1/(2N) Σ_p [ (le_v,p / w_v,p)² + (le_σ,p / w_σ,p)² ] )
//! w_u,p = atol_u + atol_rel · s_u + rtol · û_p
//! ‖v‖_∞ = max(max_p v̂_p, max_p σ̂_p / z_p),   ‖σ‖_∞ = max(max_p σ̂_p, max_p v̂_p z_p),
//! ```
//!
//! `s_u` the weights' field scale: the last checked step's `‖u‖_∞` until one of this
//! check's scales grows by more than 10 %, then the larger of the two — the rule of both
//! dimensions, [`crate::temporal::scales`].
//!
//! **One pass.** The weights are formed before the sweep from the last checked step's
//! scales, and the sums redone with the larger ones only when a scale grew by more than the
//! slack; with no previous step (the first, or after a lost history) a pass over the fields
//! alone gives the scales first.
//!
//! **Deferred checks** ([`crate::temporal::deferral`]): while `dsm` stays far below the
//! tolerance the checks of the next trials are deferred (1, 2, 4, up to 8 trials). On a
//! grid-decomposed run a trial that moves particles between processes is always checked,
//! so that the history keeps following the committed order.
//!
//! **Runs over several processes.** Each process judges *its own* particles: its `dsm` is
//! the norm over them with its own field scales, and the controller rejects the step when
//! any process rejects it and takes the smallest filter proposal of all
//! ([`crate::reduce`]). Over the particles that stay on their process this is at least as
//! strict as the norm over the whole run (an RMS over a part where errors concentrate is
//! larger); it needs no collective of its own — a process whose trial failed does not
//! judge, so a reduction here could wait forever — and equals the undivided run's
//! judgement on one process. On a grid-decomposed run ([`crate::nd::SplitNd`]) particles
//! move between processes inside the trial: they are matched across the committed state
//! and the trial by their run-wide ids, and **a particle that changes process in a trial
//! is judged by no process for that trial** (its committed state stayed behind); in the
//! next step it takes the first-step form. On the 10⁵-particle disks split in two,
//! 1 054 of 102 936 particles ended on the other process over the whole run.
//!
//! **Threads.** On the controller's threads
//! ([`Controller::with_threads`](crate::controller::Controller::with_threads)) the sweep
//! takes the particles in chunks of 8 192 in parallel and adds the chunks' sums in chunk
//! order: `dsm` is the same bit for bit on any number of threads, and differs from the
//! sum over all particles in one chunk (no pool, or a grid-decomposed run, which stays
//! on the calling thread) by round-off.
//!
//! **Replacing the state.** The history is the previous accepted step's rates: after the
//! state is replaced outside the controller (`SolverNd::set_velocity_and_stress`), build
//! a new limit (and controller), or the first estimate compares rates of two different
//! motions.
//!
//! **Not carried over:** the balancing of eq 44's spatial error (`balance`), whose
//! estimators are 1D; a configured `balance` is reported as an error, not ignored.

mod passes;

use super::temporal_sweep::{rates_into, stamp, History, Pairing, LEFT_OUT, NONE};
use crate::dimension::{Dim, Dimension};
use crate::limit::LimitError;
use crate::nd::ViewNd;
use crate::temporal::limit::{Estimate, Shared, TemporalDim, TemporalEstimator};
use crate::temporal::{TemporalError, TemporalErrorConfig, TEMPORAL_ERROR};

/// The temporal-error limit in `d` dimensions, `TemporalError<D>`: an alias. It
/// proposes nothing itself (the controller's filter does, from the `dsm` it reports) and
/// judges each trial by `dsm ≤ 1` (the estimate, its weights and its deferral are in the
/// [module docs](self)). The per-particle arrays are allocated once per run and reused.
///
/// # Memory
///
/// One history of rates per particle (O(particles)): `a_p` and `σ̇_p`, `(D + D²)·8` bytes
/// (96 in 3D, 48 in 2D), or `(D + D(D+1)/2)·8` (72, 40) while every stress rate is exactly
/// symmetric, as the reference solver's are (then only the upper triangles are kept, and
/// unpacked to the very tensors stored), plus the run-wide ids on a grid-decomposed run
/// (8). A judged trial's rates are not kept: when it is accepted they are formed again from the two
/// states, `(u^{n+1} − u^n)/dt` with the same operations, and written over the history
/// in place. Only where particles changed process in a trial (a grid-decomposed run) are
/// its rates formed into a second history while it is judged, and the run-wide id table
/// kept (4 bytes per particle of the whole run). [`TemporalError::memory_bytes`] sums what
/// is held.
pub type TemporalErrorNd<const D: usize> = TemporalError<D>;

impl<const D: usize> TemporalError<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    /// A limit with the tolerances of `config` (the 1D limit's settings; `enabled` is for
    /// [`crate::controller::standard_limits`]), checked before the first proposal.
    pub fn new(config: TemporalErrorConfig) -> Self {
        Self::with_config(config)
    }
}

/// The 2D/3D estimator of the temporal-error limit (module docs): the sweeps of
/// `temporal_sweep` over the particles, matched across processes by run-wide id on a
/// grid-decomposed run. Its own memory is the id table of such a run.
#[derive(Clone, Debug, Default)]
pub struct RateSweeps<const D: usize> {
    /// Run-wide id → committed index (grid-decomposed runs, steps where particles moved).
    slot_before: Vec<u32>,
}

impl<const D: usize> TemporalDim for Dim<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    type Estimator = RateSweeps<D>;
}

fn other(message: String) -> LimitError {
    LimitError::Other {
        limit: TEMPORAL_ERROR.to_string(),
        message,
    }
}

impl<const D: usize> RateSweeps<D> {
    /// Whether particles changed process in the trial: a grid-decomposed run whose trial
    /// holds other run-wide ids than the committed state.
    fn moved(before: &ViewNd<'_, D>, after: &ViewNd<'_, D>) -> bool {
        matches!((before.split, after.split), (Some(b), Some(a)) if a.particle_id != b.particle_id)
    }

    /// Checks the slices the estimate reads: the weights and nodal fields too where it
    /// reads them (`nodal`: no usable history, the first step's nodal rates).
    fn check(view: &ViewNd<'_, D>, nodal: bool) -> Result<(), LimitError> {
        let n = view.n_particles();
        let w = view.weights;
        let nodes = view.node_mass.len();
        if nodal && !view.holds_arrays() {
            return Err(other(
                "the first check reads the nodal fields: a view without them".to_string(),
            ));
        }
        let ok = [
            view.v.len(),
            view.sigma.len(),
            view.density.len(),
            view.lame_lambda.len(),
            view.lame_mu.len(),
        ]
        .iter()
        .all(|&len| len == n)
            && (!nodal
                || (w.n_particles() == n
                    && view.node_velocity.len() == nodes
                    && view.node_acceleration.len() == nodes
                    && w.n_nodes() == nodes))
            && view.split.is_none_or(|s| s.particle_id.len() == n);
        if ok {
            Ok(())
        } else {
            Err(other(
                "view's particle, weight and nodal arrays have inconsistent sizes".to_string(),
            ))
        }
    }

    /// Fills `slot[id] = index` for `ids` (growing `slot` to `n_total`, all [`NONE`]).
    fn index_ids(slot: &mut Vec<u32>, ids: &[u64], n_total: usize) -> Result<(), LimitError> {
        slot.clear();
        slot.resize(n_total, NONE);
        for (k, &id) in ids.iter().enumerate().filter(|(_, &id)| id != LEFT_OUT) {
            let cell = slot
                .get_mut(id as usize)
                .ok_or_else(|| other(format!("particle id {id} ≥ total {n_total}")))?;
            *cell = k as u32;
        }
        Ok(())
    }
}

impl<const D: usize> TemporalEstimator<Dim<D>> for RateSweeps<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    type History = History<D>;

    const INCONSISTENT: &'static str =
        "cannot restore state: rates, ids and step do not belong together";

    /// The steppers of `crate::nd` may hand over their arrays on demand.
    const ON_DEMAND: bool = true;

    /// The 1D-only balancing is refused, not ignored; invalid tolerances (as
    /// [`TemporalErrorConfig::validate`] finds them) likewise.
    fn supported(config: &TemporalErrorConfig) -> Result<(), LimitError> {
        config.validate().map_err(|source| LimitError::Config {
            limit: TEMPORAL_ERROR.to_string(),
            source,
        })?;
        match config.balance {
            Some(_) => Err(other(
                "temporal.balance (eq 44's spatial error) is 1D only".to_string(),
            )),
            None => Ok(()),
        }
    }

    /// A single-process history as consistent and, where the trial's particles are
    /// loaded, as long as they are many (the estimate decides with the history it can use).
    fn particles_suffice(history: &History<D>, state: &ViewNd<'_, D>) -> bool {
        let n = state.n_particles();
        history.consistent() && history.ids.is_empty() && (n == 0 || history.accel.len() == n)
    }

    /// When the trial keeps its particles in their committed order (on a grid-decomposed
    /// run a trial that moves particles between processes is checked, so that the history
    /// keeps following that order).
    fn deferrable(_history: &History<D>, before: &ViewNd<'_, D>, after: &ViewNd<'_, D>) -> bool {
        match (before.split, after.split) {
            (None, None) => true,
            (Some(b), Some(a)) => a.particle_id == b.particle_id,
            _ => false,
        }
    }

    /// Only where particles changed process in the trial (the type's docs, "Memory").
    fn keeps_rates(before: &ViewNd<'_, D>, after: &ViewNd<'_, D>) -> bool {
        Self::moved(before, after)
    }

    /// Computes the estimate of a trial and writes its rates into `out`.
    fn estimate(
        &mut self,
        shared: Shared<'_, History<D>>,
        before: &ViewNd<'_, D>,
        after: &ViewNd<'_, D>,
        dt: f64,
        mut out: Option<&mut History<D>>,
    ) -> Result<Estimate, LimitError> {
        Self::supported(shared.config)?;
        let history = Self::usable_history(shared.history, before);
        Self::check(before, history.is_none())?;
        Self::check(after, history.is_none())?;
        let n = after.n_particles();
        // Partners by index, or by run-wide id where particles changed process.
        let (split, moved) = self.partners(before, after)?;
        let before_ids = before.split.map(|b| b.particle_id);
        // Every entry is written by the first sweep (the arrays keep their length).
        if let Some(out) = out.as_deref_mut() {
            Self::prepare(out, n, split);
        }
        let pair = Pairing {
            moved,
            slot_before: &self.slot_before,
            before_ids,
            history,
        };
        let passes = Self::passes(&shared, before, after, dt, &pair, out.as_deref_mut());
        if let Some(out) = out {
            stamp(out, dt, passes.v_scale, passes.sigma_scale);
        }
        Ok(passes.estimate())
    }

    /// `(u^{n+1} − u^n)/dt` with the sweep's operations (the same values, bit for bit).
    fn rates_into(
        pool: Option<&rayon::ThreadPool>,
        before: &ViewNd<'_, D>,
        after: &ViewNd<'_, D>,
        dt: f64,
        e: &Estimate,
        out: &mut History<D>,
    ) {
        rates_into(pool, before, after, dt, out);
        stamp(out, dt, e.v_scale, e.sigma_scale);
    }

    fn consistent(history: &History<D>) -> bool {
        history.consistent()
    }

    fn history_bytes(history: &History<D>) -> usize {
        history.heap_bytes()
    }

    /// The id table (4 bytes per particle of the whole run, where particles moved).
    fn memory_bytes(&self) -> usize {
        self.slot_before.capacity() * std::mem::size_of::<u32>()
    }
}
