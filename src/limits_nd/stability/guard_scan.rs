//! The layout guard's pass over the particles ([`super::guard`]): whether some particle
//! moved past the threshold, the largest growth of the moduli `V_p C_p` since the
//! analysed state, and whether some value forces a refresh. A pass over a range of
//! particles reads plain slices only, so that ranges can run on several threads
//! ([`crate::controller::Controller::with_threads`]); the results combine by `any` and
//! `max`, which do not depend on the order.

use super::guard::{moduli_of, moved_past};
use crate::nd::{GridNd, Tensor, Vector, ViewNd};

/// Particles per range of a threaded scan (fixed: not the thread count).
pub(super) const GUARD_CHUNK: usize = 8192;

/// The particle fields the guard reads.
pub(super) struct GuardRows<'a, const D: usize> {
    x: &'a [Vector<D>],
    f: &'a [Tensor<D>],
    volume0: &'a [f64],
    lame_lambda: &'a [f64],
    lame_mu: &'a [f64],
    /// Run-wide particle identities on a decomposed grid (the references' keys).
    ids: Option<&'a [u64]>,
}

impl<'a, const D: usize> GuardRows<'a, D> {
    /// The rows of `view`.
    pub fn of(view: &ViewNd<'a, D>) -> Self {
        Self {
            x: view.x,
            f: view.f,
            volume0: view.volume0,
            lame_lambda: view.lame_lambda,
            lame_mu: view.lame_mu,
            ids: view.split.as_ref().map(|s| s.particle_id),
        }
    }
}

/// The analysed state's references and the thresholds.
pub(super) struct GuardRefs<'a, const D: usize> {
    pub x: &'a [[f32; D]],
    pub moduli: &'a [(f64, f64)],
    /// The whole grid (walls and periods).
    pub grid: &'a GridNd<D>,
    /// Each axis's period (`∞` on a fixed axis).
    pub period: [f64; D],
    /// The motion threshold in cells.
    pub lim: f64,
    /// The moduli's growth beyond which the cached value is stale.
    pub growth_limit: f64,
}

/// What a scan found.
#[derive(Clone, Copy, Debug)]
pub(super) struct GuardScan {
    /// Some value forces a refresh.
    pub stale: bool,
    /// Some particle moved past the threshold.
    pub moved: bool,
    /// The largest growth of the moduli (≥ 1).
    pub growth: f64,
}

impl Default for GuardScan {
    fn default() -> Self {
        Self {
            stale: false,
            moved: false,
            growth: 1.0,
        }
    }
}

impl GuardScan {
    /// Both scans' findings.
    pub fn merge(self, other: Self) -> Self {
        Self {
            stale: self.stale || other.stale,
            moved: self.moved || other.moved,
            growth: self.growth.max(other.growth),
        }
    }
}

/// The guard's pass over the particles `range` (module docs); with `check_motion` false
/// the positions are not read. Stops at the first particle that makes the state stale.
pub(super) fn scan<const D: usize>(
    rows: &GuardRows<'_, D>,
    refs: &GuardRefs<'_, D>,
    range: std::ops::Range<usize>,
    check_motion: bool,
) -> GuardScan {
    if !check_motion && rows.ids.is_none() {
        return scan_moduli(rows, refs, range);
    }
    let mut found = GuardScan::default();
    for p in range {
        let key = rows.ids.map_or(p, |ids| ids[p] as usize);
        if check_motion && !found.moved {
            match moved_past(&rows.x[p], &refs.x[key], refs.grid, &refs.period, refs.lim) {
                Some(m) => found.moved = m,
                None => {
                    found.stale = true;
                    return found;
                }
            }
        }
        let r = growth_of(rows, refs, p, key);
        // NaN (a non-finite modulus) forces a refresh.
        if r.is_nan() || r > refs.growth_limit {
            found.stale = true;
            return found;
        }
        found.growth = found.growth.max(r);
    }
    found
}

/// [`scan`] without the positions on an undivided grid: every particle read, without
/// the early exit, so that the loop has no branch on the values. The findings are
/// [`scan`]'s: the same `stale`, and where not stale the same `growth` (the maximum of
/// the same ratios; [`f64::max`] returns one of its arguments, in any order).
fn scan_moduli<const D: usize>(
    rows: &GuardRows<'_, D>,
    refs: &GuardRefs<'_, D>,
    range: std::ops::Range<usize>,
) -> GuardScan {
    let (mut stale, mut growth) = (false, 1.0f64);
    for p in range {
        let r = growth_of(rows, refs, p, p);
        stale |= r.is_nan() | (r > refs.growth_limit);
        growth = growth.max(r);
    }
    GuardScan {
        stale,
        moved: false,
        growth,
    }
}

/// Particle `p`'s growth of the moduli since the analysed state (reference `key`):
/// `max(bulk/bulk_ref, shear/shear_ref)`, NaN where a modulus is not finite.
#[inline(always)]
fn growth_of<const D: usize>(
    rows: &GuardRows<'_, D>,
    refs: &GuardRefs<'_, D>,
    p: usize,
    key: usize,
) -> f64 {
    let vol = crate::nd::det(&rows.f[p]) * rows.volume0[p];
    let (bulk, shear) = moduli_of::<D>(vol, rows.lame_lambda[p], rows.lame_mu[p]);
    let (bulk_ref, shear_ref) = refs.moduli[key];
    let r_bulk = bulk / bulk_ref;
    let r_shear = if shear_ref > 0.0 {
        shear / shear_ref
    } else if shear > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    r_bulk.max(r_shear)
}
