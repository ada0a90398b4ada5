//! The full map's critical step from the nodes: matrix-free, for layouts of any size.
//!
//! [`super::full_map`] assembles the frozen-particle linearised USL step `z' = T(dt) z` on
//! the particle state `z = (v_p, σ_p)` densely — `(d + d(d+1)/2)·n_p` unknowns, a dense
//! eigenvalue problem per trial step, so it stops at a few hundred unknowns. Its spectrum
//! reduces to the nodes exactly, and its critical step to one symmetric eigenvalue.
//!
//! # The reduction
//!
//! Write the map (eqs 17–29 as read in docs/design.md, every stage linear) through two
//! nodal vectors on the free active nodes (`Π` zeroes the others), the velocity
//! `g = Π M⁻¹ Sᵀ m v` and the acceleration `f = −Π M⁻¹ Dᵀ V σ`:
//!
//! ```text
//! v_p' = v_p + dt S f,        σ_p' = σ_p + dt C_p D (g + dt f)
//! ```
//!
//! so `T − I = U W` with `W z = (g, f)` (particles → nodes) and `U` (nodes → particles).
//! The nonzero eigenvalues of `UW` are those of `WU`, which acts on `(g, f)` as
//!
//! ```text
//! g' = dt P f,    f' = −dt A (g + dt f),    A = M⁻¹K,  P = M⁻¹Q,  Q = Sᵀ diag(m_p) S
//! ```
//!
//! (`K` the stiffness of eq 56, `Q` the consistent mass, both on the free active nodes).
//! Every eigenvalue of `T` is 1 or `μ = 1 + ν` with `ν` such an eigenvalue. At `μ = −1`
//! (`ν = −2`): `g = −(dt/2) P f` and then `A (I − P/2) f = (2/dt²) f`. So the map has the
//! eigenvalue −1 exactly at the steps
//!
//! ```text
//! dt = √(2/λ),    λ ∈ spec(A (I − P/2)),
//! ```
//!
//! and the first of them is `dt_c = √(2/λ*)`, `λ* = λmax(A (I − P/2))`. `A (I − P/2)` is
//! similar to `A_s (I − Q_s/2)` with `A_s = M^{-1/2} K M^{-1/2}` (eq 56's operator) and
//! `Q_s = M^{-1/2} Q M^{-1/2}`, and `0 ≤ Q ≤ M` (`M − Q` is a weighted graph Laplacian:
//! the rows of `Q` sum to the lumped masses — for non-negative weights that form a
//! partition of unity and nodal masses `m_i = Σ_p S_ip m_p`; on a view that breaks this the
//! iteration returns no answer), so `B = I − Q_s/2` is symmetric positive
//! definite and `A_s B` is self-adjoint in the `B` inner product: its eigenvalues are real
//! and non-negative, and Lanczos in that inner product finds `λ*` from products with `A_s`
//! and `Q_s` alone, each one pass over the particles' weights. Its Ritz values are Rayleigh
//! quotients `⟨x, A_s B x⟩_B / ⟨x, x⟩_B` over a growing Krylov space, so they rise to `λ*`
//! from below: the step `√(2/θ)` of a Ritz value `θ` is at or above `dt_c` until it
//! converges (the tolerance is tight for that reason, [`NodalLanczos`]).
//!
//! With `Q = 0` (no coupling through the particle velocities) this is eq 56's `√(2/λmax)`;
//! with `Q_s = I` (each particle on a node of its own, weight 1 there: the consistent mass
//! equal to the lumped one) it
//! is `√(4/λmax)`, the leapfrog limit. `Q` lies between: the full map's critical step is
//! between eq 56's and `√2` times it.
//!
//! # What it assumes
//!
//! The first instability is an eigenvalue leaving the unit circle through −1 (a pair
//! colliding there). That is what the dense map shows on every layout it has been run on
//! (the module [`super::full_map`]'s note; `tests/full_map_nodal.rs` compares the two on
//! 1D, 2D and 3D layouts of every shape): the complex eigenvalues `μ` lie inside the unit
//! circle because the map dissipates — exactly so when `P` and `A` commute (then `|μ|² =
//! 1 − dt²λ(1 − p)` for a complex pair, `p ≤ 1` the eigenvalue of `P`). A departure
//! elsewhere on the circle is not excluded in general; the dense map remains the
//! reference on small layouts.

use crate::lanczos::{self, dot, Inner, Settle};

mod one_d;
pub use one_d::{critical_dt_nodal_1d, NodalPencil1d};

