//! Push-back: kinematic contact (Taylor and Flanagan, PRONTO), with Coulomb friction.
//!
//! # Why kinematic, not penalty
//!
//! A kinematic method removes the penetration found at the end of the predicted step exactly, with
//! the impulse the masses involved require; it adds no stiffness, so it does not lower the explicit
//! stable step, needs no penalty parameter to tune per material, and leaves no penetration that
//! depends on one. A penalty spring stiff enough to keep penetration small would cut the stable step
//! (its frequency enters `2/omega_max`); a soft one lets bodies sink into each other. PRONTO-3D,
//! the code the design follows, uses the kinematic method for the same reasons.
//!
//! # The impulse of one contact
//!
//! Node `s` (mass `m_s`) is `d` behind face `f` at parametric point `xi`, normal `n`; the face's
//! corners `i` have masses `m_i` and shape functions `N_i(xi)`. Write the contact as the weights
//! `w_s = 1`, `w_i = -N_i` (they sum to zero because the `N_i` sum to one) on the node positions: the
//! gap along `n` is `g = n . sum_j w_j x_j`. A normal impulse `P` (N s) gives node `j` the position
//! correction `dx_j = w_j P dt n / m_j` over the step, so the gap grows by `P dt sum_j w_j^2 / m_j`.
//! Closing the penetration exactly:
//!
//! ```text
//!   lambda = P dt = d / (1/m_s + sum_i N_i^2 / m_i)        (kg m)
//!   F_j    = w_j lambda n / dt^2                           (N, force on node j over the step)
//! ```
//!
//! i.e. the node's mass against the face's mass seen at the contact point, `(sum_i N_i^2/m_i)^-1`
//! (a face whose four corners are one rigid mass `M` with the point at the centre sees `M`). The
//! forces sum to `lambda n (1 - sum_i N_i) / dt^2 = 0`: momentum is conserved to round-off. With the
//! corrections applied, the node lies on the corrected face at the same `xi` (the face position there
//! moves by `sum_i N_i dx_i`, exactly linear), so no penetration is left. A node with infinite mass
//! (prescribed motion) has `1/m = 0`: it takes the reaction and does not move.
//!
//! # Infinite masses on both sides
//!
//! A row's impulse `lambda` acts between its two sides, the node (positive weight) and the
//! face's corners (negative weights): between node `p` of one side and node `q` of the other
//! as `lambda w_p |w_q| / P`, `P` the sum of either side's weights in size. Where both nodes
//! of such a pair are infinite masses (a held node on a face whose corners are partly held:
//! two held bodies side by side, touching along their held faces), that part moves nothing
//! and cannot be measured, while `lambda` itself may be huge: the row moves only its free
//! corners, whose weights `N_i` may be round-off at a contact point on the face's held edge,
//! so `lambda = d / sum_i N_i^2 / m_i` is as large as round-off makes it (measured: a 20 mm
//! cube on a plate, both held on their common side face, 1.8 N of weight, the two held
//! groups' reactions 1e15 N and opposite; a held tank of five touching parts, 38 N of weight,
//! 1e16 N in its one group's, the round-off of such terms). So the
//! infinite masses' impulses leave that part out: an infinite mass takes `w` times the share
//! of the other side's weight that lies on nodes that can move, a node that can move its whole
//! `w` (`Row::with_reaction_weights`). The nodes that can move, and so the solve, are as
//! before; the infinite masses' impulses still balance theirs (momentum exact), now as the
//! force the free nodes actually carry. A row with one side wholly movable gives the other
//! side's infinite masses their whole share; a row with only infinite masses takes no impulse
//! ("Never energy out of contact").
//!
//! # Several contacts sharing nodes
//!
//! Several nodes on one face, or a node that is both a contact node and a face corner (two surfaces
//! crossing each other, self-contact), couple the impulses: `A lambda = d`, `lambda >= 0`, with
//! `A_kl = n_k . n_l sum_j w_kj w_lj / m_j` symmetric positive semidefinite. This is solved by
//! projected Gauss-Seidel: sweeps over the contacts in (node gid, face gid) order, each contact's
//! accumulated impulse updated from its current residual penetration and kept non-negative, until the
//! largest residual (penetration left, or separation where the impulse is positive) is at most
//! `tol` times the largest depth, or `max_sweeps`. A contact alone converges in one sweep. Every
//! update conserves momentum, so the result does at any sweep count.
//!
//! # A node on a node, found by both passes
//!
//! Node `s` of one surface pressed on node `p` of the other: the two-pass search describes the
//! one gap twice, `s` against a face around `p` with its contact point at `p` (normal `n1`) and
//! `p` against a face around `s` with its contact point at `s` (normal `n2`, about `-n1`, a
//! few degrees off where the surfaces curve). The two rows act on nearly the same nodes with
//! nearly the same weights, along directions a small angle `a` apart: Gauss-Seidel then
//! converges at `cos^2 a` per sweep (measured: 200 sweeps without converging on a ball landing
//! pole first on a plate node, the contact energy 1.6e-9 apart between rank counts where the
//! rest agreed to 1e-12), and both rows active hold the pair together sideways as well. Such a
//! mutual pair (one contact each way, each contact point within `same_point_tol` times its
//! face's diameter of the other node, the two normals opposite within `MUTUAL_OPPOSITE_COS`)
//! is one row: weights `(1, -1)` on `(s, p)`, the mean of the two surfaces' normals
//! `(n1 - n2) / |n1 - n2|`, the depth `n . (x_p - x_s)`. It takes the impulse of both
//! (reported on the first contact in (node gid, face gid) order, 0 on the other) and is
//! re-measured linearly (a node on a node needs no projection). Contacts near each other but
//! not at each other's nodes (meshes offset by a fraction of an element), and a node on a node
//! whose two normals are at an angle (two gaps, at a junction of bodies), are two independent
//! constraints and stay two rows.
//!
//! The system is linearised at the contact points and normals found by the search. With several
//! contacts on one warped face the corners move along several normals, so each node's contact
//! point also slides and a second-order penetration remains. So each contact is then re-measured
//! on the corrected geometry (the corrected node projected on the corrected face) and, if any
//! penetration above `tol` times the largest depth is left, the system is solved again for it at
//! the new points and normals (at most `MAX_GEOMETRIC_PASSES` passes; impulses only add). A lone
//! contact needs one pass: its node lands on the corrected face exactly. Redundant contacts (two
//! coincident surfaces, each node penetrating the other's face) share the impulse instead of
//! pushing twice. The answer depends only on the contacts handed in (sorted internally), never on
//! their order.
//!
//! # Sweeps in cells: one answer however the contacts are spread over ranks
//!
//! Gauss-Seidel's answer depends on the order of its updates, so a solve spread over ranks must
//! fix that order without reference to the ranks. Each contact has an *anchor* node ([`anchor`]:
//! its node, or for a contact point on a face corner the lower gid of the two, so both
//! contacts of a mutual pair share it) and a *reach* ([`reach`]: the farthest of its nodes from
//! the anchor, end positions). Space is cut into cubic cells of side `L > 2 R` ([`Cells`], `R`
//! the largest reach of the solve, origin 0), and a cell's *colour* is the parity of its three
//! indices (8 colours). Two contacts sharing a node have anchors less than `2 R < L` apart, so
//! their cells are the same or neighbours, and neighbouring cells differ in colour: **contacts
//! of one colour in different cells share no node**. A sweep takes the colours in turn, and in a
//! colour the cells in any order, each cell's contacts in (node gid, face gid) order. Every node
//! is then changed by one cell at most in each colour, so its accumulated impulse takes the same
//! sequence of values whichever cells are solved together and whichever first: a rank solving
//! some cells needs, after each colour, only the new values of the nodes it shares with other
//! ranks' cells ([`Exchange::sync`]), and the largest residuals over all ranks ([`Exchange::max`])
//! to stop where every rank stops. [`push_back`] is the solve alone ([`Alone`]); the coupling
//! layer runs [`push_back_in`] on each rank's cells.
//!
//! The state of a node is its accumulated impulse `I_j = sum_k w_kj lambda_k n_k` (kg m): its
//! force over the step is `I_j / dt^2` (an infinite mass takes it as its reaction) and its
//! position correction `I_j / m_j`, both functions of `I_j` alone, so ranks holding copies of a
//! node agree bit for bit.

