//! A mesh node against a face: the node is a point (contact radius 0).
//!
//! Rules (SCENE.md, "Contact"): pairs between different bodies are always searched; pairs within
//! one body only with `self_contact`; a node never contacts a face it is a corner of (compared by
//! global id, so a box's copies cannot defeat the rule).

use super::{crossing, Hit};
use crate::data::ContactBox;
use crate::SearchParams;

/// Whether the rules exclude the pair whatever the geometry: the node is a corner of the face,
/// the same body without self-contact, or the wrong order of bodies in one pass.
pub(super) fn excluded(b: &ContactBox, j: usize, f: usize, params: &SearchParams) -> bool {
    b.faces.node_gid[f].contains(&b.nodes.gid[j])
        || (!params.self_contact && b.nodes.body[j] == b.faces.body[f])
        || (params.one_pass && b.nodes.body[j] < b.faces.body[f])
}

/// See [`super::test`].
pub(super) fn test(b: &ContactBox, j: usize, f: usize, params: &SearchParams) -> Option<Hit> {
    if excluded(b, j, f, params) {
        return None;
    }
    let tol = if b.nodes.body[j] == b.faces.body[f] {
        params.self_param_tol
    } else {
        params.param_tol
    };
    crossing(b, j, f, 0.0, tol, params)
}
