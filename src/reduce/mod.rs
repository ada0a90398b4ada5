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
//!    (a non-finite trial, a limit's veto), and whether any rank's growth detection would
//!    take its safety below `growth.min_safety_scale` — one [`Reduce::any_flags`]; a rank
//!    that accepted its own part rejects with
//!    [`RejectCause::OtherRank`](crate::limit::RejectCause), and on the last flag every
//!    rank stops (the detecting ranks with `ControllerError::GrowthPersists`, the others
//!    with `ControllerError::OtherRank`);
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
//! rank's limits see only its own particles). The stability tracker
//! ([`crate::limits_nd::StabilityNd`]) receives the reducer through
//! [`StepLimit::set_reduce`](crate::limit::StepLimit::set_reduce): it sums each Lanczos
//! product `A u` and the diagonal of `A` over the processes and agrees on when to refresh,
//! so its `λmax` is that of the whole problem on every process. The growth monitor
//! ([`crate::limits_nd::GrowthNd`]) watches each process's own energy: its verdict comes
//! after the trial, where a process whose trial failed takes no part, so it must not reduce
//! there; a growth on any process rejects everywhere through step 2.
//!
//! # What a split stepper must provide
//!
//! Its trial takes part in the same collectives on every process, in the same order, also
//! when its own pass fails (it then contributes zeros and sends no particles), and it
//! reports the failure through its `StepError` as usual. Its view comes in one of two
//! forms, both done by the reference solver:
//!
//! * **Split by particle, whole grid** ([`crate::nd::SolverNd::new_distributed`]): the
//!   view holds this process's particles and the *global* nodal fields (masses,
//!   velocities, accelerations, active flags), the same on every process, with
//!   [`crate::nd::ViewNd::split`] `None`. Products with the stiffness are completed with
//!   [`Reduce::sum`] over whole-grid vectors. Simple; memory and the nodal reduction grow
//!   with the whole grid.
//! * **Decomposed grid** ([`crate::nd::SolverNd::new_slab`]: slabs along the last axis):
//!   the view holds this process's particles and its window of nodes — owned nodes plus
//!   ghost copies of the neighbours' nodes its particles reach — with complete nodal
//!   fields at every copy, and describes the split in [`crate::nd::SplitNd`]: the whole
//!   grid, each local node's global index and owner flag, each particle's run-wide
//!   identity (kept when it moves to another process), and a
//!   [`NodalHalo`](crate::nd::NodalHalo) that completes nodal sums with the neighbours
//!   ([`Reduce::exchange`]). The stability tracker then completes each product `A u`
//!   with the halo, sums dot products over owned nodes and then over the processes, and
//!   builds its starts and tie-breaks from global indices, so its `λmax` does not depend
//!   on the split. Its summary ([`crate::nd::SummaryNd`]) is the whole run's, so the
//!   growth monitor sees the whole run's energy as particles move between processes.
//!
//! Either way 1, 2 and 4 processes take the same steps to the rounding of the sums
//! (`tests/mpi_ranks.rs`).

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
    /// A neighbour exchange (one shift of a halo swap): sends `send` to process `to` and
    /// returns what process `from` sent to this one with the same `tag`, `None` when
    /// `from` is `None`. Both sides must call it together (the decomposed solver's ghost
    /// sums and particle migration, [`crate::nd::SolverNd::new_slab`]); it does not
    /// deadlock when every process sends and receives in the same call.
    fn exchange(
        &self,
        to: Option<usize>,
        from: Option<usize>,
        tag: u16,
        send: &[f64],
    ) -> Option<Vec<f64>>;
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
    /// On one process the only partner is itself: what it sends comes back.
    fn exchange(
        &self,
        to: Option<usize>,
        from: Option<usize>,
        _tag: u16,
        send: &[f64],
    ) -> Option<Vec<f64>> {
        (to == Some(0) && from == Some(0)).then(|| send.to_vec())
    }
}

mod timed;
pub use timed::Timed;

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
