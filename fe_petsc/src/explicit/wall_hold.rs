//! The rigid walls' hold on the mesh nodes they put back, through the step's closing half-kick.
//!
//! Why. A wall's correction acts between the kicks (after the drift): it stops the start kick
//! `p = (dt/2) a(n)` and the closing kick of the step before, so a node pressed on a wall ends
//! each step with the closing kick `q = (dt/2) a(n+1)` into the wall, a velocity no motion
//! makes. On a bar driven by a wall at 1 m/s the driven nodes read 0.27 m/s, and the wall's
//! impulse in a step was the kicks of `(dt_old + dt)/2`: where the step changes (the run's last
//! step, shortened to end at `end_time`) the row's mean force grew by `(dt_old + dt)/(2 dt)`,
//! three times the force on a last step a fifth of the one before, the nodes' velocities
//! jumping with it.
//!
//! What. After the closing kick, every node a wall put back in the step loses the part of `q`
//! that points into that wall, `dv = -min(0, q . n) n` (its constraints applied to `dv`, as to
//! a correction), wall by wall in the scene's order, `q` less what the walls before took (a
//! node in a corner of walls). A wall cannot give way, and its reaction over the closing
//! half-step is what stops that kick, as the push-back stops the first half's (the SPH stage
//! holds particles on walls the same way, `SphStage::hold_on_faces` in `coupling`). The node
//! then ends the step at the wall's normal velocity, the next step's correction stops only its
//! own start kick, and a wall's impulse in each step is that step's: `m (p + q)` for a node
//! pressed on it, `m a dt`. On a node that stays pressed the positions are those without the
//! hold (the next correction puts it on the same plane either way); only the full-step
//! velocity and the impulses' split between steps change.
//!
//! With `friction` the hold also stops the node's sliding relative to the wall up to `friction`
//! times its normal change, by the correction's Coulomb rule (`contact::Wall::correction`):
//! else the closing half of a step's normal impulse would carry no friction (a block sliding
//! on a rough floor slowed at half mu g).
//!
//! Energy. The velocity Verlet step with a correction `dv` between the kicks and a hold `h`
//! after them changes the kinetic energy by the trapezoids' work plus `m dv . (v(n) + dv/2) +
//! m h . (v' + h/2) + m (|q|^2 - |p|^2) / 2` (`v'` the velocity after the closing kick). The
//! hold books `m h . (v' - q/2 + h/2)` in the walls' energy (`coupling`'s `Walls`: what a wall
//! took is its work `W . J` less what its corrections and holds book), and a held node's next
//! correction is booked as one met first (`contact::energy::booked_kick`: its push-back bit is
//! cleared), `m dv . (v(n) + p/2 + dv/2)`. A node resting on a wall at rest then books nothing
//! in either (`dv = -p`, `h = -q`, both along the normal), one pressed on a moving wall only
//! the wall's work, and the leftover `m (|q . t|^2 - |p . t|^2) / 2` of the kicks along the
//! wall telescopes over the steps as in any explicit run; `contact_energy` does not swing with
//! the kicks' size from step to step.
use super::*;
use crate::nodal::inverse_mass;

/// One local node (owned or a ghost copy: every copy takes the same hold) that rigid wall
/// `wall` (the scene's index) put back in this step, its plane's unit normal `normal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallHold {
    /// The local node.
    pub node: u32,
    /// The wall's unit normal, towards the bodies.
    pub normal: [f64; 3],
    /// The wall's index in the scene.
    pub wall: usize,
    /// The wall's velocity over the step, m/s.
    pub velocity: [f64; 3],
    /// Its Coulomb coefficient.
    pub friction: f64,
}

/// The holds of a step and what they did.
#[derive(Clone, Debug, Default)]
pub(crate) struct WallHolds {
    /// This step's holds ([`ExplicitFe::set_wall_holds`]), taken by `finish_step`.
    pending: Vec<WallHold>,
    /// What the last `finish_step`'s holds did over the owned nodes: fold 0 the change of
    /// the kinetic energy `sum m dv . (v + dv/2)` (J, on the energy grid), then each wall's
    /// impulse `sum m dv`, x, y, z (N s, on the momentum grid).
    sums: Vec<Folds>,
}

impl ExplicitFe {
    /// The nodes the `walls` rigid walls put back in this step (every local copy), to be held
    /// through its closing kick (module doc); every rank calls it at every step of a run with
    /// walls, so that [`ExplicitFe::wall_hold_sums`] has the same length everywhere.
    pub fn set_wall_holds(&mut self, holds: Vec<WallHold>, walls: usize) {
        self.wall_holds.pending = holds;
        self.wall_holds.sums = vec![[0.0; 3]; 1 + 3 * walls];
    }

    /// What the last step's holds did on this rank's owned nodes: the change of the kinetic
    /// energy (fold 0), then each wall's impulse x, y, z; to be summed over ranks. Empty in a
    /// run without walls.
    pub fn wall_hold_sums(&self) -> &[Folds] {
        &self.wall_holds.sums
    }