//!
//! # Only the step's own penetration
//!
//! The search counts a node as having started outside a face when it started at most the
//! capture tolerance behind it (`gap_tol` of the face's diameter), so that a node push-back left
//! on a face at round-off stays in contact. Closing such a node's whole depth in one step would
//! also close what it had at the start: a correction `p0` that no motion of the step explains,
//! which leaves the pair separating at `p0 / dt` (measured on `container_crush`, np 2: a node
//! 9.8 um behind a face at the start, moving away from it, pushed out at 47 m/s through a
//! face whose other side rested on a fixed wall: 1.5 times the initial energy in one step).
//! So each row closes in all at most what the step explains: with `c = g0 - g1` the
//! penetration the step's motion made along it (`g = n . sum_j w_j x_j` the row's gap, at the
//! start `x0` and the predicted end `x1`) and `u` the approach speed at the step's start
//! (`-n . sum_j w_j v_j`, the records' start-of-step velocities),
//!
//! ```text
//!   d_used = min(d, max(c, min(2 c, 2 u dt)))      (0 where c < 0: moving apart)
//! ```
//!
//! - `c`: a node that started outside closes its whole depth (`d <= c`), whatever its
//!   acceleration (a node pressed onto a face from rest stops on it);
//! - `2 c`: with `d_used <= 2 c` the relative normal velocity after the correction lies
//!   between its predicted value and its reverse, so the kinetic energy of the predicted
//!   velocities, `dK = sum_k lambda_k (u_k + u'_k) / (2 dt)`, every `u_k + u'_k <= 0`, can
//!   only fall;
//! - `2 u dt`: the work the step's energy balance books for the correction,
//!   `sum m dv . (v(n) + dv / 2)` on the start velocities ([`PushBack::kinetic_energy_change`]), is then `<= 0`
//!   as well (an elastic reversal of the approach at most). A node resting on a face under a
//!   steady load approaches at `u = a dt / 2` and closes `c = a dt^2 = 2 u dt`: no more, so
//!   a held stack of touching parts is not pumped up by remainders it keeps recovering.
//!
//! A node that started inside (within the capture tolerance) keeps what the bound leaves of
//! its start penetration and takes it back over the following steps at most as fast as it
//! approaches; one moving away takes no impulse. The later geometric passes take from the same
//! budget what the earlier passes' corrections have already opened along the row.
//!
//! # Never energy out of contact
//!
//! The bound makes `dK <= 0` exact for the linearised rows; what the geometric passes and
//! friction leave is checked where the forces reach the bodies (the coupling layer scales a
//! step's contact forces down if they would add energy, and reports it). Rows none of whose
//! nodes can move (two prescribed surfaces touching from the start) take no impulse and are
//! counted ([`PushBack::immovable`]).
//!
//! # Friction
//!
//! After the normal impulses, each contact's tangential slip over the step is measured on the
//! corrected positions: `s = sum_j w_j (x1_j + dx_j - x0_j)`, its tangential part
//! `s_t = s - (s . n) n` (the node's motion relative to the face point it touches, m). The
//! tangential impulse that stops it (sticking) is `lambda_t = |s_t| / sum_j w_j^2 / m_j`, the
//! same mass weighting as the normal one; Coulomb's law bounds it by `mu lambda_n` (one
//! coefficient, static and kinetic, as PRONTO's), so a contact slips when the stopping impulse
//! would be larger, and then takes `mu lambda_n` against the slip. With several contacts sharing
//! nodes the tangential impulses are found by the same projected Gauss-Seidel sweeps, each
//! contact's accumulated tangential impulse kept inside its friction disc. The forces sum to
//! zero (the weights do), so momentum is conserved; the friction forces' work over the step is
//! part of [`PushBack::work`] (dissipated: it never adds energy, as the impulse opposes the
//! slip it reduces). Where the normal impulse is zero there is no friction.

