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
//! Steps 1-6 are not repeated every step: after a rebuild the stage keeps the decomposition, the
//! ghost faces (sent with a skin) and a plan that sends each node's record from its FE or SPH
//! owner straight to every box holding it, and each box keeps candidate lists (a Verlet list
//! per node, `contact::Candidates`); both stay valid while the nodes move less than the skins
//! allow (see [`ContactStage::step`] and [`GHOST_SKIN_STEPS`]), and every step then finds what a
//! rebuild would.
//!
//! Every contact is found in exactly one box (a node is owned by one rank), so nothing is counted
//! twice. The push-back (step 7b, `cells`) is solved where the contacts are: each contact goes to
//! the rank owning its cell, and ranks exchange only the nodes their cells share; its
//! Gauss-Seidel order is fixed by the cells, not the ranks, so the forces do not depend on where
//! the cuts fall (`contact::pushback`, "Sweeps in cells"); each rank keeps those of its contact
//! nodes.
//!
//! The search is two-pass by default (`[contact] passes = 2`: every pair of bodies both ways), so
//! a touching pair of surfaces is usually found from both sides, a node of each in a face of the
//! other, often in different boxes. Solved box by box, each box would remove the whole
//! penetration and the pair would be pushed apart twice (why the stage once searched one pass,
//! the later body's nodes against the earlier body's faces: the answer then depended on the order
//! of the bodies in the mesh, a ball meshed before its plate sank 2 mm into it). In the one
//! solve of step 7b the two descriptions of one gap are two rows of one system on the same
//! nodes, which share the impulse (`contact::push_back`); in cells, the two rows share nodes, so
//! they are in one cell or in cells of different colours, and are solved in turn either way.
use crate::kernels::comm::CommPlan;
use crate::kernels::rcb::{CutTree, Rcb, RcbItem, RcbStats};
use bytemuck::{Pod, Zeroable};
use contact::{
    face_records_search_aabb, search_candidates, within_skin, Candidates, Contact, ContactBox,
    FaceRecord, NodeRecord, SearchParams,
};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use rustc_hash::FxHashMap as HashMap;
use std::rc::Rc;
use std::time::Instant;

/// Parametric tolerance of "the node projects inside the face" in runs: `|xi|, |eta| <= 1.02`.
/// A node over a ridge where two faces meet at an angle (a fold of a wall, seen from the side
/// the faces bend away from) projects just outside both faces; with a tolerance of round-off
/// size (the crate's default, 1e-6) it is missed there, sinks past the capture tolerance in
/// a few steps and is then never found again (it started the step behind the face). Measured
/// on `tube_crush` (nodes on the folds' creases, which lie on the opposite wall's face seams):
/// 0.32 mm (a third of the wall) inside the wall at 1e-6, 1e-9 m at 0.02. A node near a seam
/// may then be found against both faces; the search keeps the deeper (both where their normals
/// differ by more than 25 degrees: `contact::search::SAME_NORMAL_COS`). Used for self-contact
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
    /// Position among the home's mesh (non-particle) nodes; `u64::MAX` for a particle.
    fe_idx: u64,
}

impl RcbItem for CNode {
    fn position(&self) -> [f64; 3] {
        self.rec.x1
    }
    fn id(&self) -> u64 {
        self.rec.gid
    }
}

pub use crate::transfer::fe_contact::FullFace;

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
    /// The push-back's solves and rechecks.
    pub pushback: PushbackCounts,
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

/// Most push-back solves in one step (see `solve_rechecked`). Measured on `rod_wall` (np 2,
/// 4,666 steps): the rechecks added 529 contacts in all, 0.62 solves per step on average over
/// all steps (none in steps without contact), and this limit was reached in some steps (what
/// the last solve leaves is the next step's, within its capture tolerance); `tube_crush` (np 1)
/// never needed a second solve.
pub const MAX_SOLVES: usize = 4;

/// One box's share of step 7b: the box, the candidate lists its search used, its contacts.
pub(crate) struct Part<'a> {
    pub b: &'a mut ContactBox,
    pub cands: &'a Candidates,
    pub contacts: Vec<Contact>,
}

/// What [`solve_rechecked`] returns: the forces on `owned`, the push-back's work, the bytes
/// this rank sent, the solves made and the contacts the rechecks added over all ranks (the
/// same on every rank).
pub(crate) struct Settled {
    pub force: Vec<[f64; 3]>,
    pub work: f64,
    pub bytes: u64,
    pub counts: PushbackCounts,
}

/// The push-back's counts in one step (the same on every rank).
#[derive(Clone, Copy, Debug, Default)]
pub struct PushbackCounts {
    /// Push-back solves (1 + the rounds after rechecks that found contacts).
    pub solves: u64,
    /// Contacts the rechecks added, over all ranks.
    pub rechecked: u64,
    /// Contacts (of the last solve) touching a node that another rank's cells touch (what
    /// the push-back exchanges between ranks after each colour).
    pub coupled: u64,
    /// Gauss-Seidel sweeps, all solves.
    pub sweeps: u64,
    /// Bytes the push-back sent: this rank's in `solve_rechecked`, over all ranks in the
    /// step's outcome.
    pub bytes: u64,
    /// The largest over ranks of the push-back's bytes (set in the step's outcome).
    pub bytes_max: u64,
    /// Contacts solved (all solves): this rank's in `solve_rechecked`, the largest over ranks
    /// in the step's outcome (the push-back's work on its busiest rank).
    pub rows: u64,
    /// Contacts of the applied solve none of whose nodes can move (skipped), over all ranks.
    pub immovable: u64,
    /// Contacts of the applied solve whose depth was bounded by the step's own penetration.
    pub bounded: u64,
    /// Contacts by kind, over all ranks: a node of a later body in a face of an earlier
    /// one (bodies numbered by their lowest element id), of an earlier body in a later one's,
    /// within one body (self-contact), a particle.
    pub kinds: [u64; 4],
}

/// [`PushbackCounts::kinds`] of `contacts` found in `b` (this rank's).
pub(crate) fn kinds(b: &ContactBox, contacts: &[Contact]) -> [u64; 4] {
    let mut k = [0u64; 4];
    for c in contacts {
        let (j, f) = (c.node as usize, c.face as usize);
        let i = if b.nodes.particle[j] {
            3
        } else {
            match b.nodes.body[j].cmp(&b.faces.body[f]) {
                std::cmp::Ordering::Greater => 0,
                std::cmp::Ordering::Less => 1,
                std::cmp::Ordering::Equal => 2,
            }
        };
        k[i] += 1;
    }
    k
}

