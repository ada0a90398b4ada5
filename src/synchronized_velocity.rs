//! The *synchronised velocity* of a state: the particle velocity moved forward by a closing
//! half kick, `v_sync,p = v_p + ℓ Σ_i S_ip a_i`, so that it approximates the exact velocity
//! at the state's time `t` to second order in the step instead of lagging it by half a step.
//!
//! # Why the particle velocity lags
//!
//! The update-stress-last step (eqs 17–29, [`crate::mpm`]) starts from `vⁿ`, `σⁿ` at `tⁿ`
//! and *kicks the velocity first*:
//!
//! ```text
//! a_pⁿ    = Σ_i S_ip(xⁿ) a_iⁿ,   a_iⁿ = f_i(σⁿ, xⁿ)/m_i             (18, 21)
//! v_pⁿ⁺¹ = v_pⁿ + dt_n a_pⁿ                                         (22)
//! σⁿ⁺¹, Fⁿ⁺¹, xⁿ⁺¹ from the *new* velocity vⁿ⁺¹                       (24–29)
//! ```
//!
//! That is symplectic Euler (kick, then drift): the leapfrog scheme with `vⁿ` standing for
//! the velocity at `tⁿ − dt/2`. Along a particle, with `a(t)` its exact acceleration and
//! `eₙ = v_pⁿ − v(tₙ)` (spatial error left aside), one step gives
//! `eₙ₊₁ = eₙ + dt_n a(tₙ) − ∫_{tₙ}^{tₙ₊₁} a = eₙ − (dt_n²/2) a'(tₙ) + O(dt³)`, so
//!
//! ```text
//! v_pᴺ − v(T) ≈ −Σ_n (dt_n²/2) a'(tₙ)
//!             ≈ −(dt(T)/2) a(T) + (dt₀/2) a(0) + ½ ∫₀ᵀ a d(dt)            (S1)
//! ```
//!
//! (the sum read as `∫ (dt/2) a' dt`, integrated by parts). At a fixed step the first term
//! is an error `(dt/2) |a(T)|` of **first** order in dt; for the standing wave
//! ([`crate::problems::StandingWave`]) it is `A c ω (dt/2) |sin ωT|`. On a uniform particle
//! layout, whose spatial error is tiny, it dominates the final velocity error.
//!
//! # The closing half kick
//!
//! The committed state already holds what the next step would kick with: its nodal
//! accelerations `a_i = f_i/m_i` at `xᴺ` from `σᴺ` (eq 18, [`View::node_acceleration`]) and
//! the weights `S_ip` at `xᴺ` ([`View::weights`]). Adding the kick of a step `ℓ`,
//!
//! ```text
//! v_sync,p = v_pᴺ + ℓ Σ_i S_ip a_iᴺ                                    (S2)
//! ```
//!
//! cancels the first term of (S1) when `ℓ = dt/2` of the *regular* step at the end. A last
//! step shortened to land on an end time (`δ < dt`) does not change that: it contributes
//! only `−(δ²/2) a'` to (S1), and the lag it inherits is still `dt/2` of the step before. So
//! `ℓ` is half the last step that was not shortened to land ([`closing_half_step`] reads it
//! from a controller's decisions); a run whose only step was a landing step has `ℓ = 0`.
//! `ℓ = dt` reproduces the next step's particle velocity (eq 22) exactly: (S2) is that kick,
//! scaled.
//!
//! # What it does not fix
//!
//! (S2) removes the first term of (S1) only. The result is second order in dt when
//!
//! * the run started from rest in stress, `a(0) = 0` (the standing wave at `t = 0`,
//!   `σ = 0`), **or** it opened with a half kick (`v⁰ ← v⁰ − (dt₀/2) a⁰`, the leapfrog
//!   start): otherwise the second term `(dt₀/2) a(0)` stays, and it has already fed a
//!   first-order error into `σ` and `x` that no final correction can undo;
//! * the step varies slowly: the third term `½ ∫ a d(dt)` is of the size of the step's
//!   *change* over the run (zero at a fixed step; small on a stability-bound run whose step
//!   follows a slowly moving λmax). A step that changes by an O(1) factor leaves a
//!   first-order remainder of that size.
//!
//! And (S1) is the lag of the kick alone. The USL step has another first-order term that no
//! output correction reaches: the velocity that drives `σ` and `x` is the grid velocity
//! `v_iⁿ⁺¹ = v_i + dt a_i` (eqs 19, 24), where `v_i` is the projection (eq 17) of the
//! particle velocities, while the kicked particle velocities project to
//! `v_i + dt (P Sᵀ a)_i` (`P` the eq 17 projection). The two differ by `dt (I − P Sᵀ) a`,
//! which for a smooth mode is `O(dt (κh)²)` (the projection of the gathered acceleration is
//! a smoothed `a_i`), and larger when particles moving across cells feed non-smooth modes.
//! So, on a fixed grid, the synchronised velocity converges at second order only while
//! `dt ≫ (κh)²`-sized terms, and at first order with an `h²` constant below that. Measured
//! (the unit test's uniform standing wave, error against the same grid at a 64× smaller
//! step, relative to `A c`): at 128 cells, `A = 10⁻⁴`, steps 0.6 → 0.3 → 0.15 h/c, orders
//! 2.14, 2.30 (raw velocity 1.00, 1.00); at 16 cells the synchronised order falls to 0.7–0.9
//! below 0.15 h/c (errors ≈ 10⁻⁴ against the raw 10⁻²); at 128 cells with `A = 10⁻²`
//! (displacements 20 % of a cell) it is 1.34, 1.21, at errors 100–250× below the raw ones.
//!
//! The synchronised velocity is an output, not a state: it is never fed back into the
//! solver, so the run itself (and every controller decision) is unchanged.

