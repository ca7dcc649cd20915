//! Narrow phase: does a node cross a face during the step? One file per pair kind, one dispatcher.
//!
//! Both kinds share one crossing test (`crossing`). The node moves from `p0` to `p1` while the
//! face moves from its start configuration `X0(xi)` to its end configuration `X1(xi)` (bilinear
//! surfaces, [`crate::Quad`]); `r` is the node's contact radius (0 for a mesh node), so the node
//! meets the face when it reaches the surface offset outward by `r`. The end position is
//! projected on the end configuration (closest point of the unbounded bilinear surface): `xi1`,
//! signed distance `s1 = (p1 - X1(xi1)) . n1(xi1)`. The pair is a contact when
//!
//! 1. the node ends behind the offset surface: `s1 < r`;
//! 2. the node started outside it, or within the capture tolerance `tol = gap_tol * diameter`
//!    (a particle whose centre started outside the face but its sphere across the offset
//!    surface: see "A particle that starts across the offset surface" below);
//! 3. the node's path crossed the surface *on the face*, and then the contact point, normal and
//!    depth are taken where it did:
//!    - **the end projection falls on the face** (`|xi1|, |eta1| <= 1 + param_tol`, the usual
//!      case): started outside means `s0 = (p0 - X0(xi1)) . n0(xi1) >= r - tol` at the same
//!      parametric point; the contact is at `xi1`, normal `n1(xi1)`, depth `r - s1`;
//!    - **the end projection falls off the face** (beyond an edge or a corner): the start position
//!      is projected on the start configuration too (`xi0`, `s0`), started outside means
//!      `s0 >= r - tol`, and the path met the offset surface at the parametric point
//!      `xi_c = xi0 + t (xi1 - xi0)`, `t = (s0 - r) / (s0 - s1)` (0 when `s0 < r`), which must lie
//!      on the face (`|xi_c|, |eta_c| <= 1 + param_tol`). The contact is at `xi_c` clamped to the
//!      face, `xi*`, with the face's normal there `n1(xi*)` and the depth behind the tangent
//!      plane there, `r - (p1 - X1(xi*)) . n1(xi*)` (> 0);
//! 4. the node's end position is one the step can produce: the depth `r - s1` (end projection on
//!    the face), or the distance `|p1 - X1(xi*)|` (off it), is at most `|p1 - p0| + max_i |X1_i -
//!    X0_i| + r + tol` (a node cannot get farther from the point where it met the face than it and
//!    the face moved, plus the tolerance; exact for a face that does not turn). This bounds how far
//!    a contacted node can be from the face's end configuration, which is what makes the
//!    bounding-box search complete (see [`crate::face_search_aabb`]).
//!
//! Test 2 is what makes this a test of *crossing during the step*: a node that is behind a face at
//! both ends (the far face of a thin plate, say) is not a contact. The tolerance keeps a node that
//! push-back left on the face (at a signed distance of round-off) in contact at the next step.
//!
//! # A particle that starts across the offset surface
//!
//! A particle's sphere can start a step already across a face's offset surface, its centre
//! still outside the face: a particle born from a failed element next to the face (the element
//! crushed against a striker, its centroid 0.17 mm from the ball's surface for a contact radius
//! of 0.45 mm, half its size), or one whose neighbours pushed it there. Rule 2 with the radius
//! `r` would never count it again (it started behind the offset surface, past the tolerance),
//! and the face would pass through it: measured on a 4 mm ball at 600 m/s through a plate whose
//! failed elements become particles, such a particle kept -329 m/s while the ball moved at
//! -550 m/s and ended 0.8 mm inside it. So such a pair (`0 <= s0 < r - tol`, with `s0` as in
//! rule 2) is measured with the radius the particle started with, `s0` (the [`Hit`]'s
//! `radius`): it is a contact when the step brings the centre closer than that, its depth what
//! the step made. As for a node within the capture tolerance, the overlap the particle started
//! with is kept, not pushed out at once (which no motion of the step explains and would give
//! energy back); the face then carries the particle on at that distance. A particle whose centre
//! started behind the face is not a contact, as a node.
//!
//! # Why the second branch (a node over a node, an edge or a corner)
//!
//! A node pressed onto a node of the other surface dimples it: push-back leaves the node on the
//! corner shared by the faces around that node, and those faces now slope down towards it (a
//! valley, seen from the node's side). Behind the bottom of a valley lies a dead zone of the
//! closest-point projection: a point just behind the shared corner (or edge) projects *off* every
//! face that shares it (each face's surface, continued past its edge, passes below the point). At
//! the next step the node moves on, ends in that dead zone, and a test that asks only "does the
//! end position project on the face" finds no face at all; one step later the node starts behind
//! every face and is never found again. Measured on a block dropped flat onto a plate with the
//! nodes of the two meshes aligned (the ball with a plate node under its pole: 1.1-1.6 mm):
//! contacts 25, 17, 13, 8 over the first steps and nodes 0.21 mm (4 % of an element) inside the
//! plate, where an offset mesh left 2 nm. Widening `param_tol` only narrows the dead zone (its
//! width grows with the depth times the slope). The second branch asks the question of the
//! swept test instead, *where did the path meet the face's surface*: on a face that does not
//! turn, the parametric coordinates and the signed distance are affine along the relative path,
//! so `xi_c` is that point exactly, and a node that started on the shared corner crossed there,
//! on every face around it (`xi_c` = the corner to round-off). A node that falls past the outer
//! edge of a plate crosses the continued surface off the face and stays free.
//!
//! The second branch takes the face's own normal at the clamped point (not the direction from
//! the node to it): a node that slides off an edge while it sinks a little is pushed back up onto
//! the face's plane, not dragged back along the face. Behind a shallow valley the node is then
//! left behind the other faces of the corner by a second-order amount (its depth times the
//! square of the slope), within the capture tolerance at the next step.