/// Above this many active nodal unknowns (`d` per active node) the critical-step tools skip the
/// reduction: its Lanczos keeps two vectors of this size per iteration (up to 400: 128 MB
/// at the limit), and on
/// the flat top of a large uniform layout's spectrum (a 1D bar of 5·10⁴ cells) 400
/// iterations do not settle. Within it, layouts of 10⁴–3·10⁵ particle unknowns take
/// 0.02–1.2 s (measured; docs/design.md, "The full map from the nodes").
pub const NODAL_FULL_MAP_LIMIT: usize = 20_000;

/// The reduced problem's operators on the nodal components, scaled by `M^{-1/2}`: vectors
/// hold one value per nodal component (`d` per node) and vanish on inactive ones.
pub trait NodalPencil {
    /// Number of nodal components (`d · n_nodes`).
    fn len(&self) -> usize;
    /// Whether `len() == 0`.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Whether component `k` belongs to a free active node.
    fn is_active(&self, k: usize) -> bool;
    /// `y = A_s u = M^{-1/2} K M^{-1/2} u` (overwrites `y`).
    fn stiffness(&self, u: &[f64], y: &mut [f64]);
    /// `y = Q_s u = M^{-1/2} Sᵀ diag(m_p) S M^{-1/2} u` (overwrites `y`).
    fn consistent_mass(&self, u: &[f64], y: &mut [f64]);
}

/// The reduced problem's answer.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct NodalCritical {
    /// `λ* = λmax(A (I − P/2))` (1/s²), the largest Ritz value.
    pub lambda: f64,
    /// `dt_c = √(2/λ*)`, the full map's critical step.
    pub dt: f64,
    /// The Lanczos residual bound of `λ*` (1/s²).
    pub residual: f64,
    /// Products with `A_s` (each with one product with `Q_s` beside it).
    pub products: usize,
    /// Whether the residual bound met the tolerance, the Ritz value settled
    /// ([`NodalLanczos::settle`]) or the Krylov space was exhausted (an exact invariant
    /// subspace); `false` when the iteration cap ended it.
    pub converged: bool,
}

/// Settings of the Lanczos iteration for [`nodal_critical_dt`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodalLanczos {
    /// Stop when the residual bound is below `tol · λ*` (default `1e-10`).
    pub tol: f64,
    /// Or stop when the largest Ritz value moved by less than `settle · λ*` in each of
    /// three evaluations running (default `1e-12`; evaluated every iteration for the first
    /// 32, then every fourth): on the clustered top of a uniform layout's spectrum the
    /// value converges long before the residual bound does.
    pub settle: f64,
    /// Most iterations (default 400); each keeps two nodal vectors.
    pub max_iter: usize,
}

impl Default for NodalLanczos {
    fn default() -> Self {
        Self {
            tol: 1e-10,
            settle: 1e-12,
            max_iter: 400,
        }
    }
}

/// The active components of a pencil and full-length buffers for its products: the
/// iteration runs on the active components only (every vector vanishes on the others), so
/// bodies in a mostly empty box cost what their own nodes cost.
struct Active<'p> {
    pencil: &'p dyn NodalPencil,
    comps: Vec<usize>,
    input: Vec<f64>,
    output: Vec<f64>,
}

impl<'p> Active<'p> {
    fn new(pencil: &'p dyn NodalPencil) -> Self {
        let n = pencil.len();
        Self {
            pencil,
            comps: (0..n).filter(|&k| pencil.is_active(k)).collect(),
            input: vec![0.0; n],
            output: vec![0.0; n],
        }
    }

    fn len(&self) -> usize {
        self.comps.len()
    }

    /// `y = A_s u` (`stiffness`) or `y = B u = u − Q_s u/2` on the active components.
    fn product(&mut self, stiffness: bool, u: &[f64], y: &mut [f64]) {
        for (&k, &x) in self.comps.iter().zip(u) {
            self.input[k] = x;
        }
        match stiffness {
            true => self.pencil.stiffness(&self.input, &mut self.output),
            false => self.pencil.consistent_mass(&self.input, &mut self.output),
        }
        for ((y, &k), &x) in y.iter_mut().zip(&self.comps).zip(u) {
            *y = match stiffness {
                true => self.output[k],
                false => x - 0.5 * self.output[k],
            };
        }
    }
}