use crate::data::{Config, ContactBox};
use crate::search::Contact;
use crate::shape;
use crate::vec3::{add, axpy, dot, norm, scale, sub, V3};

mod sweep;
use sweep::*;

/// Default [`PushBackParams::max_sweeps`].
pub const DEFAULT_MAX_SWEEPS: usize = 200;
/// Default [`PushBackParams::tol`].
pub const DEFAULT_TOL: f64 = 1e-12;
/// A row closes at most this many times the penetration the step made along it (module
/// documentation, "Only the step's own penetration"): 2 is an elastic impact's restitution.
const RESTITUTION_BOUND: f64 = 2.0;
/// Most geometric passes (solve linearised, re-measure on the corrected geometry, solve again).
const MAX_GEOMETRIC_PASSES: usize = 4;
/// Two contacts of a node on a node, one each way, are one gap seen from both sides (one row,
/// see the module documentation) only when their normals are opposite: `-n1 . n2` at least
/// this (within about 25 degrees, the search's bound for one surface,
/// [`crate::search::SAME_NORMAL_COS`]). Normals at an angle are two gaps: at a junction of
/// bodies, a brick's corner on the rod's face at the rod's node, which in turn is behind the
/// brick's side face at that corner. One row along their mean normal closes the pair's
/// separation along that mean only and leaves each contact open by the pair's offset across
/// it times the sine of half the angle. Measured on `rod_wall` (np 2) without this test: 598
/// such pairs over the run; one, normals 89.5 degrees apart, left a brick's corner
/// 3.1e-5 m behind the rod's face after the step's last solve, past the capture tolerance
/// (2.1e-5 m on that 15 mm face), and 1.65 mm inside the rod 50 us later.
const MUTUAL_OPPOSITE_COS: f64 = crate::search::SAME_NORMAL_COS;

/// How push-back is computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushBackParams {
    /// The time step over which the forces act, s.
    pub dt: f64,
    /// Most Gauss-Seidel sweeps.
    pub max_sweeps: usize,
    /// Stop when the largest residual is at most `tol` times the largest depth.
    pub tol: f64,
    /// Coulomb's friction coefficient (`[contact] friction`), >= 0.
    pub friction: f64,
    /// A contact point within this fraction of its face's diameter of a corner is at that node
    /// (two contacts of a node on a node, one each way, become one row: see the module
    /// documentation). The search's capture tolerance ([`crate::SearchParams::gap_tol`]).
    pub same_point_tol: f64,
}

