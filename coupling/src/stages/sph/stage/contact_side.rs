//! The SPH stage's side of contact: its particles as contact nodes (radius, start and
//! predicted position, start velocity), the push-back's energy terms and its correction applied.
use super::*;
use sph::particles::{HELD_LAST, HELD_NOW, PUSHED_NOW};

impl SphStage {
    /// Sets each material's initial density (per EOS index), kg/m^3: the contact radius's
    /// (`contact_records`).
    pub fn set_contact_density(&mut self, rho: Vec<f64>) {
        self.contact_rho = rho;
    }

    /// The density that fixes owned particle `i`'s contact radius, kg/m^3: its material's
    /// initial density, else its EOS's reference density, else its own.
    pub(super) fn contact_density(&self, i: usize) -> f64 {
        let p = &self.parts;
        let mat = p.mat[i] as usize;
        self.contact_rho
            .get(mat)
            .copied()
            .or_else(|| self.params.eos[mat].reference_density())
            .unwrap_or(p.rho[i])
    }

    /// Owned particle `i`'s contact radius, m: half its size at its material's initial
    /// density, `(m / rho_init)^(1/3) / 2` (half the spacing it was seeded at; see
    /// [`SphStage::contact_records`] for why it does not follow the density). The rigid walls
    /// keep a particle this far from their planes, as a mesh face does.
    pub fn contact_radius(&self, i: usize) -> f64 {
        0.5 * libm::cbrt(self.parts.m[i] / self.contact_density(i))
    }

    /// Contact-node records of the owned particles after `drift` (start and predicted end
    /// position, start-of-step velocity), ids `gid_offset + id`. Fixed particles have infinite
    /// mass (they take reactions but do not move). The contact radius is half the particle's
    /// size at its material's initial density, (m/rho_init)^(1/3)/2 (half the spacing it was
    /// seeded at), and does not change over the run. It must not grow: the search counts a
    /// contact only for a sphere that was outside the face (within the capture tolerance) at
    /// the start of the step, and the push-back closes only what the step's motion made (see
    /// `contact::pushback`), so a radius that grows while the particle rests on a face (a
    /// compressed particle expanding back, detonation products expanding to several times
    /// their volume) puts the particle behind the face by the growth and, past the tolerance,
    /// loses the contact. Measured on `cloud_on_plate` with the radius of the current density:
    /// particles at the bottom compressed to 1190 kg/m^3 and expanding back to 860 fell through
    /// the plate at 9 m/s.
    pub fn contact_records(&self, gid_offset: u64, dt: f64) -> Vec<::contact::NodeRecord> {
        let p = &self.parts;
        // The start-of-step velocity v(n) = v(n+1/2) - (dt/2) f(n)/m, as `apply_contact`
        // measures its work.
        let start = |i: usize| -> [f64; 3] {
            std::array::from_fn(|c| p.v[i][c] - 0.5 * dt * p.f[i][c] / p.m[i])
        };
        (0..p.n_owned)
            .map(|i| ::contact::NodeRecord {
                gid: gid_offset + p.id[i],
                body: u32::MAX,
                flags: ::contact::FLAG_PARTICLE,
                mass: if p.fixed[i] { f64::INFINITY } else { p.m[i] },
                radius: self.contact_radius(i),
                x0: self.x_start[i],
                x1: p.x_real[i],
                v: start(i),
            })
            .collect()
    }

    /// The terms `[A, B]` of the change of the half-step kinetic energy that `force` scaled by
    /// `alpha` makes, `dK(alpha) = alpha A + alpha^2 B`, over owned moving particles (J):
    /// `A = sum m dv . v(n+1/2)`, `B = sum m |dv|^2 / 2`, `dv = F dt / m`
    /// ([`::contact::energy::half_step_terms`]).
    pub fn contact_energy_terms(&self, force: &[[f64; 3]], dt: f64) -> [Folds; 2] {
        let p = &self.parts;
        let e = &self.grids.energy;
        let mut t = [[0.0; 3]; 2];
        for (i, f) in force.iter().enumerate().take(p.n_owned) {
            if *f == [0.0; 3] || p.fixed[i] {
                continue;
            }
            for c in 0..3 {
                let dv = f[c] * dt / p.m[i];
                let [a, b] = ::contact::energy::half_step_terms(p.m[i], dv, p.v[i][c]);
                e.add(&mut t[0], a);
                e.add(&mut t[1], b);
            }
        }
        t
    }

