//! The baseline the paper argues against (§5, "the commonly used approach"): contact searched on
//! the static FE decomposition. For benchmarking only: `tdyn run --contact-decomposition static`
//! (`scripts/bench_contact.sh`); the scene format has no key for it (it changes how contact is
//! computed, not the answer).
//!
//! Each step:
//! 1. every rank bounds the region its FE-owned contact nodes can reach this step (the union of
//!    their search boxes: end position grown by the step's motion) and the P boxes are
//!    all-gathered;
//! 2. each face (on the FE rank of its element) goes to every other rank whose box its search
//!    box overlaps (the same search box, grown by the zone of influence, as the dynamic stage);
//! 3. each rank searches its FE-owned nodes against its own faces and the faces it received
//!    (the `contact` crate);
//! 4. the push-back is solved as the dynamic stage solves it (its step 7b, `cells`), with no
//!    cut tree: every cell and every node's home on rank 0 (the baseline is for comparing
//!    searches), and each rank keeps the forces on its FE-owned nodes (every face corner is a
//!    contact node, FE-owned by some rank).
//!
//! The contacts found are the same as the dynamic stage's (a node is searched by its FE owner,
//! once; a face reaches every rank that owns a node whose search box meets it). What differs is
//! who does the work: as bodies move, a rank's nodes spread and its box (and the faces it must
//! receive) grows, and the nodes + faces searched per rank follow the FE partition, not the
//! contact surfaces.
use crate::kernels::comm::CommPlan;
use crate::stages::contact::stage::{ContactOutcome, FullFace, Settled};
use contact::{
    face_records_search_aabb, search_candidates, Aabb, Candidates, Contact, FaceRecord, NodeRecord,
    SearchParams,
};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::collections::HashMap;
use std::rc::Rc;
use std::time::Instant;

/// Bytes of one rank's box in the all-gather (six f64).
const BOX_BYTES: u64 = 48;

/// The baseline contact stage of one run.
pub struct BaselineStage {
    comm: Rc<SimpleCommunicator>,
    /// Search parameters (the dynamic stage's).
    pub params: SearchParams,
    /// Coulomb's friction coefficient (the dynamic stage's).
    pub friction: f64,
}

impl BaselineStage {
    /// A stage over `comm` with the search parameters of the dynamic stage (collective).
    pub fn new(comm: &SimpleCommunicator, params: SearchParams) -> BaselineStage {
        BaselineStage {
            comm: Rc::new(comm.duplicate()),
            params,
            friction: 0.0,
        }
    }

    /// One detection and push-back (collective). `nodes`: this rank's FE-owned contact nodes;
    /// `faces`: the faces of this rank's elements with their nodes' records.
    pub fn step(
        &mut self,
        nodes: &[NodeRecord],
        faces: &[FullFace],
        dt: f64,
    ) -> Result<ContactOutcome, String> {
        let t0 = Instant::now();
        let comm = &self.comm;
        let p = comm.size() as usize;
        // 1. The zone of influence and every rank's box.
        let (motion, radius, boxes) = rank_boxes(comm, nodes);
        let mut bytes = BOX_BYTES * (p as u64 - 1);

        // 2. Faces to every other rank whose box their search box overlaps.
        let grown = (&self.params, radius, motion);
        let (received, ghost_bytes) = ghost_faces(comm, &boxes, faces, grown);

        // 3. The local search: owned nodes first, then copies of face nodes.
        let (recs, face_recs) = box_records(nodes, faces, &received);
        let n_owned = nodes.len();
        let work_items = (n_owned + face_recs.len()) as f64;
        let mut b =
            crate::stages::contact::stage::box_on_every_rank(comm, &recs, n_owned, &face_recs)?;
        let cands = Candidates::build(&b, &self.params, 0.0);
        let contacts = search_candidates(&b, &self.params, &cands);
        bytes += ghost_bytes;

        // 4. The push-back (the dynamic stage's step 7b, all on rank 0 here): two contacts
        // sharing nodes, found on different ranks (a touching pair found from both sides by
        // the two passes), are solved as one.
        let owned: Vec<u64> = nodes.iter().map(|r| r.gid).collect();
        use crate::stages::contact::stage::{solve_rechecked, Part};
        let mut parts = [Part {
            b: &mut b,
            cands: &cands,
            contacts,
        }];
        let settled = solve_rechecked(
            comm,
            None,
            &mut parts,
            &owned,
            dt,
            (self.friction, &self.params),
        )?;
        let [Part { contacts, .. }] = parts;
        let body_pairs = crate::stages::contact::stage::body_pairs(&b, &contacts);
        bytes += settled.bytes;
        Ok(outcome(
            comm,
            settled,
            (&contacts, body_pairs),
            (bytes, work_items),
            t0,
        ))
    }
}

