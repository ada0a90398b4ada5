//! [`StabilityNd`]: the eq 56 stability limit in d dimensions, `dt = safety · √(2/λmax)`
//! with `λmax = λmax(M⁻¹K)` ([`super::stiffness`]) tracked on the evolving state.
//!
//! # What is recomputed, and when
//!
//! `λmax` moves only as particles move against the grid (weights and nodal masses change)
//! or their tangent moduli and volumes change. So the limit recomputes it by Lanczos,
//! warm-started from the previous Ritz vector, only when
//!
//! * some particle has moved more than `refresh_cells` of a cell on some axis since the
//!   last refresh, or
//! * the smallest active nodal mass fell by more than `refresh_mass` (relative) *and* the
//!   largest diagonal entry of `M^{-1/2} K M^{-1/2}` grew by more than `refresh_diagonal`
//!   since the refresh (below), or
//! * some particle's moduli grew by more than `refresh_modulus` (relative, 10 % by default, below), or
//! * `max_age` proposals have passed, or the node count changed;
//!
//! and between refreshes proposes from the cached value, scaled for the moduli's growth.
//!
//! **Moduli between refreshes.** On symmetric tensors the isotropic `V_p C_p` has two
//! eigenvalues, `V(dλ_t + 2μ_t)` (volumetric) and `2Vμ_t` (deviatoric). If each grew at
//! most by the factor `r_p` since the refresh then `V'_p C'_p ⪯ r_p V_p C_p`, so with the
//! weights unchanged `K' ⪯ (max_p r_p) K` in the Loewner order and
//! `λmax(M⁻¹K') ≤ (max_p r_p) λmax(M⁻¹K)`: the cached value times `max(1, max_p r_p)` is
//! a bound for the new moduli, exact in the frozen-weight sense. A collision, where `J`
//! and the tangent moduli change every step, thus costs no Lanczos run until some
//! particle's moduli grew by `refresh_modulus`; then the factor is reset by a refresh
//! (which also wins back the step when moduli fall).
//!
//! **Light nodes.** Nearly empty nodes set `λmax` on linear-hat layouts: a node with mass
//! `m_i → 0` keeps a stiffness row of order one, and the Rayleigh quotient of a unit
//! velocity there, the diagonal entry `K_ii/m_i`, grows without bound. With GIMP and
//! B-spline weights the stiffness row vanishes with the mass (weight gradients vanish where
//! the weights do) and a node's mass falling as a body slides over it is harmless. So when
//! the smallest nodal mass falls, the limit computes `max diag(A)` (one pass over the weight
//! gradients, [`super::stiffness::diagonal_argmax`]): if it grew by more than
//! `refresh_diagonal`, `λmax` is recomputed; else the cached value is multiplied by that
//! growth (≥ 1) until the next refresh — a heuristic scaling, not a bound, since the
//! diagonal only bounds `λmax` from below. The per-step guard is one pass over
//! the particles (positions and moduli against their values at the refresh): O(n), no
//! weights read. A Lanczos Ritz value is a lower bound on `λmax` that converges fast; the
//! cached value is the Ritz value times `(1 + tol)·margin` — a margin, not a rigorous bound
//! (the residual bound would be one for the nearest eigenvalue, but in the clustered top of
//! a uniform layout's spectrum it stays large long after the value has settled).
//!
//! # What this guarantees, and what it does not
//!
//! Between refreshes the proposal is for a state within `refresh_cells` of the analysed
//! one; it is not a certificate (the 1D tracker's `LDLᵀ` certificate is not carried over).
//! The frozen-particle `λmax` is a rough function of the positions: on a jittered block
//! drifting across a periodic grid (`tests/stability_tracking_nd.rs`) the true value rose
//! up to 1.09× (linear hat), 1.49× (GIMP) and 1.21× (B-spline) above the tracked one
//! within half a cell of motion (refreshing every eighth of a cell still left 1.34× with
//! GIMP, measured with a Lanczos tolerance of 10⁻³) — so a step of `0.9·√(2/λ)` can exceed
//! the frozen critical step by up to about 10 % for a few steps. A refreshed value is the Lanczos Ritz value, which is the
//! top eigenvalue unless a new mode far from the warm start has just risen above the old
//! one (measured: at worst 3 % low). Frozen-particle analysis itself
//! overestimates the true limit when particles move (docs/design.md: with quadratic
//! B-splines by about a fifth). The controller's growth monitor ([`super::GrowthNd`]) is
//! the guard that catches all three: it rejects a step whose energy grows and lowers this
//! limit's safety for the rest of the run ([`StepLimit::scale_safety`]).

