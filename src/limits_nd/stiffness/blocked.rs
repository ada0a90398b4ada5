//! The product `y = A u` ([`super::apply_scaled`]) on a pool of threads: the particles in
//! [`BLOCKS`] fixed contiguous ranges, each range's sum into a nodal vector of its own, the
//! vectors then added in range order. The ranges depend on the particle count only, so
//! the product is the same bit for bit on any number of threads; it differs from the
//! one-range sum of [`super::apply_scaled`] by round-off (the order of the nodal sums).
//!
//! **Memory:** the ranges' vectors, `8·D` numbers per node, are held through one Lanczos
//! run and freed after it (not in [`crate::limit::StepLimit::memory_bytes`], which counts
//! what a limit keeps between steps): 32 B per particle on a 2D wave of 2 particles per
//! cell and axis, 24 B in 3D, at most `32·D` B where a layout is still blocked.

use crate::nd::{det, Tensor, Vector, ViewNd, ViewWeightsNd};
use rayon::prelude::*;

/// Ranges of particles of a blocked product: a fixed count, so that the sums' order does
/// not depend on the number of threads.
pub(super) const BLOCKS: usize = 8;

/// Fewest particles for which a product is blocked (below, one range on the calling
/// thread: a small layout's product costs less than the nodal vectors' sum).
pub(super) const MIN_PARTICLES: usize = 16_384;

/// Whether a product over `particles` particles and `active` active nodes is blocked:
/// enough particles, and at most half an active node per particle (`8·active ≤
/// 4·particles`: the ranges' vectors, which hold the active nodes only, then hold at most
/// four nodes per particle in all). Depends on the layout only, never on the number of
/// threads.
pub(super) fn is_blocked(particles: usize, active: usize) -> bool {
    particles >= MIN_PARTICLES && active * BLOCKS <= 4 * particles
}

/// What a product reads of the view: its particle fields and weights (the view's
/// process-split part is not shared between threads).
#[derive(Clone, Copy)]
pub(super) struct ProductFields<'a, const D: usize> {
    pub(super) weights: ViewWeightsNd<'a, D>,
    f: &'a [Tensor<D>],
    volume0: &'a [f64],
    lame_lambda: &'a [f64],
    lame_mu: &'a [f64],
}

impl<'a, const D: usize> ProductFields<'a, D> {
    /// The fields of `view`.
    pub(super) fn of(view: &ViewNd<'a, D>) -> Self {
        Self {
            weights: view.weights,
            f: view.f,
            volume0: view.volume0,
            lame_lambda: view.lame_lambda,
            lame_mu: view.lame_mu,
        }
    }
}

/// A blocked product's layout-dependent part, formed once per Lanczos run (the view does
/// not change between its products): each node's slot among the active nodes (the ranges'
/// vectors hold the active nodes only, numbered in node order, so that bodies in a mostly
/// empty box cost no more than a dense layout), and the ranges' vectors kept between
/// products.
pub(super) struct BlockedProduct {
    slot: Vec<u32>,
    active: usize,
    parts: Vec<Vec<f64>>,
}

impl BlockedProduct {
    /// The plan for `view`, or `None` where its layout is not blocked ([`is_blocked`]).
    pub(super) fn plan<const D: usize>(view: &ViewNd<'_, D>) -> Option<Self> {
        let (slot, active) = active_slots(view.node_active);
        is_blocked(view.n_particles(), active).then(|| Self {
            slot,
            active,
            parts: Vec::new(),
        })
    }

    /// `y = A u` on `pool` (module docs) for the view the plan was formed for; `y` has the
    /// length of `u`.
    pub(super) fn apply<const D: usize>(
        &mut self,
        pool: &rayon::ThreadPool,
        view: &ViewNd<'_, D>,
        inv_sqrt_m: &[f64],
        u: &[f64],
        y: &mut [f64],
    ) {
        let fields = ProductFields::of(view);
        let n = view.n_particles();
        let per_block = n.div_ceil(BLOCKS);
        let (slot, active, parts) = (&self.slot, self.active, &mut self.parts);
        pool.install(|| {
            parts.resize_with(BLOCKS, Vec::new);
            parts.par_iter_mut().enumerate().for_each(|(b, part)| {
                part.clear();
                part.resize(active * D, 0.0);
                let range = (b * per_block).min(n)..((b + 1) * per_block).min(n);
                add_range(&fields, inv_sqrt_m, u, range, part, Some(slot));
            });
            let parts = &*parts;
            y.par_chunks_mut(NODES_PER_TASK * D)
                .enumerate()
                .for_each(|(k, chunk)| {
                    let first = k * NODES_PER_TASK;
                    for (j, node) in chunk.chunks_mut(D).enumerate() {
                        let s = slot[first + j];
                        for (a, out) in node.iter_mut().enumerate() {
                            let mut sum = 0.0;
                            if s != INACTIVE {
                                for part in parts {
                                    sum += part[s as usize * D + a];
                                }
                            }
                            *out = sum;
                        }
                    }
                });
        });
    }
}

