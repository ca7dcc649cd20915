//! Parallel recursive coordinate bisection (the paper's §3, Figs. 6-7).
//!
//! [`Rcb::balance`] takes each rank's items (anything plain-old-data with a position, a weight
//! and a global id) and returns the items each rank now owns. At each level the group of ranks
//! `[lo, hi)` is cut across the longest dimension of its items' bounding box so that the lower
//! `mid - lo` ranks get that share of the group's weight, for any group size (not only powers of
//! two). The weighted median is found by iterating on a guess: every rank of the group proposes
//! the item at the wanted quantile of its still-undecided items, the group takes the weighted
//! median of the proposals, sums the weight below it (one all-reduce), and discards the side
//! that cannot hold the median; once few undecided items remain they are gathered and the split
//! is finished exactly. Items are ordered by (coordinate, global id), so ties split cleanly and
//! even identical points balance. Items on the wrong side go to a partner in the other half
//! through the unstructured-communication plan ([`crate::kernels::comm::CommPlan`]); the two halves
//! recurse on their own sub-communicators (built once, in [`Rcb::new`]). At the end every rank
//! holds all P-1 cuts ([`CutTree`]).
//!
//! A second call starts from the previous call's cuts: the cut axis is kept (unless another
//! axis has become twice as long), the previous cut value is the first guess, and an item that
//! must cross goes straight to its rank in the previous tree when that rank is on the other
//! side. Items that did not cross a cut do not move, so when points move little, little data
//! moves.
//!
//! Written here rather than called from Zoltan: the SPH and contact stages need the cut tree's
//! queries and the incremental start on their own types without Zoltan's callback interface;
//! `coupling/examples/rcb_vs_zoltan.rs` (`scripts/bench_rcb.sh`) compares the two on the same
//! points.
mod tree;

pub use tree::{Cut, CutTree};

use crate::kernels::comm::CommPlan;
use bytemuck::Pod;
use mpi::collective::SystemOperation;
use mpi::topology::{Color, SimpleCommunicator};
use mpi::traits::*;
use std::time::Instant;

/// Undecided items below which the median search gathers them and finishes exactly.
const GATHER_MAX: f64 = 2048.0;

/// An item RCB can balance: a position, a weight (default 1) and a global id, unique over ranks.
pub trait RcbItem: Pod {
    /// Position.
    fn position(&self) -> [f64; 3];
    /// Weight (work) of the item, >= 0.
    fn weight(&self) -> f64 {
        1.0
    }
    /// Global id, unique over all ranks.
    fn id(&self) -> u64;
}

/// What one call to [`Rcb::balance`] did (the same on every rank).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RcbStats {
    /// Items over all ranks.
    pub items: u64,
    /// Max over ranks of the weight owned, over the mean.
    pub imbalance: f64,
    /// Items whose owner changed in this call.
    pub migrated: u64,
    /// Bytes sent point to point by all ranks (items and their origin tags).
    pub bytes_sent: u64,
    /// Wall time of the call, max over ranks, s.
    pub wall_s: f64,
    /// Median-search iterations summed over this rank's levels, max over ranks.
    pub iterations: u64,
}

/// Errors of a balance call (returned on every rank alike).
#[derive(Debug, thiserror::Error)]
pub enum RcbError {
    /// An item's position or weight is not finite (or a weight is negative). Every rank gets
    /// the id; the position and weight are the item's on the rank that holds it (NaN elsewhere).
    #[error("RCB: item {id} has position {x:?} and weight {w}: positions must be finite and weights finite and >= 0")]
    BadItem {
        /// Its id.
        id: u64,
        /// Its position.
        x: [f64; 3],
        /// Its weight.
        w: f64,
    },
}

/// A reusable parallel RCB over one communicator.
pub struct Rcb {
    comm: SimpleCommunicator,
    /// This rank's path down the tree: (node index, communicator of that node's group).
    path: Vec<(usize, SimpleCommunicator)>,
    tree: CutTree,
    has_cuts: bool,
}

/// One undecided item in the median search: coordinate along the cut axis, id, weight, index.
#[derive(Clone, Copy)]
struct Key {
    c: f64,
    id: u64,
    w: f64,
    i: u32,
}

#[inline]
fn less(a: (f64, u64), b: (f64, u64)) -> bool {
    a.0 < b.0 || (a.0 == b.0 && a.1 < b.1)
}

