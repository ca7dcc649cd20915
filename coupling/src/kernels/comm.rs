//! The unstructured-communication kernel (the paper's §3, Fig. 5).
//!
//! Each rank knows what it sends and to whom, not what it will receive. A [`CommPlan`] is built
//! once from the destination rank of each item:
//! 1. counts: a reduce-scatter of the P-long 0/1 vector "I send to rank r" tells each rank how
//!    many messages it will receive;
//! 2. sizes: each sender posts its item count to each destination (non-blocking); each receiver
//!    takes that many messages from any source, learning who sends and how much;
//! 3. data: [`CommPlan::exchange`] moves the items (non-blocking sends, receives in source order),
//!    and [`CommPlan::reverse`] sends one value per received item back to where the item came from.
//!
//! The plan is reused: `exchange` is the halo `gather` (owner values to copies) and `reverse`
//! followed by a sum is the halo `scatter_add` (copies' contributions back to the owner).
//! Items are any plain-old-data type (`bytemuck::Pod`), moved as bytes.
use bytemuck::Pod;
use mpi::collective::SystemOperation;
use mpi::request::WaitGuard;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::rc::Rc;

/// Message tag for the sizes of a plan's messages.
const TAG_SIZES: i32 = 7001;
/// Message tag for data.
const TAG_DATA: i32 = 7002;
/// Message tag for [`CommPlan::reverse_lists`].
const TAG_LISTS: i32 = 7003;

/// A reusable plan: who sends how many items to whom.
pub struct CommPlan {
    /// The plan's own duplicate of the communicator ([`CommPlan::new`]), or one shared with the
    /// caller's other plans ([`CommPlan::new_shared`]).
    comm: Rc<SimpleCommunicator>,
    /// Destination ranks with a message, ascending, and the item count for each.
    send_ranks: Vec<i32>,
    send_counts: Vec<usize>,
    /// Item indices in send order (grouped by destination, original order inside a group).
    send_order: Vec<usize>,
    /// Source ranks with a message, ascending, and the item count from each.
    recv_ranks: Vec<i32>,
    recv_counts: Vec<usize>,
    /// Bytes this rank sent to other ranks through the plan so far.
    pub bytes_sent: u64,
    /// Messages this rank sent to other ranks through the plan so far.
    pub messages_sent: u64,
}

impl CommPlan {
    /// Builds the plan from each item's destination rank (collective), on a duplicate of `comm`
    /// (its messages cannot meet anyone else's).
    pub fn new(comm: &SimpleCommunicator, dest: &[i32]) -> CommPlan {
        Self::new_shared(&Rc::new(comm.duplicate()), dest)
    }

    /// [`CommPlan::new`] on `comm` itself, shared with other plans of the caller (no
    /// duplicate: one collective fewer). Safe for plans used one after the other: a plan's
    /// data receives name their source, and its size messages (from any source) cannot meet
    /// the next plan's, which are sent only after the next plan's reduce-scatter, which no
    /// rank leaves before every rank has entered it.
    pub fn new_shared(comm: &Rc<SimpleCommunicator>, dest: &[i32]) -> CommPlan {
        let p = comm.size() as usize;
        let mut per_rank = vec![0usize; p];
        for &d in dest {
            assert!(
                (d as usize) < p && d >= 0,
                "destination rank {d} out of 0..{p}"
            );
            per_rank[d as usize] += 1;
        }
        let mut send_order: Vec<usize> = (0..dest.len()).collect();
        send_order.sort_by_key(|&i| dest[i]);
        let send_ranks: Vec<i32> = (0..p as i32)
            .filter(|&r| per_rank[r as usize] > 0)
            .collect();
        let send_counts: Vec<usize> = send_ranks.iter().map(|&r| per_rank[r as usize]).collect();
        // 1. How many messages will I receive: reduce-scatter of the 0/1 vector.
        let flags: Vec<i32> = per_rank.iter().map(|&c| (c > 0) as i32).collect();
        let mut n_recv = 0i32;
        comm.reduce_scatter_block_into(
            &flags[..],
            std::slice::from_mut(&mut n_recv),
            SystemOperation::sum(),
        );
        // 2. Sizes, point to point.
        let sizes: Vec<u64> = send_counts.iter().map(|&c| c as u64).collect();
        let mut recv: Vec<(i32, usize)> = Vec::with_capacity(n_recv as usize);
        mpi::request::scope(|scope| {
            let mut guards = Vec::with_capacity(send_ranks.len());
            for (k, &r) in send_ranks.iter().enumerate() {
                let req = comm
                    .process_at_rank(r)
                    .immediate_send_with_tag(scope, &sizes[k], TAG_SIZES);
                guards.push(WaitGuard::from(req));
            }
            for _ in 0..n_recv {
                let (n, status) = comm.any_process().receive_with_tag::<u64>(TAG_SIZES);
                recv.push((status.source_rank(), n as usize));
            }
        });
        recv.sort_unstable();
        CommPlan {
            comm: Rc::clone(comm),
            send_ranks,
            send_counts,
            send_order,
            recv_ranks: recv.iter().map(|r| r.0).collect(),
            recv_counts: recv.iter().map(|r| r.1).collect(),
            bytes_sent: 0,
            messages_sent: 0,
        }
    }