    /// After the closing kick: the holds of this step (module doc), their kinetic energy and
    /// momentum taken into `sums` (the owned nodes' terms of the kick's velocity replaced by
    /// the held velocity's: the exact sums take a term and its negation to nothing).
    pub(super) fn hold_on_walls(&mut self, dt: f64, sums: &mut StepFolds) {
        let mut holds = std::mem::take(&mut self.wall_holds.pending);
        if holds.is_empty() {
            return;
        }
        // a node's walls together, in the scene's order (a stable sort)
        holds.sort_by_key(|h| h.node);
        let constraint_of: std::collections::HashMap<u32, usize> = self
            .constraints
            .iter()
            .enumerate()
            .filter(|(_, (n, _))| holds.binary_search_by_key(n, |h| h.node).is_ok())
            .map(|(i, (n, _))| (*n, i))
            .collect();
        let (ge, gp) = (self.grids.energy, self.grids.momentum);
        let mut out = std::mem::take(&mut self.wall_holds.sums);
        for group in holds.chunk_by(|a, b| a.node == b.node) {
            let n = group[0].node as usize;
            let m = self.mass[n];
            if m <= 0.0 {
                continue;
            }
            let con = constraint_of
                .get(&group[0].node)
                .map(|&i| &self.constraints[i].1);
            let mut q = self.closing_kick(n, con.is_some(), dt);
            let v0 = self.v[n];
            let mut v = v0;
            for (i, hold) in group.iter().enumerate() {
                // the node's other walls (a corner): their normals hold their own directions
                let others = group.iter().enumerate().filter(|&(j, _)| j != i);
                let others: Vec<[f64; 3]> = others.map(|(_, h)| h.normal).collect();
                let Some(mut dv) = hold_change(hold, v, q, &others) else {
                    continue;
                };
                if let Some(con) = con {
                    apply(con, &mut dv, false);
                }
                if self.owned[n] {
                    for c in 0..3 {
                        ge.add(&mut out[0], m * dv[c] * (v[c] - 0.5 * q[c] + 0.5 * dv[c]));
                        gp.add(&mut out[1 + 3 * hold.wall + c], m * dv[c]);
                    }
                }
                for c in 0..3 {
                    v[c] += dv[c];
                    q[c] += dv[c];
                }
            }
            if v == v0 {
                continue;
            }
            // held: the next step's correction meets it as a first one (module doc)
            self.pushed[n] &= !2;
            if self.owned[n] {
                for c in 0..3 {
                    ge.add(&mut sums[0], -(m * (v0[c] * v0[c])));
                    ge.add(&mut sums[0], m * (v[c] * v[c]));
                    gp.add(&mut sums[3 + c], -(m * v0[c]));
                    gp.add(&mut sums[3 + c], m * v[c]);
                }
            }
            self.v[n] = v;
        }
        self.wall_holds.sums = out;
    }

    /// Node `n`'s closing kick `(dt/2) a(n+1)` as `finish_step` gave it: a constrained node's
    /// acceleration as its constraint left it, a free node's from its force and gravity (the
    /// same operations, the same bits).
    fn closing_kick(&self, n: usize, constrained: bool, dt: f64) -> [f64; 3] {
        let h = 0.5 * dt;
        if constrained {
            return self.a[n].map(|c| h * c);
        }
        let (f, g, im) = (self.force[n], self.gravity, inverse_mass(self.mass[n]));
        std::array::from_fn(|c| h * (f[c] * im + g[c]))
    }
}

/// The hold of one wall on a node moving at `v` after the closing kick `q` (what the walls
/// before left of it), m/s: `None` where `q` does not point into the wall; else the normal
/// change `du = -q . n` that stops the kick into it, and with friction the stop of the sliding
/// relative to the wall up to `friction du` (`contact::Wall::correction`'s Coulomb rule with
/// the hold's normal change for the correction's), less its parts along the normals of the
/// node's `others` walls: in a corner each wall holds its own direction, and a rough floor's
/// friction taking the motion into the wall beside it booked that as friction (a rubber cube
/// resting in a floor-wall corner with a rough floor passed 5 % of energy error in 4 ms).
fn hold_change(hold: &WallHold, v: [f64; 3], q: [f64; 3], others: &[[f64; 3]]) -> Option<[f64; 3]> {
    let n = hold.normal;
    let k = q[0] * n[0] + q[1] * n[1] + q[2] * n[2];
    if !(k < 0.0) {
        return None;
    }
    let du = -k;
    if hold.friction == 0.0 {
        return Some(n.map(|c| du * c));
    }
    let w: [f64; 3] = std::array::from_fn(|c| v[c] + du * n[c] - hold.velocity[c]);
    let wn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
    let mut wt: [f64; 3] = std::array::from_fn(|c| w[c] - wn * n[c]);
    for m in others {
        let wm = wt[0] * m[0] + wt[1] * m[1] + wt[2] * m[2];
        wt = std::array::from_fn(|c| wt[c] - wm * m[c]);
    }
    let slide = (wt[0] * wt[0] + wt[1] * wt[1] + wt[2] * wt[2]).sqrt();
    let stop = if slide > 0.0 {
        (hold.friction * du / slide).min(1.0)
    } else {
        0.0
    };
    Some(std::array::from_fn(|c| du * n[c] - stop * wt[c]))
}
