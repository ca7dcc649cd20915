//! The explicit integrator's side of the contact push-back: start positions and velocities,
//! the accelerations the kick used, the forces summed over ranks, their velocity corrections
//! and the push-back's work in the step's energy balance.
use super::*;

/// The share of the start kick `(dt/2) a(n)` that a contact correction `dv` is booked against,
/// as a multiple of `dt a(n)`: a node (or particle) the push-back or a wall also corrected in
/// the last step books `m dv . (v(n) + dv/2)`, one met first in this step `m dv . (v(n) +
/// (dt/4) a(n) + dv/2)` (`pushed`: bit 0 set when corrected in the last step).
///
/// Why. Velocity Verlet with an impulse `dv` between the kicks changes the full-step kinetic
/// energy by `dK = W_trapezoid + m dv . (v(n) + dv/2) + m (|q|^2 - |p|^2) / 2`, with `p = (dt/2)
/// a(n)` and `q = (dt/2) a(n+1)` the two half kicks; the last term is the integrator's own
/// O(dt^2) difference between the full-step kinetic energy and a conserved one, which
/// telescopes over the steps and is the energy error of any explicit run. For a pair pressed
/// together (the contact force balancing `m a`), `v(n)` is not the pair's motion: the closing
/// kick left it `p` into the face, and every step the push-back takes `2p` out again at no
/// work (`dv = -2p`, `m dv . (v(n) + dv/2) = 0`). That full-step `p` is a kinetic energy
/// `m |p|^2 / 2` no motion makes; it appears the step the pressing starts (from rest: `v(n) =
/// 0`, `dv = -p`, booked work `m |p|^2 / 2`, i.e. contact would give it) and leaves through
/// the telescoping term when the pressing stops. Booking a pair's first correction against
/// `v(n) + p/2` (the trapezoid's share of the start kick) takes nothing at that onset (`m (-p)
/// . (p/2 - p/2) = 0`) and leaves the inelastic impact's loss unchanged to first order (`v(n)
/// = V` into the face, `p = 0`: `m V^2 / 2`); the onset's `m |p|^2 / 2` then stays with the
/// integrator's telescoping term in the energy error (history.csv `energy_error`), where the
/// pressed pair's full-step kinetic energy sits, instead of in `contact_energy`, which only
/// takes energy (docs/scene.md). A particle the immovable faces held at the end of the last
/// step (`SphStage::hold_on_faces`) starts as one met first: the hold took that kick.
/// Measured on `underwater_explosion` (detonation products pressed on their cavity from rest):
/// with every correction booked against `v(n)` (and the hold booked on its own) the first
/// row's `contact_energy` fell 143 J, 1.28e-3 of the energy scale; booked so, its largest fall
/// between rows is 1.2e-5 and the energy error's largest value 1.65 % (1.44 % before: the
/// onset's kinetic energy moved there), the motion the same bits.
pub fn booked_kick(pushed: u8) -> f64 {
    if pushed & 1 == 0 {
        0.25
    } else {
        0.5
    }
}

impl ExplicitFe {
    /// Positions at the start of the step (before `kick_drift` moved them). Panics without a
    /// contact stage ([`ExplicitFe::set_contact_stage`]): they are not kept then.
    pub fn x_start(&self) -> &[[f64; 3]] {
        assert!(
            self.contact,
            "the start positions are not kept (no contact stage)"
        );
        &self.x_old
    }

    /// Whether a contact stage runs between `kick_drift` and `element_forces` (the default).
    /// It reads every node's start position ([`ExplicitFe::x_start`]) and the start-of-step
    /// forces ([`ExplicitFe::acceleration`], the push-back's work). A model without contact
    /// turns it off: the kick then neither copies nor holds the start positions (48 B per
    /// node-step with the line's fill, 24 B per node) and zeroes the forces as it reads them,
    /// so that the element loop needs no pass to clear them (about 1.5 ns per element-cycle).
    pub fn set_contact_stage(&mut self, present: bool) {
        self.contact = present;
        self.x_old = if present { self.x.clone() } else { Vec::new() };
    }

    /// Whether local node `n` has a constraint that prescribes all its velocity components
    /// (fixed or velocity): contact treats it as an infinite mass.
    pub fn fully_constrained(&self) -> Vec<bool> {
        let mut out = vec![false; self.x.len()];
        for (n, c) in &self.constraints {
            if matches!(c, Constraint::Fixed | Constraint::Velocity(_)) {
                out[*n as usize] = true;
            }
        }
        out
    }

    /// Sums contact push-back forces over ranks: `force` holds each node's force on this
    /// rank's owned nodes (zero on the others); after the call every copy holds the sum.
    pub fn sum_contact_forces(
        &mut self,
        force: &mut [[f64; 3]],
        exchange: &mut NodeExchange,
    ) -> Result<(), StepError> {
        exchange.sum_shared(flat(force))?;
        Ok(())
    }