impl Rcb {
    /// Builds the sub-communicators of this rank's path (collective over `comm`).
    pub fn new(comm: &SimpleCommunicator) -> Rcb {
        let comm = comm.duplicate();
        let tree = CutTree::skeleton(comm.size());
        let me = comm.rank();
        let mut path = Vec::new();
        let mut group = comm.duplicate();
        let mut node = if tree.nodes.is_empty() { None } else { Some(0) };
        while let Some(i) = node {
            let n = &tree.nodes[i];
            let low = me < n.mid;
            let sub = group
                .split_by_color(Color::with_value(low as i32))
                .expect("MPI_Comm_split gave no communicator");
            path.push((i, group));
            group = sub;
            node = if low { n.left } else { n.right };
        }
        Rcb {
            comm,
            path,
            tree,
            has_cuts: false,
        }
    }

    /// The cut tree of the last balance (all P-1 cuts, the same on every rank).
    pub fn tree(&self) -> &CutTree {
        &self.tree
    }

    /// The cuts of the last balance, node by node (None before the first): what a restart
    /// needs to start the next balance from the same cuts.
    pub fn cuts(&self) -> Option<Vec<Cut>> {
        self.has_cuts
            .then(|| self.tree.nodes.iter().map(|n| n.cut).collect())
    }

    /// Sets the cuts [`Rcb::cuts`] gave (the same rank count); `false` when they do not fit.
    pub fn set_cuts(&mut self, cuts: &[Cut]) -> bool {
        if cuts.len() != self.tree.nodes.len() {
            return false;
        }
        for (n, c) in self.tree.nodes.iter_mut().zip(cuts) {
            n.cut = *c;
        }
        self.has_cuts = true;
        true
    }

    /// Forgets the previous cuts: the next balance starts from scratch.
    pub fn reset(&mut self) {
        self.has_cuts = false;
    }

    /// Balances `items` over the ranks (collective). Returns the items this rank now owns (those
    /// it kept first, in their previous order, then those received) and the call's statistics.
    pub fn balance<T: RcbItem>(&mut self, items: Vec<T>) -> Result<(Vec<T>, RcbStats), RcbError> {
        let t0 = Instant::now();
        let me = self.comm.rank();
        self.refuse_bad_items(&items)?;
        let prev = self.has_cuts.then(|| self.tree.clone());
        let mut items = items;
        let mut origin: Vec<i32> = vec![me; items.len()];
        let mut bytes = 0u64;
        let mut iterations = 0u64;
        let path = std::mem::take(&mut self.path);
        for (idx, g) in &path {
            let (lo, mid, hi) = {
                let n = &self.tree.nodes[*idx];
                (n.lo, n.mid, n.hi)
            };
            let prev_cut = prev.as_ref().map(|t| t.nodes[*idx].cut);
            let (cut, it) = split_level(g, &items, lo, mid, hi, prev_cut);
            iterations += it;
            self.tree.nodes[*idx].cut = cut;
            // Items on the other side of the cut go to the other half.
            let i_am_low = me < mid;
            // Kept items are compacted in place (no new item-sized arrays per level: at 10^6
            // items those are fresh pages, which showed up as a quarter of the time in a
            // profile); crossing ones are collected for the exchange.
            let mut w = 0;
            let mut send = Vec::new();
            let mut send_origin = Vec::new();
            let mut dest = Vec::new();
            let partner = if i_am_low {
                mid + (me - lo) % (hi - mid)
            } else {
                lo + (me - mid) % (mid - lo)
            };
            for k in 0..items.len() {
                let it = items[k];
                let x = it.position();
                if cut.is_low(&x, it.id()) == i_am_low {
                    items[w] = it;
                    origin[w] = origin[k];
                    w += 1;
                } else {
                    // Straight to the previous owner when it is on the other side.
                    let d = match &prev {
                        Some(t) => {
                            let o = t.owner_of_item(&x, it.id());
                            let other = if i_am_low {
                                o >= mid && o < hi
                            } else {
                                o >= lo && o < mid
                            };
                            if other {
                                o
                            } else {
                                partner
                            }
                        }
                        None => partner,
                    };
                    send.push(it);
                    send_origin.push(origin[k]);
                    dest.push(d - lo);
                }
            }
            items.truncate(w);
            origin.truncate(w);
            let mut plan = CommPlan::new(g, &dest);
            let got = plan.exchange(&send);
            let got_origin = plan.exchange(&send_origin);
            bytes += plan.bytes_sent;
            items.extend_from_slice(&got);
            origin.extend_from_slice(&got_origin);
        }
        self.path = path;
        self.share_cuts();
        self.has_cuts = true;

        // Statistics.
        let w_loc: f64 = items.iter().map(|it| it.weight()).sum();
        let migrated_loc = origin.iter().filter(|&&o| o != me).count() as u64;
        let mut sums = [0u64; 3];
        self.comm.all_reduce_into(
            &[migrated_loc, bytes, items.len() as u64][..],
            &mut sums[..],
            SystemOperation::sum(),
        );
        let mut wsum = 0.0;
        self.comm
            .all_reduce_into(&w_loc, &mut wsum, SystemOperation::sum());
        let mut maxes = [0.0f64; 3];
        self.comm.all_reduce_into(
            &[w_loc, t0.elapsed().as_secs_f64(), iterations as f64][..],
            &mut maxes[..],
            SystemOperation::max(),
        );
        let mean = wsum / self.comm.size() as f64;
        Ok((
            items,
            RcbStats {
                items: sums[2],
                imbalance: if mean > 0.0 { maxes[0] / mean } else { 1.0 },
                migrated: sums[0],
                bytes_sent: sums[1],
                wall_s: maxes[1],
                iterations: maxes[2] as u64,
            },
        ))
    }

