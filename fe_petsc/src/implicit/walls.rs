//! Rigid walls in implicit mode: an active set of nodes held on each plane inside the Newmark
//! step.
//!
//! **The constraint.** A node in contact with wall k (point `p_k(t)`, unit normal `n_k` towards
//! the bodies, velocity `W_k`) ends the step on the plane: `n_k . (x(n) + du) = n_k . p_k(t(n+1))`.
//! Its increment's normal part is prescribed and the rest stays free, as a symmetry plane's
//! with a prescribed offset ([`NodeDof::Walled`]). With symmetry planes at the same node the
//! constrained directions are made orthonormal by Gram-Schmidt, the planes first; a wall normal
//! that is a combination of the earlier ones adds nothing.
//!
//! **The active set** (Wriggers, *Computational Contact Mechanics*, 2nd ed. 2006, §6.3.2):
//! Newton converges with the set fixed; then a node behind a wall outside the set joins it, and
//! a node the wall pulls leaves it: a frictionless wall, its normal reaction at the step's end
//! (with the velocity update's part) below `-rtol F`, the Newton tolerance; a wall with
//! friction, its normal impulse over the step (the trapezoid of its reaction plus the velocity
//! update's part) below `-rtol F dt`. Newton runs again from the converged increment until the
//! set stands, at most [`MAX_ROUNDS`] times. A node whose state changed twice in the step only
//! joins after that (it stays on every wall it was on): a node landing with a small speed can be such that the
//! trapezoidal rule neither holds it on the plane without a pull nor lets it go without passing
//! it; it is then held, and the wall pulls it for that step. The set at a step's start is the
//! last step's. With friction the release looks at the impulse and not at the reaction at the
//! step's end: the trapezoidal rule does not damp a body's modes much faster than the step, so
//! the end reaction of a node held on a wall can alternate about its mean from step to step (a
//! block whose weight comes at once: between nought and twice its weight), and where
//! friction's moment lowers the mean (the rear edge of a sliding block: 10 % of the mean
//! pressure on a 20 mm cube with mu = 0.3) every other end dipped below zero, let those nodes
//! go, their friction with them, and landed them again the next step: a chatter that never
//! settled (with the friction below, the floor held that cube in 32 % of the steps at
//! dt = 2e-5 s and it slid 8 % slow). The impulse is what the step's momentum sees. A
//! frictionless wall keeps the end reaction, which releases a step earlier (the 1D impact's
//! bar leaves 2.3 steps after 2 L / c, 3.3 by the impulse). Every copy of a node
//! holds the same bits, so every rank takes the same decisions; the rounds are agreed
//! collectively.
//!
//! **Velocity.** A node in contact leaves the step with the wall's normal velocity, `n_k . v =
//! n_k . W_k`, and no normal acceleration relative to it (the wall's mean velocity over the
//! step is constant): Newmark's own update would send a node that arrives with speed `u` away
//! with about `u` and make a persistent contact ring (Laursen & Love, Int. J. Numer. Meth.
//! Engng 53, 2002, 245-274, §2). This is the inelastic arrival of the explicit wall
//! (`contact::Wall::correction`).
//!
//! **Friction** (`friction` mu > 0; Coulomb's law in its stick/slip split, Wriggers 2006 §5.2):
//! a node in contact sticks or slips, a second set beside the first. A sticking node moves with
//! the wall along the plane too (its tangential increment `W dt` and velocity `W` prescribed:
//! three constrained directions). A slipping node is free along the plane, and the force of
//! sliding friction is part of the equation of motion that Newton solves and that the
//! trapezoidal rule integrates ([`ImplicitFe::add_wall_friction`]):
//!
//! ```text
//! M a(n+1) = f(u(n+1)) + M g + R(n+1) + F(n+1),    F(n+1) = mu N(n+1) d
//! ```
//!
//! with `N(n+1) = -n_k . (f + M g)_k` wall k's normal force at the step's end at the present
//! iterate (its part of the constraint force, as booked) and `d` friction's unit direction,
//! fixed over the step: against the slip relative to the wall at the step's start, for a node
//! that starts to slip in the step along the tangential impulse that held it while it stuck,
//! for one that lands against its slip then. The step's friction impulse is the trapezoid
//! `dt/2 (F(n) + F(n+1)) = mu dt/2 (N(n) + N(n+1)) d`, mu times the wall's normal impulse from
//! its forces; the velocity update's normal impulse `J_u` (a landing's) is not a force, and its
//! friction `mu J_u` changes the velocity at the step's end (slowing the slip to zero at most).
//! So each step's friction impulse is mu times the wall's normal impulse, and the acceleration
//! holds the friction: Newmark's `du`, `v` and `a` agree. `N(n+1)` is not clipped at zero (a
//! node the wall pulls at the step's end but not over it, which the release keeps, brakes less
//! in that step): clipping each end makes the friction exceed mu times the impulse where the
//! end forces alternate (+3 % of the friction on the 20 mm cube). A slipping node whose slip
//! at the step's end (Newmark's velocity) has turned round along `d` stopped in the step: it
//! sticks (and slips again if the cone cannot hold it). A node comes into contact slipping when
//! it moves along the wall, else sticking. After Newton: a sticking node whose tangential
//! impulse over the step exceeds `mu` times its normal impulse slips, and a sticking node the
//! wall pulls slips before it may leave. The tangent leaves out friction's dependence on the
//! normal force (`mu d (n^T K)`, not symmetric): Newton converges linearly at a rate of about
//! mu times the coupling between the slip and the normal forces (measured: 11-12 iterations a
//! step for a 20 mm cube sliding on a floor, 2 without friction).
//!
//! Before, the friction acted on the velocity after Newton only (a slipping node's position over
//! the step the frictionless one, its acceleration without friction): the next step's
//! trapezoid started from an acceleration that did not match the velocity, each step kicked the
//! sliding nodes alone, and the block rocked on its front edge and chattered (the cube
//! accelerated at 3.50 m/s^2 where Coulomb gives 2.356, and its elements inverted at
//! dt = 2e-4 s).
//!
//! **Impulse and energy.** Wall k's impulse over the step is the trapezoid of its reaction
//! (friction's force included) plus what the velocity update changed along it,
//! `J_k = sum dt/2 (R_k(n) + R_k(n+1)) + (m (v(n+1) - v_N(n+1)))_k` over the owned nodes
//! (`v_N`: Newmark's velocity), so the bodies' momentum changes by the impulses of all forces
//! exactly. The energy the walls took in the step is
//! what the other forces' work leaves unexplained in the kinetic energy of the nodes in contact
//! at either end of the step: `dE = sum (F'(n) + F'(n+1))/2 . du - dK`, with
//! `F' = f + m g + R'` the forces other than the walls' (zero for a node resting on a wall at rest: there `du`
//! and the wall's force are orthogonal; `1/2 m u^2` for an arrival at speed `u`). A moving
//! wall's own work `W_k . J_k` is booked by the caller, as in explicit mode.
use super::*;
use crate::exact::{self as exact_sum, Folds};