/// Step 7b with its rechecks: the push-back of every contact, solved in cells where the
/// contacts are (`cells::solve_in_cells`); then each box tests its nodes again on the corrected
/// positions (`contact::recheck`: the crossings the corrections made, a node pushed out of one
/// face of a crease into the next), and while any box finds new contacts the push-back is solved
/// again with them added (at most [`MAX_SOLVES`] solves; what the last one leaves is found by
/// the next step's search, within its capture tolerance). The new contacts join `parts`' lists.
/// Every rank takes part in each solve; the rounds end on every rank together (a sum over ranks
/// of the new contacts). The contacts and forces do not depend on the cuts: the solve's answer
/// does not (`contact::pushback`, "Sweeps in cells"), and each node's rechecks see the same
/// corrected positions wherever the node is held. `tree`: the contact decomposition's cuts
/// (where cells and nodes' homes are; `None`: all on rank 0).
pub(crate) fn solve_rechecked(
    comm: &Rc<SimpleCommunicator>,
    tree: Option<&CutTree>,
    parts: &mut [Part],
    owned: &[u64],
    dt: f64,
    (friction, params): (f64, &SearchParams),
) -> Result<Settled, String> {
    let mut counts = PushbackCounts::default();
    let boxes: Vec<&ContactBox> = parts.iter().map(|p| &*p.b).collect();
    let mut holders = super::cells::Holders::new(comm, tree, &boxes);
    drop(boxes);
    let mut bytes = holders.bytes();
    loop {
        let views: Vec<(&ContactBox, &[Contact])> =
            parts.iter().map(|p| (&*p.b, &p.contacts[..])).collect();
        let super::cells::Solved {
            all,
            work,
            sent,
            total,
            coupled,
            sweeps,
            rows,
            immovable,
            bounded,
        } = super::cells::solve_in_cells(comm, tree, &views, &mut holders, dt, friction)?;
        counts.immovable = immovable;
        counts.bounded = bounded;
        bytes += sent;
        counts.solves += u64::from(total > 0);
        counts.coupled = coupled;
        counts.sweeps += sweeps;
        counts.rows += rows;
        counts.bytes = bytes;
        // This rank's contacts by kind (the outcome sums them over ranks).
        counts.kinds = [0; 4];
        for p in parts.iter() {
            for (t, k) in counts.kinds.iter_mut().zip(kinds(p.b, &p.contacts)) {
                *t += k;
            }
        }
        let done = Settled {
            force: owned
                .iter()
                .map(|g| all.get(g).copied().unwrap_or([0.0; 3]))
                .collect(),
            work,
            bytes,
            counts,
        };
        if total == 0 || counts.solves >= MAX_SOLVES as u64 {
            return Ok(done);
        }
        let mut added = 0u64;
        for p in parts.iter_mut() {
            let n = &p.b.nodes;
            let dx: Vec<[f64; 3]> = (0..n.len())
                .map(|j| match all.get(&n.gid[j]) {
                    Some(f) if n.mass[j].is_finite() => {
                        let s = dt * dt / n.mass[j];
                        [f[0] * s, f[1] * s, f[2] * s]
                    }
                    _ => [0.0; 3],
                })
                .collect();
            let new = contact::recheck(p.b, params, p.cands, &dx, &p.contacts);
            added += new.len() as u64;
            p.contacts.extend(new);
            // The search's order: by node gid (stable: a node's first contacts stay first).
            p.contacts.sort_by_key(|c| c.node_gid);
        }
        let mut total = 0u64;
        comm.all_reduce_into(&added, &mut total, SystemOperation::sum());
        if total == 0 {
            return Ok(done);
        }
        counts.rechecked += total;
    }
}

/// Ghost skin as a multiple of the step's largest node motion `m`: the decomposition, the
/// ghost faces and the record plan are kept while `(2 + 2 tau) D + (3 + 2 tau) m` stays under
/// the skin (`D`: the largest node displacement since the build; see `contact::Candidates`,
/// whose bound is the same for a rank's region as for a node's box): at constant speed a
/// rebuild about every 90 steps. Capped at [`GHOST_SKIN_FACES`] mean face diameters (fast
/// bodies: the ghost layer would otherwise grow past a face and bring every face of the
/// neighbouring boxes), and never under [`MIN_SKIN_STEPS`] motions.
pub const GHOST_SKIN_STEPS: f64 = 200.0;
/// See [`GHOST_SKIN_STEPS`].
pub const GHOST_SKIN_FACES: f64 = 2.0;
/// Skin of each box's candidate lists, as a multiple of the step's largest motion: a list is
/// rebuilt (on its rank alone, no communication) about every 13 steps at constant speed. Capped
/// at [`CANDIDATE_SKIN_FACES`] mean face diameters (more candidates per node cost more per
/// step than the rebuilds they save), never under [`MIN_SKIN_STEPS`] motions nor over the ghost
/// skin. Measured on `container_crush` (np 2, the first 1.2 ms): contact share 0.20 with skins of
/// (30, 12) motions, 0.13 with (200, 30); on `bricks` (0.036 elements per step) larger ghost
/// skins than 20 motions only added ghost faces.
pub const CANDIDATE_SKIN_STEPS: f64 = 30.0;
/// See [`CANDIDATE_SKIN_STEPS`].
pub const CANDIDATE_SKIN_FACES: f64 = 0.25;
/// A kept decomposition is rebuilt (and so rebalanced) when the contact work's imbalance
/// (max/mean over ranks) has grown this much over its value at the rebuild.
pub const IMBALANCE_DRIFT: f64 = 0.05;

/// The smallest skin, in step motions: under `3 + 2 tau` a kept decomposition would be
/// refused at the very next step.
pub const MIN_SKIN_STEPS: f64 = 12.0;

/// The ghost and candidate skins for a step of largest motion `motion` over faces of mean
/// diameter `face`, with the multiples `k` (ghost, candidates) of the motion.
fn skins(motion: f64, face: f64, k: (f64, f64)) -> (f64, f64) {
    let floor = MIN_SKIN_STEPS * motion;
    let ghost = (k.0 * motion).min(GHOST_SKIN_FACES * face).max(floor);
    let cand = (k.1 * motion)
        .min(CANDIDATE_SKIN_FACES * face)
        .max(floor)
        .min(ghost);
    (ghost, cand)
}

