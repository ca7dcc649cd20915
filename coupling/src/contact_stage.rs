//! The contact stage on its own dynamic decomposition (the paper's §5, Fig. 10).
//!
//! Contact nodes (mesh surface nodes and SPH particle centres) live on their FE or SPH owners;
//! contact faces on the FE rank of the element they bound. Each step:
//! 1. every node's record goes to its contact owner of the previous step (the previous cut tree's
//!    owner of its predicted position), so that
//! 2. the RCB rebalance over nodes + particles, started from the previous cuts, moves little;
//! 3. each face, with the records of its four nodes ("full data"), goes to the contact owner of its
//!    first node;
//! 4. the cuts are shared (every rank holds the tree after the balance);
//! 5. (and 6.) each face goes to every rank whose box its search box (grown by the zone of
//!    influence: the largest node motion of the step and the largest particle radius) overlaps;
//! 7. each rank searches its owned nodes against the faces it holds (the `contact` crate) and
//!    computes the push-back;
//! 8. every contact owner sends the force of its nodes back to the node's FE or SPH owner.
//!
//! Every contact is found in exactly one box (a node is owned by one rank), so nothing is counted
//! twice. The push-back of all contacts is solved together (step 7b: the step's contacts are
//! gathered on every rank and solved as one box, Gauss-Seidel in the `contact` crate), so the
//! forces do not depend on where the cuts fall; each rank keeps those of its contact nodes.
use crate::comm::CommPlan;
use crate::rcb::{CutTree, Rcb, RcbItem, RcbStats};
use bytemuck::{Pod, Zeroable};
use contact::{
    face_records_search_aabb, push_back, search, Contact, ContactBox, FaceRecord, NodeRecord,
    PushBackParams, SearchParams,
};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use rustc_hash::FxHashMap as HashMap;
use std::time::Instant;

/// Parametric tolerance of "the node projects inside the face" in runs: `|xi|, |eta| <= 1.02`.
/// A node over a ridge where two faces meet at an angle (a fold of a wall, seen from the side
/// the faces bend away from) projects just outside both faces; with a tolerance of round-off
/// size (the crate's default, 1e-6) it is missed there, sinks past the capture tolerance in
/// a few steps and is then never found again (it started the step behind the face). Measured
/// on `tube_crush` (nodes on the folds' creases, which lie on the opposite wall's face seams):
/// 0.32 mm (a third of the wall) inside the wall at 1e-6, 1e-9 m at 0.02. A node near a seam
/// may then be found against both faces; the search keeps the deeper. Used for self-contact
/// pairs only: between bodies the crate's default keeps contacts of neighbouring faces apart,
/// whose push-backs, when they land in different contact boxes, are solved separately (with
/// 0.02 between bodies too, `underwater_explosion`'s plug moved 1.4 % differently at np 1 and 3).
pub const MESH_PARAM_TOL: f64 = 2e-2;

/// A contact node travelling through the stage: its record and where its owner keeps it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct CNode {
    rec: NodeRecord,
    home: u64,
    home_idx: u64,
}

impl RcbItem for CNode {
    fn position(&self) -> [f64; 3] {
        self.rec.x1
    }
    fn id(&self) -> u64 {
        self.rec.gid
    }
}

/// A face with the records of its four nodes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FullFace {
    /// The face.
    pub face: FaceRecord,
    /// Its corner nodes, in the face's order.
    pub nodes: [NodeRecord; 4],
}

/// A force for one node, keyed by an index or a gid.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Back {
    key: u64,
    f: [f64; 3],
}

/// What one contact step found and cost.
#[derive(Clone, Debug, Default)]
pub struct ContactOutcome {
    /// Push-back force on each input node (aligned with the `nodes` given), N.
    pub force: Vec<[f64; 3]>,
    /// Contacts found, over all ranks.
    pub contacts: u64,
    /// The contacts found on this rank: (node gid, face gid, depth).
    pub found: Vec<(u64, u64, f64)>,
    /// Work of the push-back forces, over all ranks, J.
    pub work: f64,
    /// Max over ranks of (owned nodes + faces held) over the mean: the balance of the search.
    pub imbalance: f64,
    /// Owned nodes + faces held: the largest over ranks, and the sum over ranks.
    pub work_items_max: f64,
    /// See `work_items_max`.
    pub work_items_total: f64,
    /// Bytes sent point to point by all ranks in this step (RCB included).
    pub bytes_sent: u64,
    /// The RCB call's statistics.
    pub rcb: RcbStats,
    /// Wall time of the step, max over ranks, s.
    pub wall_s: f64,
    /// The transfers between decompositions inside the step (included in the above).
    pub transfer: TransferStats,
}

