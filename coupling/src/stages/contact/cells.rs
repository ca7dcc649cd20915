//! Step 7b, the push-back, solved where the contacts are: each contact goes to the rank owning
//! its cell, each rank solves its cells, and neighbours exchange only the nodes their cells
//! share (`contact::pushback`, "Sweeps in cells", for why the answer does not depend on the
//! ranks).
//!
//! One solve:
//! 1. every rank takes its boxes' contacts with their node and face records (a packet, 664
//!    bytes), their anchors and reaches; the largest reach over all ranks sets the cell size;
//! 2. each packet goes to the rank whose contact region (the cut tree) holds its cell's centre:
//!    most stay where they were found;
//! 3. each node the rank's contacts touch is announced, with the colours that touch it, at the
//!    node's *home* (the rank whose region holds its start position; every copy of a record
//!    names the same one), which tells every toucher the others: these are the shared nodes;
//! 4. the rank solves its cells (`contact::push_back_in`), sending after each colour the new
//!    impulses of the shared nodes its cells changed to the other touchers, and taking the
//!    largest residuals over all ranks;
//! 5. the forces go to the homes, and from the homes to every rank whose boxes hold the node
//!    (registered once per step, [`Holders`]): the FE and SPH owners' forces and the rechecks'
//!    corrections.
//!
//! Bytes per rank per step: the packets of the contacts whose cell another rank owns, 16 bytes
//! per touched node (announce), 32 per touched node home and per registered node forwarded, 8
//! per box node registered, and per colour and sweep 32 per shared node: all proportional to
//! the rank's own contacts and box, none to the model's.
use crate::kernels::comm::{exchange_known, CommPlan};
use crate::kernels::rcb::CutTree;
use bytemuck::{Pod, Zeroable};
use contact::{
    anchor, push_back_in, reach, Cells, Contact, ContactBox, Exchange, FaceRecord, NodeRecord,
    PushBackParams, COLOURS, V3,
};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use rustc_hash::FxHashMap as HashMap;
use std::rc::Rc;

/// A contact with what the push-back needs: the node, the face and its corners, and its cell
/// (Pod, 664 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Packet {
    contact: Contact,
    node: NodeRecord,
    face: FaceRecord,
    corners: [NodeRecord; 4],
    cell: [i64; 3],
}

/// A node a rank's contacts touch, with the colours touching it (bit c: colour c).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Touch {
    gid: u64,
    mask: u64,
}

/// Another rank touching a node, with its colours.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Toucher {
    gid: u64,
    rank: u64,
    mask: u64,
}

/// A node's value (an impulse or a force).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Value {
    gid: u64,
    v: [f64; 3],
}

/// The home of a node (step 3): the owner of its start position in the cut tree, rank 0
/// without one (the static baseline). Every copy of a node's record has the same start
/// position, so every rank names the same home.
fn home(tree: Option<&CutTree>, r: &NodeRecord) -> i32 {
    tree.map_or(0, |t| t.owner_of_item(&r.x0, r.gid))
}

/// Where the nodes of this rank's boxes are registered at their homes for the forces (step
/// 5): built once per step, used by every solve of the step.
pub(crate) struct Holders {
    plan: CommPlan,
    /// The gids registered here by each source of `plan`, in its order.
    by_source: Vec<Vec<u64>>,
}

impl Holders {
    /// Registers every node of `boxes` (each gid once) at its home (collective).
    pub(crate) fn new(
        comm: &Rc<SimpleCommunicator>,
        tree: Option<&CutTree>,
        boxes: &[&ContactBox],
    ) -> Holders {
        let mut seen: HashMap<u64, ()> = HashMap::default();
        let (mut gids, mut dest) = (Vec::new(), Vec::new());
        for b in boxes {
            let n = &b.nodes;
            for j in 0..n.len() {
                if seen.insert(n.gid[j], ()).is_none() {
                    gids.push(n.gid[j]);
                    dest.push(home(tree, &n.record(j)));
                }
            }
        }
        let mut plan = CommPlan::new_shared(comm, &dest);
        let got = plan.exchange(&gids);
        let mut by_source = Vec::new();
        let mut at = 0;
        for (_, n) in plan.sources() {
            by_source.push(got[at..at + n].to_vec());
            at += n;
        }
        Holders { plan, by_source }
    }

    /// Bytes sent through the registration so far.
    pub(crate) fn bytes(&self) -> u64 {
        self.plan.bytes_sent
    }
}

