//! The time-stepping error of a run: the distance of its end state from the same solver's
//! run with a converged step (module docs of `work_precision`).
//!
//! With `N` particles, `U = √(2E₀/M)` the speed that carries the initial energy `E₀` over
//! the total mass `M` (the motion's velocity scale) and `U·t_end` its length scale:
//!
//! ```text
//! e_x = √( (1/N) Σ_p |x_p − x_p^ref|² ) / (U t_end)
//! e_v = √( (1/N) Σ_p |v_p − v_p^ref|² ) / U
//! e_E = |E − E^ref| / E₀
//! ```
//!
//! (RMS over particles of the Euclidean distance; the end states of both runs are at
//! `t_end`, the particles in the same order.)

use super::runs::EndState;
use serde::Serialize;

/// The scales that make the measures relative.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Scales {
    /// `U = √(2E₀/M)`.
    pub velocity: f64,
    /// `U·t_end`.
    pub length: f64,
    /// `E₀`.
    pub energy: f64,
}

impl Scales {
    /// The scales of a scene whose initial energy is `e0`, total mass `mass`, run to `t_end`.
    pub fn new(e0: f64, mass: f64, t_end: f64) -> Self {
        let velocity = (2.0 * e0 / mass).sqrt();
        Self {
            velocity,
            length: velocity * t_end,
            energy: e0,
        }
    }
}

/// The three error measures of one run against the reference.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Errors {
    /// `e_x`: RMS position error over the length scale.
    pub position: f64,
    /// `e_v`: RMS velocity error over the velocity scale.
    pub velocity: f64,
    /// `e_E`: energy difference over the initial energy.
    pub energy: f64,
}

impl Errors {
    /// The measures as `(name, value)` pairs, in the plot's panel order.
    pub fn named(&self) -> [(&'static str, f64); 3] {
        [
            ("position", self.position),
            ("velocity", self.velocity),
            ("energy", self.energy),
        ]
    }
}

/// RMS over particles of the Euclidean distance of `a` and `b` (`d` numbers per particle).
fn rms_distance(a: &[f64], b: &[f64], n: usize) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum();
    (sum / n.max(1) as f64).sqrt()
}

/// The errors of `run` against `reference` (`n` particles), or why they cannot be taken.
pub fn errors(
    run: &EndState,
    reference: &EndState,
    n: usize,
    s: &Scales,
) -> Result<Errors, String> {
    if run.x.len() != reference.x.len() || run.v.len() != reference.v.len() {
        return Err("end states of different sizes".into());
    }
    if (run.t - reference.t).abs() > 1e-9 * reference.t.abs().max(1.0) {
        return Err(format!(
            "ended at t = {} (reference {})",
            run.t, reference.t
        ));
    }
    Ok(Errors {
        position: rms_distance(&run.x, &reference.x, n) / s.length,
        velocity: rms_distance(&run.v, &reference.v, n) / s.velocity,
        energy: (run.energy - reference.energy).abs() / s.energy,
    })
}