    /// Refuses non-finite positions and negative or non-finite weights on every rank alike
    /// (the median search would never settle): the error names the lowest such id over the
    /// ranks (collective).
    fn refuse_bad_items<T: RcbItem>(&self, items: &[T]) -> Result<(), RcbError> {
        // Refuse non-finite input on every rank alike (the median search would never settle).
        let bad = items.iter().find(|it| {
            let x = it.position();
            let w = it.weight();
            !(x.iter().all(|c| c.is_finite()) && w.is_finite() && w >= 0.0)
        });
        let flag = bad.map(|b| b.id()).unwrap_or(u64::MAX);
        let mut first_bad = u64::MAX;
        self.comm
            .all_reduce_into(&flag, &mut first_bad, SystemOperation::min());
        if first_bad != u64::MAX {
            let (x, w) = items
                .iter()
                .find(|it| it.id() == first_bad)
                .map(|it| (it.position(), it.weight()))
                .unwrap_or(([f64::NAN; 3], f64::NAN));
            return Err(RcbError::BadItem {
                id: first_bad,
                x,
                w,
            });
        }
        Ok(())
    }

    /// The paper's "expand": each cut is known to its group; the first rank of each group
    /// contributes it and one all-reduce gives every rank the whole tree (sums of one non-zero
    /// term and zeros are exact).
    fn share_cuts(&mut self) {
        let n = self.tree.nodes.len();
        if n == 0 {
            return;
        }
        let me = self.comm.rank();
        let mut vals = vec![0.0f64; n];
        let mut ints = vec![0u64; 2 * n];
        for (i, node) in self.tree.nodes.iter().enumerate() {
            if node.lo == me {
                vals[i] = node.cut.value;
                ints[2 * i] = node.cut.dim as u64;
                ints[2 * i + 1] = node.cut.tie_id;
            }
        }
        let mut gvals = vec![0.0f64; n];
        let mut gints = vec![0u64; 2 * n];
        self.comm
            .all_reduce_into(&vals[..], &mut gvals[..], SystemOperation::sum());
        self.comm
            .all_reduce_into(&ints[..], &mut gints[..], SystemOperation::sum());
        for (i, node) in self.tree.nodes.iter_mut().enumerate() {
            node.cut = Cut {
                dim: gints[2 * i] as usize,
                value: gvals[i],
                tie_id: gints[2 * i + 1],
            };
        }
    }
}

/// Finds the cut of the group `[lo, hi)` (communicator `g`) over its items: the lower
/// `mid - lo` ranks get that share of the weight. Returns the cut and the iterations taken.
fn split_level<T: RcbItem>(
    g: &SimpleCommunicator,
    items: &[T],
    lo: i32,
    mid: i32,
    hi: i32,
    prev: Option<Cut>,
) -> (Cut, u64) {
    let (dim, guess, target) = cut_axis(g, items, lo, mid, hi, prev);
    let (low, iterations) = median_search(g, items, dim, guess, target);
    let (value, tie_id) = cut_plane(g, items, dim, &low, guess);
    (Cut { dim, value, tie_id }, iterations)
}