/// What [`solve_in_cells`] returns.
pub(crate) struct Solved {
    /// The force on every node of this rank's boxes that took one, by gid, N.
    pub all: HashMap<u64, [f64; 3]>,
    /// The push-back's work over all ranks, J (the same on every rank).
    pub work: f64,
    /// Bytes this rank sent.
    pub sent: u64,
    /// Contacts over all ranks.
    pub total: u64,
    /// Contacts over all ranks that touch a node another rank's cells touch.
    pub coupled: u64,
    /// Gauss-Seidel sweeps (all passes, normal and friction; the same on every rank).
    pub sweeps: u64,
    /// Contacts this rank solved (those of its cells).
    pub rows: u64,
    /// Contacts over all ranks none of whose nodes can move (skipped), and those whose
    /// depth was bounded by the step's own penetration (`contact::PushBack`).
    pub immovable: u64,
    /// See `immovable`.
    pub bounded: u64,
}

/// The push-back of the contacts found in `parts` (each box with its contacts), solved in
/// cells (module documentation). `owned`: the boxes whose first `n_owned` nodes this rank owns
/// (the work is summed over owned nodes, each once over all ranks). Collective.
pub(crate) fn solve_in_cells(
    comm: &Rc<SimpleCommunicator>,
    tree: Option<&CutTree>,
    parts: &[(&ContactBox, &[Contact])],
    holders: &mut Holders,
    dt: f64,
    friction: f64,
) -> Result<Solved, String> {
    let params = PushBackParams {
        friction,
        ..PushBackParams::new(dt)
    };
    // 1. Packets, and the cell size from the largest reach.
    let (mut mine, anchors, reaches) = packets(parts, params.same_point_tol);
    let largest = crate::kernels::collective::max(comm, reaches);
    let total = crate::kernels::collective::sum(comm, mine.len() as f64) as u64;
    if total == 0 {
        return Ok(Solved {
            all: HashMap::default(),
            work: 0.0,
            sent: 0,
            total: 0,
            coupled: 0,
            sweeps: 0,
            rows: 0,
            immovable: 0,
            bounded: 0,
        });
    }
    let cells = Cells::for_reach(largest);
    // 2. Each packet to its cell's owner.
    let dest: Vec<i32> = mine
        .iter_mut()
        .zip(&anchors)
        .map(|(p, x)| {
            p.cell = cells.cell(*x);
            let centre = std::array::from_fn(|a| (p.cell[a] as f64 + 0.5) * cells.size);
            tree.map_or(0, |t| t.owner_of_item(&centre, 0))
        })
        .collect();
    let mut route = CommPlan::new_shared(comm, &dest);
    let mut got = route.exchange(&mine);
    drop(mine);
    let mut sent = route.bytes_sent;
    got.sort_by_key(|p| (p.contact.node_gid, p.contact.face_gid));
    let local = LocalBox::new(comm, &got)?;
    // 3. The shared nodes.
    let mut halo = Halo::new(comm, tree, &local)?;
    // 4. The solve.
    let pb = push_back_in(&local.b, &local.contacts, &local.cell, &params, &mut halo);
    sent += halo.bytes;
    let coupled = local
        .contacts
        .iter()
        .filter(|c| {
            let f = &local.b.faces.nodes[c.face as usize];
            std::iter::once(c.node)
                .chain(f.iter().copied())
                .any(|j| halo.shared[j as usize])
        })
        .count();
    // 5. The forces home, and to the holders.
    let values: Vec<Value> = (0..local.b.nodes.len())
        .map(|j| Value {
            gid: local.b.nodes.gid[j],
            v: pb.force[j],
        })
        .collect();
    let at_home = halo.announce.exchange(&values);
    let mut force: HashMap<u64, [f64; 3]> = HashMap::default();
    for v in &at_home {
        force.entry(v.gid).or_insert(v.v);
    }
    let lists: Vec<Vec<Value>> = holders
        .by_source
        .iter()
        .map(|gids| {
            gids.iter()
                .filter_map(|g| force.get(g).map(|&v| Value { gid: *g, v }))
                .collect()
        })
        .collect();
    let before = holders.plan.bytes_sent;
    let back = holders.plan.reverse_lists(&lists);
    sent += holders.plan.bytes_sent - before + halo.announce.bytes_sent;
    let all: HashMap<u64, [f64; 3]> = back.iter().map(|v| (v.gid, v.v)).collect();
    let mut sums = [0.0f64; 4];
    comm.all_reduce_into(
        &[
            owned_work(parts, &all, dt),
            coupled as f64,
            pb.immovable as f64,
            pb.bounded as f64,
        ][..],
        &mut sums[..],
        SystemOperation::sum(),
    );
    Ok(Solved {
        all,
        work: sums[0],
        sent,
        total,
        coupled: sums[1] as u64,
        sweeps: pb.sweeps as u64,
        rows: local.contacts.len() as u64,
        immovable: sums[2] as u64,
        bounded: sums[3] as u64,
    })
}

