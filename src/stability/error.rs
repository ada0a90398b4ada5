//! The error type of the stability module.

use crate::limit::LimitError;
pub(crate) use crate::view_check::all_finite;

/// Why a stability quantity could not be computed. Bad input is reported, never panicked on.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StabilityError {
    /// A field of the view holds a value the analysis cannot use (NaN stress, a modulus,
    /// density, volume or deformation gradient that is not positive and finite, …).
    #[error("invalid {field} at index {index}: {value}")]
    InvalidField {
        /// Which field (`"sigma"`, `"tangent_modulus"`, `"node_mass"`, …).
        field: &'static str,
        /// Particle or node index; for `"nodal_stiffness"` the position in
        /// [`crate::NodalStiffness::values`] (its diagonal, then `upper1`, then `upper2`).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A slice of the view has the wrong length.
    #[error("{field} has length {len}, expected {expected}")]
    LengthMismatch {
        /// Which field.
        field: &'static str,
        /// Its length.
        len: usize,
        /// The expected length.
        expected: usize,
    },
    /// The view has no particles.
    #[error("the state has no particles")]
    NoParticles,
    /// No node is active (every node empty or constrained): the operator is zero.
    #[error("no active node: every node is empty or constrained")]
    NoActiveNodes,
    /// A time step is not positive and finite.
    #[error("invalid time step {dt}")]
    InvalidDt {
        /// The offending step.
        dt: f64,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration {field} = {value}: {reason}")]
    InvalidConfig {
        /// Which field.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// The admissible range.
        reason: &'static str,
    },
    /// A dense eigenvalue or singular value computation did not converge.
    #[error("dense {what} did not converge")]
    NoConvergence {
        /// Which decomposition.
        what: &'static str,
    },
    /// A solver run needed by the empirical critical step could not be set up.
    #[error("setting up a run failed: {0}")]
    Setup(String),
    /// A search for a critical step found no bracket.
    #[error("no bracket for the critical step: stable up to dt = {stable}, tried up to {tried}")]
    NoBracket {
        /// Largest step found stable.
        stable: f64,
        /// Largest step tried.
        tried: f64,
    },
}

impl StabilityError {
    /// Converts to the [`LimitError`] a [`crate::limit::StepLimit`] returns.
    pub fn into_limit_error(self, limit: &str, t: f64) -> LimitError {
        match self {
            StabilityError::InvalidField {
                field,
                index,
                value,
            } => LimitError::InvalidState {
                limit: limit.to_owned(),
                field,
                index,
                value,
                t,
            },
            other => LimitError::Other {
                limit: limit.to_owned(),
                message: other.to_string(),
            },
        }
    }
}

/// Checks the fields the stability analysis reads: lengths, finite `x`, `v`, `σ`, positive
/// finite `F`, `V⁰`, `m_p`, `E_t`, `ρ`, and positive finite mass at every active node, and at
/// least one active node.
///
/// Every limit calls this on every view it sees, so it is on the controller's per-step path.
/// A view with a [`crate::PassSummary`] is the stepper's guarantee that these checks hold:
/// only the sizes are checked then.
/// A valid view (the normal case) is confirmed by one fused pass over the particles
/// ([`scan_particles`]) and one over the nodes, branch-free within blocks of particles so
/// that it vectorises. Only when that pass finds a problem does [`check_view_exact`] run the
/// field-by-field checks, so the error reported (which field, which index, which check
/// first) is exactly the one the field-by-field order gives.
pub(crate) fn check_view(view: &crate::stepper::View<'_>) -> Result<(), StabilityError> {
    match check_view_scan(view, false) {
        Some(_) => Ok(()),
        None => check_view_exact(view),
    }
}

/// The particles' speeds a state's sound-speed step is formed from (all `≥ 0`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Speeds {
    /// `max_p E_t,p/ρ_p`, the squared largest wave speed.
    pub c2: f64,
    /// `max_p |v_p|`.
    pub v: f64,
    /// `max_p (√(E_t,p/ρ_p) + |v_p|)`, the largest signal speed
    /// ([`crate::sound_speed`]).
    pub signal: f64,
}