impl PushBackParams {
    /// Defaults for step `dt`.
    pub fn new(dt: f64) -> Self {
        PushBackParams {
            dt,
            max_sweeps: DEFAULT_MAX_SWEEPS,
            tol: DEFAULT_TOL,
            friction: 0.0,
            same_point_tol: crate::search::DEFAULT_GAP_TOL,
        }
    }
}

/// The push-back of one box.
#[derive(Debug, Clone, PartialEq)]
pub struct PushBack {
    /// Contact force on each box node over the step, N, aligned with the box's nodes (zero where the
    /// node takes part in no contact). The driver adds `force / mass` to the node's acceleration;
    /// [`PushBack::contributions`] gives the same keyed by gid for summing to owners.
    pub force: Vec<V3>,
    /// Normal force of each contact, N, in the order of the contacts handed in (>= 0).
    pub normal_force: Vec<f64>,
    /// Work of the contact forces over the step, J: each force times the corrected displacement of
    /// its node over the step, `sum_j F_j . (x1_j + dx_j - x0_j)` with `dx_j = F_j dt^2 / m_j`
    /// (the work to add to `contact_energy`, with the sign flipped, in an energy balance). For a
    /// frictionless contact it is `-F_n` times the gap the pair closed during the step: zero while
    /// two surfaces stay together, negative at an impact.
    pub work: f64,
    /// Change of the kinetic energy `sum_j m_j |v_j|^2 / 2` of the records' start-of-step
    /// velocities `v` made by the correction, J: `sum_j F_j . (v_j + dv_j / 2) dt`, `dv_j = F_j
    /// dt / m_j`: in a central-difference scheme the work the step's energy balance books for
    /// the push-back (the correction of `v(n+1/2)` measured from `v(n)`). Not positive, but
    /// where a load presses a node that started outside onto a face faster than it approached
    /// (module documentation, "Only the step's own penetration"): second order in `dt`.
    pub kinetic_energy_change: f64,
    /// Gauss-Seidel sweeps done (all passes).
    pub sweeps: usize,
    /// Largest penetration left that the step made, m, measured on the corrected geometry
    /// (re-projected), or 0.
    pub max_residual: f64,
    /// Contacts none of whose nodes can move (two prescribed surfaces touching): skipped.
    pub immovable: usize,
    /// Contacts whose depth was more than the step's own penetration (the node started the
    /// step inside, within the capture tolerance): only the step's part was closed.
    pub bounded: usize,
}

impl PushBack {
    /// The nonzero forces keyed by node gid, sorted by gid (for a sum at the owners).
    pub fn contributions(&self, b: &ContactBox) -> Vec<(u64, V3)> {
        let mut out: Vec<(u64, V3)> = self
            .force
            .iter()
            .enumerate()
            .filter(|(_, f)| f.iter().any(|c| *c != 0.0))
            .map(|(j, f)| (b.nodes.gid[j], *f))
            .collect();
        out.sort_by_key(|e| e.0);
        out
    }

    /// The position correction of box node `j` over the step, `F dt^2 / m`, m.
    pub fn position_correction(&self, b: &ContactBox, j: usize, dt: f64) -> V3 {
        scale(self.force[j], dt * dt * inverse_mass(b.nodes.mass[j]))
    }
}

/// `1/m`, 0 for an infinite (prescribed-motion) mass.
fn inverse_mass(m: f64) -> f64 {
    if m.is_finite() {
        1.0 / m
    } else {
        0.0
    }
}

/// One contact as weights on node positions (repeated corners merged).
struct Row {
    nodes: [usize; 5],
    w: [f64; 5],
    len: usize,
    normal: V3,
    depth: f64,
    /// `sum_j w_j^2 / m_j`.
    inv_mass: f64,
    /// A mutual node-on-node pair's row (see the module documentation).
    node_on_node: bool,
    /// The weights with which the row's impulses reach the nodes' accumulated impulses:
    /// `w` at a node that can move, the transmitted part of `w` at an infinite mass (module
    /// documentation, "Infinite masses on both sides": [`Row::with_reaction_weights`]).
    rw: [f64; 5],
}

/// The corner of `c`'s face nearest its contact point, if that point lies within `tol` times
/// the face's diameter of it (end configuration): the box node.
fn corner_node(b: &ContactBox, c: &Contact, tol: f64) -> Option<usize> {
    let q = b.quad(c.face as usize, Config::End);
    let x = q.point(c.xi);
    let (k, d) = (0..4)
        .map(|k| (k, norm(sub(q.x[k], x))))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    (d <= tol * q.diameter()).then_some(b.faces.nodes[c.face as usize][k] as usize)
}