use super::stiffness::{diagonal_argmax, lanczos_reduced, NodalSpace};
use super::transfer::{apic_gain, TransferNd};
use crate::dimension::{Dim, Dimension};
use crate::limit::{LimitError, Metrics, Proposal, StepLimit};
use crate::nd::{Vector, ViewNd};
use crate::reduce::{Reduce, SingleProcess};
use serde::{Deserialize, Serialize};
use std::rc::Rc;

/// Name in logs: `"stability"`.
pub const STABILITY: &str = "stability";

/// Settings of [`StabilityNd`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StabilityNdConfig {
    /// Fraction of `dt_eq56` proposed (default 0.9, as in 1D).
    pub safety: f64,
    /// Refresh when a particle moved this many cells on some axis (default 0.5).
    pub refresh_cells: f64,
    /// Refresh when the smallest active nodal mass fell by this much, relative (default 0.1).
    pub refresh_mass: f64,
    /// Refresh when some particle's moduli grew by this much, relative (default 0.1);
    /// smaller growth scales the cached `λmax` instead (module docs). The scaling is a
    /// bound, so this threshold trades steps up to 10 % smaller against Lanczos runs:
    /// on the colliding spheres 0.05 refreshed 53 times (355 products) in 136 steps, 0.1
    /// refreshes 33 times (237 products) in the same 136 steps, a 22 % shorter run.
    pub refresh_modulus: f64,
    /// Refresh when, after a nodal mass fell, the largest diagonal entry of `A` grew by
    /// this much, relative (default 0.05); smaller growth scales the cached `λmax` by it —
    /// a heuristic (the diagonal bounds `λmax` from below only), so kept tighter than
    /// `refresh_modulus`.
    pub refresh_diagonal: f64,
    /// Refresh at least every this many proposals (default 200).
    pub max_age: u32,
    /// Lanczos tolerance (default 1e-2): residual below `tol·λ` or the value settled to
    /// `tol·λ/10` in one iteration; the Ritz value is raised by this fraction.
    pub tol: f64,
    /// Lanczos products per refresh at most (default 40).
    pub max_iter: usize,
    /// Multiplier on the refreshed `λmax` bound (default 1.0).
    pub margin: f64,
    /// The scheme's velocity transfer (default [`TransferNd::Flip`], the paper's USL):
    /// with [`TransferNd::Apic`] the limit is `√(2(1 + p)/λmax)`, `p` the transfer's
    /// Rayleigh quotient on the tracked top mode (`limits_nd/transfer.rs`).
    pub transfer: TransferNd,
}

impl Default for StabilityNdConfig {
    fn default() -> Self {
        Self {
            safety: 0.9,
            refresh_cells: 0.5,
            refresh_mass: 0.1,
            refresh_modulus: 0.1,
            refresh_diagonal: 0.05,
            max_age: 200,
            tol: 1e-2,
            max_iter: 40,
            margin: 1.0,
            transfer: TransferNd::Flip,
        }
    }
}

/// The tracked eq 56 limit in d dimensions (module docs).
#[derive(Clone, Debug)]
pub struct StabilityNd<const D: usize> {
    config: StabilityNdConfig,
    safety: f64,
    lambda: Option<f64>,
    ritz: Vec<f64>,
    x_ref: Vec<Vector<D>>,
    /// `(V(dλ_t + 2μ_t), Vμ_t)` per particle at the refresh.
    moduli_ref: Vec<(f64, f64)>,
    /// Smallest active nodal mass at the refresh.
    mass_ref: f64,
    /// `max diag(A)` at the refresh ([`super::stiffness::diagonal_argmax`]).
    diag_ref: f64,
    /// Growth of `max diag(A)` accepted without a refresh since the last one (≥ 1).
    diag_growth: f64,
    /// `1 + p` of the scheme's transfer on the tracked top mode (1 for FLIP).
    gain: f64,
    age: u32,
    refreshes: u64,
    applications: u64,
    /// The run's reductions ([`StepLimit::set_reduce`]).
    reduce: Rc<dyn Reduce>,
}