/// `max_p (√(E_t,p/ρ_p) + |v_p|)` by a plain pass, for values known to be finite and positive.
fn plain_signal(view: &crate::stepper::View<'_>) -> f64 {
    (0..view.n_particles())
        .map(|p| view.wave_speed(p) + view.v[p].abs())
        .fold(0.0, max)
}

/// [`check_view`] and, from the same pass over the particles, the [`Speeds`]. The squared
/// wave speed is returned rather than `max_p √(E_t/ρ)`: `√` is monotone and correctly
/// rounded, so `√(max_p E_t/ρ) = max_p √(E_t/ρ)` bit for bit.
pub(crate) fn check_view_speeds(view: &crate::stepper::View<'_>) -> Result<Speeds, StabilityError> {
    match check_view_scan(view, true) {
        Some((c2, v, signal)) => Ok(Speeds {
            c2,
            v,
            signal: signal.unwrap_or_else(|| plain_signal(view)),
        }),
        None => {
            check_view_exact(view)?;
            // Unreachable in practice: the scan fails only where the exact check fails.
            // Computed plainly so that a disagreement could never change a result.
            let n = view.n_particles();
            let c2 = (0..n)
                .map(|p| view.tangent_modulus[p] / view.density[p])
                .fold(0.0, f64::max);
            let v = view.v.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            Ok(Speeds {
                c2,
                v,
                signal: plain_signal(view),
            })
        }
    }
}

/// Lanes of the scans: each lane keeps its own accumulators, so the loops are plain
/// element-wise float operations (which the compiler vectorises) instead of one sequential
/// chain, and `f64::is_finite` (which compiles to scalar integer bit tests) is not used.
const LANES: usize = 8;

/// The fast path of [`check_view`]: `Some((max E_t/ρ, max |v|, max (√(E_t/ρ) + |v|)))` (zeros
/// unless `speeds`; the last `None` where a trusted summary vouches for the values but does
/// not carry it) when every check passes, `None` when any may fail.
///
/// The scan only has to be *sound*: it never returns `Some` for a view the exact check
/// rejects, while a false alarm (an overflowing sum of large finite values) merely sends
/// the caller to [`check_view_exact`].
fn check_view_scan(
    view: &crate::stepper::View<'_>,
    speeds: bool,
) -> Option<(f64, f64, Option<f64>)> {
    let n = view.n_particles();
    let nn = view.grid.n_nodes();
    if n == 0
        || [
            view.v.len(),
            view.sigma.len(),
            view.f.len(),
            view.volume0.len(),
            view.mass.len(),
            view.tangent_modulus.len(),
            view.density.len(),
            view.weights.n_particles(),
        ]
        .iter()
        .any(|&len| len != n)
        || [
            view.weights.n_nodes(),
            view.node_mass.len(),
            view.node_velocity.len(),
            view.node_acceleration.len(),
            view.node_active.len(),
        ]
        .iter()
        .any(|&len| len != nn)
    {
        return None;
    }
    // The stepper's summary vouches for the per-value checks and carries the maxima
    // (`crate::pass_summary`): only the sizes, O(1), were left to check.
    if let Some(summary) = view.trusted_summary() {
        return Some(if speeds {
            (
                summary.max_wave_speed_sq,
                summary.max_speed,
                summary.max_signal_speed,
            )
        } else {
            (0.0, 0.0, Some(0.0))
        });
    }
    let out = if speeds {
        scan_particles::<true>(view)?
    } else {
        scan_particles::<false>(view)?
    };
    // Active nodes: positive finite mass; inactive ones count as mass 1.
    let (mut bad, mut lo) = ([0.0_f64; LANES], [f64::INFINITY; LANES]);
    let mut any = false;
    let mass = view.node_mass.chunks_exact(LANES);
    let active = view.node_active.chunks_exact(LANES);
    let (mass_rest, active_rest) = (mass.remainder(), active.remainder());
    for (m, a) in mass.zip(active) {
        for k in 0..LANES {
            let mk = if a[k] { m[k] } else { 1.0 };
            bad[k] += mk * 0.0;
            lo[k] = min(mk, lo[k]);
            any |= a[k];
        }
    }
    for (&m, &a) in mass_rest.iter().zip(active_rest) {
        let m = if a { m } else { 1.0 };
        bad[0] += m * 0.0;
        lo[0] = min(m, lo[0]);
        any |= a;
    }
    let bad = bad.into_iter().fold(0.0, |a, b| a + b);
    let lo = lo.into_iter().fold(f64::INFINITY, min);
    (bad == 0.0 && lo > 0.0 && any).then_some(out)
}