    /// The terms `[A, B]` of the change of the half-step kinetic energy that the summed
    /// contact forces `force` scaled by `alpha` make, `dK(alpha) = alpha A + alpha^2 B`, over
    /// owned nodes: `A = sum m dv . v(n+1/2)`, `B = sum m |dv|^2 / 2` for the constrained
    /// velocity corrections `dv = F dt / m` (J). Called after `kick_drift`, before
    /// `apply_contact`.
    pub fn contact_energy_terms(&self, force: &[[f64; 3]], dt: f64) -> [Folds; 2] {
        let mut t = [[0.0; 3]; 2];
        let e = &self.grids.energy;
        for n in 0..self.x.len() {
            let f = force[n];
            if f == [0.0; 3] || !self.owned[n] {
                continue;
            }
            let dv = self.contact_dv(n, f, dt);
            let v = self.v[n];
            for c in 0..3 {
                e.add(&mut t[0], self.mass[n] * dv[c] * v[c]);
                e.add(&mut t[1], 0.5 * self.mass[n] * dv[c] * dv[c]);
            }
        }
        t
    }

    /// Node `n`'s velocity correction for contact force `f` over `dt`, its constraints applied.
    fn contact_dv(&self, n: usize, f: [f64; 3], dt: f64) -> [f64; 3] {
        let mut dv = [
            f[0] * dt / self.mass[n],
            f[1] * dt / self.mass[n],
            f[2] * dt / self.mass[n],
        ];
        if self.constrained[n] {
            for (m, c) in &self.constraints {
                if *m as usize == n {
                    apply(c, &mut dv, false);
                }
            }
        }
        dv
    }

    /// Applies contact push-back forces after `kick_drift`: `force` holds each node's force
    /// summed over ranks ([`ExplicitFe::sum_contact_forces`]); the half-step velocity gets
    /// `F dt / m` and the position `F dt^2 / m`, with the nodal constraints applied to the
    /// correction. Returns the local work of the push-back over owned nodes,
    /// `m dv . (v + dv/2 - a_n dt/2)` with `dv` the velocity correction: what closes the energy
    /// balance of the step with the element and external work.
    pub fn apply_contact(&mut self, force: &[[f64; 3]], dt: f64) -> Folds {
        let mut cons: Vec<Option<usize>> = vec![None; self.x.len()];
        for (i, (n, _)) in self.constraints.iter().enumerate() {
            cons[*n as usize] = Some(i);
        }
        let mut work = [0.0; 3];
        let grid = self.grids.energy;
        for n in 0..self.x.len() {
            let f = force[n];
            if f == [0.0; 3] {
                continue;
            }
            let mut dv = [
                f[0] * dt / self.mass[n],
                f[1] * dt / self.mass[n],
                f[2] * dt / self.mass[n],
            ];
            if let Some(i) = cons[n] {
                // The constraint removes what it does not allow of the correction: it applies
                // m (dv_constrained - dv_free) / dt to the node over the step (-F for a fixed
                // node), the push-back's share of its reaction (`constraint_reactions`).
                let free = dv;
                apply(&self.constraints[i].1, &mut dv, false);
                let m_dt = self.mass[n] / dt;
                self.contact_reaction[i] = std::array::from_fn(|c| m_dt * (dv[c] - free[c]));
            }
            let a_n = self.acceleration(n);
            if self.owned[n] {
                // The old forces' half of the element work over the push-back's dt dv.
                let f = self.force[n];
                for c in 0..3 {
                    grid.add(&mut self.kick_work, f[c] * (dt * dv[c]));
                }
            }
            let kick = crate::explicit::booked_kick(self.pushed[n]);
            self.pushed[n] |= 2;
            for c in 0..3 {
                if self.owned[n] {
                    // The change of the half-step kinetic energy, less the part of the start
                    // kick that the element and external work (trapezoids over the corrected
                    // displacement) already count: velocity Verlet with an impulse dv between
                    // the kicks gives dKE = W_trapezoid + m dv.(v + dv/2) - (dt/2) m a_n.dv;
                    // a node the push-back meets first books half of that kick
                    // ([`crate::explicit::booked_kick`]).
                    let w =
                        self.mass[n] * dv[c] * (self.v[n][c] + 0.5 * dv[c] - kick * dt * a_n[c]);
                    grid.add(&mut work, w);
                }
                self.v[n][c] += dv[c];
                self.x[n][c] += dv[c] * dt;
            }
        }
        work
    }

    /// Node `n`'s velocity at the start of the step (between `kick_drift` and the element
    /// loop), `v(n) = v(n+1/2) - a(n) dt / 2` with the kick's `dt`, m/s: the velocity against
    /// which the step's energy balance measures a contact correction
    /// ([`ExplicitFe::apply_contact`]'s work is `m dv . (v(n) + dv/2)`).
    pub fn start_velocity(&self, n: usize) -> [f64; 3] {
        let (a, h) = (self.acceleration(n), 0.5 * self.kick_dt);
        let v = self.v[n];
        [v[0] - h * a[0], v[1] - h * a[1], v[2] - h * a[2]]
    }

    /// Node `n`'s acceleration at the start of the step (between `kick_drift` and the element
    /// loop: the forces are the last step's), m/s^2: f / m + g, as the kick formed it; a
    /// constrained node's as its constraints left it in the last `finish_step` (kept in `a`).
    pub fn acceleration(&self, n: usize) -> [f64; 3] {
        assert!(
            !self.forces_zeroed,
            "the kick cleared the forces (no contact stage: `set_contact_stage`)"
        );
        if self.constrained[n] {
            return self.a[n];
        }
        let (f, im, g) = (self.force[n], 1.0 / self.mass[n], self.gravity);
        [f[0] * im + g[0], f[1] * im + g[1], f[2] * im + g[2]]
    }
}