/// The axis of the group's cut (its items' longest extent, or the previous cut's while no
/// other is twice as long), the previous cut's (value, id) on that axis as the first pivot,
/// and the weight the lower `mid - lo` ranks get (collective over `g`).
fn cut_axis<T: RcbItem>(
    g: &SimpleCommunicator,
    items: &[T],
    lo: i32,
    mid: i32,
    hi: i32,
    prev: Option<Cut>,
) -> (usize, Option<(f64, u64)>, f64) {
    // Totals and bounding box of the group's items.
    let mut w_loc = 0.0;
    let mut bb = [f64::INFINITY; 6]; // min xyz, -max xyz
    for it in items {
        w_loc += it.weight();
        let x = it.position();
        for d in 0..3 {
            bb[d] = bb[d].min(x[d]);
            bb[3 + d] = bb[3 + d].min(-x[d]);
        }
    }
    let mut gbb = [0.0f64; 6];
    g.all_reduce_into(&bb[..], &mut gbb[..], SystemOperation::min());
    let mut sums = [0.0f64; 2];
    g.all_reduce_into(
        &[w_loc, items.len() as f64][..],
        &mut sums[..],
        SystemOperation::sum(),
    );
    let (w_total, n_total) = (sums[0], sums[1]);
    let ext: [f64; 3] = std::array::from_fn(|d| {
        if n_total > 0.0 {
            -gbb[3 + d] - gbb[d]
        } else {
            0.0
        }
    });
    let longest = (0..3).fold(0, |b, d| if ext[d] > ext[b] { d } else { b });
    // Keep the previous axis unless another has become twice as long (hysteresis keeps the
    // decomposition, and so the data, still when points move little).
    let dim = match prev {
        Some(p) if ext[p.dim] >= 0.5 * ext[longest] => p.dim,
        _ => longest,
    };
    let guess = prev.filter(|p| p.dim == dim).map(|p| (p.value, p.tie_id));
    let target = w_total * (mid - lo) as f64 / (hi - lo) as f64;
    (dim, guess, target)
}

/// The median search along `dim`: which items go to the lower ranks (their weight reaching
/// `target`, the ties split by id), and the iterations taken (collective over `g`).
fn median_search<T: RcbItem>(
    g: &SimpleCommunicator,
    items: &[T],
    dim: usize,
    guess: Option<(f64, u64)>,
    target: f64,
) -> (Vec<bool>, u64) {
    // Median search over the undecided items. -0.0 becomes 0.0 so that the sort order
    // (total_cmp) and `<` agree.
    let mut active: Vec<Key> = items
        .iter()
        .enumerate()
        .map(|(i, it)| Key {
            c: it.position()[dim] + 0.0,
            id: it.id(),
            w: it.weight(),
            i: i as u32,
        })
        .collect();
    let mut low = vec![false; items.len()];
    let mut w_below = 0.0; // global weight decided low
    let mut iterations = 0u64;
    let mut first = true;
    loop {
        iterations += 1;
        let w_act_loc: f64 = active.iter().map(|k| k.w).sum();
        let mut act = [0.0f64; 2];
        g.all_reduce_into(
            &[active.len() as f64, w_act_loc][..],
            &mut act[..],
            SystemOperation::sum(),
        );
        let (n_act, w_act) = (act[0], act[1]);
        if n_act <= GATHER_MAX {
            finish_gathered(g, &active, w_below, target, &mut low);
            break;
        }
        // The pivot: the previous cut first, then the weighted median of the ranks' proposals.
        let pivot = match (first, guess) {
            (true, Some(p)) => p,
            _ => {
                let f = if w_act > 0.0 {
                    ((target - w_below) / w_act).clamp(0.0, 1.0)
                } else {
                    0.5
                };
                propose_pivot(g, &mut active, f, w_act_loc)
            }
        };
        first = false;
        let (mut wl, mut wp) = (0.0, 0.0);
        for k in &active {
            if less((k.c, k.id), pivot) {
                wl += k.w;
            } else if (k.c, k.id) == pivot {
                wp += k.w;
            }
        }
        let mut gw = [0.0f64; 2];
        g.all_reduce_into(&[wl, wp][..], &mut gw[..], SystemOperation::sum());
        let a = w_below + gw[0]; // weight of keys < pivot
        let b = a + gw[1]; // weight of keys <= pivot
        if b < target {
            for k in &active {
                if !less(pivot, (k.c, k.id)) {
                    low[k.i as usize] = true;
                }
            }
            active.retain(|k| less(pivot, (k.c, k.id)));
            w_below = b;
        } else if a >= target {
            active.retain(|k| less((k.c, k.id), pivot));
        } else {
            // The pivot is the item where the cumulative weight reaches the target: it goes
            // to the side that leaves the split closer to the target (high on a tie).
            let pivot_low = target - a > b - target;
            for k in &active {
                let key = (k.c, k.id);
                low[k.i as usize] = less(key, pivot) || (pivot_low && key == pivot);
            }
            break;
        }
    }
    (low, iterations)
}

