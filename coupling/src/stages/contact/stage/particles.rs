//! The particles a kept contact decomposition holds in a step: their own box beside the kept
//! mesh box, refreshed in place while they stay.
use super::*;

/// The particles a kept box holds this step (`pgot`), searched against its faces in a box of
/// their own: the particles owned, every node of the kept box as copies, the same faces. The
/// same particles as at the last step, in the same order: that box is updated in place and its
/// candidate lists kept while their skin covers; others: a new box and lists (skin
/// `cand_skin`). Returns the candidate lists built.
pub(super) fn refresh_particle_box(
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

/// The box in which a kept decomposition searches the particles it holds this step: the
/// particles owned, then every node of the kept box `b` as a copy, and `b`'s faces. `None`
/// without particles.
pub(super) fn particle_box(b: &ContactBox, particles: &[CNode]) -> Option<ContactBox> {
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

pub(super) fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Which of box `b`'s first `n` nodes are particles held only by immovable faces in this step:
/// each of their contacts in `contacts` is with a face whose corners all have infinite mass
/// (fixed or prescribed nodes). Such a particle pressed onto the face by its load takes, in
/// the step's closing half-kick, a velocity into a face that cannot give way; its SPH owner
/// removes that part (`SphStage::hold_on_faces`), as the face's reaction would. Measured on
/// `underwater_explosion` (the products pressed on the fixed faces that stand in for the
/// charge's symmetry planes): without it, the half-kick's kinetic energy, sum m (a dt/2)^2 / 2,
/// booked by contact as its own, was 150 J of the 231 J (2.1e-3 of the energy scale) by which
/// `contact_energy` fell in the first steps.
pub(super) fn held_particles(b: &ContactBox, contacts: &[Contact], n: usize) -> Vec<bool> {
    // 0: no contact; 1: only immovable faces so far; 2: some face can move.
    let mut state = vec![0u8; n];
    for c in contacts {
        let j = c.node as usize;
        if j >= n || !b.nodes.particle[j] {
            continue;
        }
        let immovable = b.faces.nodes[c.face as usize]
            .iter()
            .all(|&k| b.nodes.mass[k as usize].is_infinite());
        state[j] = match (state[j], immovable) {
            (2, _) | (_, false) => 2,
            _ => 1,
        };
    }
    state.into_iter().map(|s| s == 1).collect()
}