/// The mutual node-on-node pairs among `contacts` (see the module documentation), each as
/// (first, second) in `order`.
fn mutual_pairs(
    b: &ContactBox,
    contacts: &[Contact],
    order: &[usize],
    tol: f64,
) -> Vec<(usize, usize)> {
    // (node, corner) -> the contacts of that node at that corner, and each contact's corner.
    let mut at: std::collections::BTreeMap<(usize, usize), Vec<usize>> = Default::default();
    let mut corner = vec![None; contacts.len()];
    for &k in order {
        corner[k] = corner_node(b, &contacts[k], tol);
        if let Some(p) = corner[k] {
            at.entry((contacts[k].node as usize, p))
                .or_default()
                .push(k);
        }
    }
    let rank: Vec<usize> = {
        let mut r = vec![0; contacts.len()];
        for (i, &k) in order.iter().enumerate() {
            r[k] = i;
        }
        r
    };
    let mut pairs = Vec::new();
    for &k in order {
        let (s, Some(p)) = (contacts[k].node as usize, corner[k]) else {
            continue;
        };
        if let (Some(mine), Some(theirs)) = (at.get(&(s, p)), at.get(&(p, s))) {
            let m = theirs[0];
            let n = sub(contacts[k].normal, contacts[m].normal);
            let opposite = -dot(contacts[k].normal, contacts[m].normal) >= MUTUAL_OPPOSITE_COS;
            if mine.len() == 1
                && theirs.len() == 1
                && rank[k] < rank[m]
                && opposite
                && dot(n, n) > 0.0
            {
                pairs.push((k, m));
            }
        }
    }
    pairs
}

impl Row {
    /// A row that takes no impulse (the second contact of a mutual pair).
    fn inert() -> Row {
        Row {
            nodes: [0; 5],
            w: [0.0; 5],
            len: 0,
            normal: [0.0; 3],
            depth: 0.0,
            inv_mass: 0.0,
            node_on_node: false,
            rw: [0.0; 5],
        }
    }

    /// The row of the mutual pair `c` (node `s` at corner `p`) and `d` (node `p` at corner `s`),
    /// with the position corrections `dx` already made (or none).
    fn node_on_node(b: &ContactBox, c: &Contact, d: &Contact, dx: &[V3]) -> Row {
        let (s, p) = (c.node as usize, d.node as usize);
        let n = sub(c.normal, d.normal);
        let normal = scale(n, 1.0 / dot(n, n).sqrt());
        let mut r = Row {
            nodes: [s, p, 0, 0, 0],
            w: [1.0, -1.0, 0.0, 0.0, 0.0],
            len: 2,
            normal,
            depth: 0.0,
            inv_mass: inverse_mass(b.nodes.mass[s]) + inverse_mass(b.nodes.mass[p]),
            node_on_node: true,
            rw: [0.0; 5],
        };
        r.depth = r.gap_left(b, dx);
        r.with_reaction_weights(b).or_inert_if_massless(b)
    }

    /// A node-on-node row's penetration left with corrections `dx` (or none):
    /// `n . ((x_p + dx_p) - (x_s + dx_s))`.
    fn gap_left(&self, b: &ContactBox, dx: &[V3]) -> f64 {
        let at = |j: usize| match dx.get(j) {
            Some(d) => add(b.nodes.x1[j], *d),
            None => b.nodes.x1[j],
        };
        dot(self.normal, sub(at(self.nodes[1]), at(self.nodes[0])))
    }

    /// Contact `c` linearised at parametric point `xi` with `normal`, `depth` to close.
    fn new(b: &ContactBox, c: &Contact, xi: [f64; 2], normal: V3, depth: f64) -> Row {
        let mut r = Row {
            nodes: [0; 5],
            w: [0.0; 5],
            len: 0,
            normal,
            depth,
            inv_mass: 0.0,
            node_on_node: false,
            rw: [0.0; 5],
        };
        r.add(c.node as usize, 1.0);
        let n = shape(xi);
        for (k, &i) in b.faces.nodes[c.face as usize].iter().enumerate() {
            r.add(i as usize, -n[k]);
        }
        r.inv_mass = (0..r.len)
            .map(|k| r.w[k] * r.w[k] * inverse_mass(b.nodes.mass[r.nodes[k]]))
            .sum();
        r.with_reaction_weights(b).or_inert_if_massless(b)
    }

    /// The row with its reaction weights `rw` (module documentation, "Infinite masses on both
    /// sides"): the row's two sides are its nodes of positive weight (the contact node) and of
    /// negative weight (the face's corners), each side's weights summing to `P` in size; the
    /// row's impulse `lambda` acts between each node `p` of one side and each node `q` of the
    /// other as `lambda w_p |w_q| / P`. Between two infinite masses that part moves nothing
    /// and is not measurable: it is left out, so an infinite mass of one side takes `w` times
    /// the share `s` of the other side's weight on nodes that can move (`rw = s w`), and a
    /// node that can move takes its whole `w`. The impulses on the nodes that can move, and so
    /// the solve, are unchanged; the infinite masses' impulses still balance them (momentum
    /// exact). With one side wholly movable the infinite masses of the other keep their whole
    /// `w`; with every node of both sides infinite the row takes no impulse anyway.
    fn with_reaction_weights(mut self, b: &ContactBox) -> Row {
        let len = self.len;
        let held = |k: usize| !b.nodes.mass[self.nodes[k]].is_finite();
        let (mut pos, mut neg, mut pos_free, mut neg_free) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..len {
            let w = self.w[k];
            if w > 0.0 {
                pos += w;
                if !held(k) {
                    pos_free += w;
                }
            } else if w < 0.0 {
                neg -= w;
                if !held(k) {
                    neg_free -= w;
                }
            }
        }
        // The movable share of each side (1 where the side has no weight at all).
        let share = |free: f64, all: f64| if all > 0.0 { free / all } else { 1.0 };
        let (pos_share, neg_share) = (share(pos_free, pos), share(neg_free, neg));
        for k in 0..len {
            let w = self.w[k];
            self.rw[k] = if !held(k) {
                w
            } else if w > 0.0 {
                w * neg_share
            } else {
                w * pos_share
            };
        }
        self
    }