/// This rank's packets (each contact of `parts` with its records; the cell still unset), the
/// positions of their anchors, and the largest reach among them, m.
fn packets(parts: &[(&ContactBox, &[Contact])], tol: f64) -> (Vec<Packet>, Vec<V3>, f64) {
    let mut out = Vec::new();
    let mut anchors = Vec::new();
    let mut largest = 0.0f64;
    for (b, contacts) in parts {
        let rec = |i: usize| b.nodes.record(i);
        for c in contacts.iter() {
            let a = anchor(b, c, tol);
            largest = largest.max(reach(b, c, a));
            anchors.push(b.nodes.x1[a]);
            let f = c.face as usize;
            out.push(Packet {
                contact: *c,
                node: rec(c.node as usize),
                face: b.faces.record(f),
                corners: std::array::from_fn(|k| rec(b.faces.nodes[f][k] as usize)),
                cell: [0; 3],
            });
        }
    }
    (out, anchors, largest)
}

/// The work of the push-back forces `all` on the nodes this rank owns (each box's first
/// `n_owned`): `sum_j F_j . (x1_j - x0_j + F_j dt^2 / m_j)`, J.
fn owned_work(parts: &[(&ContactBox, &[Contact])], all: &HashMap<u64, [f64; 3]>, dt: f64) -> f64 {
    let mut w = 0.0;
    for (b, _) in parts {
        let n = &b.nodes;
        for j in 0..n.n_owned {
            if let Some(f) = all.get(&n.gid[j]) {
                let s = if n.mass[j].is_finite() {
                    dt * dt / n.mass[j]
                } else {
                    0.0
                };
                for a in 0..3 {
                    w += f[a] * (n.x1[j][a] - n.x0[j][a] + f[a] * s);
                }
            }
        }
    }
    w
}

/// The contacts of the cells this rank owns, as one box: their nodes (each once) and faces.
struct LocalBox {
    b: ContactBox,
    contacts: Vec<Contact>,
    cell: Vec<[i64; 3]>,
}

impl LocalBox {
    /// From the packets received (sorted by node and face gid). Collective (an error on one
    /// rank stops every rank).
    fn new(comm: &SimpleCommunicator, got: &[Packet]) -> Result<LocalBox, String> {
        let mut nodes: Vec<NodeRecord> = Vec::new();
        let mut slot: HashMap<u64, usize> = HashMap::default();
        for p in got {
            slot.entry(p.node.gid).or_insert_with(|| {
                nodes.push(p.node);
                nodes.len() - 1
            });
        }
        let n_contact_nodes = nodes.len();
        let mut faces: Vec<FaceRecord> = Vec::new();
        let mut face_slot: HashMap<u64, usize> = HashMap::default();
        for p in got {
            for r in &p.corners {
                slot.entry(r.gid).or_insert_with(|| {
                    nodes.push(*r);
                    nodes.len() - 1
                });
            }
            face_slot.entry(p.face.gid).or_insert_with(|| {
                faces.push(p.face);
                faces.len() - 1
            });
        }
        let b = super::stage::box_on_every_rank(comm, &nodes, n_contact_nodes, &faces)?;
        let contacts = got
            .iter()
            .map(|p| Contact {
                node: slot[&p.contact.node_gid] as u32,
                face: face_slot[&p.contact.face_gid] as u32,
                ..p.contact
            })
            .collect();
        Ok(LocalBox {
            b,
            contacts,
            cell: got.iter().map(|p| p.cell).collect(),
        })
    }
}

/// The nodes this rank's cells share with other ranks' (step 3) and their exchange after each
/// colour (step 4): [`contact::Exchange`] over MPI.
struct Halo<'a> {
    comm: &'a SimpleCommunicator,
    /// The announcement of the touched nodes at their homes (reused to send the forces home).
    announce: CommPlan,
    /// Per box node: shared with another rank's cells.
    shared: Vec<bool>,
    /// Per colour: (rank, the box nodes whose new impulse goes to it), ascending rank, nodes
    /// in gid order.
    sends: [Vec<(i32, Vec<u32>)>; COLOURS],
    /// Per colour: (rank, the box nodes whose impulse it sends), as `sends`.
    recvs: [Vec<(i32, Vec<u32>)>; COLOURS],
    bytes: u64,
}

