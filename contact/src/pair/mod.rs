//! Narrow phase: does a node cross a face during the step? One file per pair kind, one dispatcher.
//!
//! Both kinds share one crossing test (`crossing`): the node's end position `p1` is projected on
//! the face's end configuration (closest point of the bilinear surface, [`crate::Quad`]); the pair
//! is a contact when
//!
//! 1. the projection falls inside the face: `|xi|, |eta| <= 1 + param_tol`;
//! 2. the node ends behind the offset surface: `s1 = (p1 - X1(xi)) . n1(xi) < r`, depth `r - s1`;
//! 3. the node started outside it, or within the capture tolerance: at the same parametric point
//!    of the start configuration, `s0 = (p0 - X0(xi)) . n0(xi) >= r - gap_tol * diameter`;
//! 4. the depth is one the step can produce: `r - s1 <= |p1 - p0| + max_i |X1_i - X0_i| + r +
//!    gap_tol * diameter` (a node cannot sink deeper than it and the face moved, plus the
//!    tolerance; exact for a face that does not turn). This bounds how far a contacted node can be
//!    from the face, which is what makes the bounding-box search complete (see
//!    [`crate::face_search_aabb`]).
//!
//! `r` is the node's contact radius (0 for a mesh node). Test 3 is what makes this a test of
//! *crossing during the step*: a node that is behind a face at both ends (the far face of a thin
//! plate, say) is not a contact. The tolerance keeps a node that push-back left on the face (at a
//! signed distance of round-off) in contact at the next step.

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
    /// Penetration depth, m (> 0).
    pub depth: f64,
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
/// tested against every face). A pair excluded here is never a contact of [`test`].
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
    let q1 = b.quad(f, Config::End);
    let proj = q1.closest_point(b.nodes.x1[j])?;
    let lim = 1.0 + param_tol;
    if proj.xi[0].abs() > lim || proj.xi[1].abs() > lim {
        return None;
    }
    let depth = r - proj.signed_distance;
    if depth.is_nan() || depth <= 0.0 {
        return None;
    }
    let q0 = b.quad(f, Config::Start);
    let tol = params.gap_tol * q1.diameter();
    let max_depth = norm(sub(b.nodes.x1[j], b.nodes.x0[j])) + max_corner_motion(&q0, &q1) + r + tol;
    if depth > max_depth {
        return None;
    }
    let n0 = q0.normal(proj.xi)?;
    let s0 = dot(sub(b.nodes.x0[j], q0.point(proj.xi)), n0);
    if s0 < r - tol {
        return None;
    }
    Some(Hit {
        xi: proj.xi,
        normal: proj.normal,
        depth,
    })
}