/// Most solves of one step while its set of nodes in contact changes.
pub const MAX_ROUNDS: u32 = 20;
/// Changes of one node's contact state within a step before it only joins (module doc).
const MAX_CHANGES: u8 = 2;
/// A wall normal whose part outside the earlier constrained directions is below this (relative)
/// adds no constraint.
const DEPENDENT: f64 = 1e-6;

/// A rigid wall as it stands over one implicit step: its plane at the step's end and the
/// velocity it moves at through the step.
#[derive(Debug, Clone, Copy)]
pub struct WallPlane {
    /// A point of the plane at t(n+1), m.
    pub point: [f64; 3],
    /// The unit normal, towards the bodies.
    pub normal: [f64; 3],
    /// The wall's (mean) velocity over the step, m/s.
    pub velocity: [f64; 3],
    /// Coulomb's coefficient between the wall and the nodes on it.
    pub friction: f64,
}

/// The rigid walls of an implicit run and the nodes in contact with them.
pub(super) struct WallSet {
    /// The walls over the present step (set by [`ImplicitFe::set_wall_planes`]).
    planes: Vec<WallPlane>,
    /// Each local node's constraint without walls.
    base: Vec<NodeDof>,
    /// The symmetry-plane normals of the nodes that have them.
    plane_normals: std::collections::HashMap<usize, Vec<[f64; 3]>>,
    /// The step, s.
    dt: f64,
    /// Each local node's walls in contact (bit k: wall k), now and at the step's start.
    pub(super) active: Vec<u32>,
    active_n: Vec<u32>,
    /// Each local node's walls with friction on which it slips (bit k); it sticks to the
    /// others it is in contact with.
    slip: Vec<u32>,
    /// How often each node's contact state changed in the present step.
    changes: Vec<u8>,
    /// Wall k's reaction on node n at the accepted state and at the step's start, `[n * nw + k]`.
    force: Vec<[f64; 3]>,
    force_n: Vec<[f64; 3]>,
    /// Friction's unit direction on each node slipping on wall k in the present step (against
    /// its slip; zero: not yet chosen), `[n * nw + k]` ([`WallSet::start_direction`]).
    dir: Vec<[f64; 3]>,
    /// Friction's force on each node slipping on wall k at the present iterate, `[n * nw + k]`,
    /// and its sum over the walls per node.
    friction: Vec<[f64; 3]>,
    node_friction: Vec<[f64; 3]>,
    /// The (node, wall) pairs slipping with friction, as Newton sees them ([`Slipping`]).
    slipping: Vec<Slipping>,
    /// This rank's sums of the step: [energy taken, then per wall impulse x, y, z].
    folds: Vec<Folds>,
    /// The last step's global results: each wall's impulse (N s) and the energy taken (J).
    pub(super) impulse: Vec<[f64; 3]>,
    pub(super) energy: f64,
    /// Solves repeated because the set changed, over the run.
    pub(super) rounds: u64,
}