    /// Applies the contact stage's push-back forces (aligned with `contact_records`) over the
    /// step: dv = f dt / m on the half-step (and predicted) velocity, dx = dv dt. Returns the
    /// change of kinetic energy beyond what the pair and gravity work count (velocity Verlet
    /// with an impulse between the kicks: m dv.(v + dv/2) - (dt/2) m a_n.dv, a_n = f_n/m, the
    /// contact stage's bookkeeping [`::contact::energy::booked_work`]), summed over this rank's
    /// particles.
    /// `held`: who holds each particle through the closing kick (see `hold_on_faces`): 0 none,
    /// 1 the immovable faces alone, 2 + k rigid wall k.
    pub fn apply_contact(&mut self, force: &[[f64; 3]], held: &[u8], dt: f64) -> Folds {
        let standard = self.params.profile == Profile::Standard;
        let p = &mut self.parts;
        let grid = self.grids.energy;
        let mut work = [0.0; 3];
        // what the last step's holds left each particle to book (`hold`), from its first
        // correction of the step on
        let left = &mut self.hold_left;
        if left.len() < p.n_owned {
            left.resize(p.n_owned, 0.0);
        }
        let rough = &self.rough_walls;
        for (i, f) in force.iter().enumerate().take(p.n_owned) {
            if *f == [0.0; 3] || p.fixed[i] {
                continue;
            }
            // The predicted velocity vhat = v(n+1/2) + dt/2 a(n) (the rates' velocity) still
            // carries the half kick into the face that the push-back stopped: a particle held
            // on a face would expand (continuity density, p dV work) as if it moved into it.
            // Its part along the push-back's direction n, when it points into the face, is
            // removed, so the rates see the particle resting on the face.
            let fn_ = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
            let n = [f[0] / fn_, f[1] / fn_, f[2] / fn_];
            let kick_n = (0..3)
                .map(|c| 0.5 * dt * p.f[i][c] / p.m[i] * n[c])
                .sum::<f64>();
            // The standard profile books the pair work at full-step velocities
            // (`sph::book_work_at_step_velocity`): the correction books its own change of the
            // kinetic energy, m dv . (v + dv/2), which with that work and the integrator's
            // telescoping m (|p|^2 - |q|^2) / 2 (p = (dt/2) a(n), q = (dt/2) a(n+1)) is the
            // step's whole change; and, for a particle that faces or walls held through the
            // last step's closing kick, m (p . n)^2 / 2 of the start kick into the face: the
            // share of that telescoping term the hold took back with the closing kick q's
            // (`hold_on_faces`; p = q, the same a(n)), so that a particle resting on a face
            // books nothing. Once per holder of that kick (`Particles::held_by`): the step's
            // first correction takes its own holder's share (or the first holder's), a later
            // one only its own holder's, so that a particle resting in a corner of walls books
            // the share each wall took (for walls at right angles the shares add up to the
            // whole hold, |p . n1|^2 + |p . n2|^2) and one held by one face books one. The
            // later ones book at most what the holds took and the earlier ones left,
            // m |d|^2 / 2 in all (`hold_on_faces`, kept in `hold` between steps): friction
            // leans a wall's push-back towards the other wall of a corner, and the two shares
            // along the push-backs would count that part twice. Not for
            // one corrected without a hold (pressed on a moving face): its telescoping is
            // whole, and the term booked every step it stays pressed was a loss of
            // m (a dt/2)^2 / 2 a step, first order in dt over a run. The LIGGGHTS profile
            // (pair work at v^) books it against the start velocity and the share of the start
            // kick `contact::energy::booked_kick` gives.
            // The holder of this correction (`held`): 0 none, 1 the immovable faces alone,
            // 2 + k rigid wall k.
            let tag = held.get(i).copied().unwrap_or(0);
            let kick = if standard {
                let first = p.pushed[i] & PUSHED_NOW == 0;
                if first && p.pushed[i] & HELD_LAST != 0 {
                    // what the last step's holds left to book, kept in `hold` since
                    left[i] = p.hold[i][0];
                    p.hold[i] = [0.0; 3];
                }
                if p.pushed[i] & HELD_LAST != 0
                    && kick_n < 0.0
                    && take_holder(&mut p.held_by[i], tag, first)
                {
                    let term = 0.5 * p.m[i] * kick_n * kick_n;
                    let booked = if first {
                        term
                    } else {
                        term.min(left[i].max(0.0))
                    };
                    grid.add(&mut work, booked);
                    left[i] -= booked;
                }
                0.0
            } else {
                ::contact::energy::booked_kick(p.pushed[i])
            };
            p.pushed[i] |= PUSHED_NOW;
            // The rates' velocity loses the kick into the face along the face's normal: a
            // rough wall's push-back leans along the wall by its friction, and the kick along
            // that lean would leave the particle moving into the wall and along it in the
            // rates (water on a rough floor expanded into tension and rose).
            let (vn, k_vhat) = match rough_wall_normal(&self.wall_normals, rough, tag) {
                Some(m) => (
                    m,
                    (0..3)
                        .map(|c| 0.5 * dt * p.f[i][c] / p.m[i] * m[c])
                        .sum::<f64>(),
                ),
                None => (n, kick_n),
            };
            for c in 0..3 {
                let dv = f[c] * dt / p.m[i];
                let start_kick = kick * dt * p.f[i][c] / p.m[i];
                let w = ::contact::energy::booked_work(p.m[i], dv, p.v[i][c], start_kick);
                grid.add(&mut work, w);
                p.v[i][c] += dv;
                p.vhat[i][c] += dv - k_vhat.min(0.0) * vn[c];
                p.x[i][c] += dv * dt;
            }
            p.x_real[i] = p.x[i];
            if tag > 0 {
                add_holder(p, i, n, tag);
            }
        }
        work
    }

