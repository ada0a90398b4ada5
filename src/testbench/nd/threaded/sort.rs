//! Phase 2 of the threaded step ([`super`]): the particle indices sorted by slab.

use super::{ThreadScratch, CHUNK};
use rayon::prelude::*;

/// Phase 2: the particle indices sorted by slab, stable (a counting sort), on the current
/// pool: each chunk of [`CHUNK`] particles counts its slabs, the counts give each chunk
/// where its particles of each slab go (after the earlier chunks' and slabs'), and the
/// chunks place their particles in parallel. The order is the serial counting sort's.
pub(super) fn sort_by_slab(scratch: &mut ThreadScratch, count: usize) {
    let counts: Vec<Vec<usize>> = scratch
        .slab_of
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut c = vec![0usize; count];
            for &s in chunk {
                c[s as usize] += 1;
            }
            c
        })
        .collect();
    let starts = &mut scratch.starts;
    starts.clear();
    starts.resize(count + 1, 0);
    for c in &counts {
        for (s, &n) in c.iter().enumerate() {
            starts[s + 1] += n;
        }
    }
    for s in 0..count {
        starts[s + 1] += starts[s];
    }
    // Where chunk `k` puts its first particle of each slab.
    let mut next = starts[..count].to_vec();
    let firsts: Vec<Vec<usize>> = counts
        .iter()
        .map(|c| {
            let first = next.clone();
            for (s, &n) in c.iter().enumerate() {
                next[s] += n;
            }
            first
        })
        .collect();
    scratch.order.resize(scratch.slab_of.len(), 0);
    let order = SharedOrder(scratch.order.as_mut_ptr(), scratch.order.len());
    scratch
        .slab_of
        .par_chunks(CHUNK)
        .zip(firsts)
        .enumerate()
        .for_each(|(k, (chunk, mut next))| {
            for (j, &s) in chunk.iter().enumerate() {
                let at = next[s as usize];
                next[s as usize] += 1;
                // SAFETY: the positions of different chunks are disjoint (each owns its
                // own range within every slab).
                unsafe { order.write(at, (k * CHUNK + j) as u32) };
            }
        });
}

/// The particle order of phase 2, written by the chunks at disjoint positions.
#[derive(Clone, Copy)]
struct SharedOrder(*mut u32, usize);

impl SharedOrder {
    /// Writes `value` at position `at` (checked against the length).
    ///
    /// # Safety
    /// No other thread may read or write position `at` meanwhile.
    unsafe fn write(&self, at: usize, value: u32) {
        assert!(at < self.1, "slab position {at} outside the order");
        // SAFETY: `at` is in bounds (checked); the caller keeps it to itself.
        unsafe { *self.0.add(at) = value };
    }
}

// SAFETY: the chunks that share it write disjoint positions (`sort_by_slab`).
unsafe impl Send for SharedOrder {}
unsafe impl Sync for SharedOrder {}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel counting sort gives the serial stable order: several chunks, many
    /// slabs, empty slabs, on pools of 1, 2 and 3 threads.
    #[test]
    fn the_sort_is_the_stable_order_on_any_number_of_threads() {
        let (n, count) = (3 * CHUNK + 517, 13usize);
        let mut seed = 0x5eed_u64;
        let slab_of: Vec<u32> = (0..n)
            .map(|_| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                // Slab 5 stays empty.
                let s = ((seed >> 33) % (count as u64 - 1)) as u32;
                if s >= 5 {
                    s + 1
                } else {
                    s
                }
            })
            .collect();
        let mut expected: Vec<u32> = (0..n as u32).collect();
        expected.sort_by_key(|&p| slab_of[p as usize]); // stable
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let mut scratch = ThreadScratch {
                slab_of: slab_of.clone(),
                ..ThreadScratch::default()
            };
            pool.install(|| sort_by_slab(&mut scratch, count));
            assert_eq!(scratch.order, expected, "{threads} threads");
            assert_eq!(scratch.starts.len(), count + 1);
            for s in 0..count {
                let range = scratch.starts[s]..scratch.starts[s + 1];
                assert!(scratch.order[range]
                    .iter()
                    .all(|&p| slab_of[p as usize] as usize == s));
            }
            assert_eq!(scratch.starts[5], scratch.starts[6]);
        }
    }
}
