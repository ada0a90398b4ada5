//! The empirical critical step: bisection on real nonlinear runs of the reference solver.
//!
//! The protocol is docs/design.md's `critical_dt` contract. From a particle layout (positions,
//! volumes, masses, widths), one run with step `dt`:
//!
//! * starts from `v_p = A c sin(2π x_p/L) + η_p`, `σ = 0`, `F = 1`, with `c` the largest
//!   initial wave speed `max_p √(E_t(1)/ρ_p)` and seeded noise `η_p` uniform in
//!   `[−1, 1]·noise·A·c` (`noise = 10⁻⁶`; the contract's "10⁻⁶·A" made dimensionally
//!   consistent by the factor `c`, equal to 1 in the unit-speed scenarios). The noise seeds
//!   every mode, in particular the checkerboard, so that an unstable mode is found from any
//!   initial wave;
//! * takes `steps = 4000` steps of the reference [`ReferenceStepper`];
//! * is **unstable** when the total energy (kinetic + strain, [`ReferenceStepper::total_energy`])
//!   exceeds `growth = 10` times its initial value, or the step fails (a non-finite value,
//!   some `F ≤ 0`, a particle leaving a fixed domain — any [`crate::StepError`]).
//!
//! Bisection on `dt` between a stable and an unstable step then locates the critical step to
//! the relative tolerance `rel_tol`. With the small amplitude `A = 10⁻⁴` the particles barely
//! move and the result approaches the frozen-particle limit of [`crate::stability::full_map`] (an
//! instability growing from the noise level `10⁻⁶` to 10× the energy in 4000 steps needs
//! `|λ| − 1 ≳ 4·10⁻³`, i.e. `dt` only about `10⁻⁵` above the frozen limit); with `A = 10⁻²`
//! the particles move and the critical step can be lower (weights change every step).
//!
//! The pseudo-random noise is a seeded splitmix64 stream (the library does not depend on
//! `rand`); the same seed gives the same runs.

use crate::grid::Grid;
use crate::mpm::{Material, ParticleInit, ReferenceStepper};
use crate::shape::Shape;
use crate::stability::error::{check_dt, StabilityError};
use crate::stepper::Stepper;

/// Settings of the empirical protocol.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EmpiricalConfig {
    /// Velocity amplitude `A` as a fraction of `c` (default `10⁻⁴`).
    pub amplitude: f64,
    /// Noise relative to `A c` (default `10⁻⁶`).
    pub noise: f64,
    /// Steps per run (default 4000).
    pub steps: usize,
    /// Energy growth factor that counts as unstable (default 10).
    pub growth: f64,
    /// Seed of the noise (default 2024).
    pub seed: u64,
    /// Relative bracket width at which bisection stops (default `10⁻³`).
    pub rel_tol: f64,
}

impl Default for EmpiricalConfig {
    fn default() -> Self {
        Self {
            amplitude: 1e-4,
            noise: 1e-6,
            steps: 4000,
            growth: 10.0,
            seed: 2024,
            rel_tol: 1e-3,
        }
    }
}

impl EmpiricalConfig {
    fn validate(&self) -> Result<(), StabilityError> {
        let checks: [(&'static str, f64, bool, &'static str); 5] = [
            (
                "amplitude",
                self.amplitude,
                self.amplitude > 0.0 && self.amplitude.is_finite(),
                "must be positive and finite",
            ),
            (
                "noise",
                self.noise,
                self.noise >= 0.0 && self.noise.is_finite(),
                "must be non-negative and finite",
            ),
            (
                "steps",
                self.steps as f64,
                self.steps > 0,
                "must be at least 1",
            ),
            (
                "growth",
                self.growth,
                self.growth > 1.0 && self.growth.is_finite(),
                "must exceed 1",
            ),
            (
                "rel_tol",
                self.rel_tol,
                self.rel_tol > 0.0 && self.rel_tol < 1.0,
                "must be in (0, 1)",
            ),
        ];
        for (field, value, ok, reason) in checks {
            if !ok {
                return Err(StabilityError::InvalidConfig {
                    field,
                    value,
                    reason,
                });
            }
        }
        Ok(())
    }
}

