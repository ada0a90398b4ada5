//! The exact frozen-particle critical step of the whole USL method.
//!
//! Freeze the weights `S`, `D`, the volumes `V_p`, the moduli `E_p` and the nodal masses of a
//! state, and linearise the update-stress-last step (eqs 17–29 as read in docs/design.md) in the
//! particle state `z = (v_p, σ_p)`. Every stage is linear:
//!
//! ```text
//! v_i  = (1/m_i) Σ_p S_ip m_p v_p                      (eq 17; 0 at inactive/constrained i)
//! a_i  = −(1/m_i) Σ_p D_ip V_p σ_p                     (eq 18; 0 at inactive/constrained i)
//! v_i' = v_i + dt a_i                                  (eq 19)
//! v_p' = v_p + dt Σ_i S_ip a_i                         (eqs 21–22)
//! σ_p' = σ_p + dt E_p Σ_i D_ip v_i'                    (eqs 24, 27)
//! ```
//!
//! so `z' = T(dt) z` with `T(dt) = T₀ + dt T₁ + dt² T₂` (`2n_p × 2n_p`). Linearising about
//! rest (`σ = 0`, `F = 1`) is exact to first order: `δ(σV) = V δσ` there, and the position
//! update (eq 29) only moves the frozen weights. About a stressed state the map is the
//! frozen-coefficient map with the state's `V_p`, `E_p`.
//!
//! `T` is assembled densely (faer) and its complex eigenvalues give the spectral radius
//! `ρ(T(dt))`. The frozen-particle critical step is the first `dt` (scanning upward) at which
//! `ρ(T(dt)) > 1 + growth_tol`.
//!
//! **Eigenvalue 1.** `T` has many eigenvalues exactly 1 for every `dt`: rigid translation
//! (periodic grids), velocity patterns with zero nodal momentum (`Σ_p S_ip m_p v_p = 0` for
//! all `i`, possible when particles outnumber nodes), and stress patterns in the null space of
//! `D 𝐕`. Some of them form Jordan blocks, which rounding splits into `1 ± O(√ε)`
//! (`√ε ≈ 1.5·10⁻⁸`). With `growth_tol = 10⁻⁶` these are ignored, while a mode that goes
//! unstable leaves the unit circle like `1 + c√(dt − dt_c)` (a pair colliding at −1), so the
//! critical step is located to about `(10⁻⁶/c)²` relative — far below the bisection tolerance.
//! At one particle per cell the map's velocity half decouples and the critical step equals
//! eq 56's (tested).

use crate::stability::error::{check_dt, check_view, StabilityError};
use crate::stepper::View;
use crate::weights::{WeightKind, Weights};
use faer::Mat;

/// Settings of the critical-step search.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FullMapConfig {
    /// `ρ(T) > 1 + growth_tol` counts as unstable (default `1e-6`).
    pub growth_tol: f64,
    /// Multiplicative scan step (default 1.01): the scan goes `dt₀, 1.01 dt₀, …`.
    pub scan_factor: f64,
    /// Relative width at which bisection stops (default `1e-7`).
    pub rel_tol: f64,
    /// Largest multiple of the starting step the scan tries before giving up (default 20).
    pub max_factor: f64,
}

impl Default for FullMapConfig {
    fn default() -> Self {
        Self {
            growth_tol: 1e-6,
            scan_factor: 1.01,
            rel_tol: 1e-7,
            max_factor: 20.0,
        }
    }
}

/// The frozen-particle linearised one-step map of a state.
#[derive(Clone, Debug)]
pub struct FullMap {
    t0: Mat<f64>,
    t1: Mat<f64>,
    t2: Mat<f64>,
}

/// The frozen coefficients the linear step reads.
struct Frozen<'a> {
    weights: &'a Weights,
    mass: Vec<f64>,
    volume: Vec<f64>,
    modulus: Vec<f64>,
    inv_node_mass: Vec<f64>,
}

impl Frozen<'_> {
    /// One linear USL step of `(v, σ)` with step `dt`.
    fn step(&self, dt: f64, v: &[f64], sigma: &[f64], v_out: &mut [f64], s_out: &mut [f64]) {
        let n_nodes = self.inv_node_mass.len();
        let mv: Vec<f64> = v.iter().zip(&self.mass).map(|(v, m)| v * m).collect();
        let sv: Vec<f64> = sigma.iter().zip(&self.volume).map(|(s, v)| s * v).collect();
        let mut vi = vec![0.0; n_nodes];
        let mut ai = vec![0.0; n_nodes];
        self.weights.scatter(WeightKind::S, &mv, &mut vi);
        self.weights.scatter(WeightKind::D, &sv, &mut ai);
        for i in 0..n_nodes {
            let im = self.inv_node_mass[i];
            ai[i] *= -im;
            vi[i] = vi[i] * im + dt * ai[i];
        }
        let mut ap = vec![0.0; v.len()];
        let mut lp = vec![0.0; v.len()];
        self.weights.gather(WeightKind::S, &ai, &mut ap);
        self.weights.gather(WeightKind::D, &vi, &mut lp);
        for p in 0..v.len() {
            v_out[p] = v[p] + dt * ap[p];
            s_out[p] = sigma[p] + dt * self.modulus[p] * lp[p];
        }
    }

    fn dense(&self, dt: f64) -> Mat<f64> {
        let n = self.mass.len();
        let mut t = Mat::<f64>::zeros(2 * n, 2 * n);
        let mut e = vec![0.0; 2 * n];
        let (mut vo, mut so) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..2 * n {
            e.iter_mut().for_each(|x| *x = 0.0);
            e[j] = 1.0;
            self.step(dt, &e[..n], &e[n..], &mut vo, &mut so);
            for p in 0..n {
                t[(p, j)] = vo[p];
                t[(n + p, j)] = so[p];
            }
        }
        t
    }
}

