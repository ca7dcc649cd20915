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
use crate::kernels::rcb::{CutTree, Rcb, RcbStats};
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

use crate::transfer::bodies_contact::{home_items, to_owners};
use crate::transfer::contact_bodies::send_home;
use crate::transfer::contact_fe::mesh_forces_home;
use crate::transfer::contact_sph::particle_forces_home;
pub use crate::transfer::fe_contact::FullFace;
use crate::transfer::fe_contact::{faces_to_owners, send_mesh_records};
use crate::transfer::sph_contact::particles_to_boxes;
use crate::transfer::{is_particle, CNode};

mod ghosts;
mod particles;
mod solve;
mod steps;
mod sticky;
use ghosts::*;
use particles::*;
pub(crate) use solve::*;
use sticky::*;

/// What one contact step found and cost.
#[derive(Clone, Debug, Default)]
pub struct ContactOutcome {
    /// Push-back force on each input node (aligned with the `nodes` given), N.
    pub force: Vec<[f64; 3]>,
    /// Each input node that is a particle held by immovable faces only in this step
    /// (`held_particles`; aligned with `force`, false for mesh nodes).
    pub held: Vec<bool>,
    /// Contacts found, over all ranks.
    pub contacts: u64,
    /// The contacts found on this rank: (node gid, face gid, depth).
    pub found: Vec<(u64, u64, f64)>,
    /// The pairs of different bodies (node's, face's) this rank's contacts touch, each once
    /// (`body_pairs`).
    pub body_pairs: Vec<(u32, u32)>,
    /// The particles (gid) this rank's contacts hold against faces, with the face's body
    /// (`particle_faces`).
    pub particle_faces: Vec<(u64, u32)>,
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

    /// Drops the kept decomposition, its ghost faces and candidate lists, so that the next
    /// step rebuilds them from the faces lent then (the faces changed: failed elements).
    /// Call on every rank alike.
    pub fn forget_decomposition(&mut self) {
        self.sticky = None;
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
    /// ghost skin since the last rebuild, or the node lists changed, or the faces did (failed
    /// elements: [`ContactStage::forget_decomposition`]); in between, each step sends
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
            held: p.held,
            pushback,
            contacts: sums[0] as u64,
            found: p
                .contacts
                .iter()
                .map(|c| (c.node_gid, c.face_gid, c.depth))
                .collect(),
            body_pairs: p.body_pairs,
            particle_faces: p.particle_faces,
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
    held: Vec<bool>,
    pushback: PushbackCounts,
    contacts: &'a [Contact],
    body_pairs: Vec<(u32, u32)>,
    particle_faces: Vec<(u64, u32)>,
    pb_work: f64,
    bytes: u64,
    work_items: f64,
    t_bytes: u64,
    t_s: f64,
    rcb: RcbStats,
    t0: Instant,
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
