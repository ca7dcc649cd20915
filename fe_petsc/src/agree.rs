//! The agreement step: where ranks may disagree (one rank read a file, one rank's element
//! inverted), every rank learns whether any failed and returns the same error together, so
//! that no rank goes on into a collective call the others have left.
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// If any rank has an error, every rank returns the error of the lowest such rank (collective:
/// every rank calls it at the same point, with `None` when it has nothing to report).
pub fn first_error(comm: &SimpleCommunicator, err: Option<String>) -> Result<(), String> {
    let me = if err.is_some() {
        comm.rank()
    } else {
        comm.size()
    };
    let mut who = 0i32;
    comm.all_reduce_into(&me, &mut who, SystemOperation::min());
    if who == comm.size() {
        return Ok(());
    }
    let root = comm.process_at_rank(who);
    let mut len = err.as_ref().map(|e| e.len() as u64).unwrap_or(0);
    root.broadcast_into(&mut len);
    let mut buf = match err {
        Some(e) if comm.rank() == who => e.into_bytes(),
        _ => vec![0u8; len as usize],
    };
    root.broadcast_into(&mut buf[..]);
    Err(String::from_utf8_lossy(&buf).into_owned())
}