impl FullMap {
    /// A map `T(dt) = t0 + dt t1 + dt² t2` from its coefficients (square, equal sizes),
    /// as the d-dimensional map assembles it ([`crate::limits_nd::full_map`]).
    pub(crate) fn from_coefficients(t0: Mat<f64>, t1: Mat<f64>, t2: Mat<f64>) -> Self {
        Self { t0, t1, t2 }
    }

    /// The map of state `view` (typed errors on invalid fields).
    pub fn new(view: &View<'_>) -> Result<Self, StabilityError> {
        check_view(view)?;
        let frozen = Frozen {
            weights: view.weights.get(),
            mass: view.mass.to_vec(),
            volume: view
                .f
                .iter()
                .zip(view.volume0)
                .map(|(f, v)| f * v)
                .collect(),
            modulus: view.tangent_modulus.to_vec(),
            inv_node_mass: view
                .node_mass
                .iter()
                .zip(view.node_active)
                .map(|(&m, &a)| if a { 1.0 / m } else { 0.0 })
                .collect(),
        };
        // T(dt) is a quadratic polynomial in dt: recover its coefficients from dt = 0, ±1.
        let t0 = frozen.dense(0.0);
        let tp = frozen.dense(1.0);
        let tm = frozen.dense(-1.0);
        let t1 = Mat::from_fn(t0.nrows(), t0.ncols(), |i, j| {
            0.5 * (tp[(i, j)] - tm[(i, j)])
        });
        let t2 = Mat::from_fn(t0.nrows(), t0.ncols(), |i, j| {
            0.5 * (tp[(i, j)] + tm[(i, j)]) - t0[(i, j)]
        });
        Ok(Self { t0, t1, t2 })
    }

    /// Dimension `2 n_p` of the state `(v, σ)`.
    pub fn dim(&self) -> usize {
        self.t0.nrows()
    }

    /// The dense map `T(dt)`.
    pub fn matrix(&self, dt: f64) -> Mat<f64> {
        Mat::from_fn(self.dim(), self.dim(), |i, j| {
            self.t0[(i, j)] + dt * (self.t1[(i, j)] + dt * self.t2[(i, j)])
        })
    }

    /// The spectral radius `ρ(T(dt)) = max |λ|` over the complex eigenvalues.
    ///
    /// The eigenvalues come from nalgebra's real Schur decomposition with an iteration cap
    /// (faer's unbounded Schur iteration did not return on some uniform layouts, e.g. 20
    /// periodic cells at 4 particles per cell); if the cap is hit, from Gelfand's formula
    /// `ρ = lim ‖T^k‖^{1/k}` by repeated squaring (`k = 2⁴⁰`, Frobenius norm, rescaled at each
    /// squaring), which converges to `ρ` for any matrix.
    pub fn spectral_radius(&self, dt: f64) -> Result<f64, StabilityError> {
        check_dt(dt)?;
        let t = self.matrix(dt);
        let n = t.nrows();
        let m = nalgebra::DMatrix::<f64>::from_fn(n, n, |i, j| t[(i, j)]);
        if let Some(schur) =
            nalgebra::linalg::Schur::try_new(m.clone(), f64::EPSILON, 20 * n.max(50))
        {
            let ev = schur.complex_eigenvalues();
            return Ok(ev.iter().map(|z| z.re.hypot(z.im)).fold(0.0, f64::max));
        }
        // Gelfand: log ρ ≈ (log ‖T^(2^k)‖)/2^k, accumulated with rescaling.
        let mut p = m;
        let mut log_scale = 0.0_f64;
        let mut power = 1.0_f64;
        for _ in 0..40 {
            let norm = p.norm();
            if !(norm.is_finite() && norm > 0.0) {
                break;
            }
            p /= norm;
            log_scale = 2.0 * (log_scale + norm.ln());
            p = &p * &p;
            power *= 2.0;
        }
        let norm = p.norm();
        if !(norm.is_finite()) {
            return Err(StabilityError::NoConvergence {
                what: "eigenvalues of the full map",
            });
        }
        let log_rho = if norm > 0.0 {
            (log_scale + norm.ln()) / power
        } else {
            f64::NEG_INFINITY
        };
        Ok(log_rho.exp())
    }

    /// The first `dt ≥ dt_start` at which `ρ(T(dt)) > 1 + growth_tol`: a scan upward by
    /// `scan_factor` from `dt_start` (which must be stable), then bisection to `rel_tol`.
    /// Returns the largest step found stable.
    pub fn critical_dt(&self, dt_start: f64, config: FullMapConfig) -> Result<f64, StabilityError> {
        check_dt(dt_start)?;
        let unstable = |dt: f64| -> Result<bool, StabilityError> {
            Ok(self.spectral_radius(dt)? > 1.0 + config.growth_tol)
        };
        if unstable(dt_start)? {
            return Err(StabilityError::NoBracket {
                stable: 0.0,
                tried: dt_start,
            });
        }
        let mut lo = dt_start;
        let mut hi = lo * config.scan_factor;
        while !unstable(hi)? {
            lo = hi;
            hi *= config.scan_factor;
            if hi > dt_start * config.max_factor {
                return Err(StabilityError::NoBracket {
                    stable: lo,
                    tried: hi,
                });
            }
        }
        while hi - lo > config.rel_tol * lo {
            let mid = 0.5 * (lo + hi);
            if unstable(mid)? {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Ok(lo)
    }
}