    /// Items this rank receives in an `exchange`.
    pub fn n_recv(&self) -> usize {
        self.recv_counts.iter().sum()
    }

    /// Ranks this rank receives from (ascending), with the item count from each.
    pub fn sources(&self) -> impl Iterator<Item = (i32, usize)> + '_ {
        self.recv_ranks
            .iter()
            .copied()
            .zip(self.recv_counts.iter().copied())
    }

    /// Sends `items` (one per destination given at build time, in that order) and returns what
    /// this rank receives: grouped by source rank ascending, each group in the sender's order.
    pub fn exchange<T: Pod>(&mut self, items: &[T]) -> Vec<T> {
        assert_eq!(
            items.len(),
            self.send_order.len(),
            "one item per destination"
        );
        let packed: Vec<T> = self.send_order.iter().map(|&i| items[i]).collect();
        let (send_r, send_c) = (self.send_ranks.clone(), self.send_counts.clone());
        let (recv_r, recv_c) = (self.recv_ranks.clone(), self.recv_counts.clone());
        self.move_data(&packed, &send_r, &send_c, &recv_r, &recv_c)
    }

    /// Sends back one value per item received in `exchange` (in that order) and returns, for
    /// each original item (in the order given at build time), the value sent back for it.
    pub fn reverse<T: Pod>(&mut self, values: &[T]) -> Vec<T> {
        assert_eq!(values.len(), self.n_recv(), "one value per received item");
        let (send_r, send_c) = (self.recv_ranks.clone(), self.recv_counts.clone());
        let (recv_r, recv_c) = (self.send_ranks.clone(), self.send_counts.clone());
        let back = self.move_data(values, &send_r, &send_c, &recv_r, &recv_c);
        // `back` is in send order: undo the grouping by destination.
        let mut out = back.clone();
        for (k, &i) in self.send_order.iter().enumerate() {
            out[i] = back[k];
        }
        out
    }

    /// Sends back to each rank this rank receives from in `exchange` a list of any length
    /// (`lists[k]` to the k-th source of [`CommPlan::sources`], possibly empty), and returns
    /// the lists from every rank this rank sends to, concatenated in rank order. No collective:
    /// the plan already says who talks to whom (a sparse answer, e.g. forces on the few contacted
    /// nodes, with no new plan).
    pub fn reverse_lists<T: Pod>(&mut self, lists: &[Vec<T>]) -> Vec<T> {
        assert_eq!(lists.len(), self.recv_ranks.len(), "one list per source");
        let comm = &self.comm;
        let me = comm.rank();
        let mut out: Vec<T> = Vec::new();
        mpi::request::scope(|scope| {
            let mut guards = Vec::with_capacity(lists.len());
            for (k, &r) in self.recv_ranks.iter().enumerate() {
                let bytes: &[u8] = bytemuck::cast_slice(&lists[k]);
                let req = comm
                    .process_at_rank(r)
                    .immediate_send_with_tag(scope, bytes, TAG_LISTS);
                guards.push(WaitGuard::from(req));
            }
            for &r in &self.send_ranks {
                let (bytes, _) = comm
                    .process_at_rank(r)
                    .receive_vec_with_tag::<u8>(TAG_LISTS);
                out.extend(
                    bytes
                        .chunks_exact(std::mem::size_of::<T>())
                        .map(bytemuck::pod_read_unaligned::<T>),
                );
            }
        });
        for (k, &r) in self.recv_ranks.iter().enumerate() {
            if r != me {
                self.bytes_sent += std::mem::size_of_val(&lists[k][..]) as u64;
                self.messages_sent += 1;
            }
        }
        out
    }

    /// Halo scatter-add: the copies' contributions `values` (one per received item) are sent
    /// back and added into `target` at the index each original item names (`index[i]` for
    /// item i), with `add`.
    pub fn scatter_add<T: Pod>(
        &mut self,
        values: &[T],
        index: &[usize],
        target: &mut [T],
        add: impl Fn(&mut T, &T),
    ) {
        let back = self.reverse(values);
        for (i, v) in back.iter().enumerate() {
            add(&mut target[index[i]], v);
        }
    }

    fn move_data<T: Pod>(
        &mut self,
        send: &[T],
        send_ranks: &[i32],
        send_counts: &[usize],
        recv_ranks: &[i32],
        recv_counts: &[usize],
    ) -> Vec<T> {
        let total: usize = recv_counts.iter().sum();
        let mut out: Vec<T> = vec![T::zeroed(); total];
        let sz = std::mem::size_of::<T>();
        let comm = &self.comm;
        let bytes: &[u8] = bytemuck::cast_slice(send);
        mpi::request::scope(|scope| {
            let mut guards = Vec::with_capacity(send_ranks.len());
            let mut off = 0;
            for (k, &r) in send_ranks.iter().enumerate() {
                let len = send_counts[k] * sz;
                let req = comm.process_at_rank(r).immediate_send_with_tag(
                    scope,
                    &bytes[off..off + len],
                    TAG_DATA,
                );
                guards.push(WaitGuard::from(req));
                off += len;
            }
            let rbytes: &mut [u8] = bytemuck::cast_slice_mut(&mut out[..]);
            let mut off = 0;
            for (k, &r) in recv_ranks.iter().enumerate() {
                let len = recv_counts[k] * sz;
                comm.process_at_rank(r)
                    .receive_into_with_tag(&mut rbytes[off..off + len], TAG_DATA);
                off += len;
            }
        });
        // Bytes and messages to other ranks (a rank's message to itself moves nothing).
        let me = self.comm.rank();
        for (k, &r) in send_ranks.iter().enumerate() {
            if r != me {
                self.bytes_sent += (send_counts[k] * sz) as u64;
                self.messages_sent += 1;
            }
        }
        out
    }
}