/// The particle part of [`check_view_scan`]; with `SPEEDS` it also takes `max E_t/ρ`,
/// `max |v|` and `max (√(E_t/ρ) + |v|)` (in the pass that checks `E_t`, `ρ` and `v`).
///
/// One vectorised pass per field (each field is still read once; `E_t` and `ρ` together).
/// A value `x` is finite exactly when `0·x` is `±0` rather than NaN, so a lane's sum of `0·x`
/// is 0 exactly when all its values are finite; the positive fields are also checked
/// through their minimum. The maxima are taken per lane and then over the lanes; for values
/// without NaN `max` does not depend on the order, so they equal the left-to-right
/// `f64::max` fold bit for bit.
fn scan_particles<const SPEEDS: bool>(
    view: &crate::stepper::View<'_>,
) -> Option<(f64, f64, Option<f64>)> {
    let ok = [view.x, view.sigma].into_iter().all(all_finite)
        && [view.f, view.volume0, view.mass]
            .into_iter()
            .all(all_positive);
    if !ok {
        return None;
    }
    if !SPEEDS {
        return (all_finite(view.v)
            && all_positive(view.tangent_modulus)
            && all_positive(view.density))
        .then_some((0.0, 0.0, Some(0.0)));
    }
    let (c2, vmax, signal) = speed_maxima(view.v, view.tangent_modulus, view.density)?;
    Some((c2, vmax, Some(signal)))
}

/// Whether every value is positive and finite (lane-wise, see [`scan_particles`]).
fn all_positive(values: &[f64]) -> bool {
    let mut bad = [0.0_f64; LANES];
    let mut lo = [f64::INFINITY; LANES];
    let mut chunks = values.chunks_exact(LANES);
    for c in chunks.by_ref() {
        for k in 0..LANES {
            bad[k] += c[k] * 0.0;
            lo[k] = min(c[k], lo[k]);
        }
    }
    for &x in chunks.remainder() {
        bad[0] += x * 0.0;
        lo[0] = min(x, lo[0]);
    }
    bad.iter().all(|&b| b == 0.0) && lo.iter().all(|&l| l > 0.0)
}

/// `(max_p e_p/r_p, max_p |v_p|, max_p (√(e_p/r_p) + |v_p|))` if every value of `v` is finite
/// and every value of `e` and `r` positive and finite (equal lengths; lane-wise, see
/// [`scan_particles`]).
fn speed_maxima(v: &[f64], e: &[f64], r: &[f64]) -> Option<(f64, f64, f64)> {
    if e.len() != r.len() || v.len() != e.len() {
        return None;
    }
    let mut bad = [0.0_f64; LANES];
    let mut lo = [f64::INFINITY; LANES];
    let (mut c2, mut vm, mut sig) = ([0.0_f64; LANES], [0.0_f64; LANES], [0.0_f64; LANES]);
    let mut lane = |k: usize, (u, a, b): (f64, f64, f64)| {
        bad[k] += u * 0.0 + a * 0.0 + b * 0.0;
        lo[k] = min(min(a, b), lo[k]);
        let q = a / b;
        c2[k] = max(q, c2[k]);
        vm[k] = max(u.abs(), vm[k]);
        sig[k] = max(q.sqrt() + u.abs(), sig[k]);
    };
    let (mut cv, mut ce, mut cr) = (
        v.chunks_exact(LANES),
        e.chunks_exact(LANES),
        r.chunks_exact(LANES),
    );
    for ((u, a), b) in cv.by_ref().zip(ce.by_ref()).zip(cr.by_ref()) {
        for k in 0..LANES {
            lane(k, (u[k], a[k], b[k]));
        }
    }
    let rest = cv
        .remainder()
        .iter()
        .zip(ce.remainder())
        .zip(cr.remainder());
    for ((&u, &a), &b) in rest {
        lane(0, (u, a, b));
    }
    let fold = |l: [f64; LANES]| l.into_iter().fold(0.0, max);
    (bad.iter().all(|&b| b == 0.0) && lo.iter().all(|&l| l > 0.0))
        .then(|| (fold(c2), fold(vm), fold(sig)))
}