/// Step 1: the largest motion and radius of the step's nodes over ranks, and every rank's box,
/// the region its nodes can reach this step (their end positions grown by their motion;
/// collective).
fn rank_boxes(comm: &SimpleCommunicator, nodes: &[NodeRecord]) -> (f64, f64, Vec<Aabb>) {
    let p = comm.size() as usize;
    let (mut motion, mut radius) = (0.0f64, 0.0f64);
    let mut mine = Aabb::EMPTY;
    for n in nodes {
        let d: f64 = (0..3)
            .map(|k| (n.x1[k] - n.x0[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        motion = motion.max(d);
        radius = radius.max(n.radius);
        let mut b = Aabb::EMPTY;
        b.include(n.x1);
        let b = b.grown(d);
        mine.include(b.min);
        mine.include(b.max);
    }
    let mut g = [0.0f64; 2];
    comm.all_reduce_into(&[motion, radius][..], &mut g[..], SystemOperation::max());
    let (motion, radius) = (g[0], g[1]);
    let mine_flat = [
        mine.min[0],
        mine.min[1],
        mine.min[2],
        mine.max[0],
        mine.max[1],
        mine.max[2],
    ];
    let mut all = vec![0.0f64; 6 * p];
    comm.all_gather_into(&mine_flat[..], &mut all[..]);
    let boxes: Vec<Aabb> = all
        .chunks(6)
        .map(|c| Aabb {
            min: [c[0], c[1], c[2]],
            max: [c[3], c[4], c[5]],
        })
        .collect();
    (motion, radius, boxes)
}

/// Step 2: each face to every other rank whose box its search box (with the largest radius,
/// grown by the largest motion) overlaps (collective). Returns the faces received and the
/// bytes sent.
fn ghost_faces(
    comm: &SimpleCommunicator,
    boxes: &[Aabb],
    faces: &[FullFace],
    (params, radius, motion): (&SearchParams, f64, f64),
) -> (Vec<FullFace>, u64) {
    let me = comm.rank() as usize;
    let mut dest = Vec::new();
    let mut ghost_of = Vec::new();
    for (i, f) in faces.iter().enumerate() {
        let bb = face_records_search_aabb(&f.nodes, params, radius).grown(motion);
        for (r, rb) in boxes.iter().enumerate() {
            if r != me && rb.overlaps(&bb) {
                dest.push(r as i32);
                ghost_of.push(i);
            }
        }
    }
    let mut plan = CommPlan::new(comm, &dest);
    let ghosts: Vec<FullFace> = ghost_of.iter().map(|&i| faces[i]).collect();
    let received = plan.exchange(&ghosts);
    (received, plan.bytes_sent)
}

/// Step 3's records: the owned nodes first, then the copies of the other face nodes (each
/// once, in the order the faces, own then received, name them), and the faces.
fn box_records(
    nodes: &[NodeRecord],
    faces: &[FullFace],
    received: &[FullFace],
) -> (Vec<NodeRecord>, Vec<FaceRecord>) {
    let mut recs: Vec<NodeRecord> = nodes.to_vec();
    let mut index: HashMap<u64, usize> = recs.iter().enumerate().map(|(i, r)| (r.gid, i)).collect();
    let mut face_recs = Vec::with_capacity(faces.len() + received.len());
    for f in faces.iter().chain(received) {
        for r in &f.nodes {
            index.entry(r.gid).or_insert_with(|| {
                recs.push(*r);
                recs.len() - 1
            });
        }
        face_recs.push(f.face);
    }
    (recs, face_recs)
}

/// The step's outcome with its statistics, as the dynamic stage reports them (collective):
/// `settled` the push-back, `contacts` and `body_pairs` what this rank found, `bytes` and
/// `work_items` this rank's, `t0` the step's start.
fn outcome(
    comm: &SimpleCommunicator,
    settled: Settled,
    (contacts, body_pairs): (&[Contact], Vec<(u32, u32)>),
    (bytes, work_items): (u64, f64),
    t0: Instant,
) -> ContactOutcome {
    let me = comm.rank() as usize;
    let p = comm.size() as usize;
    let (force, pb_work, mut pushback) = (settled.force, settled.work, settled.counts);
    let local_kinds = pushback.kinds;
    let mut sums = [0.0f64; 9];
    let k = local_kinds.map(|n| n as f64);
    comm.all_reduce_into(
        &[
            contacts.len() as f64,
            if me == 0 { pb_work } else { 0.0 },
            bytes as f64,
            work_items,
            k[0],
            k[1],
            k[2],
            k[3],
            pushback.bytes as f64,
        ][..],
        &mut sums[..],
        SystemOperation::sum(),
    );
    pushback.kinds = std::array::from_fn(|i| sums[4 + i] as u64);
    let mut maxes = [0.0f64; 4];
    comm.all_reduce_into(
        &[
            work_items,
            t0.elapsed().as_secs_f64(),
            pushback.bytes as f64,
            pushback.rows as f64,
        ][..],
        &mut maxes[..],
        SystemOperation::max(),
    );
    pushback.bytes = sums[8] as u64;
    pushback.bytes_max = maxes[2] as u64;
    pushback.rows = maxes[3] as u64;
    let mean = sums[3] / p as f64;
    ContactOutcome {
        // The baseline searches mesh nodes only: no particle is held.
        held: vec![false; force.len()],
        force,
        contacts: sums[0] as u64,
        found: contacts
            .iter()
            .map(|c| (c.node_gid, c.face_gid, c.depth))
            .collect(),
        body_pairs,
        // mesh nodes only
        particle_faces: Vec::new(),
        work: sums[1],
        imbalance: if mean > 0.0 { maxes[0] / mean } else { 1.0 },
        work_items_max: maxes[0],
        work_items_total: sums[3],
        bytes_sent: sums[2] as u64,
        rcb: Default::default(),
        wall_s: maxes[1],
        // the baseline searches where the nodes live: no transfer between
        // decompositions
        transfer: Default::default(),
        pushback,
    }
}
