//! The reference 1D update-stress-last MPM solver (eqs 6–29).
//!
//! It solves the model problem of eqs 1–2, `Du/Dt = v`, `ρ Dv/Dt = ∂σ/∂x`, on a periodic
//! or clamped bar with particles anywhere in the domain, GIMP or linear-hat weights
//! ([`crate::shape`]), and a linear elastic or 1D neo-Hookean [`Material`]. One step, as we
//! read eqs 17–29 (docs/design.md), is
//!
//! ```text
//! v_iⁿ⁺¹ = v_i + dt a_i                                      (19)
//! v_pⁿ⁺¹ = v_p + dt Σ_i S_ip a_i                              (21, 22)
//! L_p    = Σ_i D_ip v_iⁿ⁺¹                                     (24)
//! Fⁿ⁺¹   = Fⁿ (1 + dt L_p)                                     (25, one dt)
//! σⁿ⁺¹   = σⁿ + dt E L_p            (linear; 27)   or σ(Fⁿ⁺¹) (neo-Hookean)
//! x_pⁿ⁺¹ = x_p + dt v_pⁿ⁺¹                                     (29)
//! ```
//!
//! with `S`, `D` evaluated once at `xⁿ`, and the nodal mass, velocity and acceleration of
//! the new state `m_i = Σ_p S_ip m_p` (7), `v_i = Σ_p S_ip m_p v_p / m_i` (17),
//! `a_i = −(1/m_i) Σ_p D_ip σ_p F_p V_p⁰` (18) computed at `xⁿ⁺¹` in the same particle pass, so every
//! particle is read and written once per step. Choices the paper leaves open:
//!
//! * **Inactive nodes**: a node with `m_i ≤ INACTIVE_MASS_FRACTION · M/N` (see
//!   [`INACTIVE_MASS_FRACTION`]) has `v_i = a_i = 0`. Constrained nodes of a fixed grid
//!   (both ends and the ghosts) always have `v_i = a_i = 0`: the bar is clamped.
//! * **Failures** are typed [`StepError`](crate::StepError)s and leave the committed state
//!   untouched: a NaN or infinite trial value (`NonFinite`, found by a cheap accumulated
//!   check and located only when it fails), `F ≤ 0` (`Inverted`), a particle leaving a fixed
//!   domain (`OutOfDomain`). Periodic positions are wrapped into `[a, a + L)`.
//! * **Stress measure**: in 1D the cross-section does not change, so the Cauchy stress is
//!   also the first Piola–Kirchhoff stress; eq 18's `σ_p F_p V_p⁰` is `σ_p` times the current
//!   volume.
//! * **Threading**: the solver is `Send` but not `Sync` (the lazily computed view data live
//!   in `OnceCell`s).
//! * **GIMP width** `l_p` is fixed for the run (the particle domain is not stretched by `F`),
//!   and must satisfy `0 < l_p ≤ h`.

mod element_bound;
mod material;
mod particle_pass;
mod reference;
mod setup;
mod slot_window;
mod state;
pub(crate) use crate::stencil;
mod step;
mod summary_lanes;

pub use material::Material;
pub use reference::{ReferenceStepper, SolverCheckpoint, INACTIVE_MASS_FRACTION};
pub use setup::{ParticleInit, SetupError};