impl<'a> Halo<'a> {
    /// Announces the touched nodes at their homes and learns the other touchers (collective).
    fn new(
        comm: &'a Rc<SimpleCommunicator>,
        tree: Option<&CutTree>,
        local: &LocalBox,
    ) -> Result<Halo<'a>, String> {
        let b = &local.b;
        let n = b.nodes.len();
        let mut mask = vec![0u64; n];
        for (c, cell) in local.contacts.iter().zip(&local.cell) {
            let bit = 1u64 << Cells::colour(*cell);
            mask[c.node as usize] |= bit;
            for &j in &b.faces.nodes[c.face as usize] {
                mask[j as usize] |= bit;
            }
        }
        let touches: Vec<Touch> = (0..n)
            .map(|j| Touch {
                gid: b.nodes.gid[j],
                mask: mask[j],
            })
            .collect();
        let dest: Vec<i32> = (0..n).map(|j| home(tree, &b.nodes.record(j))).collect();
        let mut announce = CommPlan::new_shared(comm, &dest);
        let got = announce.exchange(&touches);
        // At the home: every toucher of each node, then each toucher's list of the others.
        let sources: Vec<(i32, usize)> = announce.sources().collect();
        let mut by_gid: HashMap<u64, Vec<(i32, u64)>> = HashMap::default();
        let mut at = 0;
        for &(r, k) in &sources {
            for t in &got[at..at + k] {
                by_gid.entry(t.gid).or_default().push((r, t.mask));
            }
            at += k;
        }
        let mut lists = Vec::with_capacity(sources.len());
        let mut at = 0;
        for &(r, k) in &sources {
            let mut l = Vec::new();
            for t in &got[at..at + k] {
                for &(o, m) in &by_gid[&t.gid] {
                    if o != r {
                        l.push(Toucher {
                            gid: t.gid,
                            rank: o as u64,
                            mask: m,
                        });
                    }
                }
            }
            lists.push(l);
            at += k;
        }
        let others = announce.reverse_lists(&lists);
        let me = comm.rank();
        let index: HashMap<u64, u32> = (0..n as u32)
            .map(|j| (b.nodes.gid[j as usize], j))
            .collect();
        let mut shared = vec![false; n];
        let mut sends: [Vec<(i32, Vec<u32>)>; COLOURS] = Default::default();
        let mut recvs: [Vec<(i32, Vec<u32>)>; COLOURS] = Default::default();
        // (colour, rank, gid, node, I write it) for every shared node and other toucher.
        let mut pairs: Vec<(usize, i32, u64, u32, bool)> = Vec::new();
        let mut clash = None;
        for t in &others {
            let j = index[&t.gid];
            shared[j as usize] = true;
            let (mine, theirs) = (mask[j as usize], t.mask);
            if mine & theirs != 0 {
                clash = Some(t.gid);
            }
            for c in 0..COLOURS {
                let bit = 1u64 << c;
                if mine & bit != 0 {
                    pairs.push((c, t.rank as i32, t.gid, j, true));
                } else if theirs & bit != 0 {
                    pairs.push((c, t.rank as i32, t.gid, j, false));
                }
            }
        }
        // Two ranks' cells of one colour never share a node (contact::pushback, "Sweeps in
        // cells"); a clash would make the answer depend on the ranks.
        let clash = clash.map(|g| {
            format!("contact push-back: node {g} is touched by one colour on rank {me} and another rank")
        });
        crate::kernels::collective::first_error(comm, clash)?;
        pairs.sort_unstable();
        for (c, r, _, j, write) in pairs {
            let side = if write { &mut sends[c] } else { &mut recvs[c] };
            match side.last_mut() {
                Some((lr, l)) if *lr == r => l.push(j),
                _ => side.push((r, vec![j])),
            }
        }
        Ok(Halo {
            comm,
            announce,
            shared,
            sends,
            recvs,
            bytes: 0,
        })
    }
}

impl Exchange for Halo<'_> {
    fn max(&mut self, x: f64) -> f64 {
        crate::kernels::collective::max(self.comm, x)
    }

    fn sync(&mut self, colour: usize, impulse: &mut [V3]) {
        if self.sends[colour].is_empty() && self.recvs[colour].is_empty() {
            return;
        }
        let sends: Vec<(i32, Vec<V3>)> = self.sends[colour]
            .iter()
            .map(|(r, l)| (*r, l.iter().map(|&j| impulse[j as usize]).collect()))
            .collect();
        let recvs: Vec<(i32, usize)> = self.recvs[colour]
            .iter()
            .map(|(r, l)| (*r, l.len()))
            .collect();
        let (got, bytes, _) = exchange_known(self.comm, &sends, &recvs);
        self.bytes += bytes;
        for ((_, l), vals) in self.recvs[colour].iter().zip(got) {
            for (&j, v) in l.iter().zip(vals) {
                impulse[j as usize] = v;
            }
        }
    }
}