impl<const D: usize> StabilityNd<D> {
    /// A limit with `config`.
    pub fn new(config: StabilityNdConfig) -> Self {
        Self {
            safety: config.safety,
            config,
            lambda: None,
            ritz: Vec::new(),
            x_ref: Vec::new(),
            moduli_ref: Vec::new(),
            mass_ref: 0.0,
            diag_ref: 0.0,
            diag_growth: 1.0,
            gain: 1.0,
            age: 0,
            refreshes: 0,
            applications: 0,
            reduce: Rc::new(SingleProcess),
        }
    }

    /// The tracked bound on `λmax(M⁻¹K)`, once computed.
    pub fn lambda_max(&self) -> Option<f64> {
        self.lambda
    }

    /// Lanczos refreshes so far.
    pub fn refreshes(&self) -> u64 {
        self.refreshes
    }

    /// The two eigenvalues of `V_p C_p` on symmetric tensors: `V(dλ_t + 2μ_t)` (volumetric)
    /// and `2Vμ_t` (deviatoric), the latter stored halved as `Vμ_t`.
    #[inline]
    fn moduli(view: &ViewNd<'_, D>, p: usize) -> (f64, f64) {
        let vol = view.volume(p);
        let (l, m) = (view.lame_lambda[p], view.lame_mu[p]);
        (vol * (D as f64 * l + 2.0 * m), vol * m)
    }

    /// Smallest active nodal mass, `+∞` when no node is active (on a decomposed grid,
    /// [`ViewNd::split`], the smallest over the processes: one reduction).
    fn smallest_node_mass(&self, view: &ViewNd<'_, D>) -> f64 {
        let local = view
            .node_mass
            .iter()
            .zip(view.node_active)
            .filter(|(_, &a)| a)
            .fold(f64::INFINITY, |m, (&mi, _)| m.min(mi));
        match view.split {
            None => local,
            Some(_) => {
                Self::agreement(&*self.reduce, view)
                    .min_and_any(local, false)
                    .0
            }
        }
    }

    /// The reductions the processes agree with: a decomposed view's own
    /// ([`crate::nd::NodalHalo::reduce`]), so that a limit the run forgot to give its
    /// reducer ([`StepLimit::set_reduce`]) still takes part in every collective; else
    /// `own`.
    fn agreement<'r>(own: &'r dyn Reduce, view: &ViewNd<'r, D>) -> &'r dyn Reduce {
        match &view.split {
            Some(s) => s.halo.reduce(),
            None => own,
        }
    }

    /// Where particle `p`'s reference values are kept: its run-wide identity on a
    /// decomposed grid (particles move between processes), else its index.
    #[inline]
    fn key(view: &ViewNd<'_, D>, p: usize) -> usize {
        view.split.as_ref().map_or(p, |s| s.particle_id[p] as usize)
    }

    /// Number of particle references kept: the whole run's on a decomposed grid.
    fn n_refs(view: &ViewNd<'_, D>) -> usize {
        view.split
            .as_ref()
            .map_or(view.n_particles(), |s| s.n_particles_total)
    }

    /// `None` when the cached `λmax` must be recomputed, else the factor `r ≥ 1` it is
    /// multiplied by for the moduli's growth since the refresh (module docs).
    /// `m_min` is the view's [`Self::smallest_node_mass`]; `diag` receives
    /// [`diagonal_argmax`] of the view when the check computes it (a refresh reuses it).
    fn staleness(
        &mut self,
        view: &ViewNd<'_, D>,
        m_min: f64,
        diag: &mut Option<(f64, usize)>,
    ) -> Option<f64> {
        if self.lambda.is_none()
            || self.age >= self.config.max_age
            || self.x_ref.len() != Self::n_refs(view)
            || self.ritz.len() != view.n_nodes() * D
        {
            return None;
        }
        let growth_limit = 1.0 + self.config.refresh_modulus;
        if m_min.is_infinite() {
            // No active node.
            return None;
        }
        if m_min < (1.0 - self.config.refresh_mass) * self.mass_ref {
            // A lighter node: refresh only if some node's diagonal of A grew (module docs).
            let d = diag.insert(diagonal_argmax(view, &*self.reduce)).0;
            let growth = d / self.diag_ref;
            if growth.is_nan() || growth > 1.0 + self.config.refresh_diagonal {
                return None;
            }
            self.diag_growth = self.diag_growth.max(growth);
            self.mass_ref = m_min;
        }
        let grid = view.split.as_ref().map_or(view.grid, |s| s.whole);
        let h = grid.h;
        let lim = self.config.refresh_cells;
        // On a periodic axis a particle that wrapped around shows a jump of one box length:
        // its displacement is taken modulo the box.
        let period: [f64; D] = std::array::from_fn(|a| match grid.boundary[a] {
            crate::Boundary::Periodic => grid.length(a),
            _ => f64::INFINITY,
        });
        let mut growth: f64 = 1.0;
        for p in 0..view.n_particles() {
            let key = Self::key(view, p);
            let dx = view.x[p] - self.x_ref[key];
            for a in 0..D {
                if dx[a].abs() <= lim * h[a] {
                    continue;
                }
                let d = if period[a].is_finite() {
                    dx[a] - period[a] * (dx[a] / period[a]).round()
                } else {
                    dx[a]
                };
                if d.is_nan() || d.abs() > lim * h[a] {
                    return None;
                }
            }
            let (bulk, shear) = Self::moduli(view, p);
            let (bulk_ref, shear_ref) = self.moduli_ref[key];
            let r_bulk = bulk / bulk_ref;
            let r_shear = if shear_ref > 0.0 {
                shear / shear_ref
            } else if shear > 0.0 {
                f64::INFINITY
            } else {
                0.0
            };
            let r = r_bulk.max(r_shear);
            // NaN (a non-finite modulus) forces a refresh.
            if r.is_nan() || r > growth_limit {
                return None;
            }
            growth = growth.max(r);
        }
        Some(growth.max(self.diag_growth))
    }

