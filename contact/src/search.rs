//! Contact search inside one box: for every owned node, the face it crossed during the step.

use bytemuck::{Pod, Zeroable};

use crate::data::{Aabb, Config, ContactBox};
use crate::geometry::Quad;
use crate::grid::Grid;
use crate::pair;
use crate::vec3::{dot, norm, sub, V3};

/// Default [`SearchParams::gap_tol`].
pub const DEFAULT_GAP_TOL: f64 = 1e-3;
/// Default [`SearchParams::param_tol`].
pub const DEFAULT_PARAM_TOL: f64 = 1e-6;

/// What the search looks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchParams {
    /// Also search pairs within one body (`[contact] self_contact`).
    pub self_contact: bool,
    /// One pass between a master body and another (`[contact] passes = 1`): nodes of master
    /// bodies ([`crate::FLAG_MASTER`]) are not searched against faces of the other bodies, whose
    /// nodes are searched against the master's faces (LS-DYNA's one-way, slave nodes against
    /// master segments); pairs of two master bodies or of two others are searched both ways.
    /// Off (the default, two passes): every pair of bodies both ways, so the answer does not
    /// depend on which body is which, nor on their order in the mesh. The price of one pass:
    /// a node of the master can cross a face of the other body unseen (a coarse master's
    /// corner through a fine slave surface). Two passes find a touching pair from both sides
    /// (a node of each in a face of the other, two descriptions of one gap); the push-back
    /// solves them in one system, where such rows share the impulse rather than push twice
    /// ([`crate::push_back`], "Several contacts sharing nodes").
    pub one_pass: bool,
    /// Capture tolerance, as a fraction of the face's diameter: a node that starts the step up to
    /// this far behind a face still counts as having been outside it (see [`crate::pair`]).
    pub gap_tol: f64,
    /// Parametric tolerance of "the projection falls inside the face": `|xi|, |eta| <= 1 + param_tol`
    /// (closes the seams between neighbouring faces against round-off).
    pub param_tol: f64,
    /// The same for a node against a face of its own body (self-contact), where a fold's crease
    /// can sit on the seam of two faces at an angle: the parallel layer widens it there only, as
    /// a wider tolerance between bodies couples more contacts across boxes (see the parallel
    /// stage's `MESH_PARAM_TOL`).
    pub self_param_tol: f64,
}

impl Default for SearchParams {
    fn default() -> Self {
        SearchParams {
            self_contact: false,
            one_pass: false,
            gap_tol: DEFAULT_GAP_TOL,
            param_tol: DEFAULT_PARAM_TOL,
            self_param_tol: DEFAULT_PARAM_TOL,
        }
    }
}

/// One detected contact: owned node `node` crossed face `face` (box indices; the gids too).
/// `Pod`, so results can be sent as bytes (80 bytes, no padding).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Contact {
    /// Box index of the node.
    pub node: u32,
    /// Box index of the face.
    pub face: u32,
    /// Global id of the node.
    pub node_gid: u64,
    /// Global id of the face.
    pub face_gid: u64,
    /// Parametric coordinates of the contact point on the face (see [`crate::shape`]).
    pub xi: [f64; 2],
    /// Unit outward normal of the face at the contact point, end-of-step configuration.
    pub normal: V3,
    /// Penetration depth, m (> 0): how far the node (or the particle's sphere) is behind the face.
    pub depth: f64,
    /// The contact radius the depth is measured with, m: the node's own (0 for a mesh node), or
    /// less for a particle whose sphere started the step across the face's offset surface
    /// ([`crate::pair`], "A particle that starts across the offset surface").
    pub radius: f64,
}

/// Growth of a face's box per unit of `param_tol * diameter`: a point of the face at parametric
/// coordinates up to `1 + param_tol` lies within `param_tol * diameter` of the corners' hull (the
/// tangents are at most a diameter long); doubled for safety.
const PARAM_REACH: f64 = 2.0;

/// The box in which face `f` must be visible for the search to be complete: the box of its corners
/// at both ends of the step, grown by the largest corner motion `max_i |X1_i - X0_i|`, by
/// `max_radius` (the largest contact radius of any node that may meet it), and by
/// `(gap_tol + 2 param_tol)` times the face's diameter. A node can only contact the face if its
/// end position is within `|p1 - p0| + max_i |X1_i - X0_i| + r + gap_tol * diameter` of a point
/// of the face's end configuration with `|xi|, |eta| <= 1 + param_tol` (rule 4 of
/// [`crate::pair`], in both of its branches: the end projection on the face, or the clamped
/// point where the path met it); so a node whose
/// [`node_search_aabb`] misses this box cannot contact the face, and the parallel layer ghosts a
/// face to every box this overlaps.
pub fn face_search_aabb(b: &ContactBox, f: usize, params: &SearchParams, max_radius: f64) -> Aabb {
    quads_search_aabb(
        &b.quad(f, Config::Start),
        &b.quad(f, Config::End),
        params,
        max_radius,
    )
}

