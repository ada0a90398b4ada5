//! taichi's `mpm88` scene on the MLS-MPM solver ([`super::solver`]): its settings, its
//! initial state and the controller's config for it (module docs of `mls_mpm`).

use super::solver::{MlsMpm, Model};
use mpm_dt::controller::ControllerConfig;
use mpm_dt::limits_nd::TransferNd;
use nalgebra::Vector2;
use rand::{Rng, SeedableRng};

/// mpm88's shipped fixed step.
pub const MPM88_DT: f64 = 2e-4;

/// The scene's settings.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    pub n_grid: usize,
    pub t_end: f64,
    /// mpm88's own weakly compressible fluid instead of the jelly.
    pub fluid: bool,
    /// The stability limit analyses the scheme's APIC transfer (the default), or the
    /// paper's FLIP step as eq 56 stands (`--eq56`) (`limits_nd::TransferNd`).
    pub apic: bool,
    /// Whether the controlled run's solver hands the library its pass's totals (the
    /// opt-in contract; `--generic` turns it off). Fixed-step runs never compute them.
    pub summary: bool,
}

pub fn build(scene: Scene) -> MlsMpm {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(88);
    // mpm88's particle count, whatever the grid (its `n_particles = 8192`).
    let n = 8192;
    let x: Vec<Vector2<f64>> = (0..n)
        .map(|_| {
            Vector2::new(
                rng.random::<f64>() * 0.4 + 0.2,
                rng.random::<f64>() * 0.4 + 0.2,
            )
        })
        .collect();
    let v = vec![Vector2::new(0.0, -1.0); n];
    let model = if scene.fluid {
        Model::Fluid {
            bulk_modulus: 400.0,
        }
    } else {
        Model::Jelly {
            youngs_modulus: 400.0,
            poisson_ratio: 0.2,
        }
    };
    MlsMpm::new(scene.n_grid, model, 1.0, Vector2::new(0.0, -9.8), x, v).with_summary(scene.summary)
}

/// The controller's config for the scene: `base` with gravity 9.8 downwards (the growth
/// monitor's potential energy) and, unless `scene.apic` is off, the stability limit told
/// the scheme's APIC transfer.
pub fn controller_config(scene: Scene, base: &ControllerConfig) -> ControllerConfig {
    let mut config = base.clone();
    config.gravity = Some(vec![0.0, -9.8]);
    if scene.apic {
        // The stability limit told that the scheme transfers velocities by APIC with
        // quadratic B-splines (inertia h²/4): a property of the scheme, not a tuning.
        config.stability_nd.transfer = TransferNd::Apic { inertia: 0.25 };
    }
    config
}
