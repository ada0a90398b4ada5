//! A register window over the nodal accumulators of the particle→grid deposit.
//!
//! A particle adds to the [`MAX_NODES`] consecutive accumulator slots from its stencil's
//! first slot `base`. Added to memory directly, every particle's adds wait for the previous
//! particle's stores to the same slots (consecutive particles share slots): a chain of
//! store→load forwarding and addition per particle, which bounds the deposit's speed
//! whatever the width of the vector units. [`SlotWindow`] keeps the [`MAX_NODES`] slots from
//! `base` in locals (registers, once inlined) and writes a slot to memory only when the
//! window moves past it, so the chain runs through registers and each slot is written once
//! per visit.
//!
//! **Rounding.** A slot's memory value is the sum of the *partial sums* of its visits,
//! added to it in visit order; each partial sum starts from `0.0` and receives its
//! particles in particle order. When the stencils' bases never decrease along the particle
//! order (particles sorted by `x − l_p/2`, i.e. by position when the GIMP widths are equal,
//! the usual 1D layout), every slot is visited once
//! and its memory holds `0.0` before the flush, so the result is bit for bit the plain
//! loop's `((0 + c₁) + c₂) + …`. When a base goes back (a particle out of order, e.g. one
//! that crossed a periodic end), the slots it revisits get `(c₁ + … + c_k) + (c_{k+1} + …)`
//! instead: a different rounding of the same sum, and the same bits for the same particle
//! order. The step ([`super::step`]) and the set-up deposit of a restart use the same
//! window over the same particle order, so a restart still reproduces the nodal sums
//! exactly.

use crate::shape::MAX_NODES;

/// `MAX_NODES` consecutive 4-lane accumulator slots from `base`, held in locals.
pub(crate) struct SlotWindow {
    /// First slot of the window; `usize::MAX` before the first particle and after
    /// [`SlotWindow::flush`].
    base: usize,
    slots: [[f64; 4]; MAX_NODES],
}

const ZERO: [f64; 4] = [0.0; 4];

/// `mem += w`, lane by lane (one vector add).
#[inline(always)]
fn add_into(mem: &mut [f64; 4], w: [f64; 4]) {
    for k in 0..4 {
        mem[k] += w[k];
    }
}

impl SlotWindow {
    /// An empty window.
    pub(crate) fn new() -> Self {
        Self {
            base: usize::MAX,
            slots: [ZERO; MAX_NODES],
        }
    }

    /// Moves the window to start at `base` (`base + MAX_NODES ≤ mem.len()`), writing the
    /// slots it leaves to `mem`, and returns the window's slots for the particle's adds.
    #[inline(always)]
    pub(crate) fn at(&mut self, mem: &mut [[f64; 4]], base: usize) -> &mut [[f64; 4]; MAX_NODES] {
        if base != self.base {
            self.slide(mem, base);
        }
        &mut self.slots
    }

    /// The move of [`SlotWindow::at`]: by one or two slots (the slots left behind are
    /// written, the others kept), or anywhere else (every slot written, the window
    /// restarted from zero).
    #[inline(always)]
    fn slide(&mut self, mem: &mut [[f64; 4]], base: usize) {
        const _: () = assert!(MAX_NODES == 3, "the slide cases are written for 3 slots");
        let [s0, s1, s2] = self.slots;
        if self.base == usize::MAX {
            // Empty: the slots are zero.
            self.base = base;
            return;
        }
        match base.wrapping_sub(self.base) {
            1 => {
                add_into(&mut mem[self.base], s0);
                self.slots = [s1, s2, ZERO];
            }
            2 => {
                add_into(&mut mem[self.base], s0);
                add_into(&mut mem[self.base + 1], s1);
                self.slots = [s2, ZERO, ZERO];
            }
            _ => {
                self.flush(mem);
                self.slots = [ZERO; MAX_NODES];
            }
        }
        self.base = base;
    }

    /// Writes every slot of the window to `mem` and empties it.
    #[inline(always)]
    pub(crate) fn flush(&mut self, mem: &mut [[f64; 4]]) {
        if self.base != usize::MAX {
            for (k, s) in self.slots.into_iter().enumerate() {
                add_into(&mut mem[self.base + k], s);
            }
        }
        self.base = usize::MAX;
        self.slots = [ZERO; MAX_NODES];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sorted bases: bit for bit the plain loop; unsorted: the same sum to rounding.
    #[test]
    fn window_matches_the_plain_loop() {
        let n = 12;
        for bases in [
            vec![0usize, 0, 1, 1, 2, 3, 3, 3, 5, 6, 9, 9],
            vec![4usize, 0, 2, 1, 1, 8, 7, 0, 3],
        ] {
            let mut plain = vec![ZERO; n];
            let mut windowed = vec![ZERO; n];
            let mut w = SlotWindow::new();
            for (p, &b) in bases.iter().enumerate() {
                let c = |k: usize, lane: usize| 0.1 * (p + 1) as f64 / (k + lane + 3) as f64;
                for (k, slot) in plain[b..b + MAX_NODES].iter_mut().enumerate() {
                    for (lane, v) in slot.iter_mut().enumerate() {
                        *v += c(k, lane);
                    }
                }
                let slots = w.at(&mut windowed, b);
                for (k, slot) in slots.iter_mut().enumerate() {
                    for (lane, v) in slot.iter_mut().enumerate() {
                        *v += c(k, lane);
                    }
                }
            }
            w.flush(&mut windowed);
            let sorted = bases.windows(2).all(|p| p[0] <= p[1]);
            for (a, b) in plain.iter().flatten().zip(windowed.iter().flatten()) {
                if sorted {
                    assert_eq!(a.to_bits(), b.to_bits(), "{bases:?}");
                } else {
                    assert!((a - b).abs() <= 1e-15, "{bases:?}");
                }
            }
        }
    }
}
