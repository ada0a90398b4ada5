//! The stability limit's motion guard: the positions and moduli of the analysed state,
//! and whether the current state is still close enough to it (the parent module's docs).
//!
//! The positions are kept relative to the grid's origin in single precision (12 bytes a
//! particle in 3D instead of 24): a particle counts as moved past `refresh_cells·h` when
//! its displacement from the rounded reference exceeds the threshold lowered by `2^-22`
//! of the coordinates' magnitude (and the period's), a bound on the rounding. The guard thus refreshes whenever the exact
//! positions would make it refresh, and in addition only when a displacement lies within
//! that bound (about `10⁻⁷` of a coordinate) below the threshold.

use super::guard_scan::{scan, GuardRefs, GuardRows, GuardScan, GUARD_CHUNK};
use super::GuardedEq56;
use crate::limits_nd::stiffness::diagonal_argmax;
use crate::nd::{Vector, ViewNd};
use rayon::prelude::*;

/// Relative bound on the difference between a position and its single-precision
/// reference, with the rounding of the displacement's arithmetic: `2^-22`, four times the
/// half-ulp `2^-24` of `f32`.
const REFERENCE_ROUNDING: f64 = 1.0 / (1u64 << 22) as f64;

/// A position relative to the grid's `origin`, rounded to single precision (a motion-guard
/// reference: 4 bytes an axis).
fn single<const D: usize>(x: &Vector<D>, origin: &[f64; D]) -> [f32; D] {
    std::array::from_fn(|a| (x[a] - origin[a]) as f32)
}

/// `(V(dλ_t + 2μ_t), Vμ_t)` of a particle of volume `vol` ([`GuardedEq56`]'s guard).
#[inline]
pub(super) fn moduli_of<const D: usize>(vol: f64, l: f64, m: f64) -> (f64, f64) {
    (vol * (D as f64 * l + 2.0 * m), vol * m)
}

/// Whether a particle at `x` has moved more than `lim` cells on some axis from its
/// single-precision reference `x_ref` (relative to the grid's origin; on a periodic axis of
/// length `period` modulo the box); `None` where a displacement is NaN.
///
/// The reference is the position rounded to single precision: the threshold is lowered by
/// a bound on that rounding (and on the arithmetic's), so the guard refreshes whenever the
/// exact positions would have it refresh.
pub(super) fn moved_past<const D: usize>(
    x: &Vector<D>,
    x_ref: &[f32; D],
    grid: &crate::nd::GridNd<D>,
    period: &[f64; D],
    lim: f64,
) -> Option<bool> {
    let mut moved = false;
    for a in 0..D {
        let (x, xr) = (x[a] - grid.origin[a], f64::from(x_ref[a]));
        let dx = x - xr;
        let periodic = if period[a].is_finite() {
            period[a]
        } else {
            0.0
        };
        let allowed = lim * grid.h[a] - (xr.abs() + x.abs() + periodic) * REFERENCE_ROUNDING;
        if dx.abs() <= allowed {
            continue;
        }
        let d = if period[a].is_finite() {
            dx - period[a] * (dx / period[a]).round()
        } else {
            dx
        };
        if d.is_nan() {
            return None;
        }
        moved |= d.abs() > allowed;
    }
    Some(moved)
}

/// What the guard found against the analysed state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Staleness {
    /// Close enough: the cached `λmax` times this factor (≥ 1, the moduli's growth).
    Fresh(f64),
    /// Some particle moved more than `refresh_cells` of a cell, nothing else is stale;
    /// the moduli's growth factor as for [`Staleness::Fresh`].
    Moved(f64),
    /// The cached value must be recomputed.
    Stale,
}

impl<const D: usize> GuardedEq56<D> {
    /// The two eigenvalues of `V_p C_p` on symmetric tensors: `V(dλ_t + 2μ_t)` (volumetric)
    /// and `2Vμ_t` (deviatoric), the latter stored halved as `Vμ_t`.
    #[inline]
    fn moduli(view: &ViewNd<'_, D>, p: usize) -> (f64, f64) {
        moduli_of::<D>(view.volume(p), view.lame_lambda[p], view.lame_mu[p])
    }