/// [`face_search_aabb`] of a face given by its four corner records (in the face's order), with
/// no box to build: what the parallel layer needs to ghost each face.
pub fn face_records_search_aabb(
    corners: &[crate::NodeRecord; 4],
    params: &SearchParams,
    max_radius: f64,
) -> Aabb {
    let q0 = Quad {
        x: std::array::from_fn(|k| corners[k].x0),
    };
    let q1 = Quad {
        x: std::array::from_fn(|k| corners[k].x1),
    };
    quads_search_aabb(&q0, &q1, params, max_radius)
}

/// The search box of a face with start and end configurations `q0`, `q1`.
fn quads_search_aabb(q0: &Quad, q1: &Quad, params: &SearchParams, max_radius: f64) -> Aabb {
    let (q0, q1) = (*q0, *q1);
    let mut bb = Aabb::EMPTY;
    for k in 0..4 {
        bb.include(q0.x[k]);
        bb.include(q1.x[k]);
    }
    let diameter = q0.diameter().max(q1.diameter());
    bb.grown(
        pair::max_corner_motion(&q0, &q1)
            + max_radius
            + (params.gap_tol + PARAM_REACH * params.param_tol.max(params.self_param_tol))
                * diameter,
    )
}

/// The box node `j` searches with: its end position grown by the length of its step (it holds the
/// swept segment `x0 -> x1`).
pub fn node_search_aabb(b: &ContactBox, j: usize) -> Aabb {
    let p1 = b.nodes.x1[j];
    let mut bb = Aabb::EMPTY;
    bb.include(p1);
    bb.grown(norm(sub(p1, b.nodes.x0[j])))
}

/// Finds, for every owned node (`0..n_owned`), the face it penetrated during the step, if any.
///
/// Broad phase: a bucket grid over the faces' [`face_search_aabb`]s, queried with each node's
/// [`node_search_aabb`] ([`Candidates::build`] with no skin). Narrow phase: [`crate::pair::test`].
/// If a node crossed several faces its first contact is the deepest, then the lowest face gid.
/// A node can cross two or three faces at once at an edge or a corner of a valley between faces
/// at an angle (a groove, the inner corner of a box, a fold; a particle, a sphere, at any edge
/// or corner of a cavity), and one contact would leave it behind the others, by its depth times
/// the sine of the angle between the faces, where the next step's crossing test no longer sees
/// it (started behind): a node keeps, in that order, every further hit that, against each
/// kept one, is on a face of another body (`apart`: at any angle, parallel or opposite
/// included), or has a normal not within `SAME_NORMAL_COS` of the kept one's and a face that
/// forms a valley with the kept one's (`valley`: a mesh node at a convex edge needs to leave
/// one face only; a particle keeps every hit of another normal, as it always did), and the
/// push-back solves them together (on one body, coplanar neighbours across a seam, or the
/// slightly dimpled faces around a node pressed on a node, still give one contact: the
/// remainder is second order in the angle). The result is
/// sorted by node gid, then depth and face gid; it depends only on the geometry and the gids,
/// never on the storage order of nodes or faces.
pub fn search(b: &ContactBox, params: &SearchParams) -> Vec<Contact> {
    let cands = Candidates::build(b, params, 0.0);
    search_candidates(b, params, &cands)
}

