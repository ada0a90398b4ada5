//! Global reductions: one time-step decision for a run split over several processes.
//!
//! Distributed MPM codes (Uintah, CB-Geo, Karamelo) decompose the grid over MPI ranks and
//! agree on the step with a global minimum. The [`Controller`](crate::controller::Controller)
//! does the same through this small object-safe interface: every rank proposes from its own
//! part of the state, and per attempt the ranks agree on
//!
//! 1. the step: the minimum of the ranks' steps, and whether any rank failed before its
//!    trial (a limit error, no admissible step) — one [`Reduce::min_and_any`];
//! 2. the verdict: whether any rank's trial failed fatally, whether any rank rejected it
//!    (a non-finite trial, a limit's veto) — one [`Reduce::any_flags`]; a rank that
//!    accepted its own part rejects with [`RejectCause::OtherRank`](crate::limit::RejectCause);
//! 3. after a rejection, the retry step: the minimum of the ranks' retry steps.
//!
//! So every rank takes the same accepted steps and the same rejections, and a rank whose
//! trial goes non-finite makes every rank reject. Every rank calls the same collectives in
//! the same order, errors included: a rank that fails says so in the next collective and
//! the others end with [`ControllerError::OtherRank`](crate::controller::ControllerError)
//! instead of waiting for it.
//!
//! [`SingleProcess`] (the default) reduces over one process and costs nothing; `MpiReduce`
//! (feature `mpi`, rsmpi) reduces over an MPI communicator with `MPI_Allreduce`.
//!
//! What the limits reduce: the controller's minimum covers every limit's proposal (each
//! rank's limits see only its own particles). Quantities that are sums over the whole
//! state — the stability tracker's Lanczos dot products, the growth monitor's energies —
//! need a stepper that exchanges nodal sums across ranks; the reference solver is not
//! decomposed yet, so those stay per rank (a growth on any rank still rejects everywhere,
//! through step 2).
//!
//! # What a decomposed stepper must provide (not implemented yet)
//!
//! For the stability limit to apply `A = M^{-1/2} K M^{-1/2}` (eq 56 in d dimensions,
//! [`crate::limits_nd::stiffness`]) across ranks, a rank's view must hold its own particles
//! and every node they touch: the nodes it owns plus a ghost layer one stencil wide (two
//! cells for GIMP and quadratic B-splines, one for linear hats) beside its part of the grid,
//! with the *summed* nodal masses of all ranks on the ghosts as on the owned nodes (the
//! exchange its particle → grid pass already needs). A product `y = A u` is then: copy `u`
//! from owners to ghosts; apply the rank's particles; send the ghost rows of `y` to their
//! owners and add them there. The Lanczos dot products and norms are sums over owned nodes
//! only, completed with [`Reduce::sum`]; the growth monitor's energies are sums over owned
//! particles, completed the same way. With these the tracked `λmax` is that of the whole
//! grid, identical on every rank.

/// Global reductions over the processes of one run (module docs). Object safe.
pub trait Reduce: std::fmt::Debug {
    /// This process's index, `0..size`.
    fn rank(&self) -> usize;
    /// Number of processes.
    fn size(&self) -> usize;
    /// The minimum of `value` over all processes, and whether `flag` is set on any. `value`
    /// must not be NaN (the controller passes `+∞` where it has no value).
    fn min_and_any(&self, value: f64, flag: bool) -> (f64, bool);
    /// For each entry, whether it is set on any process.
    fn any_flags(&self, flags: &mut [bool]);
    /// Element-wise sums over all processes, in place.
    fn sum(&self, values: &mut [f64]);
}

/// One process: every reduction is the identity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SingleProcess;

impl Reduce for SingleProcess {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn min_and_any(&self, value: f64, flag: bool) -> (f64, bool) {
        (value, flag)
    }
    fn any_flags(&self, _flags: &mut [bool]) {}
    fn sum(&self, _values: &mut [f64]) {}
}

#[cfg(feature = "mpi")]
mod mpi_reduce;
#[cfg(feature = "mpi")]
pub use mpi_reduce::MpiReduce;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_process_is_the_identity() {
        let r: Box<dyn Reduce> = Box::new(SingleProcess);
        assert_eq!((r.rank(), r.size()), (0, 1));
        assert_eq!(r.min_and_any(2.5, true), (2.5, true));
        assert_eq!(r.min_and_any(f64::INFINITY, false), (f64::INFINITY, false));
        let mut f = [true, false];
        r.any_flags(&mut f);
        assert_eq!(f, [true, false]);
        let mut v = [1.0f64, -2.0];
        r.sum(&mut v);
        assert_eq!(v.map(f64::to_bits), [1.0f64, -2.0].map(f64::to_bits));
    }
}