    /// The row, or an inert one where a node of it has no mass (a mesh node all of whose
    /// elements became particles: a point without inertia that neither pushes nor is pushed;
    /// a row through it would take momentum from its partners and give the node none).
    fn or_inert_if_massless(self, b: &ContactBox) -> Row {
        if self.nodes[..self.len]
            .iter()
            .any(|&n| b.nodes.mass[n] == 0.0)
        {
            Row::inert()
        } else {
            self
        }
    }

    /// The row's depth bounded by what the step explains (see the module documentation,
    /// "Only the step's own penetration"): with `c = n . sum_j w_j (x0_j - x1_j)` the
    /// penetration the step's motion made along the row and `s = -2 dt n . sum_j w_j v_j`
    /// twice the approach at the step's start, the row closes in all at most
    /// `max(c, min(2 c, s))`, of which `o = n . sum_j w_j dx_j` the corrections of earlier
    /// passes already opened. A depth `d <= 0` (a gap the row keeps, from a recheck) is left
    /// as it is. Returns the row and whether the bound cut its depth.
    fn bounded(mut self, b: &ContactBox, dx: &[V3], dt: f64) -> (Row, bool) {
        if self.depth <= 0.0 {
            return (self, false);
        }
        let (mut made, mut approach, mut opened) = (0.0, 0.0, 0.0);
        for q in 0..self.len {
            let j = self.nodes[q];
            let w = self.w[q];
            made += w * dot(self.normal, sub(b.nodes.x0[j], b.nodes.x1[j]));
            approach -= w * dot(self.normal, b.nodes.v[j]);
            if let Some(d) = dx.get(j) {
                opened += w * dot(self.normal, *d);
            }
        }
        let total = made.max((RESTITUTION_BOUND * made).min(RESTITUTION_BOUND * dt * approach));
        let most = (total - opened).max(0.0);
        // Counted only past round-off.
        let cut = most < self.depth * (1.0 - 1e-6);
        self.depth = self.depth.min(most);
        (self, cut)
    }

    /// Whether no node of the row can move (every mass infinite: two prescribed surfaces).
    fn immovable(&self) -> bool {
        self.len > 0 && self.inv_mass == 0.0
    }

    fn add(&mut self, node: usize, w: f64) {
        if let Some(k) = self.nodes[..self.len].iter().position(|&n| n == node) {
            self.w[k] += w;
        } else {
            self.nodes[self.len] = node;
            self.w[self.len] = w;
            self.len += 1;
        }
    }
}

/// Geometric penetration left by corrections `dx` for contact `c`: re-projects the corrected node
/// on the corrected face. Returns `(xi, normal, penetration)` (penetration < 0: a gap), or `None`
/// where the projection fails.
fn regauge(b: &ContactBox, c: &Contact, dx: &[V3]) -> Option<([f64; 2], V3, f64)> {
    let j = c.node as usize;
    let p = add(b.nodes.x1[j], dx[j]);
    let mut q = b.quad(c.face as usize, Config::End);
    for (k, &i) in b.faces.nodes[c.face as usize].iter().enumerate() {
        q.x[k] = add(q.x[k], dx[i as usize]);
    }
    let proj = q.closest_point(p)?;
    Some((proj.xi, proj.normal, c.radius - proj.signed_distance))
}

/// Number of cell colours ([`Cells::colour`]): the parities of three indices.
pub const COLOURS: usize = 8;

/// What a push-back spread over ranks needs from its neighbours (see the module documentation,
/// "Sweeps in cells"). The `contact` crate never talks to other ranks itself.
pub trait Exchange {
    /// The largest of `x` over every part of the solve (collective: every part calls it the same
    /// number of times).
    fn max(&mut self, x: f64) -> f64;
    /// After the contacts of `colour` were updated: the new accumulated impulses of the nodes
    /// this part shares with others' cells, from the part whose cell changed them (collective).
    fn sync(&mut self, colour: usize, impulse: &mut [V3]);
}

/// The solve in one piece: nothing to exchange.
pub struct Alone;

impl Exchange for Alone {
    fn max(&mut self, x: f64) -> f64 {
        x
    }
    fn sync(&mut self, _colour: usize, _impulse: &mut [V3]) {}
}