/// What the stage keeps between rebuilds of its decomposition ("sticky" steps, see
/// [`ContactStage::step`]).
struct Sticky {
    /// The contact node gids given at the build, in that order (another list forces a rebuild).
    gids: Vec<u64>,
    /// Their predicted end positions at the build.
    x_ref: Vec<[f64; 3]>,
    /// The ghost skin the faces were sent with, m.
    skin: f64,
    /// Mean face diameter at the build, m.
    face_size: f64,
    /// The largest contact radius at the build (the faces' search boxes hold it).
    max_radius: f64,
    /// Records go from the FE and SPH owners straight to every box holding a copy:
    /// `send_idx[k]` is the input node sent as the plan's item k.
    send_idx: Vec<u32>,
    /// The records in plan order (kept to reuse its memory).
    send_buf: Vec<NodeRecord>,
    plan: CommPlan,
    /// Box slot of each record received through `plan`, in arrival order.
    recv_slot: Vec<u32>,
    /// This rank's box (owned nodes first), positions updated in place each step.
    b: ContactBox,
    /// Home rank and index of each owned node (where its force goes).
    owned_home: Vec<(i32, u64)>,
    /// For each rank, its position among `plan`'s sources (`u32::MAX`: not a source).
    source_of_home: Vec<u32>,
    /// The box's candidate lists.
    cands: Candidates,
    /// The particles' box of the last step (their gids, the box, its candidate lists).
    pbox: Option<(Vec<u64>, ContactBox, Candidates)>,
    /// Owned nodes + faces held.
    work_items: f64,
    /// The contact work's imbalance at the rebuild.
    imbalance: f64,
}

/// A request for a node's record: "send input node `idx` to rank `to`" (to the node's home), or
/// "who holds `gid`? send it to `to`" (to its contact owner, who forwards it to the home).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Ask {
    key: u64,
    to: u64,
}

/// Counts of the stage's rebuilds.
#[derive(Clone, Copy, Debug, Default)]
pub struct RebuildStats {
    /// Steps that rebuilt the decomposition (RCB, faces, ghosts, plans).
    pub decomposition: u64,
    /// Candidate-list rebuilds, summed over ranks.
    pub candidates: u64,
}

/// The contact stage of one run.
pub struct ContactStage {
    /// The stage's communicator, shared by its plans.
    comm: Rc<SimpleCommunicator>,
    rcb: Rcb,
    tree: Option<CutTree>,
    /// Search parameters (`self_contact` from the scene).
    pub params: SearchParams,
    /// Keep the decomposition between steps while the skin allows (off: `TDYN_CONTACT_STICKY=0`,
    /// every step rebuilds; the results are the same, which a test checks).
    sticky_enabled: bool,
    /// Steps so far, steps the current kept decomposition served, and the back-off of set-ups
    /// that never served (see [`ContactStage::step`]).
    step_count: u64,
    kept_steps: u64,
    backoff: u64,
    retry_at: u64,
    sticky: Option<Box<Sticky>>,
    /// The skins, as multiples of the step's largest motion: ghosts and candidate lists
    /// ([`GHOST_SKIN_STEPS`], [`CANDIDATE_SKIN_STEPS`]; `TDYN_CONTACT_SKINS=G,C` for tuning).
    skins: (f64, f64),
    /// Rebuilds so far.
    pub rebuilds: RebuildStats,
    /// The contact work's imbalance at the last step.
    last_imbalance: f64,
    /// Coulomb's friction coefficient of every contact pair (`[contact] friction`).
    pub friction: f64,
}

impl ContactStage {
    /// Chooses whether the decomposition and candidate lists are kept between steps (`kept`,
    /// default true; false rebuilds every step) and the skins as multiples of the step's largest
    /// motion (`skins`: ghosts, candidates; `None` keeps [`GHOST_SKIN_STEPS`],
    /// [`CANDIDATE_SKIN_STEPS`]). Call before the first step, with the same values on every rank.
    pub fn configure(&mut self, kept: bool, skins: Option<(f64, f64)>) {
        self.sticky_enabled = kept;
        if let Some(s) = skins {
            self.skins = s;
        }
    }

    /// A stage over `comm` (collective): pairs within one body too with `self_contact`, one
    /// pass between master bodies and the others with `one_pass` (see `contact::SearchParams`).
    pub fn new(comm: &SimpleCommunicator, self_contact: bool, one_pass: bool) -> ContactStage {
        ContactStage {
            comm: Rc::new(comm.duplicate()),
            rcb: Rcb::new(comm),
            tree: None,
            params: SearchParams {
                self_contact,
                one_pass,
                self_param_tol: MESH_PARAM_TOL,
                ..SearchParams::default()
            },
            sticky_enabled: true,
            step_count: 0,
            kept_steps: 0,
            backoff: 0,
            retry_at: 0,
            sticky: None,
            skins: (GHOST_SKIN_STEPS, CANDIDATE_SKIN_STEPS),
            rebuilds: RebuildStats::default(),
            last_imbalance: 1.0,
            friction: 0.0,
        }
    }

    /// The contact decomposition's cut tree after the last step.
    pub fn tree(&self) -> Option<&CutTree> {
        self.tree.as_ref()
    }

