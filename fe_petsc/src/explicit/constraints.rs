//! Boundary conditions: gravity and the velocity curves in time, the constraints on velocities
//! and accelerations, and the reactions they apply.
use super::*;

impl ExplicitFe {
    /// Gravity at time `t`: the scene's times its curve's value, m/s^2.
    pub(crate) fn gravity_at(&self, t: f64) -> [f64; 3] {
        match &self.gravity_curve {
            Some(c) => {
                let s = c.value(t);
                self.gravity0.map(|g| g * s)
            }
            None => self.gravity0,
        }
    }

    /// Sets each velocity constraint with a curve to its velocity times the curve's mean
    /// over the step `[t, t + dt]` (its value at `t` for `dt = 0`): in central differences
    /// the velocity of the half step, which moves the node by exactly the curve's integral.
    pub(super) fn scale_velocities(&mut self, t: f64, dt: f64) {
        for (i, v, c) in &self.velocity_curves {
            let s = c.mean(t, dt);
            self.constraints[*i].1 = Constraint::Velocity(v.map(|x| x * s));
        }
    }

    /// The velocity constraints with a curve at t = 0: their acceleration v ds/dt (the
    /// slope just after the start), and the reaction that gives it (m a - m g: no element
    /// force yet), the first step's trapezoid of the reaction's work starting from it.
    pub(super) fn start_curved_velocities(&mut self) {
        for (i, v, c) in &self.velocity_curves {
            let n = self.constraints[*i].0 as usize;
            let rate = c.slope_after(0.0);
            self.a[n] = v.map(|x| x * rate);
            for k in 0..3 {
                self.reaction[n][k] = self.mass[n] * (self.a[n][k] - self.gravity[k]);
            }
        }
    }

    pub(super) fn constrain_velocities(&mut self) {
        for (n, c) in &self.constraints {
            let v = &mut self.v[*n as usize];
            apply(c, v, true);
        }
    }

    pub(super) fn constrain_accelerations(&mut self) {
        for (n, c) in &self.constraints {
            let a = &mut self.a[*n as usize];
            apply(c, a, false);
        }
    }

    /// The force each constraint applies to its node at the end of the last step, N, for the
    /// constrained local nodes in `constraints`' order (the explicit mode's; the implicit
    /// integrator has its own, `ImplicitFe::constraint_reactions`).
    ///
    /// Central differences at a constrained node n (mass m, element force f: stress, hourglass
    /// and bulk viscosity, gravity g): m a(n+1) = f(n+1) + m g + R(n+1), and the constraint
    /// prescribes a(n+1) (0 for `fixed` and `velocity`, its tangential part for symmetry
    /// planes), so R = m a_prescribed - f - m g = m (a_constrained - a_free), a_free = f/m + g
    /// (`finish_step` keeps it). The contact push-back between the kicks adds the impulse
    /// F_c dt, of which the constraint removes the part it does not allow: its force over the
    /// step is m (dv_constrained - dv_free) / dt (-F_c at a fixed node), added here
    /// ([`ExplicitFe::apply_contact`]). With R at every step, the bodies' momentum changes over
    /// a step by dt/2 (R(n) + R(n+1)) summed over nodes, plus M g dt (velocity Verlet's two
    /// half kicks; the element forces sum to zero): the trapezoid rule over the rows of
    /// reactions.csv integrates the reactions exactly.
    pub fn constraint_reactions(&self) -> impl Iterator<Item = (u32, [f64; 3])> + '_ {
        self.constraints
            .iter()
            .zip(&self.contact_reaction)
            .map(|((n, _), rc)| {
                let i = *n as usize;
                // Before the first step: the initial state's (`new`: a(0) constrained).
                let r = if self.step == 0 {
                    let (m, a, f, g) = (self.mass[i], self.a[i], self.force[i], self.gravity);
                    std::array::from_fn(|c| m * (a[c] - g[c]) - f[c])
                } else {
                    self.reaction[i]
                };
                (*n, std::array::from_fn(|c| r[c] + rc[c]))
            })
    }
}