/// The cells of a solve: cubes of side `size`, origin 0 (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cells {
    /// Side, m.
    pub size: f64,
}

impl Cells {
    /// Cells for contacts reaching at most `reach` (m, the largest [`reach`] of the solve) from
    /// their anchors: side `2 reach` and a margin of 1e-6 of it (two anchors of contacts sharing a
    /// node are under `2 reach` apart, so their cell indices differ by at most one per axis).
    pub fn for_reach(reach: f64) -> Cells {
        Cells {
            size: (2.0 * reach * (1.0 + 1e-6)).max(f64::MIN_POSITIVE),
        }
    }

    /// The cell of point `x`.
    pub fn cell(&self, x: V3) -> [i64; 3] {
        std::array::from_fn(|a| (x[a] / self.size).floor() as i64)
    }

    /// The colour of cell `c`, in `0..COLOURS`.
    pub fn colour(c: [i64; 3]) -> usize {
        ((c[0] & 1) | (c[1] & 1) << 1 | (c[2] & 1) << 2) as usize
    }
}

/// The anchor of contact `c` in `b` (a box node): its node, or where its contact point lies on a
/// face corner (within `tol` of the face's diameter, [`PushBackParams::same_point_tol`]), the
/// lower gid of the node and that corner, so the two contacts of a mutual node-on-node pair share
/// their anchor and their cell.
pub fn anchor(b: &ContactBox, c: &Contact, tol: f64) -> usize {
    let s = c.node as usize;
    match corner_node(b, c, tol) {
        Some(p) if b.nodes.gid[p] < b.nodes.gid[s] => p,
        _ => s,
    }
}

/// The reach of contact `c` from box node `a`: the largest distance from `a` to the contact's
/// node and its face's corners, end positions, m.
pub fn reach(b: &ContactBox, c: &Contact, a: usize) -> f64 {
    let xa = b.nodes.x1[a];
    let corners = b.faces.nodes[c.face as usize].map(|i| i as usize);
    std::iter::once(c.node as usize)
        .chain(corners)
        .map(|j| norm(sub(b.nodes.x1[j], xa)))
        .fold(0.0, f64::max)
}

/// Computes the kinematic push-back of `contacts` (from [`crate::search()`] on the same box) over
/// step `params.dt`, in one piece. See the module documentation for the method.
pub fn push_back(b: &ContactBox, contacts: &[Contact], params: &PushBackParams) -> PushBack {
    let cell = cells_of(b, contacts, params.same_point_tol);
    push_back_in(b, contacts, &cell, params, &mut Alone)
}

/// The cell of each of `contacts` for a solve of these contacts alone: the cells sized by their
/// largest [`reach`], each contact's cell that of its [`anchor`] (`tol`:
/// [`PushBackParams::same_point_tol`]).
pub fn cells_of(b: &ContactBox, contacts: &[Contact], tol: f64) -> Vec<[i64; 3]> {
    let anchors: Vec<usize> = contacts.iter().map(|c| anchor(b, c, tol)).collect();
    let r = contacts
        .iter()
        .zip(&anchors)
        .fold(0.0, |m: f64, (c, &a)| m.max(reach(b, c, a)));
    let cells = Cells::for_reach(r);
    anchors.iter().map(|&a| cells.cell(b.nodes.x1[a])).collect()
}

/// The contacts in sweep order (colour, cell, node gid, face gid), and where each colour's run
/// ends in it.
fn sweep_order(contacts: &[Contact], cell: &[[i64; 3]]) -> (Vec<usize>, [usize; COLOURS]) {
    let key = |k: usize| {
        (
            Cells::colour(cell[k]),
            cell[k],
            contacts[k].node_gid,
            contacts[k].face_gid,
        )
    };
    let mut order: Vec<usize> = (0..contacts.len()).collect();
    order.sort_by_key(|&k| key(k));
    let ends = std::array::from_fn(|c| order.partition_point(|&k| Cells::colour(cell[k]) <= c));
    (order, ends)
}

/// The position corrections `I_j / m_j` of the accumulated impulses.
fn corrections(impulse: &[V3], inv_m: &[f64]) -> Vec<V3> {
    impulse
        .iter()
        .zip(inv_m)
        .map(|(i, &w)| scale(*i, w))
        .collect()
}

/// The rows re-linearised on the geometry corrected by `dx` (contacts whose row holds
/// nodes): each node-on-node row's gap left, each node-on-face row regauged on its face; all
/// bounded again (`bounded` marks those cut). Returns the largest penetration left, m.
fn relinearise(
    b: &ContactBox,
    contacts: &[Contact],
    rows: &mut [Row],
    bounded: &mut [bool],
    dx: &[V3],
    dt: f64,
) -> f64 {
    let mut left = 0.0f64;
    for (k, c) in contacts.iter().enumerate() {
        if rows[k].len == 0 {
            continue;
        }
        let row = if rows[k].node_on_node {
            let mut r = std::mem::replace(&mut rows[k], Row::inert());
            r.depth = r.gap_left(b, dx);
            r
        } else if let Some((xi, normal, pen)) = regauge(b, c, dx) {
            Row::new(b, c, xi, normal, pen)
        } else {
            continue;
        };
        let (row, cut) = row.bounded(b, dx, dt);
        bounded[k] |= cut;
        left = left.max(row.depth);
        rows[k] = row;
    }
    left
}