    /// One detection and push-back (collective). `nodes`: the contact nodes this rank owns in
    /// the FE or SPH decomposition (start and predicted end positions, predicted velocity);
    /// `faces`: the faces this rank is responsible for, each with its nodes' records (called only
    /// when the decomposition is rebuilt). Returns the push-back force on each of `nodes` over
    /// the step `dt`.
    ///
    /// The decomposition (steps 1-6) is rebuilt only when the nodes have moved too far for the
    /// ghost skin since the last rebuild, or the node lists changed; in between, each step sends
    /// the nodes' records along the plan of the last rebuild straight into the boxes and
    /// searches there (step 7, with candidate lists), then 7b and 8 as always. The contacts and
    /// forces are those of a rebuild at every step: every node a face can reach in the step is
    /// still in a box holding that face (the skin's bound).
    pub fn step(
        &mut self,
        nodes: &[NodeRecord],
        faces: impl FnOnce() -> Vec<FullFace>,
        dt: f64,
    ) -> Result<ContactOutcome, String> {
        let t0 = Instant::now();
        // The step's largest motion and radius, and how far the nodes moved since the build.
        let (mut motion, mut radius, mut moved) = (0.0f64, 0.0f64, 0.0f64);
        for r in nodes {
            motion = motion.max(dist(&r.x1, &r.x0));
            radius = radius.max(r.radius);
        }
        // The mesh nodes must be the same, in the same order (particles may come and go: they
        // are sent each step to the box their position falls in).
        let n_particles = nodes.iter().filter(|r| is_particle(r)).count();
        let same = match &self.sticky {
            Some(st) if st.gids.len() + n_particles == nodes.len() => {
                let mut same = true;
                for (k, r) in nodes.iter().filter(|r| !is_particle(r)).enumerate() {
                    same &= st.gids[k] == r.gid;
                    moved = moved.max(dist(&r.x1, &st.x_ref[k]));
                }
                same
            }
            _ => false,
        };
        let mut g = [0.0f64; 5];
        self.comm.all_reduce_into(
            &[
                motion,
                radius,
                moved,
                if same { 0.0 } else { 1.0 },
                n_particles as f64,
            ][..],
            &mut g[..],
            SystemOperation::max(),
        );
        let (motion, radius, moved, changed) = (g[0], g[1], g[2], g[3] > 0.0);
        let any_particles = g[4] > 0.0;
        // Kept while the skin covers, and while the balance has not drifted (particles, owned
        // by where they are, can gather in one box) more than IMBALANCE_DRIFT over the
        // rebuild's own.
        let keep = match &self.sticky {
            Some(st) => {
                !changed
                    && radius <= st.max_radius
                    && within_skin(moved, motion, &self.params, st.skin)
                    && self.last_imbalance <= st.imbalance + IMBALANCE_DRIFT
            }
            None => false,
        };
        self.step_count += 1;
        if keep {
            self.kept_steps += 1;
            self.sticky_step(nodes, (motion, any_particles), dt, t0)
        } else {
            self.rebuilds.decomposition += 1;
            // A kept decomposition that never served because the node lists changed (SPH
            // particles moving between SPH ranks every step) cost its set-up for nothing: try
            // again after 1, 2, 4 ... 64 steps (the same on every rank: `changed` is global).
            if self.sticky.is_some() {
                if self.kept_steps == 0 && changed {
                    self.backoff = (2 * self.backoff).clamp(1, 64);
                    self.retry_at = self.step_count + self.backoff;
                } else {
                    self.backoff = 0;
                }
            }
            self.kept_steps = 0;
            self.full_step(nodes, faces(), (motion, radius), dt, t0)
        }
    }

    /// A step on the kept decomposition (see [`ContactStage::step`]).
    fn sticky_step(
        &mut self,
        nodes: &[NodeRecord],
        (motion, any_particles): (f64, bool),
        dt: f64,
        t0: Instant,
    ) -> Result<ContactOutcome, String> {
        let comm = &self.comm;
        let me = comm.rank();
        let st = self.sticky.as_mut().expect("a kept decomposition");
        let tree = self
            .tree
            .as_ref()
            .expect("the cut tree of the last rebuild");
        let mut bytes = 0u64;
        let (mut t_bytes, mut t_s) = (0u64, 0.0f64);
        // 1 (and 3, 5-6). The mesh nodes' records straight to the boxes holding them, written
        // in place.
        let tt = Instant::now();
        let fe_inputs: Vec<u32> = (0..nodes.len() as u32)
            .filter(|&i| !is_particle(&nodes[i as usize]))
            .collect();
        st.send_buf.clear();
        st.send_buf.extend(
            st.send_idx
                .iter()
                .map(|&k| nodes[fe_inputs[k as usize] as usize]),
        );
        let before = st.plan.bytes_sent;
        let got = st.plan.exchange(&st.send_buf);
        let sent = st.plan.bytes_sent - before;
        bytes += sent;
        t_bytes += sent;
        let n = &mut st.b.nodes;
        for (r, &slot) in got.iter().zip(&st.recv_slot) {
            n.set_motion(slot as usize, r);
        }
        // Particles (never face corners) to the box their predicted position falls in: the
        // ghost skin's bound holds for a node inside its box's region.
        let (pitems, pplan, pgot) = if any_particles {
            let (items, plan, got) = particles_to_boxes(comm, tree, nodes, me);
            bytes += plan.bytes_sent;
            t_bytes += plan.bytes_sent;
            (items, Some(plan), got)
        } else {
            (Vec::new(), None, Vec::new())
        };
        t_s += tt.elapsed().as_secs_f64();
        // 7. The search over the candidate lists, rebuilt here when the skin no longer covers.
        if !st.cands.still_valid(&st.b, &self.params) {
            let (_, cand_skin) = skins(motion, st.face_size, self.skins);
            st.cands = Candidates::build(&st.b, &self.params, cand_skin);
            self.rebuilds.candidates += 1;
        }
        let contacts = search_candidates(&st.b, &self.params, &st.cands);
        let n_owned = st.b.nodes.n_owned;
        let mut owned_gids: Vec<u64> = st.b.nodes.gid[..n_owned].to_vec();
        let (_, cand_skin) = skins(motion, st.face_size, self.skins);
        self.rebuilds.candidates += refresh_particle_box(st, &pgot, &self.params, cand_skin);
        let pcontacts = match &st.pbox {
            Some((_, pb, pc)) => {
                owned_gids.extend(pgot.iter().map(|c| c.rec.gid));
                search_candidates(pb, &self.params, pc)
            }
            None => Vec::new(),
        };
        let mut parts = vec![Part {
            b: &mut st.b,
            cands: &st.cands,
            contacts,
        }];
        if let Some((_, pb, pc)) = &mut st.pbox {
            parts.push(Part {
                b: pb,
                cands: pc,
                contacts: pcontacts,
            });
        }
        let settled = solve_rechecked(
            comm,
            Some(tree),
            &mut parts,
            &owned_gids,
            dt,
            (self.friction, &self.params),
        )?;
        let mut parts = parts.into_iter();
        let contacts = parts.next().map(|p| p.contacts).unwrap_or_default();
        let pcontacts = parts.next().map(|p| p.contacts).unwrap_or_default();
        let (owned_force, pb_work, pushback) = (settled.force, settled.work, settled.counts);
        bytes += settled.bytes;
        // 8. Forces back to the homes: the mesh nodes' nonzero ones along the plan's own pairs
        // of ranks, the particles' back along their plan.
        let tt = Instant::now();
        let (mut force, back_bytes) =
            mesh_forces_home(st, &owned_force[..n_owned], &fe_inputs, nodes.len());
        bytes += back_bytes;
        t_bytes += back_bytes;
        if let Some(mut plan) = pplan {
            let before = plan.bytes_sent;
            let back = plan.reverse(&owned_force[n_owned..]);
            for (item, f) in pitems.iter().zip(&back) {
                force[item.home_idx as usize] = *f;
            }
            bytes += plan.bytes_sent - before;
            t_bytes += plan.bytes_sent - before;
        }
        t_s += tt.elapsed().as_secs_f64();
        let work_items = st.work_items + pgot.len() as f64;
        let mut all_contacts = contacts;
        all_contacts.extend(pcontacts);
        self.outcome(OutcomeParts {
            pushback,
            force,
            contacts: &all_contacts,
            pb_work,
            bytes,
            work_items,
            t_bytes,
            t_s,
            rcb: RcbStats::default(),
            t0,
        })
    }