use crate::controller::{bound, Decision, Outcome};
use crate::stepper::View;
use crate::weights::WeightKind;

/// Why a synchronised velocity could not be computed. Nothing is written on error.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SyncVelocityError {
    /// The closing half step `ℓ` is negative, NaN or infinite.
    #[error("closing half step ℓ = {half_step} is not a finite non-negative number")]
    InvalidHalfStep {
        /// The offending `ℓ`.
        half_step: f64,
    },
    /// Two of the arrays involved do not have matching lengths.
    #[error("{what}: expected {expected} entries, got {got}")]
    SizeMismatch {
        /// Which array (`"node_acceleration"`, `"weights (particles)"`, `"out"`).
        what: &'static str,
        /// The length the other fields imply.
        expected: usize,
        /// Its length.
        got: usize,
    },
}

impl View<'_> {
    /// The synchronised velocity (S2) of this state with closing half step `half_step = ℓ`
    /// (module docs): `v_p + ℓ Σ_i S_ip a_i`, one value per particle.
    ///
    /// Errors: `ℓ` negative or not finite; [`View::node_acceleration`] not of the weights'
    /// node count, or the weights not of [`View::v`]'s particle count.
    pub fn synchronized_velocity(&self, half_step: f64) -> Result<Vec<f64>, SyncVelocityError> {
        let mut out = vec![0.0; self.v.len()];
        self.synchronized_velocity_into(half_step, &mut out)?;
        Ok(out)
    }

    /// [`View::synchronized_velocity`] into `out` (length [`View::v`]`.len()`, else
    /// [`SyncVelocityError::SizeMismatch`]). `out` is untouched on error.
    pub fn synchronized_velocity_into(
        &self,
        half_step: f64,
        out: &mut [f64],
    ) -> Result<(), SyncVelocityError> {
        if !(half_step.is_finite() && half_step >= 0.0) {
            return Err(SyncVelocityError::InvalidHalfStep { half_step });
        }
        let n_p = self.v.len();
        let checks = [
            ("weights (particles)", n_p, self.weights.n_particles()),
            (
                "node_acceleration",
                self.weights.n_nodes(),
                self.node_acceleration.len(),
            ),
            ("out", n_p, out.len()),
        ];
        for (what, expected, got) in checks {
            if expected != got {
                return Err(SyncVelocityError::SizeMismatch {
                    what,
                    expected,
                    got,
                });
            }
        }
        // out_p = Σ_i S_ip a_i (eq 21), then v_p + ℓ out_p.
        self.weights
            .get()
            .gather(WeightKind::S, self.node_acceleration, out);
        for (o, &v) in out.iter_mut().zip(self.v) {
            *o = v + half_step * *o;
        }
        Ok(())
    }
}

/// The closing half step `ℓ` of a controlled run (module docs): half the `dt` of the last
/// *accepted* decision that was not bound by the end time ([`bound::T_END`], a step
/// shortened to land on `t_end`). `None` when there is no such decision (no accepted step,
/// or only a landing step: use `ℓ = 0` then).
///
/// Pass every decision of the run, or any suffix of them that contains its last regular
/// accepted step (e.g. [`crate::controller::Controller::step`]'s return per step, keeping
/// the last `Some`).
pub fn closing_half_step(decisions: &[Decision]) -> Option<f64> {
    decisions
        .iter()
        .rev()
        .find(|d| d.outcome == Outcome::Accepted && d.binding != bound::T_END)
        .map(|d| 0.5 * d.dt)
}