/// The transfers between decompositions in one contact step: the contact nodes' records from
/// their FE and SPH owners to the contact owners, the faces to theirs, and the push-back forces
/// back to the FE and SPH owners.
#[derive(Clone, Copy, Debug, Default)]
pub struct TransferStats {
    /// Bytes sent by all ranks.
    pub bytes_sent: u64,
    /// Max over ranks of the bytes sent, over the mean.
    pub imbalance: f64,
    /// Wall time, max over ranks, s.
    pub wall_s: f64,
}

/// A contact with what the push-back needs: the node, the face and its corners (Pod, 640 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ContactPacket {
    contact: Contact,
    node: NodeRecord,
    face: FaceRecord,
    corners: [NodeRecord; 4],
}

/// Gathers every rank's contacts on every rank and solves their push-back as one box (see step
/// 7b). Returns the forces on `owned` (this rank's contact nodes), the push-back's work (the
/// same on every rank) and the bytes this rank sent.
fn solve_together(
    comm: &SimpleCommunicator,
    b: &ContactBox,
    contacts: &[Contact],
    owned: &[NodeRecord],
    dt: f64,
) -> Result<(Vec<[f64; 3]>, f64, u64), String> {
    let rec = |i: usize| b.nodes.record(i);
    let mine: Vec<ContactPacket> = contacts
        .iter()
        .map(|c| {
            let f = c.face as usize;
            ContactPacket {
                contact: *c,
                node: rec(c.node as usize),
                face: b.faces.record(f),
                corners: std::array::from_fn(|k| rec(b.faces.nodes[f][k] as usize)),
            }
        })
        .collect();
    let sent = (std::mem::size_of_val(&mine[..]) * (comm.size() as usize - 1)) as u64;
    let bytes: Vec<u8> = bytemuck::cast_slice(&mine).to_vec();
    let all = crate::collective::all_gather_varcount(comm, &bytes);
    let mut packets: Vec<ContactPacket> = all
        .chunks_exact(std::mem::size_of::<ContactPacket>())
        .map(bytemuck::pod_read_unaligned)
        .collect();
    let mut force = vec![[0.0; 3]; owned.len()];
    if packets.is_empty() {
        return Ok((force, 0.0, sent));
    }
    // One box: the contact nodes first, then the faces' corners, each once, in gid order of
    // the sorted contacts (the same on every rank).
    packets.sort_by(|p, q| {
        (p.contact.node_gid, p.contact.face_gid).cmp(&(q.contact.node_gid, q.contact.face_gid))
    });
    let mut nodes: Vec<NodeRecord> = Vec::new();
    let mut slot: HashMap<u64, usize> = HashMap::default();
    for p in &packets {
        slot.entry(p.node.gid).or_insert_with(|| {
            nodes.push(p.node);
            nodes.len() - 1
        });
    }
    let n_contact_nodes = nodes.len();
    let mut faces: Vec<FaceRecord> = Vec::new();
    let mut face_slot: HashMap<u64, usize> = HashMap::default();
    for p in &packets {
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
    let gb =
        ContactBox::from_records(&nodes, n_contact_nodes, &faces).map_err(|e| e.to_string())?;
    let gc: Vec<Contact> = packets
        .iter()
        .map(|p| Contact {
            node: slot[&p.contact.node_gid] as u32,
            face: face_slot[&p.contact.face_gid] as u32,
            ..p.contact
        })
        .collect();
    let pb = push_back(&gb, &gc, &PushBackParams::new(dt));
    for (i, r) in owned.iter().enumerate() {
        if let Some(&k) = slot.get(&r.gid) {
            force[i] = pb.force[k];
        }
    }
    Ok((force, pb.work, sent))
}

/// The contact stage of one run.
pub struct ContactStage {
    comm: SimpleCommunicator,
    rcb: Rcb,
    tree: Option<CutTree>,
    /// Search parameters (`self_contact` from the scene).
    pub params: SearchParams,
}

impl ContactStage {
    /// A stage over `comm` (collective).
    pub fn new(comm: &SimpleCommunicator, self_contact: bool) -> ContactStage {
        ContactStage {
            comm: comm.duplicate(),
            rcb: Rcb::new(comm),
            tree: None,
            params: SearchParams {
                self_contact,
                one_pass: true,
                self_param_tol: MESH_PARAM_TOL,
                ..SearchParams::default()
            },
        }
    }

    /// The contact decomposition's cut tree after the last step.
    pub fn tree(&self) -> Option<&CutTree> {
        self.tree.as_ref()
    }

    /// One detection and push-back (collective). `nodes`: the contact nodes this rank owns in
    /// the FE or SPH decomposition (start and predicted end positions, predicted velocity);
    /// `faces`: the faces this rank is responsible for, each with its nodes' records. Returns the
    /// push-back force on each of `nodes` over the step `dt`.
    pub fn step(
        &mut self,
        nodes: &[NodeRecord],
        faces: &[FullFace],
        dt: f64,
    ) -> Result<ContactOutcome, String> {
        let t0 = Instant::now();
        let comm = &self.comm;
        let me = comm.rank();
        let mut bytes = 0u64;
        let items: Vec<CNode> = nodes
            .iter()
            .enumerate()
            .map(|(i, r)| CNode {
                rec: *r,
                home: me as u64,
                home_idx: i as u64,
            })
            .collect();
        // The transfers between decompositions (steps 1, 3 and the last half of 8: FE and SPH
        // owners to contact owners and back): their bytes and time.
        let (mut t_bytes, mut t_s) = (0u64, 0.0f64);
        // 1. To last step's contact owners.
        let tt = Instant::now();
        let items = match &self.tree {
            Some(t) => {
                let dest: Vec<i32> = items
                    .iter()
                    .map(|n| t.owner_of_item(&n.rec.x1, n.rec.gid))
                    .collect();
                let mut plan = CommPlan::new(comm, &dest);
                let got = plan.exchange(&items);
                bytes += plan.bytes_sent;
                t_bytes += plan.bytes_sent;
                got
            }
            None => items,
        };
        t_s += tt.elapsed().as_secs_f64();
        // 2. RCB over nodes and particles, from the previous cuts.
        let (mine, rcb_stats) = self.rcb.balance(items).map_err(|e| e.to_string())?;
        bytes += rcb_stats.bytes_sent;
        let tree = self.rcb.tree().clone();
        // 3. Faces with their nodes to the contact owner of their first node.
        let tt = Instant::now();
        let dest: Vec<i32> = faces
            .iter()
            .map(|f| tree.owner_of_item(&f.nodes[0].x1, f.nodes[0].gid))
            .collect();
        let mut plan = CommPlan::new(comm, &dest);
        let my_faces = plan.exchange(faces);
        bytes += plan.bytes_sent;
        t_bytes += plan.bytes_sent;
        t_s += tt.elapsed().as_secs_f64();
        // 5-6. Ghost each face to every box its search box overlaps, grown by the zone of
        // influence: the largest node motion of the step and the largest particle radius.
        let (mut motion, mut radius) = (0.0f64, 0.0f64);
        for n in &mine {
            let d: f64 = (0..3)
                .map(|k| (n.rec.x1[k] - n.rec.x0[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            motion = motion.max(d);
            radius = radius.max(n.rec.radius);
        }
        let mut g = [0.0f64; 2];
        comm.all_reduce_into(&[motion, radius][..], &mut g[..], SystemOperation::max());
        let (motion, radius) = (g[0], g[1]);
        let mut dest = Vec::new();
        let mut ghosts = Vec::new();
        let mut ranks = Vec::new();
        for f in &my_faces {
            let bb = face_records_search_aabb(&f.nodes, &self.params, radius).grown(motion);
            ranks.clear();
            tree.ranks_overlapping(&bb.min, &bb.max, &mut ranks);
            for &r in &ranks {
                dest.push(r);
                ghosts.push(*f);
            }
        }
        let mut plan = CommPlan::new(comm, &dest);
        let held = plan.exchange(&ghosts);
        bytes += plan.bytes_sent;

        // 7. The local search: owned nodes first, then copies of face nodes not owned here.
        let mut recs: Vec<NodeRecord> = mine.iter().map(|n| n.rec).collect();
        let mut index: HashMap<u64, usize> =
            recs.iter().enumerate().map(|(i, r)| (r.gid, i)).collect();
        let n_owned = recs.len();
        let mut face_recs = Vec::with_capacity(held.len());
        let mut seen_faces: HashMap<u64, ()> =
            HashMap::with_capacity_and_hasher(held.len(), Default::default());
        for f in &held {
            if seen_faces.insert(f.face.gid, ()).is_some() {
                continue;
            }
            for r in &f.nodes {
                index.entry(r.gid).or_insert_with(|| {
                    recs.push(*r);
                    recs.len() - 1
                });
            }
            face_recs.push(f.face);
        }
        let work_items = (n_owned + face_recs.len()) as f64;
        let b = ContactBox::from_records(&recs, n_owned, &face_recs);
        crate::collective::first_error(comm, b.as_ref().err().map(|e| e.to_string()))?;
        let b = b.expect("checked on every rank");
        let contacts = search(&b, &self.params);

        // 7b. The push-back of all contacts together. Contacts that share face nodes but were
        // found in different boxes must be solved together for the answer not to depend on the
        // decomposition (solved box by box, each box removed the whole penetration of its own
        // contacts: block_drop's energies differed at 1e-3 between rank counts). Every rank
        // gathers every contact with its node's and its face's records (640 bytes each) and
        // solves the same problem in the same order, so the forces are those of one box holding
        // everything, at any rank count. The price: bytes grow as P x contacts (reported in
        // `bytes_sent`); contacts are few next to the nodes searched.
        let (owned_force, pb_work, gather_bytes) =
            solve_together(comm, &b, &contacts, &recs[..n_owned], dt)?;
        bytes += gather_bytes;
        let tt = Instant::now();
        let mut dest = Vec::new();
        let mut back = Vec::new();
        for (i, n) in mine.iter().enumerate() {
            if owned_force[i].iter().any(|c| *c != 0.0) {
                dest.push(n.home as i32);
                back.push(Back {
                    key: n.home_idx,
                    f: owned_force[i],
                });
            }
        }
        let mut plan = CommPlan::new(comm, &dest);
        let got = plan.exchange(&back);
        bytes += plan.bytes_sent;
        t_bytes += plan.bytes_sent;
        let mut force = vec![[0.0; 3]; nodes.len()];
        for bk in &got {
            let f = &mut force[bk.key as usize];
            for k in 0..3 {
                f[k] += bk.f[k];
            }
        }
        t_s += tt.elapsed().as_secs_f64();

        // Statistics.
        let mut sums = [0.0f64; 5];
        comm.all_reduce_into(
            &[
                contacts.len() as f64,
                if me == 0 { pb_work } else { 0.0 },
                bytes as f64,
                work_items,
                t_bytes as f64,
            ][..],
            &mut sums[..],
            SystemOperation::sum(),
        );
        let mut maxes = [0.0f64; 4];
        comm.all_reduce_into(
            &[work_items, t0.elapsed().as_secs_f64(), t_bytes as f64, t_s][..],
            &mut maxes[..],
            SystemOperation::max(),
        );
        let t_mean = sums[4] / comm.size() as f64;
        let mean = sums[3] / comm.size() as f64;
        self.tree = Some(tree);
        Ok(ContactOutcome {
            force,
            contacts: sums[0] as u64,
            found: contacts
                .iter()
                .map(|c| (c.node_gid, c.face_gid, c.depth))
                .collect(),
            work: sums[1],
            imbalance: if mean > 0.0 { maxes[0] / mean } else { 1.0 },
            work_items_max: maxes[0],
            work_items_total: sums[3],
            bytes_sent: sums[2] as u64,
            rcb: rcb_stats,
            wall_s: maxes[1],
            transfer: TransferStats {
                bytes_sent: sums[4] as u64,
                imbalance: if t_mean > 0.0 { maxes[2] / t_mean } else { 1.0 },
                wall_s: maxes[3],
            },
        })
    }
}
