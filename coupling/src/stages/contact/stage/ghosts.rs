//! Faces to every box their search boxes reach (Fig. 10, steps 5-6): a move within the contact
//! decomposition. The moves between decompositions are `crate::transfer`'s.
use super::*;

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