/// Nodes per task when the ranges' vectors are added.
const NODES_PER_TASK: usize = 4096;

/// The slot of an inactive node.
const INACTIVE: u32 = u32::MAX;

/// Each node's slot among the active nodes (in node order; [`INACTIVE`] for the others)
/// and their count.
fn active_slots(node_active: &[bool]) -> (Vec<u32>, usize) {
    let mut count = 0usize;
    let slot = node_active
        .iter()
        .map(|&a| {
            if a {
                count += 1;
                (count - 1) as u32
            } else {
                INACTIVE
            }
        })
        .collect();
    (slot, count)
}

/// The particles `range`'s part of `A u` added into `y`, particle by particle: each
/// particle's `(V_p λ_t, V_p μ_t)`, `V_p = det(F_p) V⁰_p`, is formed here, as its weight row
/// is, so that repeated products keep no per-particle array. With `slot`, node `i`'s
/// components go to `y[slot[i]·D ..]` (active nodes only: an inactive node's
/// `M^{-1/2}` is zero and it is skipped), else to `y[i·D ..]`.
pub(super) fn add_range<const D: usize>(
    view: &ProductFields<'_, D>,
    inv_sqrt_m: &[f64],
    u: &[f64],
    range: std::ops::Range<usize>,
    y: &mut [f64],
    slot: Option<&[u32]>,
) {
    for p in range {
        let moduli = view.moduli(p);
        view.weights.with_row(p, |nodes, _, grads| {
            add_particle(moduli, nodes, grads, inv_sqrt_m, u, y, slot);
        });
    }
}

impl<const D: usize> ProductFields<'_, D> {
    /// Particle `p`'s `(V_p λ_t, V_p μ_t)`, `V_p = det(F_p) V⁰_p`.
    #[inline(always)]
    pub(super) fn moduli(&self, p: usize) -> (f64, f64) {
        let vol = det(&self.f[p]) * self.volume0[p];
        (vol * self.lame_lambda[p], vol * self.lame_mu[p])
    }
}

/// One particle's part of `A u` added into `y` ([`add_range`]): its moduli
/// `(V_p λ_t, V_p μ_t)` and its weight row's node indices and gradients. Entries at nodes
/// whose `M^{-1/2}` is zero (inactive) add nothing.
#[inline(always)]
pub(super) fn add_particle<const D: usize>(
    (vol_lambda, vol_mu): (f64, f64),
    nodes: &[u32],
    grads: &[Vector<D>],
    inv_sqrt_m: &[f64],
    u: &[f64],
    y: &mut [f64],
    slot: Option<&[u32]>,
) {
    let mut l = Tensor::<D>::zeros();
    for (&i, g) in nodes.iter().zip(grads) {
        let i = i as usize;
        let s = inv_sqrt_m[i];
        if s == 0.0 {
            continue;
        }
        let ui = Vector::<D>::from_fn(|a, _| u[i * D + a] * s);
        l += ui * g.transpose();
    }
    let eps = (l + l.transpose()) * 0.5;
    let stress = Tensor::<D>::identity() * (vol_lambda * eps.trace()) + eps * (2.0 * vol_mu);
    for (&i, g) in nodes.iter().zip(grads) {
        let i = i as usize;
        let s = inv_sqrt_m[i];
        if s == 0.0 {
            continue;
        }
        let f = stress * g;
        let at = slot.map_or(i, |slot| slot[i] as usize);
        for a in 0..D {
            y[at * D + a] += f[a] * s;
        }
    }
}

// Drives the reference solvers: tested with the `reference` feature.
#[cfg(all(test, feature = "reference"))]
mod tests {
    use super::super::{apply_scaled, apply_scaled_on, inverse_sqrt_mass};
    use crate::Stepper;

    /// A blocked product is the same bit for bit on 1, 2 and 3 threads and within
    /// round-off of the one-range product, on a walled, sheared GIMP layout.
    #[test]
    fn a_blocked_product_is_the_same_on_any_number_of_threads() {
        let s = super::super::test_layout::sheared_block(70);
        let view = s.view();
        assert!(super::BlockedProduct::plan(&view).is_some());
        let inv = inverse_sqrt_mass(&view);
        let u: Vec<f64> = (0..inv.len() * 2)
            .map(|k| ((k * 7919) % 1000) as f64 / 1000.0 - 0.5)
            .collect();
        let mut one_range = vec![0.0; u.len()];
        apply_scaled(&view, &inv, &u, &mut one_range);
        let blocked = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let mut y = vec![0.0; u.len()];
            apply_scaled_on(Some(&pool), &view, &inv, &u, &mut y);
            y
        };
        let bits = |y: &[f64]| y.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let y1 = blocked(1);
        assert_eq!(bits(&y1), bits(&blocked(2)));
        assert_eq!(bits(&y1), bits(&blocked(3)));
        let scale = one_range.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 0.0);
        let worst = y1
            .iter()
            .zip(&one_range)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst <= 1e-12 * scale, "{worst:e} against {scale:e}");
        assert_ne!(bits(&y1), bits(&one_range), "the blocked sum was not taken");
    }
}