/// Candidate faces of every owned node, kept over several steps: a Verlet list with a skin.
///
/// [`Candidates::build`] lists, for each owned node, the faces whose [`face_search_aabb`]
/// overlaps the node's [`node_search_aabb`] grown by `skin` (and that the pair rules do not
/// exclude outright: a corner of the face, the same body without self-contact, a master
/// body's node against another's face in one pass). While the box's nodes have moved little
/// since, the list still holds every face the node can contact, and [`search_candidates`] gives
/// exactly what [`search`] gives, without the grid. The bound ([`Candidates::still_valid`]): with `D` the largest displacement of any
/// node of the box since the build and `m` the largest motion of any node over the current step,
/// a node's box now lies within `D + m` of its end position at the build, and a face's box within
/// `D + 2m + 2 tau (D + m)` of its own box then (corners moved by `D`, the start configuration
/// within `m` of the end, the diameter term `tau d` with `tau = gap_tol + 2 param_tol` grown by
/// the corners' motion); so the list is complete while `(2 + 2 tau) D + (3 + 2 tau) m <= skin`
/// and the largest contact radius has not grown. Hand-written (not parry's BVH): the boxes are
/// rebuilt from raw records every few steps and a uniform grid over faces of one size is the
/// cheaper structure for that.
#[derive(Debug, Clone, Default)]
pub struct Candidates {
    /// `faces[start[j]..start[j + 1]]`: the candidate faces of owned node `j`.
    start: Vec<u32>,
    faces: Vec<u32>,
    /// End positions of every node of the box at the build.
    x_ref: Vec<V3>,
    skin: f64,
    max_radius: f64,
    n_faces: usize,
    /// Per-step work space of [`search_candidates`] (face boxes computed this step), kept so
    /// that a step allocates nothing.
    scratch: std::cell::RefCell<Scratch>,
}

/// See [`Candidates::scratch`]: `boxes[f]` is face f's search box when `stamp[f] == epoch`.
#[derive(Debug, Clone, Default)]
struct Scratch {
    boxes: Vec<Aabb>,
    stamp: Vec<u32>,
    epoch: u32,
}

impl Candidates {
    /// The candidate list of `b`'s owned nodes with skin `skin` (m, >= 0).
    pub fn build(b: &ContactBox, params: &SearchParams, skin: f64) -> Candidates {
        let max_radius = b.max_radius();
        let boxes: Vec<Aabb> = (0..b.faces.len())
            .map(|f| face_search_aabb(b, f, params, max_radius))
            .collect();
        let grid = Grid::build(&boxes);
        // stamp[f] = 1 + the last node that visited face f (removes the grid's repeats).
        let mut stamp = vec![0usize; b.faces.len()];
        let mut start = Vec::with_capacity(b.nodes.n_owned + 1);
        let mut faces = Vec::new();
        start.push(0u32);
        for j in 0..b.nodes.n_owned {
            let q = node_search_aabb(b, j).grown(skin);
            grid.query(&q, |f| {
                let fu = f as usize;
                if stamp[fu] == j + 1 {
                    return;
                }
                stamp[fu] = j + 1;
                if boxes[fu].overlaps(&q) && !pair::excluded(b, j, fu, params) {
                    faces.push(f);
                }
            });
            start.push(faces.len() as u32);
        }
        Candidates {
            start,
            faces,
            x_ref: if skin > 0.0 {
                b.nodes.x1.clone()
            } else {
                Vec::new()
            },
            skin,
            max_radius,
            n_faces: b.faces.len(),
            scratch: Default::default(),
        }
    }

    /// The candidate faces of owned node `j`.
    pub(crate) fn list(&self, j: usize) -> &[u32] {
        &self.faces[self.start[j] as usize..self.start[j + 1] as usize]
    }

    /// Number of (node, face) candidate pairs.
    pub fn len(&self) -> usize {
        self.faces.len()
    }

    /// Whether there is no candidate pair.
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// The skin the list was built with, m.
    pub fn skin(&self) -> f64 {
        self.skin
    }

    /// Whether the list still holds every face each owned node of `b` can contact in `b`'s
    /// current step (see the type's documentation). `b` must hold the same nodes and faces, in
    /// the same order, as at the build, with new positions.
    pub fn still_valid(&self, b: &ContactBox, params: &SearchParams) -> bool {
        if b.nodes.len() != self.x_ref.len()
            || b.faces.len() != self.n_faces
            || b.nodes.n_owned + 1 != self.start.len()
            || b.max_radius() > self.max_radius
        {
            return false;
        }
        let mut d2 = 0.0f64;
        let mut m2 = 0.0f64;
        for i in 0..b.nodes.len() {
            d2 = d2.max(norm2(sub(b.nodes.x1[i], self.x_ref[i])));
            m2 = m2.max(norm2(sub(b.nodes.x1[i], b.nodes.x0[i])));
        }
        within_skin(d2.sqrt(), m2.sqrt(), params, self.skin)
    }
}

