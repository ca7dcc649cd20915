//! Small collective helpers so that every rank stops together with the same message.
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::time::{Duration, Instant};

/// If any rank has an error, every rank returns the error of the lowest such rank (the one
/// implementation, in `fe_petsc`, which agrees through it too).
pub use fe_petsc::agree::first_error;

/// How long a rank whose work failed waits at the exit for the others before it stops the
/// whole job: agreed failures bring every rank to the exit within milliseconds of each other.
pub const EXIT_GRACE: Duration = Duration::from_secs(5);

/// The last agreement step of a command, the safety net under all the others: every rank
/// meets here when its work is done. A failure that some rank did not agree on (an error
/// inside a collective call of PETSc or HDF5, a check that forgot to agree) leaves the other
/// ranks waiting in a collective call they will never complete; the failed rank then stops the
/// job (`MPI_Abort`, which mpirun turns into every rank's exit) instead of hanging with them.
pub struct ExitGate {
    comm: SimpleCommunicator,
}

impl ExitGate {
    /// Collective: every rank creates it right after MPI starts, before any work (its own
    /// communicator, so no other collective call can match its barrier).
    pub fn new(world: &SimpleCommunicator) -> ExitGate {
        ExitGate {
            comm: world.duplicate(),
        }
    }

    /// Waits until every rank has arrived. A rank whose work failed (`failure`: the line it
    /// would print) waits at most `grace`; past it, it prints that line, says why it stops the
    /// job, and aborts it. A rank whose work succeeded waits for the others.
    pub fn pass(self, failure: Option<&str>, grace: Duration) {
        let mut req = self.comm.immediate_barrier();
        let t0 = Instant::now();
        loop {
            match req.test() {
                Ok(_) => return,
                Err(r) => req = r,
            }
            if let Some(line) = failure.filter(|_| t0.elapsed() > grace) {
                eprintln!("{line}");
                eprintln!(
                    "tdyn: rank {} stops the job: the other ranks did not reach the end within {} s of this failure",
                    self.comm.rank(),
                    grace.as_secs_f64()
                );
                // The barrier never completes: MPI cannot take its request back.
                std::mem::forget(req);
                self.comm.abort(1);
            }
            std::thread::sleep(EXIT_POLL);
        }
    }
}

/// How often a rank waiting at the exit looks again.
const EXIT_POLL: Duration = Duration::from_millis(2);

/// Sum of `x` over all ranks.
pub fn sum(comm: &SimpleCommunicator, x: f64) -> f64 {
    let mut g = 0.0;
    comm.all_reduce_into(&x, &mut g, SystemOperation::sum());
    g
}

/// Max of `x` over all ranks.
pub fn max(comm: &SimpleCommunicator, x: f64) -> f64 {
    let mut g = 0.0;
    comm.all_reduce_into(&x, &mut g, SystemOperation::max());
    g
}

/// Min of `x` over all ranks.
pub fn min(comm: &SimpleCommunicator, x: f64) -> f64 {
    let mut g = 0.0;
    comm.all_reduce_into(&x, &mut g, SystemOperation::min());
    g
}

/// Every rank's `mine`, concatenated in rank order, on every rank (all-gather with counts).
pub fn all_gather_varcount<T>(comm: &SimpleCommunicator, mine: &[T]) -> Vec<T>
where
    T: mpi::datatype::Equivalence + Default + Clone,
{
    let mut counts = vec![0i32; comm.size() as usize];
    comm.all_gather_into(&(mine.len() as i32), &mut counts[..]);
    let displs: Vec<i32> = counts
        .iter()
        .scan(0, |s, &c| {
            let d = *s;
            *s += c;
            Some(d)
        })
        .collect();
    let mut all = vec![T::default(); counts.iter().sum::<i32>() as usize];
    {
        let mut part = mpi::datatype::PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
        comm.all_gather_varcount_into(mine, &mut part);
    }
    all
}