    /// After the step's closing half-kick: a particle that immovable faces alone held in the
    /// step (`apply_contact`'s `held`, outward normal `n`) loses the part of that kick that
    /// points into the faces, `dv = -min(0, (dt/2) a . n) n`, `a = f / m`: the faces cannot give
    /// way, and their reaction over the second half-step is what stops it (the push-back, which
    /// acts between the kicks, stops only the first half's). Without it a particle at rest
    /// pressed on a fixed face ends each step with the velocity `a dt/2` into the face, its
    /// kinetic energy `m (a dt/2)^2 / 2` made by no motion, and contact books that energy as
    /// given back at the step the pressing starts. Energy: the hold and the push-back together
    /// do no work on a particle at rest on the faces. The standard profile (pair work at
    /// full-step velocities) books the hold's change of the kinetic energy beyond that work
    /// in `hold_work` (below: zero at rest). The LIGGGHTS profile's push-back booking counts
    /// both (a held particle starts the next step as one the push-back meets first:
    /// `contact::energy::booked_kick`, `m (-p) . (p/2 - p/2) = 0` for `p = (dt/2) a`), so
    /// there the hold books nothing itself. Momentum: the faces' nodes are prescribed (infinite
    /// mass), so the impulse goes to their constraint, as a push-back on them does.
    pub(super) fn hold_on_faces(&mut self, dt: f64) {
        let standard = self.params.profile == Profile::Standard;
        let (grid, mgrid) = (self.grids.energy, self.grids.momentum);
        let p = &mut self.parts;
        for i in 0..p.n_owned {
            let h = p.hold[i];
            if h == [0.0; 3] {
                continue;
            }
            p.hold[i] = [0.0; 3];
            let more = std::mem::take(&mut p.hold_more[i]);
            // this step's holders, from the last step's (`Particles::held_by`)
            p.held_by[i] = [0; 3];
            // Not corrected in this step: `hold` kept what the last step's holds left to book
            // (`apply_contact`), unused; it stays with the integrator's telescoping term.
            if p.fixed[i] || p.pushed[i] & PUSHED_NOW == 0 && standard {
                continue;
            }
            // the first holder's tag is the stored normal's length (`add_holder`): 1 the
            // faces, 2 + k rigid wall k; the others are rigid walls, their normals the walls'
            let tag = holder_tag(h);
            let mut n = h.map(|c| c / f64::from(tag));
            let others: Vec<(u8, [f64; 3])> = more
                .into_iter()
                .filter_map(|t| Some((t, *self.wall_normals.get(usize::from(t).checked_sub(2)?)?)))
                .collect();
            // A rough wall's push-back leans by its friction, and in a corner it leans into
            // the other walls' normals: the first holder's direction loses those parts (each
            // other wall holds its own), or its hold would give the particle velocity along
            // them, away from the other walls (water in a box of rough walls climbed them).
            let rough = usize::from(tag)
                .checked_sub(2)
                .and_then(|k| self.rough_walls.get(k))
                == Some(&true);
            if rough && !others.is_empty() {
                for (_, m) in &others {
                    let c = n[0] * m[0] + n[1] * m[1] + n[2] * m[2];
                    n = std::array::from_fn(|l| n[l] - c * m[l]);
                }
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                n = if len > 0.0 {
                    n.map(|c| c / len)
                } else {
                    [0.0; 3]
                };
            }
            // The closing kick q = (dt/2) a, less what the holders before took: in a corner
            // each wall takes the part still pointing into it (walls at right angles: each its
            // own component, in any order).
            let mut q: [f64; 3] = std::array::from_fn(|c| 0.5 * dt * p.f[i][c] / p.m[i]);
            let mut slot = 0;
            // the velocity the holds take, d
            let mut d = [0.0; 3];
            for (tag, n) in std::iter::once((tag, n)).chain(others) {
                let k = (0..3).map(|c| q[c] * n[c]).sum::<f64>();
                if k >= 0.0 {
                    continue;
                }
                if standard {
                    // The standard profile's (pair work at full-step velocities,
                    // `apply_contact`): the hold's change of the kinetic energy beyond the
                    // closing kick's pair work at the held velocity, m h . (q + h/2 - v) with
                    // h = k n the velocity taken, q = (dt/2) a the closing kick and v the
                    // velocity before, less m k^2 / 2 (the closing kick's share of the
                    // telescoping term): m k (k - v . n). Zero for a particle at rest on the
                    // face; it stays a particle corrected in this step.
                    let vn = (0..3).map(|c| p.v[i][c] * n[c]).sum::<f64>();
                    grid.add(&mut self.hold_work, p.m[i] * k * (k - vn));
                    p.pushed[i] |= HELD_NOW;
                    p.held_by[i][slot] = tag;
                    slot += 1;
                } else {
                    // Held: its start velocity in the next step carries no kick into the faces.
                    p.pushed[i] &= !PUSHED_NOW;
                }
                for c in 0..3 {
                    p.v[i][c] -= k * n[c];
                    q[c] -= k * n[c];
                    d[c] += k * n[c];
                }
                // a rigid wall's hold is part of its impulse (reactions.csv), m (-k n)
                if tag >= 2 {
                    // (sized to the scene's walls at set-up: `Walls::size_holds`)
                    if let Some(j) = self.hold_impulse.get_mut(usize::from(tag) - 2) {
                        for c in 0..3 {
                            mgrid.add(&mut j[c], -p.m[i] * k * n[c]);
                        }
                    }
                }
            }
            if standard && p.pushed[i] & HELD_NOW != 0 {
                // what the next step's corrections may book (`apply_contact`): m |d|^2 / 2
                let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                p.hold[i] = [0.5 * p.m[i] * dd, 0.0, 0.0];
            }
        }
    }
}

