//! Total momentum `Σ_p m_p v_p` is conserved to round-off on a periodic bar: with all
//! nodes active, `Σ_p m_p Δv_p = dt Σ_i a_i m_i = dt Σ_i f_i = −dt Σ_p σ_p F_p V⁰_p Σ_i D_ip = 0`
//! because `Σ_i D_ip = 0`. Checked for jittered particles with random velocities and
//! stresses (seeded), both shapes and both materials.

use mpm_dt::mpm::{Material, ParticleInit, ReferenceStepper};
use mpm_dt::{Boundary, Grid, Shape, Stepper};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn jittered(grid: &Grid, ppc: usize, rng: &mut ChaCha8Rng) -> ParticleInit {
    let n = grid.cells * ppc;
    let l = grid.h / ppc as f64;
    let x = (0..n)
        .map(|p| grid.wrap((p as f64 + 0.5 + rng.random_range(-0.4..0.4)) * l))
        .collect();
    ParticleInit {
        x,
        v: (0..n).map(|_| rng.random_range(-0.01..0.01)).collect(),
        sigma: (0..n).map(|_| rng.random_range(-0.01..0.01)).collect(),
        f: vec![1.0; n],
        volume0: vec![l; n],
        mass: (0..n).map(|_| l * rng.random_range(0.5..1.5)).collect(),
        width: vec![l; n],
    }
}

#[test]
fn momentum_is_conserved_to_round_off_on_a_periodic_bar() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5EED);
    for shape in [Shape::Gimp, Shape::Linear] {
        for material in [
            Material::LinearElastic {
                youngs_modulus: 1.0,
            },
            Material::NeoHookean {
                youngs_modulus: 1.0,
            },
        ] {
            let grid = Grid::new(Boundary::Periodic, 24, 1.0);
            let init = jittered(&grid, 3, &mut rng);
            let scale: f64 = init
                .mass
                .iter()
                .zip(&init.v)
                .map(|(m, v)| (m * v).abs())
                .sum();
            let mut s = ReferenceStepper::new(grid.clone(), shape, material, init).unwrap();
            let p0 = s.total_momentum();
            let dt = 0.2 * grid.h;
            for step in 0..300 {
                s.try_step(dt).unwrap();
                s.accept().unwrap();
                let drift = (s.total_momentum() - p0).abs();
                assert!(
                    drift <= 1e-13 * scale,
                    "{shape:?} {material:?} step {step}: momentum drift {drift:e} (scale {scale:e})"
                );
            }
            assert!(s.view().node_active.iter().all(|&a| a), "all nodes active");
        }
    }
}
