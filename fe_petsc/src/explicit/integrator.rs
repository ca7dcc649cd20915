//! The integrator's two halves around the element loop: kick and drift, then the closing kick
//! with the constraints' reactions and the local energy sums.
use super::*;

impl ExplicitFe {
    /// How many nodes the nodal passes take at a time (`nodal`): as many as the element
    /// kernel's lanes (eight with AVX-512F, four with AVX2; one off x86-64).
    pub(super) fn wide_nodes(&self) -> nodal::Nodes {
        nodal::Nodes::of(self.width)
    }

    /// First half of the step: kick to the half step, apply constraints, drift the positions.
    pub fn kick_drift(&mut self, dt: f64) {
        let t0 = std::time::Instant::now();
        // One pass: kick, keep the start position, drift (`nodal::kick_drift`); then the
        // constrained nodes' velocities and drifts again.
        let wide = self.wide_nodes();
        // The constrained nodes' start positions (every node's where they are kept).
        self.constrained_start.clear();
        let x = &self.x;
        let starts = self.constraints.iter().map(|(n, _)| x[*n as usize]);
        self.constrained_start.extend(starts);
        let t = self.time;
        self.gravity = self.gravity_at(t);
        for p in &mut self.pushed {
            *p >>= 1;
        }
        // A velocity with a curve: its nodes' v(n) + dt/2 a(n), a(n) = v ds/dt at t
        // (`finish_step`), is their half-step velocity by the kick; the constraint sets them to
        // v times the curve's mean over the new step (below). Where the curve is linear over
        // both half steps the two agree to round-off; at a kink they differ, and the
        // difference m dv is an impulse of the constraint too: booked as its force over the
        // step, m dv / dt, with its work, the half-step kinetic energy it changes (the
        // push-back's impulses are booked the same way, `apply_contact`).
        let kicked: Vec<[f64; 3]> = self
            .velocity_curves
            .iter()
            .map(|(i, _, _)| {
                let n = self.constraints[*i].0 as usize;
                std::array::from_fn(|c| self.v[n][c] + 0.5 * dt * self.a[n][c])
            })
            .collect();
        let x_old = self.contact.then_some(&mut self.x_old[..]);
        // The constrained owned nodes' forces, read below after the kick may have zeroed them.
        self.constrained_force.clear();
        let f = &self.force;
        let kept = self.constrained_nodes.iter().map(|&n| f[n as usize]);
        self.constrained_force.extend(kept);
        let input = nodal::KickInput {
            energy: self.grids.energy,
            mass: &self.mass,
            gravity: self.gravity,
            owned: &self.owned,
            constrained: &self.constrained,
        };
        let zero = !self.contact;
        self.kick_dt = dt;
        let mut work = nodal::kick_drift(
            &mut self.v,
            &mut self.force,
            zero,
            &input,
            &mut self.x,
            x_old,
            dt,
            wide,
        );
        self.forces_zeroed = zero;
        self.contact_reaction.fill([0.0; 3]);
        self.scale_velocities(t, dt);
        self.constrain_velocities();
        let grid = self.grids.energy;
        for ((i, _, _), vk) in self.velocity_curves.iter().zip(kicked) {
            let n = self.constraints[*i].0 as usize;
            let (m, v) = (self.mass[n], self.v[n]);
            for c in 0..3 {
                self.contact_reaction[*i][c] += m * (v[c] - vk[c]) / dt;
                if self.owned[n] {
                    let de = 0.5 * m * (v[c] * v[c] - vk[c] * vk[c]);
                    grid.add(&mut self.contact_reaction_work, de);
                }
            }
        }
        for ((n, _), x0) in self.constraints.iter().zip(&self.constrained_start) {
            let n = *n as usize;
            for c in 0..3 {
                self.x[n][c] = x0[c] + dt * self.v[n][c];
            }
        }
        // The constrained owned nodes' f(n) . dt v(n+1/2), with their constrained velocities.
        for (&n, f) in self.constrained_nodes.iter().zip(&self.constrained_force) {
            let n = n as usize;
            if self.owned[n] {
                let v = self.v[n];
                for c in 0..3 {
                    self.grids.energy.add(&mut work, f[c] * (dt * v[c]));
                }
            }
        }
        self.kick_work = work;
        self.timers.nodal += t0.elapsed().as_secs_f64();
    }

