//! The faces a failed element opens (`[[material]] failure` with a `[contact]` table,
//! docs/scene.md "Failure and contact").
//!
//! At set-up, every face between two elements of which the *other* may fail (its material has a
//! `failure` criterion) is given to the element, oriented outward from it as a boundary face
//! of it would be: two faces, one per side, where both may fail. Each step a face of element
//! `e` is **active** (lent to the contact stage) when `e` is alive and either it is a boundary
//! face of the selected surfaces, or it is such an inside face and the element on its other
//! side has failed. A boundary face of a failed element is no longer active. As LS-DYNA's
//! eroding contact (`*CONTACT_ERODING_...`), opened faces join whatever `[contact] surfaces`
//! names: the surfaces choose the boundary faces only.
//!
//! Every rank decides each of its faces from the same set of failed element ids (gathered from
//! all ranks when the global count of failed elements changes), so the active faces are the
//! same at any rank count.
use crate::kernels::collective::all_gather_varcount;
use contact::{face_key, BoundaryFace, HEX_FACES};
use fe_petsc::explicit::ExplicitFe;
use mpi::topology::SimpleCommunicator;
use std::collections::{HashMap, HashSet};

/// On rank 0, over the whole mesh (`hexes` in element gid order, `can_fail` and
/// `element_body` aligned with them): each face that a failing neighbour opens, as a face of
/// the element that keeps it (outward from that element, with its body), with the index of
/// the neighbour. A face between two elements that may both fail comes twice, once per side.
pub(super) fn opening_faces(
    hexes: &[[u64; 8]],
    can_fail: &[bool],
    element_body: &[u32],
) -> Vec<(BoundaryFace, usize)> {
    let corners = |e: usize, side: &[usize; 4]| side.map(|i| hexes[e][i]);
    // The faces of the elements that may fail, by key (both orientations share one).
    let mut failing: HashMap<[u64; 4], Vec<usize>> = HashMap::new();
    for e in (0..hexes.len()).filter(|&e| can_fail[e]) {
        for side in &HEX_FACES {
            failing
                .entry(face_key(corners(e, side)))
                .or_default()
                .push(e);
        }
    }
    let mut out = Vec::new();
    if failing.is_empty() {
        return out;
    }
    for e in 0..hexes.len() {
        for (s, side) in HEX_FACES.iter().enumerate() {
            let nodes = corners(e, side);
            let key = face_key(nodes);
            // A collapsed corner's "face" (a tetrahedron's) has no area.
            if key[2] == u64::MAX {
                continue;
            }
            let Some(others) = failing.get(&key) else {
                continue;
            };
            for &o in others.iter().filter(|&&o| o != e) {
                let face = BoundaryFace {
                    nodes,
                    element: e,
                    side: s as u8,
                    body: element_body[e],
                };
                out.push((face, o));
            }
        }
    }
    out
}

/// Which of this rank's contact faces are active after the failures so far (module doc).
#[derive(Debug, Clone, Default)]
pub struct Openings {
    /// Each face's element gid and the gid of the element that opens it (its own gid for a
    /// boundary face), aligned with `FeContact::faces`.
    pub(super) elems: Vec<(u64, u64)>,
    /// The elements failed over all ranks, as far as known.
    failed: HashSet<u64>,
    /// Whether `failed` has been gathered once (a restart's failed elements come with the
    /// first step).
    synced: bool,
    /// Whether each face is active.
    pub(super) active: Vec<bool>,
}

impl Openings {
    /// Faces with `elems` (element, opener), those with no opener active.
    pub(super) fn new(elems: Vec<(u64, u64)>) -> Openings {
        let active = elems.iter().map(|&(e, o)| e == o).collect();
        Openings {
            elems,
            active,
            ..Openings::default()
        }
    }

    /// Brings the active faces up to date with the elements `fe` has seen fail over all ranks
    /// (collective where a material fails: every rank reads the same global count): gathers
    /// the ids of the elements failed since the last gather when that count changed (always
    /// the first time). Returns whether any element failed since the last call, the same on
    /// every rank.
    pub fn update(&mut self, comm: &SimpleCommunicator, fe: &ExplicitFe) -> bool {
        if !fe.erodes() || (self.synced && fe.eroded() == self.failed.len() as u64) {
            return false;
        }
        let mine: Vec<u64> = (0..fe.elem_id.len())
            .filter(|&e| fe.is_failed(e) && !self.failed.contains(&fe.elem_id[e]))
            .map(|e| fe.elem_id[e])
            .collect();
        let new = all_gather_varcount(comm, &mine);
        self.synced = true;
        if new.is_empty() {
            return false;
        }
        self.failed.extend(new);
        let failed = &self.failed;
        for (a, &(e, o)) in self.active.iter_mut().zip(&self.elems) {
            *a = !failed.contains(&e) && (e == o || failed.contains(&o));
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit cubes along x sharing the face x = 1 (nodes 1, 2, 6, 5 of the first).
    fn two_cubes() -> Vec<[u64; 8]> {
        vec![[0, 1, 2, 3, 4, 5, 6, 7], [1, 8, 9, 2, 5, 10, 11, 6]]
    }

    #[test]
    fn the_face_a_failing_neighbour_opens_goes_to_the_other_element_outward() {
        // Only the second may fail: the first gets the shared face as its side x+ (HEX_FACES
        // [3]: 1, 2, 6, 5), counter-clockwise seen from x > 1; the second gets nothing.
        let f = opening_faces(&two_cubes(), &[false, true], &[0, 0]);
        assert_eq!(f.len(), 1);
        let (face, opener) = f[0];
        assert_eq!((face.element, face.side, opener), (0, 3, 1));
        assert_eq!(face.nodes, [1, 2, 6, 5]);
        // Both may fail: each gets the face, oriented outward from itself (the second as its
        // side x-, HEX_FACES[5]: 2, 1, 5, 6, the reverse cycle).
        let f = opening_faces(&two_cubes(), &[true, true], &[0, 0]);
        assert_eq!(f.len(), 2);
        assert_eq!((f[1].0.element, f[1].0.side, f[1].1), (1, 5, 0));
        assert_eq!(f[1].0.nodes, [2, 1, 5, 6]);
        // Neither fails: no face.
        assert!(opening_faces(&two_cubes(), &[false, false], &[0, 0]).is_empty());
    }
}
