//! The contact stage's moves of records between the decompositions: contact nodes to their
//! previous owners and particles to their boxes before a rebuild, faces to the boxes their
//! search boxes reach, and the push-back forces back to the nodes' homes (Fig. 10, steps 1-6
//! and 8).
use super::*;

/// Step 1 of a rebuild: the contact nodes' records (`items`) to their contact owners in the
/// previous step's cut tree (`tree`; none at the first step: they stay), so that the RCB that
/// follows starts near its answer (collective). Returns the records this rank now holds and
/// the bytes it sent.
pub(super) fn to_owners(
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

/// Step 8 for a kept box's mesh nodes: the nonzero forces of its owned nodes (`owned_force`)
/// back to their FE homes along the plan's own pairs of ranks (collective), summed there into
/// the input nodes' slots (`fe_inputs`: the input index of each mesh input, `n_inputs` in
/// all). Returns the forces on the inputs and the bytes sent.
pub(super) fn mesh_forces_home(
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

/// The contact nodes this rank hands in, each with its home (rank and index) and its index
/// among the mesh nodes (`u64::MAX` for a particle).
pub(super) fn home_items(nodes: &[NodeRecord], me: i32) -> Vec<CNode> {
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
pub(super) fn particles_to_boxes(
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

/// Steps 5-6 of Fig. 10: each face to every box its search box (grown by `skin`) overlaps
/// (collective). Returns the faces this rank holds, and the bytes it sent.
pub(super) fn ghost_faces(
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
pub(super) fn send_home(
    comm: &Rc<SimpleCommunicator>,
    owned_force: &[[f64; 3]],
    owned_home: &[(i32, u64)],
    (held, n_home): (&[bool], usize),
) -> (Vec<[f64; 3]>, Vec<bool>, u64) {
    let mut dest = Vec::new();
    let mut back = Vec::new();
    for (i, (f, &(home, idx))) in owned_force.iter().zip(owned_home).enumerate() {
        if f.iter().any(|c| *c != 0.0) {
            dest.push(home);
            // A particle held by immovable faces only (`held_particles`): the key's top bit.
            let flag = if held.get(i).copied().unwrap_or(false) {
                HELD_BIT
            } else {
                0
            };
            back.push(Back {
                key: idx | flag,
                f: *f,
            });
        }
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&back);
    let mut force = vec![[0.0; 3]; n_home];
    let mut held_home = vec![false; n_home];
    for bk in &got {
        let k = (bk.key & !HELD_BIT) as usize;
        held_home[k] |= bk.key & HELD_BIT != 0;
        let f = &mut force[k];
        for c in 0..3 {
            f[c] += bk.f[c];
        }
    }
    (force, held_home, plan.bytes_sent)
}

/// The top bit of a [`Back`] record's key: the node is a particle held by immovable faces only.
const HELD_BIT: u64 = 1 << 63;
