//! Moving a frame's rows to the rank that writes their id range, a bounded number of rows at a
//! time.
//!
//! Rank r of p writes the rows [lo(r), hi(r)) of a set of n ids ([`block`]). A column is moved
//! there and written in chunks: chunk k of rank r is the ids [lo(r) + k C, lo(r) + (k+1) C)
//! clipped to hi(r), C = the chunk's rows. Every rank takes part in every chunk's exchange, the
//! chunk count being agreed (max over ranks) before the first one.
//!
//! Why chunks (memory): moving a whole column at once keeps the send buffer (ids and values),
//! the receive buffer and the sorted result alive together: for the connectivity (8 node ids
//! and the row's id, 72 B a row sent and received, 64 B a row placed) that was 136 B per
//! element at the step-0 frame, the run's peak (massif, 110,592 hexahedra: heap peak 91.7 MB
//! against 75 MB through the loop). In chunks a rank receives and places at most C rows at a
//! time and sends at most C to each rank (C rows when its ids fall in one or two ranks' blocks,
//! as a mesh partition's do): C = 16,384 is 1.2 MB each way and 1 MB placed for the
//! connectivity, whatever the mesh size; what stays element-sized is the send order, 4 B per
//! local row ([`Plan`]). Each row's values are made straight into the send buffer by the
//! column's row function, and placed on arrival at their id's offset, so no full-size copy of a
//! column is made and nothing is sorted. A chunk of 16,384 rows keeps each independent HDF5
//! write at 0.1 to 1 MB, and the chunks few (7 per column at 110,592 rows on one rank).
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// Rows a rank receives and writes per chunk by default (see the module's derivation).
pub const CHUNK_ROWS: u64 = 16_384;

/// Writes row `i`'s values (the set's local row `i`, `ids[i]`) into the slice given (the
/// column's width).
pub type RowFn<'a> = dyn Fn(usize, &mut [f64]) + 'a;

/// The rows [lo, hi) of `n` ids that rank `r` of `p` writes.
fn block(n: u64, p: usize, r: usize) -> (u64, u64) {
    (n * r as u64 / p as u64, n * (r as u64 + 1) / p as u64)
}

/// The rank whose block holds `id` (< n): the largest r with lo(r) <= id.
fn dest(n: u64, p: usize, id: u64) -> usize {
    let mut r = ((id as u128 * p as u128) / n.max(1) as u128) as usize;
    r = r.min(p - 1);
    while r + 1 < p && block(n, p, r + 1).0 <= id {
        r += 1;
    }
    while r > 0 && block(n, p, r).0 > id {
        r -= 1;
    }
    r
}

/// Prefix sums of `counts` (MPI displacements).
fn displs(counts: &[i32]) -> Vec<i32> {
    counts
        .iter()
        .scan(0i32, |acc, &c| {
            let d = *acc;
            *acc += c;
            Some(d)
        })
        .collect()
}

/// How one set's rows (a frame's nodes, elements or particles) travel, chunk by chunk; made
/// once per set and used by each of its columns.
pub struct Plan {
    /// Ranks.
    p: usize,
    /// Rows per chunk.
    rows: u64,
    /// Chunks (the same on every rank).
    pub chunks: usize,
    /// This rank's block [lo, hi).
    lo: u64,
    hi: u64,
    /// Local rows sorted by (chunk, destination rank): the send buffers' order.
    order: Vec<u32>,
    /// `order[starts[k p + d]..starts[k p + d + 1]]`: the local rows of chunk k for rank d.
    starts: Vec<usize>,
    /// Rows received in chunk k from rank s, at `[s chunks + k]`.
    recv: Vec<i32>,
}

impl Plan {
    /// The plan for `ids` (this rank's rows' ids) of a set of `n`, `rows` rows per chunk
    /// (collective). None on every rank alike when the ids over all ranks are not 0..n each
    /// exactly once (row r must hold id r), found before any dataset is made.
    pub fn new(comm: &SimpleCommunicator, n: u64, ids: &[u64], rows: u64) -> Option<Plan> {
        let p = comm.size() as usize;
        let (lo, hi) = block(n, p, comm.rank() as usize);
        let rows = rows.max(1);
        let widest = (0..p).map(|r| block(n, p, r)).map(|(a, b)| b - a).max();
        let mine = widest.unwrap_or(0).div_ceil(rows);
        let mut chunks = 0u64;
        comm.all_reduce_into(&mine, &mut chunks, SystemOperation::max());
        let mut plan = Plan {
            p,
            rows,
            chunks: chunks as usize,
            lo,
            hi,
            order: Vec::new(),
            starts: Vec::new(),
            recv: Vec::new(),
        };
        let sorted = plan.sort(n, ids);
        plan.count(comm);
        // Both on every rank (`covers` is collective), whatever `sort` found.
        let covered = plan.covers(comm, ids);
        let ok = sorted & covered;
        let mut all_ok = false;
        comm.all_reduce_into(&ok, &mut all_ok, SystemOperation::logical_and());
        all_ok.then_some(plan)
    }