/// A node slipping on a wall with friction, for Newton's residual
/// ([`ImplicitFe::add_wall_friction`]).
struct Slipping {
    node: usize,
    wall: usize,
    /// The constrained direction the wall owns at the node (its normal after Gram-Schmidt) and
    /// its dot with the wall's normal: the wall's normal force is `(e . r)(e . n)` for the
    /// node's constraint force `r`.
    e: [f64; 3],
    en: f64,
    /// Friction's unit direction (against the slip, in the node's free directions) and
    /// Coulomb's coefficient.
    dir: [f64; 3],
    mu: f64,
}

/// The constrained directions of one node: an orthonormal basis, the constraint each vector
/// belongs to (`u32::MAX`: a symmetry plane, else the wall), and the constrained parts of the
/// increment and of the velocity.
struct Basis {
    e: [[f64; 3]; 3],
    owner: [u32; 3],
    len: usize,
    du: [f64; 3],
    v: [f64; 3],
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|c| a[c] - b[c])
}

/// Coulomb's change of the velocity `v` of a node of mass `m` slipping on `plane` for the
/// normal impulse `imp`'s normal part `J_n` (the velocity update's: a landing's): the slip
/// relative to the wall, `s`, is reduced by `mu J_n / m`, to zero at most (then the node has
/// stopped on the wall); a negative `J_n` (the update took back part of the normal impulse
/// whose friction Newton's force gave) adds its `mu |J_n| / m` back.
fn friction_change(plane: WallPlane, imp: [f64; 3], v: [f64; 3], m: f64) -> [f64; 3] {
    let jn = dot(imp, plane.normal);
    let s = tangential(sub(v, plane.velocity), plane.normal);
    let speed = norm(s);
    if speed == 0.0 {
        return [0.0; 3];
    }
    let dv = (plane.friction * jn / m).min(speed);
    if dv == speed {
        return s.map(|x| -x);
    }
    s.map(|x| -x * dv / speed)
}

/// `w` less its part along the unit `n`.
fn tangential(w: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    let d = dot(w, n);
    std::array::from_fn(|c| w[c] - d * n[c])
}

/// Two unit vectors orthogonal to the unit `n` and to each other: `t1` from the axis least
/// along `n`, `t2 = n x t1`.
fn tangents_of(n: [f64; 3]) -> [[f64; 3]; 2] {
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut a = [0.0; 3];
    a[k] = 1.0;
    let t = tangential(a, n);
    let t1 = t.map(|x| x / norm(t));
    let t2 = [
        n[1] * t1[2] - n[2] * t1[1],
        n[2] * t1[0] - n[0] * t1[2],
        n[0] * t1[1] - n[1] * t1[0],
    ];
    [t1, t2]
}

impl Basis {
    /// Gram-Schmidt over the constraints `(normal, increment target, velocity target, owner)`:
    /// `e_j = (n_j - sum_{i<j} (n_j . e_i) e_i) / |...|` and the constrained parts `c = sum
    /// beta_j e_j` with `n_j . c = target_j`, i.e. `beta_j = (target_j - sum_{i<j} (n_j . e_i)
    /// beta_i) / (n_j . e_j)`.
    fn new(constraints: impl Iterator<Item = ([f64; 3], f64, f64, u32)>) -> Basis {
        let mut b = Basis {
            e: [[0.0; 3]; 3],
            owner: [u32::MAX; 3],
            len: 0,
            du: [0.0; 3],
            v: [0.0; 3],
        };
        let (mut beta_du, mut beta_v) = ([0.0; 3], [0.0; 3]);
        for (n, t_du, t_v, owner) in constraints {
            if b.len == 3 {
                break;
            }
            let proj: Vec<f64> = (0..b.len).map(|i| dot(n, b.e[i])).collect();
            let mut r = n;
            for i in 0..b.len {
                for c in 0..3 {
                    r[c] -= proj[i] * b.e[i][c];
                }
            }
            let norm = dot(r, r).sqrt();
            if norm <= DEPENDENT * dot(n, n).sqrt() {
                continue;
            }
            let j = b.len;
            b.e[j] = r.map(|x| x / norm);
            b.owner[j] = owner;
            let ne = dot(n, b.e[j]);
            beta_du[j] = (t_du - (0..j).map(|i| proj[i] * beta_du[i]).sum::<f64>()) / ne;
            beta_v[j] = (t_v - (0..j).map(|i| proj[i] * beta_v[i]).sum::<f64>()) / ne;
            b.len += 1;
        }
        for j in 0..b.len {
            for c in 0..3 {
                b.du[c] += beta_du[j] * b.e[j][c];
                b.v[c] += beta_v[j] * b.e[j][c];
            }
        }
        b
    }

