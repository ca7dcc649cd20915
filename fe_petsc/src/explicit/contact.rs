//! The explicit integrator's side of the contact push-back: start positions and velocities,
//! the accelerations the kick used, the forces summed over ranks, their velocity corrections
//! and the push-back's work in the step's energy balance.
use super::*;

/// What the push-back's energy bookkeeping reads of one owned node's contact correction
/// ([`ExplicitFe::apply_contact`]): the bookkeeping itself is the contact stage's (the
/// `contact` crate's `energy`), the same for mesh nodes and particles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactCorrection {
    /// The node's mass, kg.
    pub mass: f64,
    /// The velocity correction `F dt / m`, the node's constraints applied, m/s.
    pub dv: [f64; 3],
    /// The half-step velocity before the correction, m/s.
    pub v: [f64; 3],
    /// The start acceleration `a(n)` ([`ExplicitFe::acceleration`]), m/s^2.
    pub a: [f64; 3],
    /// The node's push-back bits before the correction (bit 0: corrected in the last step).
    pub pushed: u8,
    /// The part of the correction `F dt / m` that the node's constraints removed (zero on a
    /// free node), m/s: a `velocity` node driven into a face takes the push-back's impulse in
    /// its reaction, and the contact force does work on it at its prescribed velocity `v`
    /// ([`ExplicitFe::apply_contact`]).
    pub removed: [f64; 3],
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

    /// Node `n`'s velocity correction for contact force `f` over `dt`, its constraints applied,
    /// `dv = F dt / m`, m/s: what [`ExplicitFe::apply_contact`] adds to the half-step velocity.
    pub fn contact_dv(&self, n: usize, f: [f64; 3], dt: f64) -> [f64; 3] {
        self.contact_dv_removed(n, f, dt).0
    }

    /// [`ExplicitFe::contact_dv`] and the part of `F dt / m` that the constraints removed
    /// ([`ContactCorrection::removed`]), m/s.
    pub fn contact_dv_removed(&self, n: usize, f: [f64; 3], dt: f64) -> ([f64; 3], [f64; 3]) {
        let free = impulse_dv(f, dt, self.mass[n]);
        let mut dv = free;
        if self.constrained[n] {
            for (m, c) in &self.constraints {
                if *m as usize == n {
                    apply(c, &mut dv, false);
                }
            }
        }
        (dv, std::array::from_fn(|c| free[c] - dv[c]))
    }

    /// Applies contact push-back forces after `kick_drift`: `force` holds each node's force
    /// summed over ranks ([`ExplicitFe::sum_contact_forces`]); the half-step velocity gets
    /// `F dt / m` and the position `F dt^2 / m`, with the nodal constraints applied to the
    /// correction. Returns the local work of the push-back over owned nodes, each node's
    /// components as `book` gives them ([`ContactCorrection`]; the contact stage's
    /// bookkeeping, `m dv . (v + dv/2 - kick a_n dt)` with `dv` the velocity correction):
    /// what closes the energy balance of the step with the element and external work.
    ///
    /// A constrained node takes in its reaction the part of the correction its constraints
    /// remove (`contact_reaction`, reactions.csv): over the step the contact force does the
    /// work `m removed . v` on it at its half-step velocity `v` (a `velocity` node's prescribed
    /// one; zero at a `fixed` node and along a symmetry plane's normal), which `book` counts
    /// with the push-back's ([`ContactCorrection::removed`]), and the reaction the opposite,
    /// counted in the external work (as the reactions at constrained nodes are). Without it a
    /// face driven by a `velocity` boundary that pushes a free node books the kinetic energy it
    /// gives the node as contact giving energy back, while the energy came from the boundary.
    pub fn apply_contact(
        &mut self,
        force: &[[f64; 3]],
        dt: f64,
        book: impl Fn(&ContactCorrection) -> [f64; 3],
    ) -> Folds {
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
            let mut dv = impulse_dv(f, dt, self.mass[n]);
            let mut removed = [0.0; 3];
            if let Some(i) = cons[n] {
                // The constraint removes what it does not allow of the correction: it applies
                // m (dv_constrained - dv_free) / dt to the node over the step (-F for a fixed
                // node), the push-back's share of its reaction (`constraint_reactions`).
                let free = dv;
                apply(&self.constraints[i].1, &mut dv, false);
                let m_dt = self.mass[n] / dt;
                for c in 0..3 {
                    self.contact_reaction[i][c] += m_dt * (dv[c] - free[c]);
                }
                removed = std::array::from_fn(|c| free[c] - dv[c]);
            }
            let a_n = self.acceleration(n);
            if self.owned[n] {
                // The old forces' half of the element work over the push-back's dt dv.
                let f = self.force[n];
                for c in 0..3 {
                    grid.add(&mut self.kick_work, f[c] * (dt * dv[c]));
                }
                // The change of the half-step kinetic energy, less the part of the start kick
                // that the element and external work (trapezoids over the corrected
                // displacement) already count: the contact stage's bookkeeping.
                let w = book(&ContactCorrection {
                    mass: self.mass[n],
                    dv,
                    v: self.v[n],
                    a: a_n,
                    pushed: self.pushed[n],
                    removed,
                });
                // The reaction's share: the opposite of the contact force's work on the node.
                if removed != [0.0; 3] {
                    let (m, v) = (self.mass[n], self.v[n]);
                    for c in 0..3 {
                        grid.add(&mut self.contact_reaction_work, -(m * removed[c] * v[c]));
                    }
                }
                for wc in w {
                    grid.add(&mut work, wc);
                }
            }
            self.pushed[n] |= 2;
            for c in 0..3 {
                self.v[n][c] += dv[c];
                self.x[n][c] += dv[c] * dt;
            }
        }
        work
    }

    /// Node `n`'s velocity at the start of the step (between `kick_drift` and the element
    /// loop), `v(n) = v(n+1/2) - a(n) dt / 2` with the kick's `dt`, m/s: the velocity against
    /// which the step's energy balance measures a contact correction
    /// ([`ExplicitFe::apply_contact`]'s booked work is `m dv . (v(n) + dv/2)`).
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
        let (f, im, g) = (
            self.force[n],
            crate::nodal::inverse_mass(self.mass[n]),
            self.gravity,
        );
        [f[0] * im + g[0], f[1] * im + g[1], f[2] * im + g[2]]
    }
}

/// `F dt / m`, m/s; zero for a node without mass (all its elements became particles).
#[inline]
fn impulse_dv(f: [f64; 3], dt: f64, m: f64) -> [f64; 3] {
    if m > 0.0 {
        [f[0] * dt / m, f[1] * dt / m, f[2] * dt / m]
    } else {
        [0.0; 3]
    }
}