    /// Keeps the positions and moduli of the analysed state. On a decomposed grid the
    /// particles of every process, by run-wide identity (one reduction of
    /// `n_total·(D + 2)` numbers), as particles move between processes before the next
    /// comparison; this costs `n_total·(D + 2)` numbers of memory on every process.
    fn store_references(&mut self, view: &ViewNd<'_, D>) {
        let Some(split) = &view.split else {
            self.x_ref = view.x.to_vec();
            self.moduli_ref = (0..view.n_particles())
                .map(|p| Self::moduli(view, p))
                .collect();
            return;
        };
        let n = split.n_particles_total;
        let w = D + 2;
        let mut buf = vec![0.0; n * w];
        for p in 0..view.n_particles() {
            let k = split.particle_id[p] as usize * w;
            let (bulk, shear) = Self::moduli(view, p);
            buf[k..k + D].copy_from_slice(view.x[p].as_slice());
            buf[k + D] = bulk;
            buf[k + D + 1] = shear;
        }
        Self::agreement(&*self.reduce, view).sum(&mut buf);
        self.x_ref = buf
            .chunks_exact(w)
            .map(|c| Vector::<D>::from_column_slice(&c[..D]))
            .collect();
        self.moduli_ref = buf.chunks_exact(w).map(|c| (c[D], c[D + 1])).collect();
    }

    /// `m_min` is the view's [`Self::smallest_node_mass`], `diag` its [`diagonal_argmax`]
    /// when [`Self::staleness`] computed it.
    fn refresh(
        &mut self,
        view: &ViewNd<'_, D>,
        m_min: f64,
        diag: Option<(f64, usize)>,
    ) -> Result<f64, LimitError> {
        let n = view.n_nodes() * D;
        let space = NodalSpace::new(view, &*self.reduce);
        // Component `c` of the local vectors is component `global(c)` of the whole grid's:
        // starts are functions of the latter, the same however the grid is split.
        let global = |c: usize| space.global(c / D) * D + c % D;
        let n_global = (space.global_nodes() * D) as f64;
        let (diag_max, diag_at) = diag.unwrap_or_else(|| diagonal_argmax(view, &*self.reduce));
        let warm = self.ritz.len() == n;
        let mut start: Vec<f64> = if warm {
            // Warm start, nudged so that it is never orthogonal to a new top mode.
            self.ritz
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v + 0.1 * (((global(i) * 7919) % 97) as f64 / 97.0 - 0.5) / n_global.sqrt()
                })
                .collect()
        } else {
            checkerboard_start(view, &space)
        };
        // A warm start plus the unit velocity at the stiffest node for its mass: a mode
        // localised on a light node, far from the previous top mode, is then in the Krylov
        // space from the first product. (Not on a cold start: there it dilutes the
        // checkerboards and costs products — measured 2 against 20 on the 3D GIMP wave, 4
        // against 11 on the linear-hat small-mass layout, with equal or higher values.)
        let scale = space.dot(&start, &start).sqrt();
        if warm && scale > 0.0 {
            for (c, value) in start.iter_mut().enumerate() {
                if global(c) == diag_at {
                    *value += scale;
                }
            }
        }
        let r = lanczos_reduced(
            view,
            &start,
            self.config.tol,
            self.config.max_iter,
            &*self.reduce,
        );
        let lambda = r.lambda * (1.0 + self.config.tol) * self.config.margin;
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(LimitError::Other {
                limit: STABILITY.into(),
                message: format!(
                    "λmax estimate {lambda:e} is not a positive number at t = {}",
                    view.t
                ),
            });
        }
        self.gain = match self.config.transfer {
            TransferNd::Flip => 1.0,
            TransferNd::Apic { inertia } => apic_gain(view, &space, &r.vector, inertia),
        };
        self.ritz = r.vector;
        self.store_references(view);
        self.mass_ref = m_min;
        self.diag_ref = diag_max;
        self.diag_growth = 1.0;
        self.age = 0;
        self.refreshes += 1;
        self.applications += r.applications as u64;
        self.lambda = Some(lambda);
        Ok(lambda)
    }
}

