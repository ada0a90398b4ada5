//! A seeded jitter of 2D/3D particle layouts, shared by the tests of the critical steps.

use mpm_dt::nd::ParticlesNd;

/// Moves every particle by up to `amp/2` of its spacing per axis (uniform, a 64-bit LCG
/// seeded with `seed`).
pub fn jitter<const D: usize>(particles: &mut ParticlesNd<D>, amp: f64, seed: u64) {
    let mut s: u64 = seed;
    for p in 0..particles.len() {
        for a in 0..D {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            particles.x[p][a] += amp * particles.domain[p][a] * u;
        }
    }
}