    /// `I - sum e e^T`.
    fn projection(&self) -> [[f64; 3]; 3] {
        let mut p = [[0.0; 3]; 3];
        for (i, row) in p.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        for e in &self.e[..self.len] {
            for i in 0..3 {
                for j in 0..3 {
                    p[i][j] -= e[i] * e[j];
                }
            }
        }
        p
    }

    /// The part of `w` along the constraint directions that belong to wall `k`.
    fn part_of(&self, k: u32, w: [f64; 3]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for j in 0..self.len {
            if self.owner[j] == k {
                let s = dot(self.e[j], w);
                for c in 0..3 {
                    out[c] += s * self.e[j][c];
                }
            }
        }
        out
    }
}

impl WallSet {
    fn nw(&self) -> usize {
        self.impulse.len()
    }

    /// Node `n`'s constraint without the walls.
    pub(super) fn base(&self, n: usize) -> &NodeDof {
        &self.base[n]
    }

    /// The constrained directions of node `n` with the walls in `bits`, at start position `x`:
    /// its symmetry planes, the walls' normals, then the tangents of those it sticks to.
    fn basis(&self, n: usize, bits: u32, x: [f64; 3]) -> Basis {
        let planes = self.plane_normals.get(&n).map_or(&[][..], |v| &v[..]);
        let on: Vec<usize> = (0..self.planes.len())
            .filter(|&k| bits >> k & 1 == 1)
            .collect();
        let normals = on.iter().map(|&k| {
            let w = &self.planes[k];
            let gap: [f64; 3] = std::array::from_fn(|c| w.point[c] - x[c]);
            (
                w.normal,
                dot(w.normal, gap),
                dot(w.normal, w.velocity),
                k as u32,
            )
        });
        let sticking = on
            .iter()
            .filter(|&&k| self.planes[k].friction > 0.0 && self.slip[n] >> k & 1 == 0);
        let tangents = sticking.flat_map(|&k| {
            let w = &self.planes[k];
            tangents_of(w.normal).map(|t| {
                let wt = dot(t, w.velocity);
                (t, wt * self.dt, wt, k as u32)
            })
        });
        Basis::new(
            planes
                .iter()
                .map(|&n| (n, 0.0, 0.0, u32::MAX))
                .chain(normals)
                .chain(tangents),
        )
    }

    /// Friction's direction on node `n` slipping on wall `k` at the step's start: against its
    /// slip relative to the wall, `-(v - W)_t`; without slip, along the friction it had then
    /// (the tangential part of its wall force). Not normalised.
    fn start_direction(&self, n: usize, k: usize, v: [f64; 3]) -> [f64; 3] {
        let plane = self.planes[k];
        let s = tangential(sub(v, plane.velocity), plane.normal);
        if s != [0.0; 3] {
            return s.map(|x| -x);
        }
        tangential(self.force_n[n * self.nw() + k], plane.normal)
    }

    /// Wall k's force on a node in contact whose other forces are `f + m g` (the accepted
    /// acceleration has no part along the constrained directions): its part of `-(f + m g)`.
    fn reaction(&self, basis: &Basis, k: usize, f_mg: [f64; 3]) -> [f64; 3] {
        basis.part_of(k as u32, f_mg.map(|x| -x))
    }
}

impl WallSet {
    /// The step from now on, s ([`ImplicitFe::set_dt`]).
    pub(super) fn set_dt(&mut self, dt: f64) {
        self.dt = dt;
    }
}

impl ImplicitFe {
    /// Rigid walls for this run (`n` of them, at most 32); their planes are set before each
    /// step ([`ImplicitFe::set_wall_planes`]).
    pub fn set_walls(&mut self, n: usize) {
        assert!(n <= 32, "at most 32 rigid walls in implicit mode");
        let nn = self.n_nodes();
        self.walls = Some(Box::new(WallSet {
            planes: Vec::new(),
            dt: self.dt,
            base: self.dofs.clone(),
            plane_normals: std::mem::take(&mut self.plane_normals),
            active: vec![0; nn],
            active_n: vec![0; nn],
            slip: vec![0; nn],
            changes: vec![0; nn],
            force: vec![[0.0; 3]; nn * n],
            force_n: vec![[0.0; 3]; nn * n],
            dir: vec![[0.0; 3]; nn * n],
            friction: vec![[0.0; 3]; nn * n],
            node_friction: vec![[0.0; 3]; nn],
            slipping: Vec::new(),
            folds: vec![[0.0; 3]; 1 + 3 * n],
            impulse: vec![[0.0; 3]; n],
            energy: 0.0,
            rounds: 0,
        }));
    }

