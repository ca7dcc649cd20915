//! Small collective helpers so that every rank stops together with the same message.
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// If any rank has an error, every rank returns the error of the lowest such rank (the one
/// implementation, in `fe_petsc`, which agrees through it too).
pub use fe_petsc::agree::first_error;

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