/// `a < b ? a : b` (one `minpd`; only used where NaN has been excluded or is caught
/// otherwise).
#[inline(always)]
fn min(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// `a > b ? a : b` (one `maxpd`; only used where NaN has been excluded or is caught
/// otherwise).
#[inline(always)]
fn max(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// The field-by-field checks, in the order that decides which error is reported.
fn check_view_exact(view: &crate::stepper::View<'_>) -> Result<(), StabilityError> {
    let n = view.n_particles();
    if n == 0 {
        return Err(StabilityError::NoParticles);
    }
    let nn = view.grid.n_nodes();
    let particle_fields: [(&'static str, &[f64], bool); 8] = [
        ("x", view.x, false),
        ("v", view.v, false),
        ("sigma", view.sigma, false),
        ("F", view.f, true),
        ("volume0", view.volume0, true),
        ("mass", view.mass, true),
        ("tangent_modulus", view.tangent_modulus, true),
        ("density", view.density, true),
    ];
    for (field, values, positive) in particle_fields {
        if values.len() != n {
            return Err(StabilityError::LengthMismatch {
                field,
                len: values.len(),
                expected: n,
            });
        }
        if let Some((index, &value)) = values
            .iter()
            .enumerate()
            .find(|(_, &v)| !v.is_finite() || (positive && v <= 0.0))
        {
            return Err(StabilityError::InvalidField {
                field,
                index,
                value,
            });
        }
    }
    if view.weights.n_particles() != n {
        return Err(StabilityError::LengthMismatch {
            field: "weights",
            len: view.weights.n_particles(),
            expected: n,
        });
    }
    if view.weights.n_nodes() != nn {
        return Err(StabilityError::LengthMismatch {
            field: "weights (nodes)",
            len: view.weights.n_nodes(),
            expected: nn,
        });
    }
    check_nodes(view)
}

/// The nodal part of [`check_view`]: lengths of the nodal fields, positive finite mass at
/// every active node, and at least one active node. What a reader of nodal data only (the
/// stability limit when the stepper provides `K_N`) needs checked.
pub(crate) fn check_nodes(view: &crate::stepper::View<'_>) -> Result<(), StabilityError> {
    let nn = view.grid.n_nodes();
    for (field, len) in [
        ("node_mass", view.node_mass.len()),
        ("node_velocity", view.node_velocity.len()),
        ("node_acceleration", view.node_acceleration.len()),
        ("node_active", view.node_active.len()),
    ] {
        if len != nn {
            return Err(StabilityError::LengthMismatch {
                field,
                len,
                expected: nn,
            });
        }
    }
    let mut any = false;
    for (i, (&m, &active)) in view.node_mass.iter().zip(view.node_active).enumerate() {
        if active {
            if !(m.is_finite() && m > 0.0) {
                return Err(StabilityError::InvalidField {
                    field: "node_mass",
                    index: i,
                    value: m,
                });
            }
            any = true;
        }
    }
    if !any {
        return Err(StabilityError::NoActiveNodes);
    }
    Ok(())
}

/// Checks that `dt` is positive and finite.
pub(crate) fn check_dt(dt: f64) -> Result<(), StabilityError> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(StabilityError::InvalidDt { dt })
    }
}