    /// The walls over the next step, in the order of [`ImplicitFe::set_walls`].
    pub fn set_wall_planes(&mut self, planes: Vec<WallPlane>) {
        if let Some(w) = self.walls.as_mut() {
            assert_eq!(planes.len(), w.nw());
            w.planes = planes;
        }
    }

    /// The last step's impulse of each wall on the bodies (N s) and the energy the walls took
    /// (J), global; `None` without walls.
    pub fn wall_step(&self) -> Option<(&[[f64; 3]], f64)> {
        self.walls.as_ref().map(|w| (&w.impulse[..], w.energy))
    }

    /// Solves repeated because a set of nodes in contact changed, over the run.
    pub fn wall_rounds(&self) -> u64 {
        self.walls.as_ref().map_or(0, |w| w.rounds)
    }

    /// The nodes' constraints with their walls in contact (the set of [`WallSet::active`]),
    /// and the nodes slipping with friction with friction's direction on each.
    pub(super) fn apply_walls(&mut self) {
        let Some(w) = self.walls.as_mut() else {
            return;
        };
        let nw = w.nw();
        w.slipping.clear();
        w.friction.fill([0.0; 3]);
        w.node_friction.fill([0.0; 3]);
        for n in 0..self.dofs.len() {
            if matches!(w.base[n], NodeDof::Prescribed(_)) {
                continue;
            }
            self.dofs[n] = match w.active[n] {
                0 => w.base[n],
                bits => {
                    let b = w.basis(n, bits, self.fe.x[n]);
                    let p = b.projection();
                    for k in 0..nw {
                        let plane = w.planes[k];
                        if (bits & w.slip[n]) >> k & 1 == 0 || plane.friction <= 0.0 {
                            continue;
                        }
                        let i = n * nw + k;
                        if w.dir[i] == [0.0; 3] {
                            w.dir[i] = w.start_direction(n, k, self.fe.v[n]);
                        }
                        // In the node's free directions (a corner's other walls and its
                        // symmetry planes hold the rest), of unit length.
                        let d = mat3_vec(&p, &w.dir[i]);
                        let l = norm(d);
                        w.dir[i] = if l > 0.0 { d.map(|x| x / l) } else { [0.0; 3] };
                        let Some(j) = (0..b.len).find(|&j| b.owner[j] == k as u32) else {
                            continue;
                        };
                        if l > 0.0 {
                            w.slipping.push(Slipping {
                                node: n,
                                wall: k,
                                e: b.e[j],
                                en: dot(b.e[j], plane.normal),
                                dir: w.dir[i],
                                mu: plane.friction,
                            });
                        }
                    }
                    NodeDof::Walled {
                        p,
                        du: b.du,
                        v: b.v,
                    }
                }
            };
        }
    }

    /// Adds Coulomb's force of sliding to the residual `r = M (a - g) - f` of every node
    /// slipping on a wall with friction, at the present iterate (module doc, Friction):
    /// `M (a - g) = f + F + R` with `F = mu N d`, `d` friction's unit direction in the free
    /// directions (`(I - P) F = 0`: the constraint forces stay as they were), and `N` wall k's
    /// normal force at the step's end as `book_wall_node` books it, its part of `-(f + M g)`
    /// (the accepted acceleration has no part along the constrained directions; a landing's
    /// inertia is the velocity update's impulse, whose friction acts on the velocity):
    /// `N = -(e_k . (f + M g))(e_k . n_k)`, `e_k` the direction it owns. A negative `N` (pulled
    /// at the step's end but not over the step) is kept, so that the step's friction impulse
    /// is mu times its normal impulse. The residual becomes `r - F`.
    pub(super) fn add_wall_friction(&mut self) {
        let Some(w) = self.walls.as_mut() else {
            return;
        };
        let nw = w.nw();
        for s in &w.slipping {
            w.node_friction[s.node] = [0.0; 3];
        }
        // Every node's friction, then its residual.
        for s in &w.slipping {
            let (f, m, g) = (self.force[s.node], self.fe.mass[s.node], self.gravity);
            let normal = -s.en * dot(s.e, std::array::from_fn(|c| f[c] + m * g[c]));
            let f = s.dir.map(|d| s.mu * normal * d);
            w.friction[s.node * nw + s.wall] = f;
            let sum = &mut w.node_friction[s.node];
            *sum = std::array::from_fn(|c| sum[c] + f[c]);
        }
        // Once per node (the list is in node order; a node slipping on two walls is in it
        // twice).
        let mut last = usize::MAX;
        for s in &w.slipping {
            if s.node != last {
                let (r, f) = (&mut self.residual[s.node], w.node_friction[s.node]);
                *r = std::array::from_fn(|c| r[c] - f[c]);
                last = s.node;
            }
        }
    }