/// What one run found.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RunOutcome {
    /// Whether the run stayed stable for all its steps.
    pub stable: bool,
    /// Steps completed (all of them when stable).
    pub steps: usize,
    /// Largest ratio of the total energy to its initial value seen.
    pub max_energy_ratio: f64,
}

/// The bisection's result.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct EmpiricalCritical {
    /// Largest step found stable.
    pub dt_stable: f64,
    /// Smallest step found unstable.
    pub dt_unstable: f64,
    /// Runs made.
    pub runs: usize,
}

impl EmpiricalCritical {
    /// The midpoint of the final bracket.
    pub fn dt(&self) -> f64 {
        0.5 * (self.dt_stable + self.dt_unstable)
    }
}

/// A particle layout and material, ready for the protocol's runs.
#[derive(Clone, Debug)]
pub struct Protocol {
    grid: Grid,
    shape: Shape,
    material: Material,
    init: ParticleInit,
    config: EmpiricalConfig,
}

fn splitmix(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

impl Protocol {
    /// The protocol on `layout`'s positions, volumes, masses and widths (its velocities,
    /// stresses and deformation gradients are replaced by the protocol's initial state).
    pub fn new(
        grid: Grid,
        shape: Shape,
        material: Material,
        layout: &ParticleInit,
        config: EmpiricalConfig,
    ) -> Result<Self, StabilityError> {
        config.validate()?;
        let n = layout.x.len();
        let c = layout
            .mass
            .iter()
            .zip(&layout.volume0)
            .map(|(m, v)| material.wave_speed(1.0, m / v))
            .fold(0.0, f64::max);
        let l = grid.length();
        let mut rng = config.seed;
        let v = layout
            .x
            .iter()
            .map(|&x| {
                let wave = config.amplitude
                    * c
                    * (2.0 * std::f64::consts::PI * (x - grid.origin) / l).sin();
                wave + config.noise * config.amplitude * c * (2.0 * splitmix(&mut rng) - 1.0)
            })
            .collect();
        let init = ParticleInit {
            x: layout.x.clone(),
            v,
            sigma: vec![0.0; n],
            f: vec![1.0; n],
            volume0: layout.volume0.clone(),
            mass: layout.mass.clone(),
            width: layout.width.clone(),
        };
        // Validate once here, so that runs only fail by instability.
        ReferenceStepper::new(grid.clone(), shape, material, init.clone())
            .map_err(|e| StabilityError::Setup(e.to_string()))?;
        Ok(Self {
            grid,
            shape,
            material,
            init,
            config,
        })
    }

    /// The protocol's initial particle state.
    pub fn initial(&self) -> &ParticleInit {
        &self.init
    }

    /// One run with step `dt`.
    pub fn run(&self, dt: f64) -> Result<RunOutcome, StabilityError> {
        check_dt(dt)?;
        let mut s = ReferenceStepper::new(
            self.grid.clone(),
            self.shape,
            self.material,
            self.init.clone(),
        )
        .map_err(|e| StabilityError::Setup(e.to_string()))?;
        let e0 = s.total_energy();
        let mut max_ratio: f64 = 1.0;
        for k in 0..self.config.steps {
            let failed = s.try_step(dt).is_err() || s.accept().is_err();
            let e = s.total_energy();
            let ratio = e / e0;
            if failed || !ratio.is_finite() {
                return Ok(RunOutcome {
                    stable: false,
                    steps: k,
                    max_energy_ratio: f64::INFINITY,
                });
            }
            max_ratio = max_ratio.max(ratio);
            if ratio > self.config.growth {
                return Ok(RunOutcome {
                    stable: false,
                    steps: k + 1,
                    max_energy_ratio: max_ratio,
                });
            }
        }
        Ok(RunOutcome {
            stable: true,
            steps: self.config.steps,
            max_energy_ratio: max_ratio,
        })
    }

    /// Bisection between `lo` and `hi` (widened geometrically, by at most 8 halvings or
    /// doublings, if `lo` is not stable or `hi` not unstable).
    pub fn critical_dt(&self, lo: f64, hi: f64) -> Result<EmpiricalCritical, StabilityError> {
        check_dt(lo)?;
        check_dt(hi)?;
        let (mut lo, mut hi) = (lo.min(hi), lo.max(hi));
        let mut runs = 0;
        let stable = |dt: f64, runs: &mut usize| -> Result<bool, StabilityError> {
            *runs += 1;
            let out = self.run(dt)?;
            tracing::debug!(dt, stable = out.stable, steps = out.steps, "empirical run");
            Ok(out.stable)
        };
        let mut tries = 0;
        while !stable(lo, &mut runs)? {
            hi = lo;
            lo *= 0.5;
            tries += 1;
            if tries > 8 {
                return Err(StabilityError::NoBracket {
                    stable: 0.0,
                    tried: lo,
                });
            }
        }
        tries = 0;
        while stable(hi, &mut runs)? {
            lo = hi;
            hi *= 2.0;
            tries += 1;
            if tries > 8 {
                return Err(StabilityError::NoBracket {
                    stable: lo,
                    tried: hi,
                });
            }
        }
        while hi - lo > self.config.rel_tol * lo {
            let mid = 0.5 * (lo + hi);
            if stable(mid, &mut runs)? {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(EmpiricalCritical {
            dt_stable: lo,
            dt_unstable: hi,
            runs,
        })
    }
}

/// Steps tried around a bisection's answer, each side, by [`scan_monotone`].
pub const SCAN_POINTS: usize = 16;

/// Whether stability is monotone in `dt` around a bisection's answer ([`scan_monotone`]).
///
/// A bisection assumes that every step below the blow-up step is stable. On layouts with
/// nearly empty nodes it is not always so (measured on a 1D linear-hat layout with a light
/// node: `dt = 0.034` blew up, 0.035–0.039 did not, 0.040 did, 0.041 did not): one
/// bisection's answer then depends on its bracket. The scan says where.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MonotoneScan {
    /// The steps tried, increasing, and whether each run stayed stable.
    pub tried: Vec<(f64, bool)>,
    /// The steps found unstable below a larger step found stable (empty: monotone where
    /// scanned).
    pub unstable_below_stable: Vec<f64>,
}

impl MonotoneScan {
    /// Whether every step below the largest stable one tried was stable.
    pub fn is_monotone(&self) -> bool {
        self.unstable_below_stable.is_empty()
    }
}

/// Runs `2·SCAN_POINTS + 1` equally spaced steps in `[0.7, 1.3]·center` (`stable(dt)` is
/// one real run) and reports the unstable ones below the largest stable one.
pub fn scan_monotone<E>(
    center: f64,
    mut stable: impl FnMut(f64) -> Result<bool, E>,
) -> Result<MonotoneScan, E> {
    let n = 2 * SCAN_POINTS;
    let mut tried = Vec::with_capacity(n + 1);
    for k in 0..=n {
        let dt = center * (0.7 + 0.6 * k as f64 / n as f64);
        tried.push((dt, stable(dt)?));
    }
    let largest_stable = tried
        .iter()
        .filter(|(_, s)| *s)
        .map(|(dt, _)| *dt)
        .fold(f64::NEG_INFINITY, f64::max);
    let unstable_below_stable = tried
        .iter()
        .filter(|(dt, s)| !s && *dt < largest_stable)
        .map(|(dt, _)| *dt)
        .collect();
    Ok(MonotoneScan {
        tried,
        unstable_below_stable,
    })
}

impl Protocol {
    /// [`scan_monotone`] with this protocol's runs around `center`.
    pub fn scan(&self, center: f64) -> Result<MonotoneScan, StabilityError> {
        check_dt(center)?;
        scan_monotone(center, |dt| self.run(dt).map(|o| o.stable))
    }
}
