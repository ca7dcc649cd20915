//! A second look after the push-back: the crossings its corrections made.
//!
//! The search tests each node's path against the faces it may cross with the *predicted* end
//! positions; the push-back then moves the contact nodes and the faces' corners. A moved node
//! can end behind a face it did not cross before the correction: a node in a fold's crease
//! pushed out of one face into the next (the search keeps one of two hits whose normals are
//! within `SAME_NORMAL_COS`), a face's corner pushed into a face of another surface, a node
//! that was clear until the face it faces was pushed onto it. Each such remainder is small (the
//! corrections are the penetrations, a few micrometres), but the next step's crossing test
//! sees the node start behind that face, and once the remainder passes the capture tolerance
//! (`gap_tol` times the face's diameter) the node is never found against it again and sinks
//! on. Measured on `tube_crush` with the default physical hourglass control (np 1, to 0.63 ms):
//! 27,900 such remainders of up to 3.5 um after the push-back, on 1-6 mm faces, 2,700 of them
//! nodes that had no contact in the step (pushed as face corners, or faces pushed onto them).
//!
//! [`recheck`] therefore repeats the crossing test ([`crate::pair::test`], the same start
//! positions) on the corrected end positions, for the nodes the correction can have changed:
//! those that moved and those whose candidate faces have a corner that moved. A hit is a new
//! contact when it is not one of the contacts already solved, it is deeper than [`RECHECK_TOL`]
//! times its face's diameter (shallower ones are left to the next step, well inside the
//! capture tolerance), and it passes the search's rule between several contacts of one node
//! against each contact the node already has: a face of another body than the contact's is
//! always taken (`search::apart`); on the same body, a mesh node takes a further face only
//! across a valley (at a convex edge the node, back on one face, is outside the body; see
//! `search::valley`), whatever the angle between the faces, and a particle takes a further
//! face of another normal. The caller solves the push-back again with the contacts found so
//! far and the new ones together (the new ones linearised at the point and normal where the
//! corrected node met the face, their depth measured on the uncorrected geometry), and repeats
//! while rechecks find contacts.

use crate::data::{Config, ContactBox};
use crate::pair;
use crate::search::{apart, valley, Candidates, Contact, SearchParams, SAME_NORMAL_COS};
use crate::vec3::{add, dot, sub, V3};

/// A crossing the recheck finds is a new contact when deeper than this fraction of its face's
/// diameter (a thousandth of the capture tolerance `gap_tol`, so a remainder left for the next
/// step is always captured there).
pub const RECHECK_TOL: f64 = 1e-6;

/// The contacts that the position corrections `dx` (m, one per box node; zero where a node did
/// not move) create in box `b`, beyond `found` (the contacts already solved, found in `b`).
/// `cands`: the candidate lists the search used on `b` (rebuilt here when the corrections
/// moved a node past their skin). Leaves `b` as it was. Sorted by node gid, then face gid.
pub fn recheck(
    b: &mut ContactBox,
    params: &SearchParams,
    cands: &Candidates,
    dx: &[V3],
    found: &[Contact],
) -> Vec<Contact> {
    let moved: Vec<usize> = (0..b.nodes.len())
        .filter(|&j| dx[j].iter().any(|c| *c != 0.0))
        .collect();
    if moved.is_empty() {
        return Vec::new();
    }
    let saved: Vec<V3> = moved.iter().map(|&j| b.nodes.x1[j]).collect();
    for &j in &moved {
        b.nodes.x1[j] = add(b.nodes.x1[j], dx[j]);
    }
    let fresh;
    let cands = if cands.still_valid(b, params) {
        cands
    } else {
        fresh = Candidates::build(b, params, 0.0);
        &fresh
    };
    let mut node_moved = vec![false; b.nodes.len()];
    for &j in &moved {
        node_moved[j] = true;
    }
    let face_moved: Vec<bool> = (0..b.faces.len())
        .map(|f| b.faces.nodes[f].iter().any(|&i| node_moved[i as usize]))
        .collect();
    let mut out = Vec::new();
    for (j, &moved_itself) in node_moved.iter().enumerate().take(b.nodes.n_owned) {
        let list = cands.list(j);
        if !moved_itself && !list.iter().any(|&f| face_moved[f as usize]) {
            continue;
        }
        out.extend(new_contacts_of_node(b, params, j, list, found));
    }
    for (&j, &x) in moved.iter().zip(&saved) {
        b.nodes.x1[j] = x;
    }
    // The depth on the uncorrected geometry, at the corrected point and normal: what the
    // push-back's linearisation starts from (it may be negative, a gap the correction closed).
    for c in &mut out {
        let q = b.quad(c.face as usize, Config::End);
        let p1 = b.nodes.x1[c.node as usize];
        c.depth = c.radius - dot(sub(p1, q.point(c.xi)), c.normal);
    }
    out.sort_by_key(|c| (c.node_gid, c.face_gid));
    out
}

/// The new contacts of owned node `j` on the corrected geometry (see [`recheck`]), deepest
/// first.
fn new_contacts_of_node(
    b: &ContactBox,
    params: &SearchParams,
    j: usize,
    list: &[u32],
    found: &[Contact],
) -> Vec<Contact> {
    let gid = b.nodes.gid[j];
    // `found` is sorted by node gid (the search's order).
    let lo = found.partition_point(|c| c.node_gid < gid);
    let hi = found.partition_point(|c| c.node_gid <= gid);
    let mut kept: Vec<(pair::Hit, usize)> = found[lo..hi]
        .iter()
        .map(|c| {
            let h = pair::Hit {
                xi: c.xi,
                normal: c.normal,
                depth: c.depth,
                radius: c.radius,
            };
            (h, c.face as usize)
        })
        .collect();
    let mut hits: Vec<(pair::Hit, usize)> = list
        .iter()
        .map(|&f| f as usize)
        .filter(|&f| !kept.iter().any(|&(_, g)| g == f))
        .filter_map(|f| pair::test(b, j, f, params).map(|h| (h, f)))
        .filter(|(h, f)| h.depth > RECHECK_TOL * b.quad(*f, Config::End).diameter())
        .collect();
    hits.sort_by(|(h, f), (k, g)| {
        k.depth
            .total_cmp(&h.depth)
            .then(b.faces.gid[*f].cmp(&b.faces.gid[*g]))
    });
    let particle = b.nodes.particle[j];
    let mut out = Vec::new();
    for (h, f) in hits {
        let fits = kept.iter().all(|&(k, g)| {
            apart(b, g, f)
                || if particle {
                    dot(k.normal, h.normal).abs() < SAME_NORMAL_COS
                } else {
                    valley(b, (&k, g), (&h, f))
                }
        });
        if fits {
            kept.push((h, f));
            out.push(Contact {
                node: j as u32,
                face: f as u32,
                node_gid: gid,
                face_gid: b.faces.gid[f],
                xi: h.xi,
                normal: h.normal,
                depth: h.depth,
                radius: h.radius,
            });
        }
    }
    out
}