    /// After Newton converged: nodes behind a wall join its set, nodes it pulls by more than
    /// `tol` (N) leave it, and the nodes on walls with friction stick or slip (module doc).
    /// Returns whether any set changed on any rank (collective).
    pub(super) fn update_wall_sets(&mut self, comm: &SimpleCommunicator, tol: f64) -> bool {
        if self.walls.is_none() {
            return false;
        }
        let mut changed = 0i32;
        let nw = self.walls.as_ref().expect("walls").nw();
        let mut dirs = vec![[0.0; 3]; nw];
        for n in 0..self.du.len() {
            let w = self.walls.as_ref().expect("walls");
            if matches!(w.base[n], NodeDof::Prescribed(_)) {
                continue;
            }
            dirs.copy_from_slice(&w.dir[n * nw..(n + 1) * nw]);
            let (bits, slip) = self.node_sets(n, tol, &mut dirs);
            let w = self.walls.as_mut().expect("walls");
            let (mut bits, mut slip) = (bits, slip);
            if (bits, slip) != (w.active[n], w.slip[n]) && w.changes[n] >= MAX_CHANGES {
                // A node that keeps changing within the step (a landing the trapezoidal rule
                // can neither hold without a pull nor leave without passing): it stays on
                // every wall it was on, slipping where it slipped.
                bits |= w.active[n];
                slip |= w.slip[n];
            }
            if (bits, slip) != (w.active[n], w.slip[n]) {
                w.changes[n] = w.changes[n].saturating_add(1);
                w.active[n] = bits;
                w.slip[n] = slip;
                w.dir[n * nw..(n + 1) * nw].copy_from_slice(&dirs);
                changed = 1;
            }
        }
        let mut any = 0;
        comm.all_reduce_into(&changed, &mut any, SystemOperation::max());
        let w = self.walls.as_mut().expect("walls");
        if any > 0 {
            w.rounds += 1;
        }
        any > 0
    }

    /// Node `n`'s walls in contact and walls it slips on after a converged solve (the rules of
    /// [`ImplicitFe::update_wall_sets`]); writes friction's direction on the walls it starts
    /// to slip on into `dirs` (not normalised).
    fn node_sets(&self, n: usize, tol: f64, dirs: &mut [[f64; 3]]) -> (u32, u32) {
        let w = self.walls.as_ref().expect("walls");
        let nw = w.nw();
        let (dt, m, g) = (self.dt, self.fe.mass[n], self.gravity);
        let (x, du, v, a, f) = (
            self.fe.x[n],
            self.du[n],
            self.fe.v[n],
            self.fe.a[n],
            self.force[n],
        );
        let (mut bits, mut slip) = (w.active[n], w.slip[n]);
        let basis = w.basis(n, bits, x);
        let f_mg: [f64; 3] = std::array::from_fn(|c| f[c] + m * g[c]);
        // Newmark's velocity at the step's end where free, and what the velocity update adds
        // along the constrained directions (`accept`).
        let c_mass = 4.0 / (dt * dt);
        let v_end: [f64; 3] = std::array::from_fn(|c| {
            let a_raw = c_mass * (du[c] - dt * v[c]) - a[c];
            v[c] + 0.5 * dt * (a[c] + a_raw)
        });
        let v_half: [f64; 3] = std::array::from_fn(|c| v[c] + 0.5 * dt * a[c]);
        let mut held = [0.0; 3];
        for j in 0..basis.len {
            let s = dot(basis.e[j], v_half);
            for c in 0..3 {
                held[c] += s * basis.e[j][c];
            }
        }
        let jump: [f64; 3] = std::array::from_fn(|c| m * (basis.v[c] - held[c]));
        for (k, plane) in w.planes.iter().enumerate() {
            let bit = 1u32 << k;
            if bits & bit == 0 {
                let end: [f64; 3] = std::array::from_fn(|c| x[c] + du[c] - plane.point[c]);
                let scale = (0..3)
                    .map(|c| x[c].abs() + du[c].abs() + plane.point[c].abs())
                    .fold(0.0, f64::max);
                if dot(end, plane.normal) < -64.0 * f64::EPSILON * scale {
                    // In contact: slipping if it moves along the wall, else sticking.
                    bits |= bit;
                    slip &= !bit;
                    let rel: [f64; 3] = std::array::from_fn(|c| v_end[c] - plane.velocity[c]);
                    let s = tangential(rel, plane.normal);
                    let l = norm(s);
                    if plane.friction > 0.0 && l > 1e-9 * (norm(v_end) + norm(plane.velocity)) {
                        slip |= bit;
                        dirs[k] = s.map(|x| -x);
                    }
                }
                continue;
            }
            // The wall's impulse on the node over the step, as `book_wall_node` books it: the
            // trapezoid of its force and the velocity update's part. A frictionless wall pulls
            // when its force at the step's end with the velocity update's part does (a landing
            // node's update holds the landing, which its force at the step's end does not); a
            // wall with friction when that impulse does (module doc, The active set).
            let rk = w.reaction(&basis, k, f_mg);
            let jk = basis.part_of(k as u32, jump);
            let r0 = w.force_n[n * nw + k];
            let imp: [f64; 3] = std::array::from_fn(|c| 0.5 * dt * (r0[c] + rk[c]) + jk[c]);
            let (jn, jt) = (dot(imp, plane.normal), tangential(imp, plane.normal));
            let pulled = match plane.friction > 0.0 {
                true => jn < -tol * dt,
                false => dot(rk, plane.normal) * dt + dot(jk, plane.normal) < -tol * dt,
            };
            if plane.friction > 0.0 && slip & bit == 0 {
                // Sticking: the impulse against Coulomb's cone; outside it (a pull included)
                // the node slips first, and may leave once slipping. Friction then acts along
                // the tangential impulse that held it.
                let t = norm(jt);
                if t > plane.friction * jn.max(0.0) || pulled {
                    slip |= bit;
                    dirs[k] = jt;
                }
                continue;
            }
            if pulled {
                bits &= !bit;
                slip &= !bit;
                continue;
            }
            if plane.friction > 0.0 && dirs[k] != [0.0; 3] {
                // Slipping: friction that turned the slip round within the step (the node's
                // slip at the step's end along friction's direction) stopped the node on the
                // wall: it sticks (and slips again if the cone cannot hold it).
                let s_end = tangential(sub(v_end, plane.velocity), plane.normal);
                if dot(s_end, dirs[k]) > 0.0 {
                    slip &= !bit;
                }
            }
        }
        (bits, slip)
    }