    /// A step that rebuilds the decomposition: the paper's Fig. 10 in full.
    fn full_step(
        &mut self,
        nodes: &[NodeRecord],
        faces: Vec<FullFace>,
        (motion, radius): (f64, f64),
        dt: f64,
        t0: Instant,
    ) -> Result<ContactOutcome, String> {
        // Set up a kept decomposition for the next steps?
        let keep_next = self.sticky_enabled && self.step_count >= self.retry_at;
        let me = self.comm.rank();
        let mut bytes = 0u64;
        let items = home_items(nodes, me);
        // The transfers between decompositions (steps 1, 3 and the last half of 8: FE and SPH
        // owners to contact owners and back): their bytes and time.
        let (mut t_bytes, mut t_s) = (0u64, 0.0f64);
        // 1. To last step's contact owners.
        let tt = Instant::now();
        let (items, sent) = to_owners(&self.comm, self.tree.as_ref(), items);
        bytes += sent;
        t_bytes += sent;
        t_s += tt.elapsed().as_secs_f64();
        // 2. RCB over nodes and particles, from the previous cuts.
        let (mine, rcb_stats) = self.rcb.balance(items).map_err(|e| e.to_string())?;
        bytes += rcb_stats.bytes_sent;
        let tree = self.rcb.tree().clone();
        let comm = &self.comm;
        // 3. Faces with their nodes to the contact owner of their first node.
        let tt = Instant::now();
        let dest: Vec<i32> = faces
            .iter()
            .map(|f| tree.owner_of_item(&f.nodes[0].x1, f.nodes[0].gid))
            .collect();
        let mut plan = CommPlan::new_shared(comm, &dest);
        let my_faces = plan.exchange(&faces);
        bytes += plan.bytes_sent;
        t_bytes += plan.bytes_sent;
        t_s += tt.elapsed().as_secs_f64();
        // 5-6. Ghost each face to every box its search box overlaps, grown by the zone of
        // influence: the largest node motion of the step and the largest particle radius (the
        // face's search box), and the skin the kept decomposition needs (at least the motion).
        let (skin, cand_skin, face_size) = if keep_next {
            let face = mean_face_diameter(comm, &my_faces);
            let (a, b) = skins(motion, face, self.skins);
            (a, b, face)
        } else {
            (motion, 0.0, 0.0)
        };
        let (held, ghost_bytes) = ghost_faces(comm, &tree, &my_faces, &self.params, radius, skin);
        bytes += ghost_bytes;

        // 7. The local search: owned nodes first, then copies of face nodes not owned here.
        let (recs, index, face_recs) = box_records(&mine, &held);
        let n_owned = mine.len();
        let work_items = (n_owned + face_recs.len()) as f64;
        let mut b = box_on_every_rank(comm, &recs, n_owned, &face_recs)?;
        let cands = Candidates::build(&b, &self.params, cand_skin);
        let contacts = search_candidates(&b, &self.params, &cands);

        // 7b. The push-back, solved in cells where the contacts are (`cells`): contacts that
        // share nodes but were found in different boxes (a touching pair found from both sides
        // by the two passes) are rows of one Gauss-Seidel whose order the cells fix, so the
        // forces are those of one box holding everything, at any rank count.
        let owned_gids: Vec<u64> = recs[..n_owned].iter().map(|r| r.gid).collect();
        let mut parts = [Part {
            b: &mut b,
            cands: &cands,
            contacts,
        }];
        let settled = solve_rechecked(
            comm,
            Some(&tree),
            &mut parts,
            &owned_gids,
            dt,
            (self.friction, &self.params),
        )?;
        let [Part { contacts, .. }] = parts;
        let (owned_force, pb_work, pushback) = (settled.force, settled.work, settled.counts);
        bytes += settled.bytes;
        let tt = Instant::now();
        let owned_home: Vec<(i32, u64)> =
            mine.iter().map(|n| (n.home as i32, n.home_idx)).collect();
        let (force, back_bytes) = send_home(comm, &owned_force, &owned_home, nodes.len());
        bytes += back_bytes;
        t_bytes += back_bytes;
        t_s += tt.elapsed().as_secs_f64();

        // The plan for the steps that keep this decomposition.
        self.sticky = None;
        if keep_next {
            let (st, setup_bytes) = build_sticky(
                comm,
                &tree,
                nodes,
                &mine,
                &index,
                SetupBox {
                    b: &b,
                    params: &self.params,
                    skin,
                    cand_skin,
                    face_size,
                    max_radius: radius,
                },
            )?;
            bytes += setup_bytes;
            self.sticky = st.map(Box::new);
        }
        self.tree = Some(tree);
        self.outcome(OutcomeParts {
            pushback,
            force,
            contacts: &contacts,
            pb_work,
            bytes,
            work_items,
            t_bytes,
            t_s,
            rcb: rcb_stats,
            t0,
        })
    }

