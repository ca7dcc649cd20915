//! Small collective helpers so that every rank stops together with the same message.
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// If any rank has an error, every rank returns the error of the lowest such rank.
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