    /// In `accept`, for node `n` (`owned` or not): splits the constraint force `full` at the
    /// step's end into the walls' parts (kept) and the rest (returned first), takes friction's
    /// change of the velocity of a node slipping on a wall (the velocity returned second), and
    /// for an owned node in contact at either end of the step adds its impulses and energy to
    /// the step's sums. `v_newmark` is Newmark's velocity before the walls' velocity update,
    /// `v_new` the node's after it; `g_n`/`g` gravity at the step's ends.
    pub(super) fn book_wall_node(
        &mut self,
        n: usize,
        full: [f64; 3],
        (v_newmark, mut v_new): ([f64; 3], [f64; 3]),
        (g_n, g): ([f64; 3], [f64; 3]),
    ) -> ([f64; 3], [f64; 3]) {
        let Some(w) = self.walls.as_mut() else {
            return (full, v_new);
        };
        let nw = w.nw();
        let (now, before) = (w.active[n], w.active_n[n]);
        if now | before == 0 {
            return (full, v_new);
        }
        let basis = w.basis(n, now, self.fe.x[n]);
        let (dt, m, du) = (self.dt, self.fe.mass[n], self.du[n]);
        // Each wall's force: its part of the constraint force and, slipping, friction's
        // (`add_wall_friction`, at the converged iterate).
        let mut rest = full;
        for k in 0..nw {
            let rk = basis.part_of(k as u32, full);
            let fk = w.friction[n * nw + k];
            w.force[n * nw + k] = std::array::from_fn(|c| rk[c] + fk[c]);
            for c in 0..3 {
                rest[c] -= rk[c];
            }
        }
        // Each wall's impulse: the trapezoid of its force, the velocity update's part along
        // its constrained directions and, slipping, the friction of that part.
        let update: [f64; 3] = std::array::from_fn(|c| m * (v_new[c] - v_newmark[c]));
        let mut impulses = vec![[0.0; 3]; nw];
        for (k, imp) in impulses.iter_mut().enumerate() {
            let jk = basis.part_of(k as u32, update);
            let (r0, r1) = (w.force_n[n * nw + k], w.force[n * nw + k]);
            *imp = std::array::from_fn(|c| 0.5 * dt * (r0[c] + r1[c]) + jk[c]);
            // A node slipping on wall k at the step's end: the velocity update's normal
            // impulse (a landing's) gives friction on the velocity, as in explicit mode; the
            // friction of the forces is in Newton's solution.
            let slipping = (now & w.slip[n]) >> k & 1 == 1;
            let plane = w.planes[k];
            if slipping && plane.friction > 0.0 {
                let dv = friction_change(plane, jk, v_new, m);
                for c in 0..3 {
                    v_new[c] += dv[c];
                    imp[c] += m * dv[c];
                }
                if dv != [0.0; 3]
                    && tangential(sub(v_new, plane.velocity), plane.normal) == [0.0; 3]
                {
                    // Stopped on the wall: it sticks from the next step.
                    w.slip[n] &= !(1 << k);
                }
            }
        }
        if !self.fe.owned[n] {
            return (rest, v_new);
        }
        let (ge, gp) = (self.fe.grids.energy, self.fe.grids.momentum);
        for (k, imp) in impulses.iter().enumerate() {
            for c in 0..3 {
                gp.add(&mut w.folds[1 + 3 * k + c], imp[c]);
            }
        }
        // dE = (F'(n) + F'(n+1))/2 . du - dK, F' = f + m g + R'.
        let (f0, f1, r0, v0) = (
            self.force_n[n],
            self.force[n],
            self.reaction_n[n],
            self.fe.v[n],
        );
        for c in 0..3 {
            let work = 0.5 * (f0[c] + m * g_n[c] + r0[c] + f1[c] + m * g[c] + rest[c]) * du[c];
            ge.add(&mut w.folds[0], work);
            ge.add(
                &mut w.folds[0],
                -0.5 * m * (v_new[c] * v_new[c] - v0[c] * v0[c]),
            );
        }
        (rest, v_new)
    }