/// A cold start close to the top of the spectrum: in component `a`, the checkerboard along
/// axis `a`, `(−1)^(j_a)` (the P wave of the highest wavenumber along each axis, which
/// carries `λmax` on uniform GIMP and linear-hat layouts: across the other axes the
/// weights sum to one, where the full checkerboard's alternating sums nearly cancel),
/// plus half the full checkerboard `(−1)^(Σ_b j_b)` and a small seeded perturbation so
/// that no mode is missed; all functions of the node in the whole grid. On the 3D GIMP
/// wave of 10⁵ particles the first Rayleigh quotient is 0.82 of `λmax`, against 0.20 for
/// the previous start (the full checkerboard plus the diagonal bump), and Lanczos settles
/// in 2 products instead of 20.
pub(super) fn checkerboard_start<const D: usize>(
    view: &ViewNd<'_, D>,
    space: &NodalSpace<'_, '_, D>,
) -> Vec<f64> {
    let n = view.n_nodes();
    let whole = view.split.as_ref().map_or(view.grid, |s| s.whole);
    let mut out = Vec::with_capacity(n * D);
    for local in 0..n {
        let i = space.global(local);
        let j = whole.lattice_of(i);
        let sign = if j.iter().sum::<i64>().rem_euclid(2) == 0 {
            1.0
        } else {
            -1.0
        };
        for (a, &ja) in j.iter().enumerate() {
            let noise = ((i * D + a) * 7919 % 101) as f64 / 101.0 - 0.5;
            let along = if ja.rem_euclid(2) == 0 { 1.0 } else { -1.0 };
            out.push(along + 0.5 * sign + 0.1 * noise);
        }
    }
    out
}

impl<const D: usize> StepLimit<D> for StabilityNd<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    fn name(&self) -> &str {
        STABILITY
    }

    fn propose(&mut self, state: &ViewNd<'_, D>) -> Result<Proposal, LimitError> {
        let mut metrics = Metrics::new();
        // The smallest nodal mass first: a reduction every process makes, on every step.
        let m_min = self.smallest_node_mass(state);
        let mut diag = None;
        let local = self.staleness(state, m_min, &mut diag);
        // The processes of a split run agree: any stale part refreshes everywhere, and
        // the moduli growth is the largest of all (`crate::reduce`).
        let (neg_growth, stale) = Self::agreement(&*self.reduce, state)
            .min_and_any(-local.unwrap_or(1.0), local.is_none());
        let agreed = (!stale).then_some(-neg_growth);
        let lambda = match (agreed, self.lambda) {
            (Some(growth), Some(cached)) => cached * growth,
            _ => {
                let l = self.refresh(state, m_min, diag)?;
                metrics.insert("refreshes".into(), self.refreshes as f64);
                metrics.insert("lanczos_applications".into(), self.applications as f64);
                l
            }
        };
        self.age += 1;
        metrics.insert(crate::controller::metric::LAMBDA_MAX.into(), lambda);
        if self.config.transfer != TransferNd::Flip {
            metrics.insert("transfer_gain".into(), self.gain);
        }
        Ok(Proposal {
            dt: self.safety * (2.0 * self.gain / lambda).sqrt(),
            metrics,
        })
    }

    fn scale_safety(&mut self, factor: f64) {
        if factor.is_finite() && factor > 0.0 {
            self.safety *= factor;
        }
    }

    fn set_reduce(&mut self, reduce: Rc<dyn Reduce>) {
        self.reduce = reduce;
    }
}