/// The completeness bound of a list built with `skin` (see [`Candidates`]): `d`, the largest
/// displacement since the build, and `m`, the largest motion over the current step.
pub fn within_skin(d: f64, m: f64, params: &SearchParams, skin: f64) -> bool {
    let tau = params.gap_tol + PARAM_REACH * params.param_tol.max(params.self_param_tol);
    (2.0 + 2.0 * tau) * d + (3.0 + 2.0 * tau) * m <= skin
}

fn norm2(a: V3) -> f64 {
    dot(a, a)
}

/// [`search`] over a candidate list built earlier on the same box (same nodes and faces, same
/// order, new positions) and still valid for it ([`Candidates::still_valid`]): the same contacts
/// as [`search`], bit for bit.
pub fn search_candidates(
    b: &ContactBox,
    params: &SearchParams,
    cands: &Candidates,
) -> Vec<Contact> {
    let max_radius = b.max_radius();
    // A face's search box, computed once per step and only for faces some node lists.
    let mut sc = cands.scratch.borrow_mut();
    let nf = b.faces.len();
    if sc.stamp.len() != nf {
        sc.boxes = vec![Aabb::EMPTY; nf];
        sc.stamp = vec![0; nf];
        sc.epoch = 0;
    }
    sc.epoch = sc.epoch.wrapping_add(1);
    if sc.epoch == 0 {
        sc.stamp.fill(0);
        sc.epoch = 1;
    }
    let epoch = sc.epoch;
    let Scratch { boxes, stamp, .. } = &mut *sc;
    let mut out = Vec::new();
    let mut hits: Vec<(pair::Hit, usize)> = Vec::new();
    let mut kept: Vec<(pair::Hit, usize)> = Vec::new();
    for j in 0..b.nodes.n_owned {
        let list = &cands.faces[cands.start[j] as usize..cands.start[j + 1] as usize];
        if list.is_empty() {
            continue;
        }
        let q = node_search_aabb(b, j);
        hits.clear();
        for &f in list {
            let f = f as usize;
            let fb = if stamp[f] == epoch {
                boxes[f]
            } else {
                stamp[f] = epoch;
                boxes[f] = face_search_aabb(b, f, params, max_radius);
                boxes[f]
            };
            if !fb.overlaps(&q) {
                continue;
            }
            if let Some(hit) = pair::test(b, j, f, params) {
                hits.push((hit, f));
            }
        }
        if hits.is_empty() {
            continue;
        }
        // Deepest first, then the lowest face gid.
        hits.sort_by(|(h, f), (k, g)| {
            k.depth
                .total_cmp(&h.depth)
                .then(b.faces.gid[*f].cmp(&b.faces.gid[*g]))
        });
        kept.clear();
        let particle = b.nodes.particle[j];
        for &(h, f) in &hits {
            let further = kept.iter().all(|&(k, g)| {
                apart(b, g, f)
                    || (dot(k.normal, h.normal).abs() < SAME_NORMAL_COS
                        && (particle || valley(b, (&k, g), (&h, f))))
            });
            if kept.is_empty() || further {
                kept.push((h, f));
            }
        }
        blend_tied_normals(b, &hits, &mut kept);
        for &(h, f) in &kept {
            out.push(Contact {
                node: j as u32,
                face: f as u32,
                node_gid: b.nodes.gid[j],
                face_gid: b.faces.gid[f],
                xi: h.xi,
                normal: h.normal,
                depth: h.depth,
                radius: h.radius,
            });
        }
    }
    // Stable: a node's contacts stay deepest first.
    out.sort_by_key(|c| c.node_gid);
    out
}

/// Depths within this fraction of the face's diameter are a tie (`blend_tied_normals`).
pub const TIE_BAND: f64 = 1e-6;

