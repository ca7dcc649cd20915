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
//! [`MAX_ROUNDS`] times. The set at a step's start is the last step's. Every copy of a node
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
}

/// The rigid walls of an implicit run and the nodes in contact with them.
pub(super) struct WallSet {
    /// The walls over the present step (set by [`ImplicitFe::set_wall_planes`]).
    planes: Vec<WallPlane>,
    /// Each local node's constraint without walls.
    base: Vec<NodeDof>,
    /// The symmetry-plane normals of the nodes that have them.
    plane_normals: std::collections::HashMap<usize, Vec<[f64; 3]>>,
    /// Each local node's walls in contact (bit k: wall k), now and at the step's start.
    pub(super) active: Vec<u32>,
    active_n: Vec<u32>,
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

    /// The constrained directions of node `n` with the walls in `bits`, at start position `x`.
    fn basis(&self, n: usize, bits: u32, x: [f64; 3]) -> Basis {
        let planes = self.plane_normals.get(&n).map_or(&[][..], |v| &v[..]);
        let walls = (0..self.planes.len())
            .filter(|&k| bits >> k & 1 == 1)
            .map(|k| {
                let w = &self.planes[k];
                let gap: [f64; 3] = std::array::from_fn(|c| w.point[c] - x[c]);
                (
                    w.normal,
                    dot(w.normal, gap),
                    dot(w.normal, w.velocity),
                    k as u32,
                )
            });
        Basis::new(planes.iter().map(|&n| (n, 0.0, 0.0, u32::MAX)).chain(walls))
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
            base: self.dofs.clone(),
            plane_normals: std::mem::take(&mut self.plane_normals),
            active: vec![0; nn],
            active_n: vec![0; nn],
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
    /// `tol` (N) leave it. Returns whether any set changed on any rank (collective).
    pub(super) fn update_wall_sets(&mut self, comm: &SimpleCommunicator, tol: f64) -> bool {
        let Some(w) = self.walls.as_mut() else {
            return false;
        };
        let g = self.gravity;
        let mut changed = 0i32;
        for n in 0..self.du.len() {
            if matches!(w.base[n], NodeDof::Prescribed(_)) {
                continue;
            }
            let (x, du) = (self.fe.x[n], self.du[n]);
            let bits = w.active[n];
            let basis = (bits != 0).then(|| w.basis(n, bits, x));
            let mut new_bits = bits;
            for (k, plane) in w.planes.iter().enumerate() {
                if bits >> k & 1 == 1 {
                    // The wall's force on the node at the step's end: its part of m (a - g) -
                    // f, where the accepted acceleration has no part along the constrained
                    // directions (module doc), as `accept` books it.
                    let (m, f) = (self.fe.mass[n], self.force[n]);
                    let r: [f64; 3] = std::array::from_fn(|c| -m * g[c] - f[c]);
                    let rk = basis.as_ref().map_or([0.0; 3], |b| b.part_of(k as u32, r));
                    if dot(rk, plane.normal) < -tol {
                        new_bits &= !(1 << k);
                    }
                } else {
                    let end: [f64; 3] = std::array::from_fn(|c| x[c] + du[c] - plane.point[c]);
                    let scale = (0..3)
                        .map(|c| x[c].abs() + du[c].abs() + plane.point[c].abs())
                        .fold(0.0, f64::max);
                    if dot(end, plane.normal) < -64.0 * f64::EPSILON * scale {
                        new_bits |= 1 << k;
                    }
                }
            }
            if new_bits != bits {
                w.active[n] = new_bits;
                changed = 1;
            }
        }
        let mut any = 0;
        comm.all_reduce_into(&changed, &mut any, SystemOperation::max());
        if any > 0 {
            w.rounds += 1;
        }
        any > 0
    }

    /// In `accept`, for node `n` (`owned` or not): splits the constraint force `full` at the
    /// step's end into the walls' parts (kept) and the rest (returned), and for an owned node
    /// in contact at either end of the step adds its impulses and energy to the step's sums.
    /// `v_newmark` is Newmark's velocity before the walls' velocity update, `v_new` the node's,
    /// `g_n`/`g` gravity at the step's ends.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn book_wall_node(
        &mut self,
        n: usize,
        full: [f64; 3],
        (v_newmark, v_new): ([f64; 3], [f64; 3]),
        (g_n, g): ([f64; 3], [f64; 3]),
    ) -> [f64; 3] {
        let Some(w) = self.walls.as_mut() else {
            return full;
        };
        let nw = w.nw();
        let (now, before) = (w.active[n], w.active_n[n]);
        if now | before == 0 {
            return full;
        }
        let basis = w.basis(n, now, self.fe.x[n]);
        let mut rest = full;
        for k in 0..nw {
            let rk = basis.part_of(k as u32, full);
            w.force[n * nw + k] = rk;
            for c in 0..3 {
                rest[c] -= rk[c];
            }
        }
        if !self.fe.owned[n] {
            return rest;
        }
        let (ge, gp) = (self.fe.grids.energy, self.fe.grids.momentum);
        let (dt, m, du) = (self.dt, self.fe.mass[n], self.du[n]);
        let jump: [f64; 3] = std::array::from_fn(|c| m * (v_new[c] - v_newmark[c]));
        for k in 0..nw {
            let jk = basis.part_of(k as u32, jump);
            let (r0, r1) = (w.force_n[n * nw + k], w.force[n * nw + k]);
            for c in 0..3 {
                gp.add(
                    &mut w.folds[1 + 3 * k + c],
                    0.5 * dt * (r0[c] + r1[c]) + jk[c],
                );
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
        rest
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
        std::mem::swap(&mut w.force_n, &mut w.force);
        w.active_n.copy_from_slice(&w.active);
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
        let bits = get("implicit.wall_active").ok_or("implicit.wall_active: missing")?;
        let force = get("implicit.wall_force_n").ok_or("implicit.wall_force_n: missing")?;
        if bits.len() != w.active.len() || force.len() != 3 * w.force_n.len() {
            return Err("implicit.wall_active / implicit.wall_force_n: wrong length".into());
        }
        for (a, b) in w.active_n.iter_mut().zip(&bits) {
            *a = *b as u32;
        }
        w.active.copy_from_slice(&w.active_n);
        w.force_n.as_flattened_mut().copy_from_slice(&force);
        Ok(())
    }
}