    /// The step's statistics over all ranks (collective).
    fn outcome(&mut self, p: OutcomeParts) -> Result<ContactOutcome, String> {
        let comm = &self.comm;
        let me = comm.rank();
        let mut sums = [0.0f64; 10];
        let k = p.pushback.kinds.map(|n| n as f64);
        comm.all_reduce_into(
            &[
                p.contacts.len() as f64,
                if me == 0 { p.pb_work } else { 0.0 },
                p.bytes as f64,
                p.work_items,
                p.t_bytes as f64,
                k[0],
                k[1],
                k[2],
                k[3],
                p.pushback.bytes as f64,
            ][..],
            &mut sums[..],
            SystemOperation::sum(),
        );
        let mut pushback = p.pushback;
        pushback.kinds = std::array::from_fn(|i| sums[5 + i] as u64);
        pushback.bytes = sums[9] as u64;
        let mut maxes = [0.0f64; 6];
        comm.all_reduce_into(
            &[
                p.work_items,
                p.t0.elapsed().as_secs_f64(),
                p.t_bytes as f64,
                p.t_s,
                p.pushback.bytes as f64,
                p.pushback.rows as f64,
            ][..],
            &mut maxes[..],
            SystemOperation::max(),
        );
        pushback.bytes_max = maxes[4] as u64;
        pushback.rows = maxes[5] as u64;
        let t_mean = sums[4] / comm.size() as f64;
        let mean = sums[3] / comm.size() as f64;
        let imbalance = if mean > 0.0 { maxes[0] / mean } else { 1.0 };
        self.last_imbalance = imbalance;
        if let Some(st) = &mut self.sticky {
            if st.imbalance.is_infinite() {
                st.imbalance = imbalance;
            }
        }
        Ok(ContactOutcome {
            force: p.force,
            pushback,
            contacts: sums[0] as u64,
            found: p
                .contacts
                .iter()
                .map(|c| (c.node_gid, c.face_gid, c.depth))
                .collect(),
            work: sums[1],
            imbalance,
            work_items_max: maxes[0],
            work_items_total: sums[3],
            bytes_sent: sums[2] as u64,
            rcb: p.rcb,
            wall_s: maxes[1],
            transfer: TransferStats {
                bytes_sent: sums[4] as u64,
                imbalance: if t_mean > 0.0 { maxes[2] / t_mean } else { 1.0 },
                wall_s: maxes[3],
            },
        })
    }
}

/// What a step's statistics are made from.
struct OutcomeParts<'a> {
    force: Vec<[f64; 3]>,
    pushback: PushbackCounts,
    contacts: &'a [Contact],
    pb_work: f64,
    bytes: u64,
    work_items: f64,
    t_bytes: u64,
    t_s: f64,
    rcb: RcbStats,
    t0: Instant,
}

/// Step 1 of a rebuild: the contact nodes' records (`items`) to their contact owners in the
/// previous step's cut tree (`tree`; none at the first step: they stay), so that the RCB that
/// follows starts near its answer (collective). Returns the records this rank now holds and
/// the bytes it sent.
fn to_owners(
    comm: &Rc<SimpleCommunicator>,
    tree: Option<&CutTree>,
    items: Vec<CNode>,
) -> (Vec<CNode>, u64) {
    let Some(t) = tree else {
        return (items, 0);
    };
    let dest: Vec<i32> = items
        .iter()
        .map(|n| t.owner_of_item(&n.rec.x1, n.rec.gid))
        .collect();
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&items);
    (got, plan.bytes_sent)
}

/// A rebuilt box's records: the owned nodes (`mine`) first, then the corners of the faces it
/// holds (`held`, each face once) not owned here. Returns the node records, the slot of each
/// node gid, and the face records.
fn box_records(
    mine: &[CNode],
    held: &[FullFace],
) -> (Vec<NodeRecord>, HashMap<u64, usize>, Vec<FaceRecord>) {
    let mut recs: Vec<NodeRecord> = mine.iter().map(|n| n.rec).collect();
    let mut index: HashMap<u64, usize> = recs.iter().enumerate().map(|(i, r)| (r.gid, i)).collect();
    let mut face_recs = Vec::with_capacity(held.len());
    let mut seen_faces: HashMap<u64, ()> =
        HashMap::with_capacity_and_hasher(held.len(), Default::default());
    for f in held {
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
    (recs, index, face_recs)
}

/// The particles a kept box holds this step (`pgot`), searched against its faces in a box of
/// their own: the particles owned, every node of the kept box as copies, the same faces. The
/// same particles as at the last step, in the same order: that box is updated in place and its
/// candidate lists kept while their skin covers; others: a new box and lists (skin
/// `cand_skin`). Returns the candidate lists built.
fn refresh_particle_box(
    st: &mut Sticky,
    pgot: &[CNode],
    params: &SearchParams,
    cand_skin: f64,
) -> u64 {
    let same_particles = match &st.pbox {
        Some((gids, _, _)) => {
            gids.len() == pgot.len() && gids.iter().zip(pgot).all(|(g, c)| *g == c.rec.gid)
        }
        None => pgot.is_empty(),
    };
    if !same_particles {
        st.pbox = particle_box(&st.b, pgot).map(|pb| {
            let pc = Candidates::build(&pb, params, cand_skin);
            (pgot.iter().map(|c| c.rec.gid).collect(), pb, pc)
        });
        return u64::from(st.pbox.is_some());
    }
    let Some((_, pb, pc)) = &mut st.pbox else {
        return 0;
    };
    let np = pgot.len();
    let q = &mut pb.nodes;
    for (i, c) in pgot.iter().enumerate() {
        q.mass[i] = c.rec.mass;
        q.radius[i] = c.rec.radius;
        q.x0[i] = c.rec.x0;
        q.x1[i] = c.rec.x1;
        q.v[i] = c.rec.v;
    }
    let n = &st.b.nodes;
    q.mass[np..].copy_from_slice(&n.mass);
    q.radius[np..].copy_from_slice(&n.radius);
    q.x0[np..].copy_from_slice(&n.x0);
    q.x1[np..].copy_from_slice(&n.x1);
    q.v[np..].copy_from_slice(&n.v);
    if pc.still_valid(pb, params) {
        return 0;
    }
    *pc = Candidates::build(pb, params, cand_skin);
    1
}

/// Step 8 for a kept box's mesh nodes: the nonzero forces of its owned nodes (`owned_force`)
/// back to their FE homes along the plan's own pairs of ranks (collective), summed there into
/// the input nodes' slots (`fe_inputs`: the input index of each mesh input, `n_inputs` in
/// all). Returns the forces on the inputs and the bytes sent.
fn mesh_forces_home(
    st: &mut Sticky,
    owned_force: &[[f64; 3]],
    fe_inputs: &[u32],
    n_inputs: usize,
) -> (Vec<[f64; 3]>, u64) {
    let mut lists: Vec<Vec<Back>> = vec![Vec::new(); st.plan.sources().count()];
    for (f, &(home, idx)) in owned_force.iter().zip(&st.owned_home) {
        if f.iter().any(|c| *c != 0.0) {
            let k = st.source_of_home[home as usize];
            lists[k as usize].push(Back { key: idx, f: *f });
        }
    }
    let before = st.plan.bytes_sent;
    let got = st.plan.reverse_lists(&lists);
    let back_bytes = st.plan.bytes_sent - before;
    let mut force = vec![[0.0; 3]; n_inputs];
    for bk in &got {
        let f = &mut force[fe_inputs[bk.key as usize] as usize];
        for k in 0..3 {
            f[k] += bk.f[k];
        }
    }
    (force, back_bytes)
}

/// The box a rebuild made, for [`build_sticky`].
struct SetupBox<'a> {
    b: &'a ContactBox,
    params: &'a SearchParams,
    skin: f64,
    cand_skin: f64,
    face_size: f64,
    max_radius: f64,
}