/// Takes the holder `tag` (`apply_contact`'s `held`) out of a particle's last holders `by`
/// ([`Particles::held_by`]); for the step's `first` correction, one that is not among them takes
/// the first there is. Whether the correction books a held share of the start kick.
fn take_holder(by: &mut [u8; 3], tag: u8, first: bool) -> bool {
    let slot = by
        .iter()
        .position(|&t| t != 0 && t == tag)
        .or_else(|| by.iter().position(|&t| t != 0).filter(|_| first));
    if let Some(s) = slot {
        by[s] = 0;
    }
    // The first correction books whether or not a holder is left (as before holders were
    // kept).
    slot.is_some() || first
}

/// Records holder `tag` (1 the faces, 2 + k rigid wall k), pushing particle `i` back along the
/// unit normal `n`, for the step's closing kick (`hold_on_faces`): the first holder of the step
/// (or the same one again) as `n` times its tag in `hold`; another rigid wall by its tag in
/// `hold_more`, its normal the wall's (a third beyond those is not held).
fn add_holder(p: &mut Particles, i: usize, n: [f64; 3], tag: u8) {
    let first = holder_tag(p.hold[i]);
    if first == 0 || first == tag {
        p.hold[i] = n.map(|c| c * f64::from(tag));
    } else if tag >= 2 && !p.hold_more[i].contains(&tag) {
        if let Some(slot) = p.hold_more[i].iter_mut().find(|t| **t == 0) {
            *slot = tag;
        }
    }
}

/// The holder's tag a stored hold carries as its length (`add_holder`), 0 for none.
fn holder_tag(h: [f64; 3]) -> u8 {
    (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt().round() as u8
}

/// The unit normal of the rough rigid wall whose tag (2 + k, wall k) is `tag`, `None` for a
/// frictionless wall or another holder.
fn rough_wall_normal(normals: &[[f64; 3]], rough: &[bool], tag: u8) -> Option<[f64; 3]> {
    let k = usize::from(tag).checked_sub(2)?;
    rough.get(k).copied()?.then(|| normals[k])
}