/// One part of a push-back spread over ranks (module documentation, "Sweeps in cells"): the
/// contacts of this part's cells, `cell[k]` the cell of contact `k` (of its anchor), the
/// neighbours through `ex`. With [`Alone`] and every contact's cell it is [`push_back`]. The
/// forces, normal forces and residuals are this part's; `work` and `kinetic_energy_change` sum
/// over this part's nodes (a node shared with another part is in both).
pub fn push_back_in(
    b: &ContactBox,
    contacts: &[Contact],
    cell: &[[i64; 3]],
    params: &PushBackParams,
    ex: &mut dyn Exchange,
) -> PushBack {
    let (order, ends) = sweep_order(contacts, cell);
    let inv_m: Vec<f64> = b.nodes.mass.iter().map(|&m| inverse_mass(m)).collect();
    let max_depth = ex.max(contacts.iter().fold(0.0, |a: f64, c| a.max(c.depth)));
    let limit = params.tol * max_depth;
    let mut rows: Vec<Row> = contacts
        .iter()
        .map(|c| Row::new(b, c, c.xi, c.normal, c.depth))
        .collect();
    for &(k, m) in &mutual_pairs(b, contacts, &order, params.same_point_tol) {
        rows[k] = Row::node_on_node(b, &contacts[k], &contacts[m], &[]);
        rows[m] = Row::inert();
    }
    let immovable = rows.iter().filter(|r| r.immovable()).count();
    let mut bounded = vec![false; rows.len()];
    for (r, cut) in rows.iter_mut().zip(bounded.iter_mut()) {
        let (row, c) = std::mem::replace(r, Row::inert()).bounded(b, &[], params.dt);
        *r = row;
        *cut = c;
    }
    let mut impulse = vec![[0.0; 3]; b.nodes.len()];
    let mut total_lambda = vec![0.0; contacts.len()];
    let mut sweeps = 0;
    let mut max_residual = max_depth;
    for _ in 0..MAX_GEOMETRIC_PASSES {
        // Linear complementarity by projected Gauss-Seidel, from the gaps measured at the start
        // of this pass (the impulses of earlier passes are already in `impulse`).
        let mut lambda = vec![0.0; rows.len()];
        let start = impulse.clone();
        let pass = Pass {
            rows: &rows,
            start: &start,
            inv_m: &inv_m,
        };
        let mut linear_residual = ex.max(pass.residual(&lambda, &impulse));
        let mut pass_sweeps = 0;
        while pass_sweeps < params.max_sweeps && linear_residual > limit {
            for (colour, range) in colour_ranges(&ends).enumerate() {
                for &k in &order[range] {
                    pass.update(k, &mut lambda, &mut impulse);
                }
                ex.sync(colour, &mut impulse);
            }
            pass_sweeps += 1;
            linear_residual = ex.max(pass.residual(&lambda, &impulse));
        }
        sweeps += pass_sweeps;
        for (t, l) in total_lambda.iter_mut().zip(&lambda) {
            *t += l;
        }
        // Measure the penetration left on the corrected geometry; re-linearise there.
        let dx = corrections(&impulse, &inv_m);
        let left = relinearise(b, contacts, &mut rows, &mut bounded, &dx, params.dt);
        max_residual = ex.max(left);
        if max_residual <= limit {
            break;
        }
    }
    if params.friction > 0.0 {
        let sweep = Sweep {
            order: &order,
            ends: &ends,
        };
        sweeps += friction(
            b,
            &rows,
            sweep,
            &total_lambda,
            params,
            &inv_m,
            &mut impulse,
            ex,
        );
    }
    let inv_dt2 = 1.0 / (params.dt * params.dt);
    let force: Vec<V3> = impulse.iter().map(|i| scale(*i, inv_dt2)).collect();
    let mut work = 0.0;
    let mut kinetic_energy_change = 0.0;
    for (j, f) in force.iter().enumerate() {
        let dv = scale(*f, params.dt * inv_m[j]);
        kinetic_energy_change += dot(*f, add(b.nodes.v[j], scale(dv, 0.5))) * params.dt;
        let moved = add(
            sub(b.nodes.x1[j], b.nodes.x0[j]),
            scale(impulse[j], inv_m[j]),
        );
        work += dot(*f, moved);
    }
    PushBack {
        force,
        normal_force: total_lambda.iter().map(|l| l * inv_dt2).collect(),
        work,
        kinetic_energy_change,
        sweeps,
        max_residual,
        immovable,
        bounded: bounded.iter().filter(|&&c| c).count(),
    }
}