    /// Smallest active nodal mass, `+∞` when no node is active (on a decomposed grid,
    /// [`ViewNd::split`], the smallest over the processes: one reduction).
    pub(super) fn smallest_node_mass(&self, view: &ViewNd<'_, D>) -> f64 {
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

    /// Number of particle references kept: the whole run's on a decomposed grid.
    fn n_refs(view: &ViewNd<'_, D>) -> usize {
        view.split
            .as_ref()
            .map_or(view.n_particles(), |s| s.n_particles_total)
    }

    /// Whether the cached `λmax` must be recomputed ([`Staleness::Stale`]), or else the
    /// factor `r ≥ 1` it is multiplied by for the moduli's growth since the refresh, and
    /// whether some particle moved more than `refresh_cells` (module docs). With
    /// `check_motion` false the positions are not read (the calibrated bound watches the
    /// layout instead, [`crate::limits_nd::bound_tracking`]).
    /// `m_min` is the view's [`Self::smallest_node_mass`]; `diag` receives
    /// [`diagonal_argmax`] of the view when the check computes it (a refresh reuses it).
    pub(super) fn staleness(
        &mut self,
        view: &ViewNd<'_, D>,
        m_min: f64,
        diag: &mut Option<(f64, usize)>,
        check_motion: bool,
        calibrated: bool,
    ) -> Staleness {
        if self.tracked.lambda.is_none()
            || self.tracked.age >= self.config.max_age
            || self.tracked.x_ref.len() != Self::n_refs(view)
            || self.tracked.ritz.len() != view.n_nodes() * D
        {
            return Staleness::Stale;
        }
        // Under the calibrated bound a growth of the moduli or of the light nodes' diagonal
        // up to `bound_drift` scales the cached value instead of refreshing it: a refresh
        // costs several products, the scaling a slightly shorter step.
        let loosen = |limit: f64| match calibrated {
            true => limit.max(self.config.bound_drift),
            false => limit,
        };
        let growth_limit = 1.0 + loosen(self.config.refresh_modulus);
        if m_min.is_infinite() {
            // No active node.
            return Staleness::Stale;
        }
        if m_min < (1.0 - self.config.refresh_mass) * self.tracked.mass_ref {
            // A lighter node: refresh only if some node's diagonal of A grew (module docs).
            let d = diag.insert(diagonal_argmax(view, &*self.reduce)).0;
            let growth = d / self.tracked.diag_ref;
            if growth.is_nan() || growth > 1.0 + loosen(self.config.refresh_diagonal) {
                return Staleness::Stale;
            }
            self.tracked.diag_growth = self.tracked.diag_growth.max(growth);
            self.tracked.mass_ref = m_min;
        }
        let grid = view.split.as_ref().map_or(view.grid, |s| s.whole);
        let lim = self.config.refresh_cells;
        // On a periodic axis a particle that wrapped around shows a jump of one box length:
        // its displacement is taken modulo the box.
        let period: [f64; D] = std::array::from_fn(|a| match grid.boundary[a] {
            crate::Boundary::Periodic => grid.length(a),
            _ => f64::INFINITY,
        });
        let rows = GuardRows::of(view);
        let refs = GuardRefs {
            x: &self.tracked.x_ref,
            moduli: &self.tracked.moduli_ref,
            grid,
            period,
            lim,
            growth_limit,
        };
        let n = view.n_particles();
        let found = match &self.pool {
            // On the controller's threads: chunks of a fixed size, combined by `any` and
            // `max`, which do not depend on the order, so the result is the one-thread
            // result bit for bit.
            Some(pool) if n > GUARD_CHUNK => pool.install(|| {
                (0..n.div_ceil(GUARD_CHUNK))
                    .into_par_iter()
                    .map(|k| {
                        let r = k * GUARD_CHUNK..((k + 1) * GUARD_CHUNK).min(n);
                        scan(&rows, &refs, r, check_motion)
                    })
                    .reduce(GuardScan::default, GuardScan::merge)
            }),
            _ => scan(&rows, &refs, 0..n, check_motion),
        };
        if found.stale {
            return Staleness::Stale;
        }
        let growth = found.growth.max(self.tracked.diag_growth);
        if found.moved {
            Staleness::Moved(growth)
        } else {
            Staleness::Fresh(growth)
        }
    }

    /// Takes the current positions as the motion guard's reference, the moduli's
    /// reference staying the refresh's (the calibrated bound re-anchored,
    /// [`crate::limits_nd::bound_tracking`]; an undivided grid only).
    pub(super) fn reanchor_positions(&mut self, view: &ViewNd<'_, D>) {
        let origin = view.grid.origin;
        self.tracked.x_ref.clear();
        self.tracked
            .x_ref
            .extend(view.x.iter().map(|x| single(x, &origin)));
    }

    /// Keeps the positions and moduli of the analysed state. On a decomposed grid the
    /// particles of every process, by run-wide identity (one reduction of
    /// `n_total·(D + 2)` numbers), as particles move between processes before the next
    /// comparison; this costs `n_total·(D + 2)` numbers of memory on every process.
    pub(super) fn store_references(&mut self, view: &ViewNd<'_, D>) {
        let origin = view.split.as_ref().map_or(view.grid, |s| s.whole).origin;
        let Some(split) = &view.split else {
            // Overwritten in place: no second copy while the old references are dropped.
            self.tracked.x_ref.clear();
            self.tracked
                .x_ref
                .extend(view.x.iter().map(|x| single(x, &origin)));
            self.tracked.moduli_ref.clear();
            self.tracked
                .moduli_ref
                .extend((0..view.n_particles()).map(|p| Self::moduli(view, p)));
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
        self.tracked.x_ref = buf
            .chunks_exact(w)
            .map(|c| single(&Vector::<D>::from_column_slice(&c[..D]), &origin))
            .collect();
        self.tracked.moduli_ref = buf.chunks_exact(w).map(|c| (c[D], c[D + 1])).collect();
    }
}
