//! Stability of the explicit update-stress-last MPM step (Section 6, eqs 49–58).
//!
//! # What is here
//!
//! | file | concept | equation |
//! |---|---|---|
//! | [`sound_speed`] | the 1D kernel of the [`SoundSpeed`] limit `dt ≤ α min_p h/(c_p + |v_p|)` (one limit for every dimension, [`crate::sound_speed`]) | eq 49, generalised |
//! | [`operator`] | the eq 56 operator `D*F`, matrix-free in `O(nnz)` and dense (faer) | eqs 50–56 |
//! | [`nodal`] | the same operator reduced to the nodes, `M^{1/2} K_N M^{1/2}` (banded, same λmax) | eq 56 |
//! | [`lambda_max`] | `λmax(D*F)` by a warm-started Lanczos iteration | eq 56 |
//! | [`certificate`] | certified bounds on `λmax`: `LDLᵀ` inertia test and Weyl drift | eq 56 |
//! | [`certified`] | the [`CertifiedTracker`]: a rigorous upper bound at every step | eq 56 |
//! | [`mod@bound58`] | the eq 58 "lower bound" on the amplification-matrix norm | eqs 33, 57, 58 |
//! | [`full_map`] | the exact frozen-particle critical step of the whole USL map | eqs 17–29 linearised |
//! | [`empirical`] | the critical step found by bisection on real nonlinear runs | docs/design.md `critical_dt` |
//! | [`limit`] | the stability limit of every dimension, [`Stability<D>`](limit::Stability): `safety·dt_crit`, its rule behind [`StabilityRule`] | eq 56 |
//! | [`one_d`] | the 1D rule [`BandedEq56`]: the certified tracker on the `K_N` band, rejecting on eq 58 (`Stability` = `Stability<1>`) | eqs 56, 58 |
//!
//! # The governing equation (eq 56), generalised to per-particle moduli
//!
//! A stress perturbation `δσ` alone (eqs 50–55) is propagated over one step by
//!
//! ```text
//! δσ_pⁿ⁺¹ = δσ_p − dt² E_p Σ_i D_ip (1/m_i) Σ_q D_iq V_q δσ_q ,   V_q = F_q V_q⁰,
//! ```
//!
//! i.e. `δσⁿ⁺¹ = A δσ` with `A = I − dt² 𝐄 K 𝐕`, `K = Dᵀ M D`, `M = diag(1/m_i)` over the
//! *active* nodes, `𝐄 = diag(E_p)`, `𝐕 = diag(V_p)`. With a uniform `E` this is the paper's
//! `A = I − E dt²/h² D*F` with `D* = (hD)ᵀ M (hD)` and `F = 𝐕`.
//!
//! `A = P (I − dt² B) P⁻¹` with `P = diag(√(E_p/V_p))` and the symmetric positive
//! semi-definite `B = diag(√(E V)) K diag(√(E V))`. Hence `A` is diagonalisable with real
//! eigenvalues `1 − dt² μ`, `μ ∈ spec(B) ⊂ [0, ∞)`, and
//!
//! ```text
//! ρ(A) ≤ 1  ⇔  dt² λmax(B) ≤ 2  ⇔  dt ≤ dt_eq56 = √(2/λmax(B)).
//! ```
//!
//! `ρ(A)` equals the norm of `A` induced by the *strain-energy norm*
//! `‖δσ‖_W = (Σ_p V_p δσ_p²/E_p)^{1/2}` (because `P⁻¹ A P` is symmetric); the spectral norm
//! `‖A‖₂` (induced by the Euclidean norm) is `≥ ρ(A)` and equal to it when `E_p V_p` is uniform.
//!
//! **Normalisation of λmax.** The paper non-dimensionalises with `ρ = 1`, so its `E` is the
//! squared wave speed. We report `λ̂ = h² λmax(B)/c²_ref` with `c²_ref = max_p E_p/ρ_p`;
//! for a uniform material this is exactly the paper's `λmax(D*F)` (4 on uniform GIMP layouts),
//! and in every case `dt_eq56 = h √(2/(c²_ref λ̂))`.
//!
//! **Nodes.** Inactive nodes (mass below the solver's threshold, `View::node_active` false)
//! are excluded from `M`: the solver never divides by their mass. Constrained nodes (the
//! clamped ends and ghosts of a fixed grid) are excluded too: their velocity is held at zero,
//! so the update never uses their acceleration and they carry no stress perturbation back to
//! the particles. `View::node_active` is false for both.
//!
//! # What is known (see docs/design.md) and what the tests here show
//!
//! * eq 49 (`E dt²/h² ≤ 1`, i.e. `dt ≤ h/c`) is **not** stable for this method;
//! * eq 56 ignores the velocity half of the state: exact for one particle per cell,
//!   conservative by up to ~8 % otherwise ([`full_map`] computes the exact frozen value);
//! * with linear-hat weights the critical step collapses near small nodal masses, and the
//!   tracked `dt_eq56` follows the collapse while eq 49 does not;
//! * eq 58 is a lower bound only in one of its readings, and stays near 1 while `‖A‖` grows
//!   (see [`mod@bound58`]).

pub mod bound58;
pub mod certificate;
pub mod certified;
pub(crate) mod element_bound;
pub(crate) mod error;
pub mod lambda_max;
pub mod limit;
mod localise;
pub mod nodal;
pub mod nodal_full_map;
pub mod one_d;
pub mod operator;
mod power_pass;
pub mod sound_speed;

pub use certified::{CertifiedConfig, CertifiedEstimate, CertifiedTracker};
pub use error::StabilityError;
pub use lambda_max::{
    LambdaEstimate, LambdaMaxTracker, LanczosConfig, SymmetricOperator, TrackerState,
};
pub use nodal::NodalOperator;

pub use crate::sound_speed::{SoundSpeed, SoundSpeedConfig};
pub use bound58::{bound58, Bound58, Bound58Reading};
// The verification tools live in the test bench (`src/testbench/stability/`): the empirical
// critical step runs the 1D reference solver, and the dense full map is a check on small
// layouts, not part of a limit. Their public paths stay here.
#[cfg(feature = "reference")]
pub use crate::testbench::stability::{empirical, full_map};
#[cfg(feature = "reference")]
pub use empirical::{
    scan_monotone, EmpiricalConfig, EmpiricalCritical, MonotoneScan, Protocol, RunOutcome,
    SCAN_POINTS,
};
#[cfg(feature = "reference")]
pub use full_map::{FullMap, FullMapConfig};
pub use limit::{Critical, Stability, StabilityDim, StabilityRule, StabilitySettings, STABILITY};
pub use one_d::{BandedEq56, BandedState, Refresh, StabilityConfig, Tracking};
pub use operator::Eq56Operator;