mod node_face;
mod particle_face;

use crate::data::{Config, ContactBox};
use crate::geometry::Quad;
use crate::vec3::{dot, norm, sub, V3};

/// Largest corner displacement between two configurations of a face.
pub(crate) fn max_corner_motion(q0: &Quad, q1: &Quad) -> f64 {
    (0..4).fold(0.0, |a: f64, k| a.max(norm(sub(q1.x[k], q0.x[k]))))
}
use crate::SearchParams;

/// A node-face crossing found by the narrow phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Parametric coordinates of the contact point on the face.
    pub xi: [f64; 2],
    /// Unit outward normal of the face at the contact point (end configuration).
    pub normal: V3,
    /// Penetration depth, m (> 0): behind the face offset outward by `radius`.
    pub depth: f64,
    /// The contact radius the pair is measured with, m: the node's (0 for a mesh node), or for
    /// a particle whose sphere started the step already across the offset surface, its centre
    /// outside the face, that start distance (see the module documentation, "A particle that
    /// starts across the offset surface").
    pub radius: f64,
}

/// Tests node `j` against face `f` of the box, with the rules of the node's kind (a mesh node or
/// a particle). `None`: not a contact, or a pair the rules exclude.
pub fn test(b: &ContactBox, j: usize, f: usize, params: &SearchParams) -> Option<Hit> {
    if b.nodes.particle[j] {
        particle_face::test(b, j, f, params)
    } else {
        node_face::test(b, j, f, params)
    }
}

/// Whether the pair rules exclude node `j` against face `f` whatever the geometry (particles are
/// tested against every face). A pair excluded here is never a contact of [`test()`].
pub fn excluded(b: &ContactBox, j: usize, f: usize, params: &SearchParams) -> bool {
    !b.nodes.particle[j] && node_face::excluded(b, j, f, params)
}

/// The crossing test shared by every kind, for a node with contact radius `r` (see the module
/// documentation).
pub(crate) fn crossing(
    b: &ContactBox,
    j: usize,
    f: usize,
    r: f64,
    param_tol: f64,
    params: &SearchParams,
) -> Option<Hit> {
    let (p0, p1) = (b.nodes.x0[j], b.nodes.x1[j]);
    let q1 = b.quad(f, Config::End);
    let end = q1.closest_point(p1)?;
    // 1. Ends behind the offset surface.
    if end.signed_distance.is_nan() || end.signed_distance >= r {
        return None;
    }
    let q0 = b.quad(f, Config::Start);
    let tol = params.gap_tol * q1.diameter();
    // 4. How far from the face the step can leave the node.
    let reach = norm(sub(p1, p0)) + max_corner_motion(&q0, &q1) + r + tol;
    let lim = 1.0 + param_tol;
    let on_face = |xi: [f64; 2]| xi[0].abs() <= lim && xi[1].abs() <= lim;
    if on_face(end.xi) {
        // 3, the end projection on the face; 2 at the same parametric point.
        let n0 = q0.normal(end.xi)?;
        let r = started_outside(dot(sub(p0, q0.point(end.xi)), n0), r, tol)?;
        let depth = r - end.signed_distance;
        if depth <= 0.0 || depth > reach {
            return None;
        }
        return Some(Hit {
            xi: end.xi,
            normal: end.normal,
            depth,
            radius: r,
        });
    }
    // 3, the end projection off the face: where did the path meet the offset surface?
    let start = q0.closest_point(p0)?;
    let (s0, s1) = (start.signed_distance, end.signed_distance);
    // 2.
    let r = started_outside(s0, r, tol)?;
    if s1 >= r {
        return None;
    }
    let t = if s0 > r { (s0 - r) / (s0 - s1) } else { 0.0 };
    let xi_c = [
        start.xi[0] + t * (end.xi[0] - start.xi[0]),
        start.xi[1] + t * (end.xi[1] - start.xi[1]),
    ];
    if !on_face(xi_c) {
        return None;
    }
    let xi = [xi_c[0].clamp(-1.0, 1.0), xi_c[1].clamp(-1.0, 1.0)];
    let normal = q1.normal(xi)?;
    let gap = sub(p1, q1.point(xi));
    let depth = r - dot(gap, normal);
    if depth.is_nan() || depth <= 0.0 || norm(gap) > reach {
        return None;
    }
    Some(Hit {
        xi,
        normal,
        depth,
        radius: r,
    })
}

/// Rule 2 for a node of contact radius `r` that started the step at signed distance `s0` from
/// the face (capture tolerance `tol`): the radius the pair is measured with, or `None` where
/// the node did not start outside. Outside is `s0 >= r - tol`, measured with `r`; a particle
/// (`r > 0`) whose centre started outside the face but its sphere across the offset surface
/// (`0 <= s0 < r - tol`) is measured with the radius `s0` it started with (module
/// documentation, "A particle that starts across the offset surface").
fn started_outside(s0: f64, r: f64, tol: f64) -> Option<f64> {
    if s0.is_nan() {
        None
    } else if s0 >= r - tol {
        Some(r)
    } else if r > 0.0 && s0 >= 0.0 {
        Some(s0)
    } else {
        None
    }
}