    /// This rank's rows [a, b) that chunk k holds.
    pub fn range(&self, k: usize) -> (u64, u64) {
        let a = (self.lo + k as u64 * self.rows).min(self.hi);
        (a, (a + self.rows).min(self.hi))
    }

    /// Fills `order` and `starts` (a counting sort by chunk and destination); false when an
    /// id is out of range (that row is left out; the set is refused on every rank).
    fn sort(&mut self, n: u64, ids: &[u64]) -> bool {
        let (p, rows) = (self.p, self.rows);
        let key = |id: u64| {
            let d = dest(n, p, id);
            ((id - block(n, p, d).0) / rows) as usize * p + d
        };
        let ok = ids.iter().all(|&id| id < n) && ids.len() < u32::MAX as usize;
        let mut starts = vec![0usize; self.chunks * p + 1];
        for &id in ids.iter().filter(|&&id| id < n) {
            starts[key(id) + 1] += 1;
        }
        for k in 1..starts.len() {
            starts[k] += starts[k - 1];
        }
        let mut fill = starts.clone();
        let mut order = vec![0u32; starts[starts.len() - 1]];
        for (i, &id) in ids.iter().enumerate().filter(|(_, &id)| id < n) {
            let s = &mut fill[key(id)];
            order[*s] = i as u32;
            *s += 1;
        }
        self.order = order;
        self.starts = starts;
        ok
    }

    /// The rows each rank sends this one per chunk (one all-to-all of chunks x ranks counts).
    fn count(&mut self, comm: &SimpleCommunicator) {
        let (p, c) = (self.p, self.chunks);
        let mut send = vec![0i32; p * c];
        for d in 0..p {
            for k in 0..c {
                send[d * c + k] = (self.starts[k * p + d + 1] - self.starts[k * p + d]) as i32;
            }
        }
        let mut recv = vec![0i32; p * c];
        if c > 0 {
            comm.all_to_all_into(&send[..], &mut recv[..]);
        }
        self.recv = recv;
    }

    /// Whether each chunk's ids received are its range, each exactly once (collective: the
    /// ids alone are moved, chunk by chunk).
    fn covers(&self, comm: &SimpleCommunicator, ids: &[u64]) -> bool {
        let mut ok = true;
        for k in 0..self.chunks {
            let (a, b) = self.range(k);
            let mut seen = vec![false; (b - a) as usize];
            for v in self.exchange(comm, ids, k, 0, &|_, _| {}) {
                let id = v as u64;
                match (id >= a && id < b).then(|| &mut seen[(id - a) as usize]) {
                    Some(s) if !*s => *s = true,
                    _ => ok = false,
                }
            }
            ok &= seen.iter().all(|&s| s);
        }
        ok
    }

    /// Chunk k of a column `w` wide (collective): this rank's rows [a, b) of `range(k)` in id
    /// order, `w` values each, converted by `conv`. Each row is placed at its id's offset, so
    /// no sort is needed ([`Plan::new`] made sure each id comes once).
    pub fn values<T: Copy + Default>(
        &self,
        comm: &SimpleCommunicator,
        ids: &[u64],
        k: usize,
        w: usize,
        row: &RowFn,
        conv: fn(f64) -> T,
    ) -> Vec<T> {
        let (a, b) = self.range(k);
        let recv = self.exchange(comm, ids, k, w, row);
        let mut out = vec![T::default(); (b - a) as usize * w];
        for r in recv.chunks_exact(w + 1) {
            let at = (r[0] as u64 - a) as usize * w;
            for (o, v) in out[at..at + w].iter_mut().zip(&r[1..]) {
                *o = conv(*v);
            }
        }
        out
    }

    /// Moves chunk k of a column `w` wide (collective): each local row of the chunk goes as
    /// its id (ids < 2^53 are exact in f64) and its values, made by `row` straight into the
    /// send buffer. Returns the rows received, (id, values) each, in no particular order.
    fn exchange(
        &self,
        comm: &SimpleCommunicator,
        ids: &[u64],
        k: usize,
        w: usize,
        row: &RowFn,
    ) -> Vec<f64> {
        let (p, c, stride) = (self.p, self.chunks, w + 1);
        let rows = &self.order[self.starts[k * p]..self.starts[(k + 1) * p]];
        let mut send = vec![0.0f64; rows.len() * stride];
        for (slot, &i) in send.chunks_exact_mut(stride).zip(rows) {
            slot[0] = ids[i as usize] as f64;
            row(i as usize, &mut slot[1..]);
        }
        let counts: Vec<i32> = (0..p)
            .map(|d| ((self.starts[k * p + d + 1] - self.starts[k * p + d]) * stride) as i32)
            .collect();
        let rcounts: Vec<i32> = (0..p)
            .map(|s| self.recv[s * c + k] * stride as i32)
            .collect();
        let mut recv = vec![0.0f64; rcounts.iter().sum::<i32>() as usize];
        let (sd, rd) = (displs(&counts), displs(&rcounts));
        let sp = Partition::new(&send[..], &counts[..], &sd[..]);
        let mut rp = PartitionMut::new(&mut recv[..], &rcounts[..], &rd[..]);
        comm.all_to_all_varcount_into(&sp, &mut rp);
        recv
    }
}
