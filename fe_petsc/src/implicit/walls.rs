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
//! a node the wall pulls (its normal reaction below `-rtol F`, the Newton tolerance) leaves it;
//! Newton runs again from the converged increment until the set stands, at most
//! [`MAX_ROUNDS`] times. A node whose state changed twice in the step only joins after that
//! (it stays on every wall it was on): a node landing with a small speed can be such that the
//! trapezoidal rule neither holds it on the plane without a pull nor lets it go without passing
//! it; it is then held, and the wall pulls it for that step. The set at a step's start is the last step's. Every copy of a node
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
//! three constrained directions). A slipping node is free along the plane in Newton, and at the
//! step's end its slip relative to the wall loses `mu J_n / m` of its speed, to zero at most,
//! `J_n` the wall's normal impulse on it over the step (the velocity update's part included, so
//! a landing's impulse gives friction as in explicit mode); stopped, it sticks from the next
//! step. A node comes into contact slipping when it moves along the wall, else sticking. After
//! Newton: a sticking node whose tangential impulse over the step exceeds `mu` times its normal
//! impulse slips, and a sticking node the wall pulls slips before it may leave. The friction
//! acts on the velocity and not inside Newton, so a slipping node's position over the step is
//! the frictionless one: an error of order `mu g dt^2` per step in the slip, none in momentum.
//!
//! **Impulse and energy.** Wall k's impulse over the step is the trapezoid of its reaction plus
//! what the velocity update changed along it, `J_k = sum dt/2 (R_k(n) + R_k(n+1)) + (m (v(n+1)
//! - v_N(n+1)))_k` over the owned nodes (`v_N`: Newmark's velocity), so the bodies' momentum
//! changes by the impulses of all forces exactly. The energy the walls took in the step is
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
    /// This rank's sums of the step: [energy taken, then per wall impulse x, y, z].
    folds: Vec<Folds>,
    /// The last step's global results: each wall's impulse (N s) and the energy taken (J).
    pub(super) impulse: Vec<[f64; 3]>,
    pub(super) energy: f64,
    /// Solves repeated because the set changed, over the run.
    pub(super) rounds: u64,
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

/// Coulomb's change of the velocity `v` of a node of mass `m` slipping on `plane` whose normal
/// impulse over the step is `imp`'s normal part `J_n`: the slip relative to the wall, `s`, is
/// reduced by `mu J_n / m`, to zero at most (then the node has stopped on the wall).
fn friction_change(plane: WallPlane, imp: [f64; 3], v: [f64; 3], m: f64) -> [f64; 3] {
    let jn = dot(imp, plane.normal).max(0.0);
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

    /// The nodes' constraints with their walls in contact (the set of [`WallSet::active`]).
    pub(super) fn apply_walls(&mut self) {
        let Some(w) = self.walls.as_ref() else {
            return;
        };
        for n in 0..self.dofs.len() {
            if matches!(w.base[n], NodeDof::Prescribed(_)) {
                continue;
            }
            self.dofs[n] = match w.active[n] {
                0 => w.base[n],
                bits => {
                    let b = w.basis(n, bits, self.fe.x[n]);
                    NodeDof::Walled {
                        p: b.projection(),
                        du: b.du,
                        v: b.v,
                    }
                }
            };
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
        for n in 0..self.du.len() {
            let w = self.walls.as_ref().expect("walls");
            if matches!(w.base[n], NodeDof::Prescribed(_)) {
                continue;
            }
            let (bits, slip) = self.node_sets(n, tol);
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
    /// [`ImplicitFe::update_wall_sets`]).
    fn node_sets(&self, n: usize, tol: f64) -> (u32, u32) {
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
                    }
                }
                continue;
            }
            // The wall's impulse on the node over the step, as `book_wall_node` books it: the
            // trapezoid of its force and the velocity update's part. The wall pulls when its
            // force at the step's end with the velocity update's part does: a landing node's
            // update holds the landing, which its force at the step's end does not.
            let rk = w.reaction(&basis, k, f_mg);
            let jk = basis.part_of(k as u32, jump);
            let r0 = w.force_n[n * nw + k];
            let imp: [f64; 3] = std::array::from_fn(|c| 0.5 * dt * (r0[c] + rk[c]) + jk[c]);
            let (jn, jt) = (dot(imp, plane.normal), tangential(imp, plane.normal));
            let pulled = dot(rk, plane.normal) * dt + dot(jk, plane.normal) < -tol * dt;
            if plane.friction > 0.0 && slip & bit == 0 {
                // Sticking: the impulse against Coulomb's cone; outside it (a pull included)
                // the node slips first, and may leave once slipping.
                let t = norm(jt);
                if t > plane.friction * jn.max(0.0) || pulled {
                    slip |= bit;
                }
                continue;
            }
            if pulled {
                bits &= !bit;
                slip &= !bit;
                continue;
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
        let mut rest = full;
        for k in 0..nw {
            let rk = basis.part_of(k as u32, full);
            w.force[n * nw + k] = rk;
            for c in 0..3 {
                rest[c] -= rk[c];
            }
        }
        // Each wall's impulse: the trapezoid of its force, the velocity update's part along
        // its constrained directions and, slipping, friction's.
        let update: [f64; 3] = std::array::from_fn(|c| m * (v_new[c] - v_newmark[c]));
        let mut impulses = vec![[0.0; 3]; nw];
        for (k, imp) in impulses.iter_mut().enumerate() {
            let jk = basis.part_of(k as u32, update);
            let (r0, r1) = (w.force_n[n * nw + k], w.force[n * nw + k]);
            *imp = std::array::from_fn(|c| 0.5 * dt * (r0[c] + r1[c]) + jk[c]);
            // Friction on a node in contact with wall k at either end of the step that does
            // not stick to it at the end (slipping, or leaving: its impulse at the start).
            let sticking = (now & !w.slip[n]) >> k & 1 == 1;
            let plane = w.planes[k];
            if (now | before) >> k & 1 == 1 && !sticking && plane.friction > 0.0 {
                let dv = friction_change(plane, *imp, v_new, m);
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