    /// After `accept`: the step's wall sums over ranks (collective), and the set and forces of
    /// the accepted state become the next step's start.
    pub(super) fn finish_wall_step(&mut self, comm: &SimpleCommunicator) {
        let Some(w) = self.walls.as_mut() else {
            return;
        };
        let flat = exact_sum::flatten(&w.folds);
        let mut g = vec![0.0; flat.len()];
        comm.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
        let g = exact_sum::values(&g);
        w.energy = g[0];
        for (k, imp) in w.impulse.iter_mut().enumerate() {
            *imp = [g[1 + 3 * k], g[2 + 3 * k], g[3 + 3 * k]];
        }
        w.folds.fill([0.0; 3]);
        // Nodes that left contact in the step keep no wall force.
        for n in 0..w.active.len() {
            if w.active[n] == 0 && w.active_n[n] != 0 {
                let nw = w.impulse.len();
                w.force[n * nw..(n + 1) * nw].fill([0.0; 3]);
            }
        }
        // (A copy, not a swap: a node out of contact keeps a zero force in both.)
        w.force_n.copy_from_slice(&w.force);
        w.active_n.copy_from_slice(&w.active);
        w.changes.fill(0);
        // Friction's directions are chosen again at the next step's start (from the velocity).
        w.dir.fill([0.0; 3]);
    }

    /// The walls' restart arrays (per node: the set's bits, then each wall's force).
    pub(super) fn wall_restart_state(&self) -> Vec<(&'static str, Vec<f64>)> {
        let Some(w) = self.walls.as_ref() else {
            return Vec::new();
        };
        vec![
            (
                "implicit.wall_active",
                w.active_n.iter().map(|&b| b as f64).collect(),
            ),
            (
                "implicit.wall_slip",
                w.slip.iter().map(|&b| b as f64).collect(),
            ),
            ("implicit.wall_force_n", w.force_n.as_flattened().to_vec()),
        ]
    }

    /// Sets what [`ImplicitFe::wall_restart_state`] gave.
    pub(super) fn set_wall_restart_state(
        &mut self,
        get: &mut dyn FnMut(&str) -> Option<Vec<f64>>,
    ) -> Result<(), String> {
        let Some(w) = self.walls.as_mut() else {
            return Ok(());
        };
        let mut take = |name: &str, len: usize| -> Result<Vec<f64>, String> {
            let v = get(name).ok_or_else(|| format!("{name}: missing"))?;
            match v.len() == len {
                true => Ok(v),
                false => Err(format!("{name}: {} values, {len} expected", v.len())),
            }
        };
        let (nn, nf) = (w.active.len(), 3 * w.force_n.len());
        let bits = take("implicit.wall_active", nn)?;
        let slip = take("implicit.wall_slip", nn)?;
        let force = take("implicit.wall_force_n", nf)?;
        for n in 0..nn {
            w.active_n[n] = bits[n] as u32;
            w.slip[n] = slip[n] as u32;
        }
        w.active.copy_from_slice(&w.active_n);
        w.force_n.as_flattened_mut().copy_from_slice(&force);
        Ok(())
    }
}
