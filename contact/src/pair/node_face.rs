//! A mesh node against a face: the node is a point (contact radius 0).
//!
//! Rules (docs/scene.md, "Contact"): pairs between different bodies are always searched (in one pass,
//! only the other body's nodes against a master body's faces); pairs within one body only with
//! `self_contact`; a node never contacts a face it is a corner of (compared by global id, so a
//! box's copies cannot defeat the rule).

use super::{crossing, Hit};
use crate::data::ContactBox;
use crate::SearchParams;

/// Whether the rules exclude the pair whatever the geometry: the node is a corner of the face,
/// the same body without self-contact, or, in one pass, a master body's node against another
/// body's face (a face's body is a master when its corners are: they are its body's nodes).
pub(super) fn excluded(b: &ContactBox, j: usize, f: usize, params: &SearchParams) -> bool {
    b.faces.node_gid[f].contains(&b.nodes.gid[j])
        || (!params.self_contact && b.nodes.body[j] == b.faces.body[f])
        || (params.one_pass && b.nodes.master[j] && !b.nodes.master[b.faces.nodes[f][0] as usize])
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