/// The cut's plane between the items `low` gives the lower ranks and the others along `dim`:
/// its value and, where both sides share the coordinate, the tie id (collective over `g`).
fn cut_plane<T: RcbItem>(
    g: &SimpleCommunicator,
    items: &[T],
    dim: usize,
    low: &[bool],
    guess: Option<(f64, u64)>,
) -> (f64, u64) {
    // The plane: midway between the last low and the first high coordinate, or a tie cut.
    let mut ext_loc = [f64::NEG_INFINITY; 2]; // max low c, -min high c
    for (i, it) in items.iter().enumerate() {
        let c = it.position()[dim] + 0.0;
        if low[i] {
            ext_loc[0] = ext_loc[0].max(c);
        } else {
            ext_loc[1] = ext_loc[1].max(-c);
        }
    }
    let mut ge = [0.0f64; 2];
    g.all_reduce_into(&ext_loc[..], &mut ge[..], SystemOperation::max());
    let (max_low, min_high) = (ge[0], -ge[1]);
    let mut tie_id = 0;
    let value = match (max_low.is_finite(), min_high.is_finite()) {
        (true, true) if max_low < min_high => {
            let m = 0.5 * (max_low + min_high);
            if m > max_low && m <= min_high {
                m
            } else {
                min_high
            }
        }
        (true, true) => {
            // Low and high items share the coordinate: split them by id.
            let c = max_low;
            let mut t_loc = u64::MAX;
            for (i, it) in items.iter().enumerate() {
                if !low[i] && it.position()[dim] + 0.0 == c {
                    t_loc = t_loc.min(it.id());
                }
            }
            g.all_reduce_into(&t_loc, &mut tie_id, SystemOperation::min());
            c
        }
        (false, true) => min_high,
        (true, false) => max_low.next_up(),
        (false, false) => guess.map(|p| p.0).unwrap_or(0.0),
    };
    (value, tie_id)
}

/// Each rank proposes the item at quantile `f` of its undecided items; the pivot is the
/// weighted (by undecided weight) median of the proposals, the same on every rank.
fn propose_pivot(g: &SimpleCommunicator, active: &mut [Key], f: f64, w_act_loc: f64) -> (f64, u64) {
    let mine = if active.is_empty() {
        [0u64, 0, 0, 0]
    } else {
        let k = ((f * active.len() as f64) as usize).min(active.len() - 1);
        let (_, p, _) =
            active.select_nth_unstable_by(k, |a, b| a.c.total_cmp(&b.c).then(a.id.cmp(&b.id)));
        [1, p.c.to_bits(), p.id, w_act_loc.to_bits()]
    };
    let mut all = vec![0u64; 4 * g.size() as usize];
    g.all_gather_into(&mine[..], &mut all[..]);
    let mut props: Vec<(f64, u64, f64)> = all
        .chunks(4)
        .filter(|c| c[0] == 1)
        .map(|c| (f64::from_bits(c[1]), c[2], f64::from_bits(c[3])))
        .collect();
    props.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let total: f64 = props.iter().map(|p| p.2).sum();
    let mut acc = 0.0;
    for p in &props {
        acc += p.2;
        if acc >= 0.5 * total {
            return (p.0, p.1);
        }
    }
    let p = props.last().expect("some rank has undecided items");
    (p.0, p.1)
}

/// Few undecided items remain: gather them on every rank of the group and finish the split
/// exactly (the first item in key order where the cumulative weight reaches the target).
fn finish_gathered(
    g: &SimpleCommunicator,
    active: &[Key],
    w_below: f64,
    target: f64,
    low: &mut [bool],
) {
    let mine: Vec<u64> = active
        .iter()
        .flat_map(|k| [k.c.to_bits(), k.id, k.w.to_bits()])
        .collect();
    let buf = crate::kernels::collective::all_gather_varcount(g, &mine);
    let mut all: Vec<(f64, u64, f64)> = buf
        .chunks(3)
        .map(|c| (f64::from_bits(c[0]), c[1], f64::from_bits(c[2])))
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    // Split key: items with key < split are low (None: all undecided items are low).
    let mut split: Option<((f64, u64), bool)> = None;
    let mut cum = w_below;
    for e in &all {
        let (a, b) = (cum, cum + e.2);
        if b >= target {
            split = Some(((e.0, e.1), target - a > b - target));
            break;
        }
        cum = b;
    }
    for k in active {
        let key = (k.c, k.id);
        low[k.i as usize] = match split {
            None => true,
            Some((p, p_low)) => less(key, p) || (p_low && key == p),
        };
    }
}
