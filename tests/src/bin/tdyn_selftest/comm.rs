//! The unstructured-communication plan's self-test under mpirun (`tdyn_selftest comm`).
use coupling::kernels::comm::CommPlan;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// Self-test under mpirun (`tdyn_selftest comm`): random send patterns including empty ranks,
/// self-sends and all-to-one; every item arrives exactly once where it was sent, `reverse`
/// returns each item's own value, and a gather then scatter-add round trip sums exactly.
/// Returns a description of the first failure.
pub fn selftest(comm: &SimpleCommunicator, seed: u64) -> Result<String, String> {
    let p = comm.size();
    let me = comm.rank();
    let mut checked = 0usize;
    for pattern in 0..4 {
        let mut s = seed ^ ((me as u64 + 1) * 0x9E37_79B9_7F4A_7C15) ^ (pattern as u64) << 32;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        // pattern 0: random; 1: everything to rank 0; 2: only to self; 3: rank 1 sends nothing.
        let n = match pattern {
            3 if me == 1 => 0,
            _ => (rnd() % 50) as usize,
        };
        let dest: Vec<i32> = (0..n)
            .map(|_| match pattern {
                1 => 0,
                2 => me,
                _ => (rnd() % p as u64) as i32,
            })
            .collect();
        // Item = (source rank, local index, destination): checkable on arrival.
        let items: Vec<[u64; 3]> = dest
            .iter()
            .enumerate()
            .map(|(i, &d)| [me as u64, i as u64, d as u64])
            .collect();
        let mut plan = CommPlan::new(comm, &dest);
        let got = plan.exchange(&items);
        for it in &got {
            if it[2] != me as u64 {
                return Err(format!(
                    "pattern {pattern}: rank {me} got an item meant for {}",
                    it[2]
                ));
            }
        }
        // Every item arrives exactly once: count per source must match what sources sent.
        let mut sent_to = vec![0u64; p as usize];
        for &d in &dest {
            sent_to[d as usize] += 1;
        }
        let mut recv_from = vec![0u64; p as usize];
        comm.all_to_all_into(&sent_to[..], &mut recv_from[..]);
        let mut seen = vec![0u64; p as usize];
        for it in &got {
            seen[it[0] as usize] += 1;
        }
        if seen != recv_from {
            return Err(format!(
                "pattern {pattern}: rank {me} received {seen:?}, expected {recv_from:?}"
            ));
        }
        // Reverse: each item gets back a value computed from itself.
        let back: Vec<u64> = got.iter().map(|it| it[0] * 1_000_000 + it[1]).collect();
        let ret = plan.reverse(&back);
        for (i, v) in ret.iter().enumerate() {
            if *v != me as u64 * 1_000_000 + i as u64 {
                return Err(format!(
                    "pattern {pattern}: reverse gave {v} for item {i} of rank {me}"
                ));
            }
        }
        // Gather / scatter-add round trip: owners send values x_i; every copy contributes
        // 2 x_i back; each owner's sum must be exactly 2 x_i per copy (integers in f64).
        let vals: Vec<f64> = (0..n).map(|i| (me as usize * 1000 + i) as f64).collect();
        let copies = plan.exchange(&vals);
        let contrib: Vec<f64> = copies.iter().map(|x| 2.0 * x).collect();
        let mut acc = vec![0.0f64; n];
        let index: Vec<usize> = (0..n).collect();
        plan.scatter_add(&contrib, &index, &mut acc, |a, b| *a += *b);
        for i in 0..n {
            if acc[i] != 2.0 * vals[i] {
                return Err(format!(
                    "pattern {pattern}: scatter_add gave {} for {}",
                    acc[i],
                    2.0 * vals[i]
                ));
            }
        }
        // Sparse answers: each receiver returns to each source the items it got from it whose
        // local index is even; each sender must get exactly its even-indexed items back.
        let mut lists: Vec<Vec<[u64; 3]>> = Vec::new();
        let mut off = 0;
        for (_, n_from) in plan.sources() {
            lists.push(
                got[off..off + n_from]
                    .iter()
                    .filter(|it| it[1] % 2 == 0)
                    .copied()
                    .collect(),
            );
            off += n_from;
        }
        let mut back = plan.reverse_lists(&lists);
        back.sort_unstable();
        let want: Vec<[u64; 3]> = items.iter().filter(|it| it[1] % 2 == 0).copied().collect();
        if back != want {
            return Err(format!(
                "pattern {pattern}: reverse_lists gave rank {me} {} items, expected {}",
                back.len(),
                want.len()
            ));
        }
        checked += got.len();
    }
    let mut total = 0u64;
    comm.all_reduce_into(&(checked as u64), &mut total, SystemOperation::sum());
    Ok(format!(
        "comm selftest passed at np {p}: {total} items checked"
    ))
}