/// `A_s B` in the `B` inner product, `B = I − Q_s/2` (module docs).
impl lanczos::Operator for Active<'_> {
    const METRIC: bool = true;

    fn inner(&self) -> Inner<'_> {
        Inner::local()
    }

    /// `y = A_s (B x)`.
    fn apply(&mut self, _x: &[f64], bx: &[f64], y: &mut [f64]) {
        self.product(true, bx, y);
    }

    fn metric(&mut self, x: &[f64], y: &mut [f64]) {
        self.product(false, x, y);
    }

    /// `xᵀBx ≥ xᵀx/2` when `0 ≤ Q ≤ M` (module docs); a negative or non-finite value means
    /// the weights or nodal masses break it: no answer rather than a wrong one.
    fn indefinite(&self, x: &[f64], xbx: f64) -> bool {
        !xbx.is_finite() || xbx < 0.25 * dot(x, x)
    }
}

/// Number of active nodal components of `pencil` (the size of the reduced problem).
pub fn active_unknowns(pencil: &dyn NodalPencil) -> usize {
    (0..pencil.len()).filter(|&k| pencil.is_active(k)).count()
}

/// A deterministic start with a component along every mode: a sign pattern times a
/// pseudo-random magnitude (splitmix64, fixed seed).
fn start_vector(n: usize) -> Vec<f64> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|k| {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            let r = 0.5 + (z >> 11) as f64 / (1u64 << 53) as f64;
            if k % 2 == 0 {
                r
            } else {
                -r
            }
        })
        .collect()
}

/// The full map's critical step `√(2/λ*)` from Lanczos on `A_s B` in the `B` inner product
/// (module docs), on the active components, with full reorthogonalisation (twice,
/// modified Gram–Schmidt in the `B` inner product; the crate's Lanczos iteration,
/// `src/lanczos.rs`). `None` when no component is active or the operator is zero on
/// the start.
pub fn nodal_critical_dt(
    pencil: &dyn NodalPencil,
    settings: NodalLanczos,
) -> Option<NodalCritical> {
    nodal_critical_dt_from(pencil, None, settings)
}

/// [`nodal_critical_dt`] warm-started from `start` (one value per nodal component, as the
/// pencil's vectors; read on the active components), nudged by a tenth of the fixed start
/// so that it is never orthogonal to the top mode. The stability limit starts it from eq
/// 56's Ritz vector ([`crate::limits_nd::StabilityNdConfig::full_map`]).
pub fn nodal_critical_dt_from(
    pencil: &dyn NodalPencil,
    start: Option<&[f64]>,
    settings: NodalLanczos,
) -> Option<NodalCritical> {
    let mut active = Active::new(pencil);
    let n = active.len();
    if n == 0 {
        return None;
    }
    let mut q = start_vector(n);
    if let Some(start) = start.filter(|s| s.len() == pencil.len()) {
        let warm: Vec<f64> = active.comps.iter().map(|&k| start[k]).collect();
        let (w, f) = (dot(&warm, &warm).sqrt(), dot(&q, &q).sqrt());
        if w > 0.0 && w.is_finite() {
            q.iter_mut()
                .zip(&warm)
                .for_each(|(q, x)| *q = x / w + 0.1 * *q / f);
        }
    }
    let mut bq = Vec::new();
    let norm = lanczos::norm(&mut active, &q, &mut bq);
    if !(norm > 0.0 && norm.is_finite()) {
        return None;
    }
    let mut work = lanczos::Work::default();
    work.start(n, &q, Some(&bq), norm);
    let max_iter = settings.max_iter.max(1).min(n);
    // Settled: within `settle` in three evaluations running; exhausted: `β ≤ tol · θ`.
    let mut rule = Settle::new(
        settings.tol,
        settings.settle,
        (3, 0),
        settings.tol,
        f64::NAN,
    )
    .with_cadence(RITZ_DENSE, RITZ_EVERY);
    let full = lanczos::Orthogonalise::Full;
    let top = lanczos::run(&mut active, &mut work, n, max_iter, full, &mut rule).ok()?;
    let theta = top.theta;
    (theta > 0.0 && theta.is_finite()).then(|| NodalCritical {
        lambda: theta,
        dt: (2.0 / theta).sqrt(),
        residual: top.residual,
        products: top.applications,
        converged: top.converged,
    })
}

/// The Ritz value costs a dense eigenproblem of the iteration's size: it is evaluated at
/// every iteration below this one, then at every [`RITZ_EVERY`]-th (and at the end).
const RITZ_DENSE: usize = 32;

/// See [`RITZ_DENSE`].
const RITZ_EVERY: usize = 4;