/// Makes a node's contact continuous where its face wins a tie by round-off: a hit dropped as
/// the same contact as a kept one (one body, normals within [`SAME_NORMAL_COS`], the same side)
/// whose depth is within `TIE_BAND d` of the kept one's (d the kept face's diameter) lends the
/// kept contact its normal, with weight `1 - (depth_kept - depth) / (TIE_BAND d)`: at an exact
/// tie (a node on the edge between two faces of a slightly dimpled surface, at the bottom of a
/// dimple) the normal is the mean of the tied faces' whichever face the order puts first, and
/// it turns into the kept face's own continuously as the depths part. The depth becomes the
/// motion along that normal that leaves every fully lending face's plane, `max depth_f / (n_f .
/// n)` (the node at the bottom of a symmetric dimple `eps` below its corner: `eps`, straight
/// up), each lender's term weighted as its normal.
/// The kept contact's face and point stay.
fn blend_tied_normals(
    b: &ContactBox,
    hits: &[(pair::Hit, usize)],
    kept: &mut [(pair::Hit, usize)],
) {
    let mut lenders: Vec<(pair::Hit, f64)> = Vec::new();
    for kk in kept.iter_mut() {
        let (k, g) = (kk.0, kk.1);
        let band = TIE_BAND * b.quad(g, Config::End).diameter();
        lenders.clear();
        for &(h, f) in hits {
            let gap = k.depth - h.depth;
            if f == g || apart(b, g, f) || gap < 0.0 || gap >= band {
                continue;
            }
            if dot(k.normal, h.normal) < SAME_NORMAL_COS {
                continue; // another normal (kept on its own, or a valley's) or the other side
            }
            lenders.push((h, 1.0 - gap / band));
        }
        if lenders.is_empty() {
            continue;
        }
        let mut n = k.normal;
        for (h, w) in &lenders {
            for (nc, hc) in n.iter_mut().zip(h.normal) {
                *nc += w * hc;
            }
        }
        let len = dot(n, n).sqrt();
        let n = [n[0] / len, n[1] / len, n[2] / len];
        // each lender's term enters with its weight, so the depth too is continuous at the band
        let own = k.depth / dot(k.normal, n);
        let mut depth = own;
        for (h, w) in &lenders {
            depth = depth.max(own + w * (h.depth / dot(h.normal, n) - own));
        }
        kk.0.normal = n;
        kk.0.depth = depth;
    }
}

/// Whether the faces of two hits of one mesh node form a valley (a concave edge or corner, seen
/// from outside): each face's centre lies in front of the other's tangent plane at its contact
/// point. Only there does leaving one face leave the node behind the other; at a convex edge the
/// node is behind both planes yet needs to leave one face only, and a second contact would push
/// it out of both (a block landing on a plate node for node: each plate node under the block's
/// lower edge is also "behind" the block's side face and would be pushed sideways with the
/// block, its top moving 15 % less than over offset meshes).
pub(crate) fn valley(
    b: &ContactBox,
    (k, g): (&pair::Hit, usize),
    (h, f): (&pair::Hit, usize),
) -> bool {
    let (qg, qf) = (b.quad(g, Config::End), b.quad(f, Config::End));
    let in_front = |n: V3, at: V3, q: &Quad| dot(n, sub(q.point([0.0, 0.0]), at)) > 0.0;
    in_front(k.normal, qg.point(k.xi), &qf) && in_front(h.normal, qf.point(h.xi), &qg)
}

/// Whether faces `g` and `f` bound different bodies: a node must then be outside both (it is
/// inside their union when behind either), so each is a contact of its own, at any angle.
/// Without this rule, on `rod_wall`, a brick node at the rod's front face, next to the
/// neighbouring brick's side face ("convex" to the valley test, which reads two faces as one
/// body's surface), is pushed out of the brick's face and left 2.7e-5 m behind the rod's, past
/// the capture tolerance, and 1.3 mm inside the rod 0.2 ms later.
///
/// "At any angle" includes the angles [`SAME_NORMAL_COS`] reads as one surface, so this rule
/// is asked first: two bodies' faces with opposite normals are the two sides of a squeeze (a
/// node of the rod in the gap between two bricks' facing sides, a brick's corner between the
/// rod's face and the next brick's front at a junction of bodies), and keeping the deeper only
/// pushes the node out of one body by its depth there, into the other. On `rod_wall` (np 2),
/// asking the |cos| rule first drops about 800 such opposite pairs and 290 parallel ones (two
/// bricks' coplanar sides) over the run, left to the recheck after the push-back: 1,190
/// rechecked contacts against 529 with this rule first, and the deepest node inside another
/// body (frames 10 us apart) 7.3e-7 m against 9.4e-8 m.
pub(crate) fn apart(b: &ContactBox, g: usize, f: usize) -> bool {
    b.faces.body[g] != b.faces.body[f]
}

/// Two hits of one node on faces of one body whose normals' |cos| is at least this (within
/// about 25 degrees) are the same contact (coplanar or nearly coplanar faces; opposite ones are
/// the two sides of a body thinner than the capture tolerance, which a node leaves through one
/// side): only the deeper is kept. Faces of two bodies are two contacts whatever the angle
/// (`apart`).
pub const SAME_NORMAL_COS: f64 = 0.9;