    /// Second half of the step: accelerations, constraints and reactions, the closing kick, and
    /// the local energy increments. Returns the local sums to be reduced, raw
    /// ([`StepFolds`]: [`ExplicitFe::accumulate`] scales them).
    pub fn finish_step(&mut self, dt: f64) -> StepFolds {
        let t0 = std::time::Instant::now();
        // Gravity at the step's end; its work over the step with the mean of both ends
        // (the trapezoid of m g . dx; g itself when it does not change).
        let g_old = self.gravity;
        self.gravity = self.gravity_at(self.time + dt);
        let g = self.gravity;
        let gravity_work = if g == g_old {
            g
        } else {
            std::array::from_fn(|c| 0.5 * (g_old[c] + g[c]))
        };
        let h = 0.5 * dt;
        let mut sums = [[0.0; 3]; 6];
        self.load_work(dt, &mut sums);
        let nn = self.x.len();
        // The arrays as slices of one length, borrowed field by field (the loops below index
        // them without bounds checks and keep the sums in registers: through `&self` methods
        // this pass took about 235 instructions per node, the sums not inlined).
        let read = NodalSums {
            dt,
            force: &self.force[..nn],
            mass: &self.mass[..nn],
            owned: &self.owned[..nn],
            gravity: g,
            gravity_work,
            grids: self.grids,
        };
        let constrained = &self.constrained[..nn];
        let wide = self.wide_nodes();
        let (a, v) = (&mut self.a[..nn], &mut self.v[..nn]);
        // One pass over the free nodes: closing kick and sums (their accelerations are not
        // kept: the next kick forms them from the same forces).
        nodal::close_free(&read, constrained, v, &mut sums, wide);
        // The constrained nodes: their free accelerations, then reaction = m a(constrained) -
        // m a(free), the force the constraint adds; then their kick and sums.
        for (node, _) in &self.constraints {
            let n = *node as usize;
            let (f, im) = (read.force[n], crate::nodal::inverse_mass(read.mass[n]));
            a[n] = [f[0] * im + g[0], f[1] * im + g[1], f[2] * im + g[2]];
        }
        std::mem::swap(&mut self.reaction, &mut self.reaction_old);
        // A velocity with a curve: its acceleration v ds/dt at the step's end, so the
        // reaction holds the force that changes the driven nodes' momentum.
        let t1 = self.time + dt;
        let mut curved = self.velocity_curves.iter().peekable();
        for (i, (node, con)) in self.constraints.iter().enumerate() {
            let n = *node as usize;
            let free = a[n];
            apply(con, &mut a[n], false);
            if let Some((_, v, curve)) = curved.next_if(|(k, _, _)| *k == i) {
                let rate = curve.slope(t1);
                a[n] = v.map(|x| x * rate);
            }
            for c in 0..3 {
                self.reaction[n][c] = read.mass[n] * (a[n][c] - free[c]);
            }
        }
        for &n in &self.constrained_nodes {
            let n = n as usize;
            let vn = &mut v[n];
            let half = *vn;
            for c in 0..3 {
                vn[c] += h * a[n][c];
            }
            read.add(
                n,
                *vn,
                half,
                self.reaction[n],
                self.reaction_old[n],
                &mut sums,
            );
        }
        // The element work's other half, counted at the kick (`nodal::kick_drift`).
        exact_sum::merge(&mut sums[1], &std::mem::take(&mut self.kick_work));
        // The constraints' reactions to the push-back, with the other reactions' work.
        exact_sum::merge(
            &mut sums[2],
            &std::mem::take(&mut self.contact_reaction_work),
        );
        // The rigid walls hold the nodes they put back through the closing kick.
        self.hold_on_walls(dt, &mut sums);
        self.timers.nodal += t0.elapsed().as_secs_f64();
        sums
    }
}
