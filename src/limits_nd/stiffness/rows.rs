//! The formed weight rows of one view, kept through one Lanczos run ([`super::lanczos_on`])
//! on the calling thread.
//!
//! The reference solver stores no weights: a product `A u` ([`super::apply_scaled`]) forms
//! every particle's row (per-axis factors, then their tensor products) and its moduli
//! `(V_p λ_t, V_p μ_t)` as it goes, which is about half of a product's work on a small GIMP
//! layout. The view does not change between the products of a run, so the first product
//! keeps what it formed — the node indices and gradients of the entries at active nodes
//! (an inactive node's `M^{-1/2}` is zero and the product skips it) and the moduli — and
//! the others read them back. The values are the formed ones and every product adds them
//! in the same order with the same operations ([`super::blocked::add_particle`]), so each
//! product is the unkept one bit for bit.
//!
//! **Memory:** `4 + 8·D` bytes per kept entry and 20 per particle, held through the run
//! and freed after it (not in [`crate::limit::StepLimit::memory_bytes`]); rows are kept
//! only for formed weights and up to [`MAX_ENTRIES`] entries (a layout above it forms its
//! rows in every product, as before).

use super::blocked::{add_particle, ProductFields};
use crate::nd::{Vector, ViewNd};

/// Most row entries (particles × row width) kept: 2²⁰, 20 MB in 2D and 28 MB in 3D at
/// most.
pub(super) const MAX_ENTRIES: usize = 1 << 20;

/// The kept rows (module docs): row `p`'s entries are `start[p]..start[p + 1]`.
pub(super) struct FormedRows<const D: usize> {
    start: Vec<u32>,
    nodes: Vec<u32>,
    grads: Vec<Vector<D>>,
    moduli: Vec<(f64, f64)>,
}

impl<const D: usize> FormedRows<D> {
    /// Empty rows for `view`, where its rows are worth keeping: formed weights, at most
    /// [`MAX_ENTRIES`] entries.
    pub fn for_view(view: &ViewNd<'_, D>) -> Option<Self> {
        let entries = view.n_particles().saturating_mul(view.weights.width());
        (view.weights.is_formed() && entries <= MAX_ENTRIES).then(|| Self {
            start: Vec::new(),
            nodes: Vec::new(),
            grads: Vec::new(),
            moduli: Vec::new(),
        })
    }

    /// Whether the rows were kept (by [`Self::record_and_add`]).
    pub fn is_kept(&self) -> bool {
        !self.start.is_empty()
    }

    /// `y = A u` over all the particles of `view`, keeping each particle's row and moduli
    /// first (entries at nodes with a zero `inv_sqrt_m` left out), then adding from them as
    /// [`Self::add`] does.
    pub fn record_and_add(
        &mut self,
        view: &ViewNd<'_, D>,
        inv_sqrt_m: &[f64],
        u: &[f64],
        y: &mut [f64],
    ) {
        let fields = ProductFields::of(view);
        let n = view.n_particles();
        let width = view.weights.width();
        self.start.reserve(n + 1);
        self.nodes.reserve(n * width);
        self.grads.reserve(n * width);
        self.moduli.reserve(n);
        self.start.push(0);
        for p in 0..n {
            self.moduli.push(fields.moduli(p));
            // Entry by entry, in row order: no row is laid out on the stack.
            fields.weights.for_each_in_row(p, |i, _, g| {
                if inv_sqrt_m[i] != 0.0 {
                    self.nodes.push(i as u32);
                    self.grads.push(*g);
                }
            });
            self.start.push(self.nodes.len() as u32);
        }
        self.add(inv_sqrt_m, u, y);
    }

    /// `y = A u` from the kept rows: the same sums as [`Self::record_and_add`]'s, bit for
    /// bit.
    pub fn add(&self, inv_sqrt_m: &[f64], u: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        for (p, &moduli) in self.moduli.iter().enumerate() {
            let r = self.start[p] as usize..self.start[p + 1] as usize;
            add_particle(
                moduli,
                &self.nodes[r.clone()],
                &self.grads[r],
                inv_sqrt_m,
                u,
                y,
                None,
            );
        }
    }
}

// Drives the reference solvers: tested with the `reference` feature.
#[cfg(all(test, feature = "reference"))]
mod tests {
    use super::super::{apply_scaled, inverse_sqrt_mass};
    use super::FormedRows;
    use crate::Stepper;

    /// Products from the kept rows are [`apply_scaled`]'s bit for bit, the first (which
    /// keeps them) and the later ones, on a walled, sheared GIMP layout.
    #[test]
    fn kept_rows_give_the_same_bits() {
        let s = super::super::test_layout::sheared_block(12);
        let view = s.view();
        let inv = inverse_sqrt_mass(&view);
        let mut rows = FormedRows::for_view(&view).expect("formed weights, a small layout");
        let bits = |y: &[f64]| y.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for k in 0..3 {
            let u: Vec<f64> = (0..inv.len() * 2)
                .map(|c| (((c + k) * 7919) % 1000) as f64 / 1000.0 - 0.5)
                .collect();
            let mut expected = vec![0.0; u.len()];
            apply_scaled(&view, &inv, &u, &mut expected);
            let mut y = vec![1.0; u.len()];
            if rows.is_kept() {
                rows.add(&inv, &u, &mut y);
            } else {
                rows.record_and_add(&view, &inv, &u, &mut y);
            }
            assert!(rows.is_kept());
            assert_eq!(bits(&y), bits(&expected), "product {k}");
        }
    }
}