/// Message tag for [`exchange_known`].
const TAG_KNOWN: i32 = 7004;

/// Moves lists between ranks that already know who sends what to whom and how much (a halo
/// whose partners and sizes were agreed earlier): `sends[k] = (rank, items)`, `recvs[k] =
/// (rank, count)`, neither naming this rank. No collective and no size messages: a step of an
/// iteration between neighbours costs one message to each partner with something to send.
/// Returns the lists received, in `recvs`' order, and the bytes and messages sent.
pub fn exchange_known<T: Pod>(
    comm: &SimpleCommunicator,
    sends: &[(i32, Vec<T>)],
    recvs: &[(i32, usize)],
) -> (Vec<Vec<T>>, u64, u64) {
    let mut out: Vec<Vec<T>> = recvs.iter().map(|&(_, n)| vec![T::zeroed(); n]).collect();
    let (mut bytes, mut messages) = (0u64, 0u64);
    mpi::request::scope(|scope| {
        let mut guards = Vec::with_capacity(sends.len());
        for (r, items) in sends {
            let b: &[u8] = bytemuck::cast_slice(&items[..]);
            bytes += b.len() as u64;
            messages += 1;
            let req = comm
                .process_at_rank(*r)
                .immediate_send_with_tag(scope, b, TAG_KNOWN);
            guards.push(WaitGuard::from(req));
        }
        for (k, &(r, _)) in recvs.iter().enumerate() {
            let b: &mut [u8] = bytemuck::cast_slice_mut(&mut out[k][..]);
            comm.process_at_rank(r).receive_into_with_tag(b, TAG_KNOWN);
        }
    });
    (out, bytes, messages)
}
