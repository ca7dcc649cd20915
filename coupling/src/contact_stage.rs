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
//! 8. forces on face-node copies go to those nodes' contact owners, and every contact owner sends
//!    the summed force of its nodes back to the node's FE or SPH owner.
//!
//! Every contact is found in exactly one box (a node is owned by one rank), so nothing is counted
//! twice; forces sum at the owners. The push-back inside one box is solved together (Gauss-Seidel,
//! the `contact` crate); contacts of one face found in different boxes are solved independently,
//! each conserving momentum.
use crate::comm::CommPlan;
use crate::rcb::{CutTree, Rcb, RcbItem, RcbStats};
use bytemuck::{Pod, Zeroable};
use contact::{
    face_records_search_aabb, push_back, search, ContactBox, FaceRecord, NodeRecord,
    PushBackParams, SearchParams,
};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::collections::HashMap;
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
        let mut seen_faces: HashMap<u64, ()> = HashMap::with_capacity(held.len());
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
        let pb = push_back(&b, &contacts, &PushBackParams::new(dt));

        // 8. Forces on copies to the nodes' contact owners, then everything to the homes.
        let mut owned_force: Vec<[f64; 3]> = pb.force[..n_owned].to_vec();
        let mut dest = Vec::new();
        let mut fwd = Vec::new();
        for j in n_owned..recs.len() {
            let f = pb.force[j];
            if f.iter().any(|c| *c != 0.0) {
                dest.push(tree.owner_of_item(&recs[j].x1, recs[j].gid));
                fwd.push(Back {
                    key: recs[j].gid,
                    f,
                });
            }
        }
        let mut plan = CommPlan::new(comm, &dest);
        let got = plan.exchange(&fwd);
        bytes += plan.bytes_sent;
        let mut err = None;
        for bk in &got {
            match index.get(&bk.key) {
                Some(&i) if i < n_owned => {
                    for k in 0..3 {
                        owned_force[i][k] += bk.f[k];
                    }
                }
                _ => {
                    err = Some(format!(
                        "contact: a force for node {} arrived at rank {me}, which does not own it (a face uses a node that is not a contact node)",
                        bk.key
                    ))
                }
            }
        }
        crate::collective::first_error(comm, err)?;
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
                pb.work,
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
