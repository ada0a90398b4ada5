//! [`MpiReduce`]: the [`Reduce`] interface over an MPI communicator (rsmpi,
//! `MPI_Allreduce`), feature `mpi`.

use super::Reduce;
use mpi::collective::{CommunicatorCollectives, SystemOperation};
use mpi::point_to_point::{Destination, Source};
use mpi::topology::{Communicator, SimpleCommunicator};

/// Reductions over the ranks of an MPI communicator: one `MPI_Allreduce` per call.
pub struct MpiReduce {
    comm: SimpleCommunicator,
}

impl MpiReduce {
    /// Reductions over `comm` (for instance `universe.world()`).
    pub fn new(comm: SimpleCommunicator) -> Self {
        Self { comm }
    }
}

impl std::fmt::Debug for MpiReduce {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MpiReduce")
            .field("rank", &self.comm.rank())
            .field("size", &self.comm.size())
            .finish()
    }
}

impl Reduce for MpiReduce {
    fn rank(&self) -> usize {
        self.comm.rank() as usize
    }

    fn size(&self) -> usize {
        self.comm.size() as usize
    }

    fn min_and_any(&self, value: f64, flag: bool) -> (f64, bool) {
        // One reduction: the flag travels as −1 (set) or 0, whose minimum is −1 if any is set.
        let send = [value, if flag { -1.0 } else { 0.0 }];
        let mut recv = [0.0f64; 2];
        self.comm
            .all_reduce_into(&send[..], &mut recv[..], SystemOperation::min());
        (recv[0], recv[1] < 0.0)
    }

    fn any_flags(&self, flags: &mut [bool]) {
        let send: Vec<i32> = flags.iter().map(|&f| i32::from(f)).collect();
        let mut recv = vec![0i32; flags.len()];
        self.comm
            .all_reduce_into(&send[..], &mut recv[..], SystemOperation::max());
        for (f, r) in flags.iter_mut().zip(recv) {
            *f = r != 0;
        }
    }

    fn sum(&self, values: &mut [f64]) {
        let send = values.to_vec();
        self.comm
            .all_reduce_into(&send[..], values, SystemOperation::sum());
    }

    fn exchange(
        &self,
        to: Option<usize>,
        from: Option<usize>,
        tag: u16,
        send: &[f64],
    ) -> Option<Vec<f64>> {
        let tag = i32::from(tag);
        // A non-blocking send and a blocking receive: no deadlock when every process
        // sends and receives in the same call.
        mpi::request::scope(|scope| {
            let request = to.map(|r| {
                self.comm
                    .process_at_rank(r as i32)
                    .immediate_send_with_tag(scope, send, tag)
            });
            let received = from.map(|r| {
                self.comm
                    .process_at_rank(r as i32)
                    .receive_vec_with_tag::<f64>(tag)
                    .0
            });
            if let Some(request) = request {
                request.wait();
            }
            received
        })
    }
}