/// `ContactBox::from_records` on every rank (collective): a rank's error (a face corner missing,
/// a node twice) stops every rank with that rank's message.
pub(crate) fn box_on_every_rank(
    comm: &SimpleCommunicator,
    nodes: &[NodeRecord],
    n_owned: usize,
    faces: &[FaceRecord],
) -> Result<ContactBox, String> {
    let b = ContactBox::from_records(nodes, n_owned, faces);
    crate::kernels::collective::first_error(comm, b.as_ref().err().map(|e| e.to_string()))?;
    Ok(b.expect("checked on every rank"))
}

fn is_particle(r: &NodeRecord) -> bool {
    r.flags & contact::FLAG_PARTICLE != 0
}

/// The box in which a kept decomposition searches the particles it holds this step: the
/// particles owned, then every node of the kept box `b` as a copy, and `b`'s faces. `None`
/// without particles.
fn particle_box(b: &ContactBox, particles: &[CNode]) -> Option<ContactBox> {
    if particles.is_empty() {
        return None;
    }
    let mut pb = ContactBox::default();
    for c in particles {
        pb.nodes.push(&c.rec);
    }
    let np = particles.len();
    pb.nodes.n_owned = np;
    let n = &b.nodes;
    let q = &mut pb.nodes;
    q.gid.extend_from_slice(&n.gid);
    q.body.extend_from_slice(&n.body);
    q.mass.extend_from_slice(&n.mass);
    q.radius.extend_from_slice(&n.radius);
    q.particle.extend_from_slice(&n.particle);
    q.master.extend_from_slice(&n.master);
    q.x0.extend_from_slice(&n.x0);
    q.x1.extend_from_slice(&n.x1);
    q.v.extend_from_slice(&n.v);
    pb.faces.gid = b.faces.gid.clone();
    pb.faces.node_gid = b.faces.node_gid.clone();
    pb.faces.body = b.faces.body.clone();
    pb.faces.nodes = b
        .faces
        .nodes
        .iter()
        .map(|c| c.map(|i| i + np as u32))
        .collect();
    Some(pb)
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The contact nodes this rank hands in, each with its home (rank and index) and its index
/// among the mesh nodes (`u64::MAX` for a particle).
fn home_items(nodes: &[NodeRecord], me: i32) -> Vec<CNode> {
    let mut n_fe = 0u64;
    nodes
        .iter()
        .enumerate()
        .map(|(i, r)| CNode {
            rec: *r,
            home: me as u64,
            home_idx: i as u64,
            fe_idx: if is_particle(r) {
                u64::MAX
            } else {
                n_fe += 1;
                n_fe - 1
            },
        })
        .collect()
}

/// Particles (never face corners) to the box their predicted position falls in (collective):
/// the records sent, the plan (for the forces' way back), the records this rank received.
fn particles_to_boxes(
    comm: &Rc<SimpleCommunicator>,
    tree: &CutTree,
    nodes: &[NodeRecord],
    me: i32,
) -> (Vec<CNode>, CommPlan, Vec<CNode>) {
    let mut dest = Vec::new();
    let mut items = Vec::new();
    for (i, r) in nodes.iter().enumerate().filter(|(_, r)| is_particle(r)) {
        dest.push(tree.owner_of_item(&r.x1, r.gid));
        items.push(CNode {
            rec: *r,
            home: me as u64,
            home_idx: i as u64,
            fe_idx: u64::MAX,
        });
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&items);
    (items, plan, got)
}

/// The mean diameter of the faces over all ranks (collective): it caps the skins.
fn mean_face_diameter(comm: &Rc<SimpleCommunicator>, faces: &[FullFace]) -> f64 {
    let mut sum = [0.0f64; 2];
    for f in faces {
        let x: [[f64; 3]; 4] = std::array::from_fn(|k| f.nodes[k].x1);
        sum[0] += dist(&x[0], &x[2]).max(dist(&x[1], &x[3]));
        sum[1] += 1.0;
    }
    let mut g = [0.0f64; 2];
    comm.all_reduce_into(&sum[..], &mut g[..], SystemOperation::sum());
    if g[1] > 0.0 {
        g[0] / g[1]
    } else {
        0.0
    }
}

/// Steps 5-6 of Fig. 10: each face to every box its search box (grown by `skin`) overlaps
/// (collective). Returns the faces this rank holds, and the bytes it sent.
fn ghost_faces(
    comm: &Rc<SimpleCommunicator>,
    tree: &CutTree,
    faces: &[FullFace],
    params: &SearchParams,
    radius: f64,
    skin: f64,
) -> (Vec<FullFace>, u64) {
    let mut dest = Vec::new();
    let mut ghosts = Vec::new();
    let mut ranks = Vec::new();
    for f in faces {
        let bb = face_records_search_aabb(&f.nodes, params, radius).grown(skin);
        ranks.clear();
        tree.ranks_overlapping(&bb.min, &bb.max, &mut ranks);
        for &r in &ranks {
            dest.push(r);
            ghosts.push(*f);
        }
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let held = plan.exchange(&ghosts);
    (held, plan.bytes_sent)
}

/// Step 8: each owned node's nonzero force to its home; returns the force on each of the
/// home's `n_home` input nodes and the bytes sent (collective).
fn send_home(
    comm: &Rc<SimpleCommunicator>,
    owned_force: &[[f64; 3]],
    owned_home: &[(i32, u64)],
    n_home: usize,
) -> (Vec<[f64; 3]>, u64) {
    let mut dest = Vec::new();
    let mut back = Vec::new();
    for (f, &(home, idx)) in owned_force.iter().zip(owned_home) {
        if f.iter().any(|c| *c != 0.0) {
            dest.push(home);
            back.push(Back { key: idx, f: *f });
        }
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&back);
    let mut force = vec![[0.0; 3]; n_home];
    for bk in &got {
        let f = &mut force[bk.key as usize];
        for k in 0..3 {
            f[k] += bk.f[k];
        }
    }
    (force, plan.bytes_sent)
}

/// After a rebuild: the kept box (the rebuild's box without its particles) and the plan that
/// sends each mesh node's record straight to every box holding it (its contact owner and the
/// boxes holding a face it is a corner of), so that the next steps skip steps 1-6 (collective).
/// Requests for owned nodes go to their homes; requests for a face's corner copy go to the
/// corner's contact owner (the cut tree's owner of its position), which forwards them to the
/// home. Nodes are named by their position among the home's mesh nodes (`CNode::fe_idx`), which
/// particles coming and going do not change. `None` (on every rank) if a request finds no owner,
/// which keeps rebuilding.
fn build_sticky(
    comm: &Rc<SimpleCommunicator>,
    tree: &CutTree,
    nodes: &[NodeRecord],
    mine: &[CNode],
    index: &HashMap<u64, usize>,
    sb: SetupBox,
) -> Result<(Option<Sticky>, u64), String> {
    let me = comm.rank() as u64;
    let mut bytes = 0u64;
    let full = sb.b;
    let n_owned = full.nodes.n_owned;
    // The kept box: the owned mesh nodes, then the corner copies (never particles), the faces.
    let owned_fe: Vec<&CNode> = mine.iter().filter(|n| !is_particle(&n.rec)).collect();
    let mut recs: Vec<NodeRecord> = owned_fe.iter().map(|n| n.rec).collect();
    let n_fe_owned = recs.len();
    recs.extend((n_owned..full.nodes.len()).map(|i| full.nodes.record(i)));
    let face_recs: Vec<FaceRecord> = (0..full.faces.len())
        .map(|f| full.faces.record(f))
        .collect();
    let b = box_on_every_rank(comm, &recs, n_fe_owned, &face_recs)?;
    let slot_of: HashMap<u64, usize> = recs.iter().enumerate().map(|(i, r)| (r.gid, i)).collect();
    // Corner copies: ask their contact owners.
    let mut dest = Vec::new();
    let mut asks = Vec::new();
    for i in n_owned..full.nodes.len() {
        let gid = full.nodes.gid[i];
        dest.push(tree.owner_of_item(&full.nodes.x1[i], gid));
        asks.push(Ask { key: gid, to: me });
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&asks);
    bytes += plan.bytes_sent;
    let mut ok = true;
    // Requests to the homes: this rank's owned mesh nodes, and the forwarded corner requests.
    let mut dest = Vec::new();
    let mut reqs = Vec::new();
    for n in &owned_fe {
        dest.push(n.home as i32);
        reqs.push(Ask {
            key: n.fe_idx,
            to: me,
        });
    }
    for a in &got {
        match index.get(&a.key) {
            Some(&i) if i < n_owned && !is_particle(&mine[i].rec) => {
                dest.push(mine[i].home as i32);
                reqs.push(Ask {
                    key: mine[i].fe_idx,
                    to: a.to,
                });
            }
            _ => ok = false,
        }
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let mut got = plan.exchange(&reqs);
    bytes += plan.bytes_sent;
    // The home's plan: by destination, mesh-node order inside each.
    got.sort_unstable_by_key(|a| (a.to, a.key));
    let fe_inputs: Vec<usize> = (0..nodes.len())
        .filter(|&i| !is_particle(&nodes[i]))
        .collect();
    ok &= got.iter().all(|a| (a.key as usize) < fe_inputs.len());
    let send_idx: Vec<u32> = got.iter().map(|a| a.key as u32).collect();
    let dest: Vec<i32> = got.iter().map(|a| a.to as i32).collect();
    let mut plan = CommPlan::new_shared(comm, &dest);
    let send: Vec<NodeRecord> = send_idx
        .iter()
        .map(|&k| nodes[fe_inputs.get(k as usize).copied().unwrap_or(0)])
        .collect();
    let arrived = plan.exchange(&send);
    bytes += plan.bytes_sent;
    // Where each arriving record goes in the box: every slot exactly once.
    let mut filled = vec![false; b.nodes.len()];
    let mut recv_slot = Vec::with_capacity(arrived.len());
    for r in &arrived {
        match slot_of.get(&r.gid) {
            Some(&i) if !filled[i] => {
                filled[i] = true;
                recv_slot.push(i as u32);
            }
            _ => ok = false,
        }
    }
    ok &= filled.iter().all(|f| *f);
    let mut all_ok = 0i32;
    comm.all_reduce_into(&(ok as i32), &mut all_ok, SystemOperation::min());
    if all_ok == 0 {
        return Ok((None, bytes));
    }
    let mut source_of_home = vec![u32::MAX; comm.size() as usize];
    for (k, (r, _)) in plan.sources().enumerate() {
        source_of_home[r as usize] = k as u32;
    }
    let cands = Candidates::build(&b, sb.params, sb.cand_skin);
    let work_items = (n_fe_owned + b.faces.len()) as f64;
    let st = Sticky {
        source_of_home,
        gids: fe_inputs.iter().map(|&i| nodes[i].gid).collect(),
        x_ref: fe_inputs.iter().map(|&i| nodes[i].x1).collect(),
        skin: sb.skin,
        face_size: sb.face_size,
        max_radius: sb.max_radius,
        send_idx,
        send_buf: Vec::new(),
        plan,
        recv_slot,
        b,
        owned_home: owned_fe.iter().map(|n| (n.home as i32, n.fe_idx)).collect(),
        cands,
        pbox: None,
        work_items,
        imbalance: f64::INFINITY,
    };
    Ok((Some(st), bytes))
}
