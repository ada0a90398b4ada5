//! The reference solver on threads: [`SolverNd::set_threads`] (the threaded step itself
//! is `crate::testbench::nd::threaded`).

use super::SolverNd;
use std::sync::Arc;

/// A thread pool could not be built ([`SolverNd::set_threads`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("cannot start the solver's threads: {0}")]
pub struct ThreadsError(pub String);

impl<const D: usize> SolverNd<D> {
    /// Runs each step on `threads` threads of a pool of its own (`None` or `Some(0)`: on the
    /// calling thread, the default): the particles' updates in fixed chunks of particles,
    /// then the particle → grid sums slab by slab across the last axis, in four colours of
    /// slabs whose stencils cannot reach the same node. Chunks and slabs depend on the
    /// particle count and the grid alone, so the state after a step is the same, bit for bit,
    /// on any number of threads, and differs from the unthreaded solver's by round-off
    /// (the nodal and energy sums are made in another order). A grid split into slabs
    /// over processes ([`Self::new_slab`]) steps on the calling thread.
    pub fn set_threads(&mut self, threads: Option<usize>) -> Result<(), ThreadsError> {
        self.threads = match threads {
            None | Some(0) => None,
            Some(n) => Some(Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| ThreadsError(e.to_string()))?,
            )),
        };
        Ok(())
    }

    /// The number of threads a step runs on (1: the calling thread).
    pub fn threads(&self) -> usize {
        self.threads.as_ref().map_or(1, |p| p.current_num_threads())
    }
}