// Drives the reference solvers: tested with the `reference` feature.
#[cfg(all(test, feature = "reference"))]
mod tests {
    use super::*;
    use crate::grid::{Boundary, Grid};
    use crate::mpm::{Material, ReferenceStepper};
    use crate::problems::StandingWave;
    use crate::shape::Shape;
    use crate::stepper::Stepper;
    use crate::view_weights::ViewWeights;
    use crate::weights::Weights;

    /// Bit patterns, for exact comparison.
    fn bits(u: &[f64]) -> Vec<u64> {
        u.iter().map(|x| x.to_bits()).collect()
    }

    /// Two particles on three nodes, every number chosen by hand.
    fn hand_weights() -> Weights {
        let mut w = Weights::new(3, 2);
        w.push_row(&[(0, 0.25, -1.0), (1, 0.75, 1.0)]).unwrap();
        w.push_row(&[(1, 0.5, -1.0), (2, 0.5, 1.0)]).unwrap();
        w
    }

    fn hand_view<'a>(
        grid: &'a Grid,
        w: &'a Weights,
        v: &'a [f64],
        a: &'a [f64],
        zeros: &'a [f64],
    ) -> View<'a> {
        View {
            t: 1.0,
            step: 3,
            grid,
            x: zeros,
            v,
            sigma: zeros,
            f: zeros,
            volume0: zeros,
            mass: zeros,
            tangent_modulus: zeros,
            density: zeros,
            weights: ViewWeights::from(w),
            node_mass: a,
            node_velocity: a,
            node_acceleration: a,
            node_active: &[true, true, true],
            nodal_stiffness: None,
            summary: None,
        }
    }

    #[test]
    fn hand_computed_case_is_exact() {
        let grid = Grid::new(Boundary::Periodic, 3, 1.0);
        let w = hand_weights();
        let (v, a, zeros) = ([1.0, -2.0], [4.0, 8.0, -16.0], [0.0; 2]);
        let view = hand_view(&grid, &w, &v, &a, &zeros);
        // a_0 = 0.25·4 + 0.75·8 = 7, a_1 = 0.5·8 − 0.5·16 = −4 (all exact in binary).
        assert_eq!(
            bits(&view.synchronized_velocity(0.5).unwrap()),
            bits(&[4.5, -4.0])
        );
        assert_eq!(bits(&view.synchronized_velocity(0.0).unwrap()), bits(&v));
        let mut out = [f64::NAN; 2];
        view.synchronized_velocity_into(0.25, &mut out).unwrap();
        assert_eq!(bits(&out), bits(&[2.75, -3.0]));
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let grid = Grid::new(Boundary::Periodic, 3, 1.0);
        let w = hand_weights();
        let (v, a, zeros) = ([1.0, -2.0], [4.0, 8.0, -16.0], [0.0; 2]);
        let view = hand_view(&grid, &w, &v, &a, &zeros);
        for half_step in [-1e-300, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(matches!(
                view.synchronized_velocity(half_step),
                Err(SyncVelocityError::InvalidHalfStep { .. })
            ));
        }
        let mut short = [7.0; 1];
        assert_eq!(
            view.synchronized_velocity_into(0.5, &mut short),
            Err(SyncVelocityError::SizeMismatch {
                what: "out",
                expected: 2,
                got: 1
            })
        );
        assert_eq!(bits(&short), bits(&[7.0]), "untouched on error");
        let a2 = [4.0, 8.0];
        let bad_nodes = hand_view(&grid, &w, &v, &a2, &zeros);
        assert_eq!(
            bad_nodes.synchronized_velocity(0.5),
            Err(SyncVelocityError::SizeMismatch {
                what: "node_acceleration",
                expected: 3,
                got: 2
            })
        );
        let v3 = [1.0, 2.0, 3.0];
        let zeros3 = [0.0; 3];
        let bad_particles = hand_view(&grid, &w, &v3, &a, &zeros3);
        assert!(matches!(
            bad_particles.synchronized_velocity(0.5),
            Err(SyncVelocityError::SizeMismatch {
                what: "weights (particles)",
                ..
            })
        ));
    }

    fn standing_wave_stepper(wave: &StandingWave, cells: usize) -> ReferenceStepper {
        let grid = Grid::new(Boundary::Periodic, cells, 1.0);
        let particles = wave.uniform_particles(&grid, 2);
        ReferenceStepper::new(
            grid,
            Shape::Gimp,
            Material::LinearElastic {
                youngs_modulus: 1.0,
            },
            particles,
        )
        .unwrap()
    }

    #[test]
    fn full_kick_is_the_next_steps_velocity() {
        let wave = StandingWave::new(1e-2, 1.0, 1.0, 1.0, 1.0);
        let mut s = standing_wave_stepper(&wave, 16);
        let dt = 0.02;
        for _ in 0..7 {
            s.try_step(dt).unwrap();
            s.accept().unwrap();
        }
        let kicked = s.view().synchronized_velocity(dt).unwrap();
        s.try_step(dt).unwrap();
        let next = s.trial_view().unwrap();
        for (k, n) in kicked.iter().zip(next.v) {
            assert!((k - n).abs() <= 1e-15, "{k} vs eq 22's {n}");
        }
    }

    /// `max_p |u_p − w_p|`.
    fn linf(u: &[f64], w: &[f64]) -> f64 {
        let e: Vec<f64> = u.iter().zip(w).map(|(a, b)| a - b).collect();
        crate::estimators::linf(&e)
    }

    /// A uniform standing wave (128 cells × 2, GIMP, `A = 10⁻⁴`) run to `T = 0.2` periods
    /// (`|sin ωT| = 0.95`) at fixed steps `T/n` for `n = n₀, 2n₀, 4n₀`, `n₀ = ⌈T/(0.6 h/c)⌉`
    /// (0.6, 0.3, 0.15 h/c; no landing step). The error is measured against the same
    /// discretisation at `T/(64 n₀)` (its synchronised velocity), which removes the spatial
    /// error: the raw velocity converges at first order, the synchronised one (`ℓ = dt/2`)
    /// at second. Measured orders: raw 0.998, 0.999; synchronised 2.14, 2.30.
    ///
    /// The grid and amplitude matter (module docs, "What it does not fix"): the USL step has
    /// a residual first-order error `O(dt h²)` (measured at 16 cells the synchronised
    /// order falls to 0.7–0.9 below 0.15 h/c) and a larger one when particles move an
    /// appreciable part of a cell (`A = 10⁻²` here: orders 1.34, 1.21).
    #[test]
    fn synchronised_velocity_converges_at_second_order() {
        let cells = 128;
        let wave = StandingWave::new(1e-4, 1.0, 1.0, 1.0, 1.0);
        let t_end = 0.2 * wave.period();
        let h = 1.0 / cells as f64;
        let run = |n: usize| {
            let dt = t_end / n as f64;
            let mut s = standing_wave_stepper(&wave, cells);
            for _ in 0..n {
                s.try_step(dt).unwrap();
                s.accept().unwrap();
            }
            assert!((s.time() - t_end).abs() < 1e-12);
            let view = s.view();
            (
                view.v.to_vec(),
                view.synchronized_velocity(0.5 * dt).unwrap(),
            )
        };
        let n0 = (t_end / (0.6 * h)).ceil() as usize;
        let (_, reference) = run(64 * n0);
        let (mut raw, mut sync) = (Vec::new(), Vec::new());
        for n in [n0, 2 * n0, 4 * n0] {
            let (v, v_sync) = run(n);
            raw.push(linf(&v, &reference));
            sync.push(linf(&v_sync, &reference));
        }
        let order = |e: &[f64], k: usize| (e[k] / e[k + 1]).log2();
        for k in 0..2 {
            let (p_raw, p_sync) = (order(&raw, k), order(&sync, k));
            assert!(
                (0.9..=1.1).contains(&p_raw),
                "raw order {p_raw} (errors {raw:?})"
            );
            assert!(
                (1.7..=2.5).contains(&p_sync),
                "synchronised order {p_sync} (errors {sync:?})"
            );
            assert!(sync[k] < 0.01 * raw[k], "{sync:?} vs {raw:?}");
        }
    }

    fn decision(dt: f64, binding: &str, outcome: Outcome) -> Decision {
        Decision {
            step: 0,
            attempt: 1,
            t: 0.0,
            dt,
            limits: Vec::new(),
            filter_dt: None,
            binding: binding.to_string(),
            bound58: None,
            lambda_max: None,
            dsm: None,
            outcome,
            cause: None,
            rejected_by: None,
            message: None,
        }
    }

    #[test]
    fn closing_half_step_skips_landing_and_rejected_steps() {
        let ds = [
            decision(0.4, "stability", Outcome::Accepted),
            decision(0.3, "growth_cap", Outcome::Accepted),
            decision(0.5, "filter", Outcome::Rejected),
            decision(0.1, bound::T_END, Outcome::Accepted),
        ];
        assert_eq!(closing_half_step(&ds), Some(0.15));
        assert_eq!(closing_half_step(&ds[3..]), None);
        assert_eq!(closing_half_step(&[]), None);
    }
}
