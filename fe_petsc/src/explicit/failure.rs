//! Element failure and erosion (`[[material]] failure`, `[[block]] failed`, docs/scene.md): an
//! element whose material fails is taken out of the element loop and carries no force from
//! then on; deleted, its mass stays on its nodes; turned into a particle, it is released a
//! step later with its mass ([`ExplicitFe::release_failed`]).
//!
//! **Inversion.** An element whose material has a criterion also fails in the step in which
//! it would invert (`ExplicitFe::fail_inverted`, from the element loop): its group is
//! updated again without it, and it keeps the state of its last update.
//!
//! **Criteria** (checked after each step's element update, on the accepted state):
//! - `plastic_strain`: the element fails when its equivalent plastic strain reaches `eps_f`;
//! - `johnson_cook` (Johnson & Cook, Eng. Fract. Mech. 21, 1985, 31-48, eq. 2-3; isothermal):
//!   the damage `D = sum d(ep) / eps_f` grows with each step's plastic strain increment, where
//!   `eps_f = (d1 + d2 exp(d3 sigma*)) (1 + d4 ln(max(rate*, 1)))`, `sigma* = -p / q` the stress
//!   triaxiality (mean stress over the von Mises stress; 0 where q = 0) and `rate*` the
//!   plastic strain rate over the reference rate `eps_dot0`; the element fails at `D >= 1`.
//!
//! **Erosion.** A failed element keeps its place in the arrays (the canonical element order of
//! the ordered sums, [`crate::assembly`], stays as it is): its stress and hourglass forces are
//! set to zero, it adds zero to its nodes, and the element loop leaves it out of its group's
//! lanes (a group with failed elements goes through the lane-by-lane path with live elements
//! only), so it neither limits the stable step nor stops the run when it inverts. Its mass
//! stays on its nodes (where it is deleted): mass and momentum are untouched by the erosion,
//! and the work the element took stays in `internal_energy` (energy it no longer gives back),
//! so the balance holds. An element that becomes a particle keeps its stress and its volume
//! at failure for it.
//! Every copy of the decision is the same bits at any rank count: it reads the element's own
//! state, which is rank-independent.
use super::*;

/// A material's failure criterion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Failure {
    /// Failure at this equivalent plastic strain.
    PlasticStrain(f64),
    /// Johnson-Cook's damage: `[d1, d2, d3, d4]` and the reference plastic strain rate, 1/s.
    JohnsonCook {
        /// d1 .. d4.
        d: [f64; 4],
        /// The reference rate of `rate*`, 1/s.
        eps_dot0: f64,
    },
}

impl Failure {
    /// Johnson-Cook's strain to failure at triaxiality `triax` and plastic strain rate `rate`
    /// (1/s); the plastic-strain criterion's own strain.
    pub fn strain_to_failure(&self, triax: f64, rate: f64) -> f64 {
        match *self {
            Failure::PlasticStrain(e) => e,
            Failure::JohnsonCook { d, eps_dot0 } => {
                let r = (rate / eps_dot0).max(1.0);
                (d[0] + d[1] * (d[2] * triax).exp()) * (1.0 + d[3] * r.ln())
            }
        }
    }
}

impl Failure {
    /// Whether a material point fails after a step of `dt` (s) whose update left the
    /// equivalent plastic strain `ep` (grown by `dep` over the step) and the Cauchy stress
    /// `stress` (Voigt, Pa): the plastic-strain criterion at `ep >= eps_f`; Johnson-Cook's
    /// adds `dep / eps_f(sigma*, dep / dt)` to the `damage` D and fails at D >= 1 (module
    /// doc). The one decision of the elements ([`ExplicitFe`]'s check after each step) and of
    /// the solid particles (coupling's stress model of a `[[particles]]` material).
    pub fn fails(&self, damage: &mut f64, ep: f64, dep: f64, stress: &[f64; 6], dt: f64) -> bool {
        match *self {
            Failure::PlasticStrain(eps_f) => ep >= eps_f,
            Failure::JohnsonCook { .. } => {
                if dep > 0.0 {
                    // (a strain to failure that a negative d4 took to zero or below, past the
                    // rates the scene check allows: the point fails)
                    let eps_f = self.strain_to_failure(triaxiality(stress), dep / dt);
                    *damage += if eps_f > 0.0 {
                        dep / eps_f
                    } else {
                        f64::INFINITY
                    };
                }
                *damage >= 1.0
            }
        }
    }
}

/// The stress triaxiality `-p / q` of a Voigt stress `[xx, yy, zz, xy, yz, zx]`: the mean
/// stress over the von Mises stress (0 where the latter is 0).
pub fn triaxiality(s: &[f64; 6]) -> f64 {
    let mean = (s[0] + s[1] + s[2]) / 3.0;
    let (dx, dy, dz) = (s[0] - mean, s[1] - mean, s[2] - mean);
    let j2 = 0.5 * (dx * dx + dy * dy + dz * dz) + s[3] * s[3] + s[4] * s[4] + s[5] * s[5];
    let q = (3.0 * j2).sqrt();
    if q > 0.0 {
        mean / q
    } else {
        0.0
    }
}

/// The failure state of the hexahedra.
#[derive(Debug, Clone)]
pub(crate) struct Erosion {
    /// Each material's criterion (`None`: it does not fail).
    pub criteria: Vec<Option<Failure>>,
    /// Whether each element has failed.
    pub failed: Vec<bool>,
    /// Each element's Johnson-Cook damage (0 for the other criteria).
    pub damage: Vec<f64>,
    /// Each element's equivalent plastic strain after the last step.
    pub ep_last: Vec<f64>,
    /// Whether any element of this rank has failed (the loop's fast test).
    pub any: bool,
    /// Failed elements over all ranks after the last step ([`ExplicitFe::count_failed`]).
    pub global: u64,
    /// Per material: whether its failed elements become particles (their mass leaves their
    /// nodes: [`ExplicitFe::release_failed`]); else they are deleted (their mass stays).
    pub release: Vec<bool>,
    /// Whether each element has been released (its mass taken off its nodes).
    pub released: Vec<bool>,
    /// Whether each failed element's nodes have had a step without its force: it is
    /// released at the next [`ExplicitFe::release_failed`].
    pub ready: Vec<bool>,
    /// Each failed element's volume in the step it failed (the last its loop accepted), m^3:
    /// its particle's volume (out of the loop, its corners may fold it before the release).
    pub vol_fail: Vec<f64>,
}

/// The volume a failed element's particle takes, m^3: the element's volume `v` when it failed,
/// bounded to [`v0` / 2, 2 `v0`] (its reference volume `v0`). A solid's volume changes by its
/// elastic strain only (plastic flow keeps it), a few per cent; an element whose corners
/// folded it nearly flat (its volume 1e-7 of `v0` in a crushed soft plate) or that would
/// invert has none to give, and its particle's density would be that many times its
/// material's. No volume recorded (0, a checkpoint from before the volume was kept) gives
/// `v0`.
pub fn particle_volume(v: f64, v0: f64) -> f64 {
    if v > 0.0 {
        v.clamp(0.5 * v0, 2.0 * v0)
    } else {
        v0
    }
}

/// A failed element as it leaves the mesh to become a particle ([`ExplicitFe::release_failed`]):
/// what it carries, at the end of the step it failed in.
#[derive(Debug, Clone, PartialEq)]
pub struct Released {
    /// The element's global id.
    pub elem_id: u64,
    /// Its material index (`ExplicitFe::materials`).
    pub material: usize,
    /// Its mass rho0 V0, kg: what its corners took off their nodes (rho0 V0 / 8 each).
    pub mass: f64,
    /// Its centroid (the mean of its corners), m.
    pub x: [f64; 3],
    /// Its corners' momentum over its mass: the mean of its nodes' velocities, m/s (the
    /// momentum sum (m/8) v_n the nodes lost, exactly as a particle of mass m carries it, to
    /// round-off).
    pub v: [f64; 3],
    /// Its corners' kinetic energy sum (m/8) |v_n|^2 / 2 less the particle's m |v|^2 / 2, J
    /// (>= 0: the motion within the element that one particle cannot carry).
    pub kinetic_loss: f64,
    /// Its volume in the step it failed, m^3 (its particle's density is mass / volume).
    pub volume: f64,
    /// Its Cauchy stress at failure (Voigt), Pa.
    pub stress: [f64; 6],
    /// Its material's history values (`Material::n_state` of them).
    pub state: Vec<f64>,
    /// Its damage at failure (>= 1: Johnson-Cook's D, or 1 for the plastic-strain
    /// criterion): its particle is born failed.
    pub damage: f64,
}

impl ExplicitFe {
    /// Each material's failure criterion (index as `materials`; `None`: it does not fail).
    /// Without one that fails the run is as without erosion, bit for bit.
    pub fn set_failure(&mut self, criteria: Vec<Option<Failure>>) {
        if criteria.iter().all(Option::is_none) {
            self.erosion = None;
            return;
        }
        let ne = self.elems.len();
        self.erosion = Some(Box::new(Erosion {
            criteria,
            failed: vec![false; ne],
            damage: vec![0.0; ne],
            ep_last: vec![0.0; ne],
            any: false,
            global: 0,
            release: Vec::new(),
            released: vec![false; ne],
            ready: vec![false; ne],
            vol_fail: vec![0.0; ne],
        }));
    }

    /// Per material (as `set_failure`'s criteria): whether its failed elements become
    /// particles ([`ExplicitFe::release_failed`]) rather than being deleted.
    pub fn set_release(&mut self, release: Vec<bool>) {
        if let Some(r) = self.erosion.as_mut() {
            r.release = release;
        }
    }

    /// Whether a material's failed elements become particles.
    pub fn releases(&self) -> bool {
        self.erosion
            .as_ref()
            .is_some_and(|r| r.release.iter().any(|&b| b))
    }

    /// The failed elements whose material turns them into particles and whose nodes have had
    /// a step without their force, released (collective: call it after each step on every
    /// rank at once where [`ExplicitFe::eroded`] grew or [`ExplicitFe::count_released`] counts
    /// elements waiting). An element that failed in this step is released after the next: the
    /// forces of the step it failed in hold its last forces, which the next step's first
    /// half-kick gives its nodes with their masses; released at once, a node it alone held
    /// would drop its share of them (no mass, no acceleration) and the momentum with it.
    ///
    /// Each leaves its record ([`Released`]) and its mass: the lumped masses are summed again
    /// over the live and deleted elements, in the canonical order of the forces
    /// ([`crate::assembly`]: the same bits at any rank count). A node all of whose elements
    /// were released keeps no mass; the nodal update gives it no acceleration. Each node keeps
    /// its velocity, so the momentum the nodes lose is (m/8) sum v_n per released element, what
    /// its particle carries.
    pub fn release_failed(
        &mut self,
        exchange: &mut NodeExchange,
    ) -> Result<Vec<Released>, StepError> {
        let Some(r) = self.erosion.as_mut() else {
            return Ok(Vec::new());
        };
        let mut out = Vec::new();
        for e in 0..self.elems.len() {
            if !r.failed[e] || r.released[e] || !r.release[self.elem_material[e]] {
                continue;
            }
            if !r.ready[e] {
                r.ready[e] = true;
                continue;
            }
            r.released[e] = true;
            let mat = &self.materials[self.elem_material[e]];
            let m = mat.density() * self.vol0[e];
            let conn = &self.elems[e];
            let xe = gather(&self.x, conn);
            let ve = gather(&self.v, conn);
            let v = centroid(&ve);
            let mut ke_nodes = 0.0;
            for vn in &ve {
                ke_nodes += 0.5 * (m / 8.0) * (vn[0] * vn[0] + vn[1] * vn[1] + vn[2] * vn[2]);
            }
            let ke_particle = 0.5 * m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            let stride = self.mat_stride;
            out.push(Released {
                elem_id: self.elem_id[e],
                material: self.elem_material[e],
                mass: m,
                x: centroid(&xe),
                v,
                kinetic_loss: (ke_nodes - ke_particle).max(0.0),
                // the volume it failed at, within [V0 / 2, 2 V0]: an element crushed flat by
                // its corners (or failed where it would invert) has no meaningful volume left
                volume: particle_volume(r.vol_fail[e], self.vol0[e]),
                stress: self.state.stress(e),
                state: self.mat_state[e * stride..e * stride + mat.n_state()].to_vec(),
                // failed: Johnson-Cook's D (>= 1), 1 for the plastic-strain criterion
                damage: r.damage[e].max(1.0),
            });
        }
        self.resum_masses(exchange)?;
        // A node all of whose elements left carries nothing: it stops where it is (massless,
        // moving on it would carry the released elements' drawing through walls and other
        // bodies, at the speed it had; no momentum or energy changes)
        for (v, &m) in self.v.iter_mut().zip(&self.mass) {
            if m == 0.0 {
                *v = [0.0; 3];
            }
        }
        Ok(out)
    }

    /// Elements released to particles over all ranks, and those failed but not yet released
    /// (collective).
    pub fn count_released(&self, comm: &SimpleCommunicator) -> (u64, u64) {
        let mine = self.erosion.as_ref().map_or([0u64; 2], |r| {
            let mut c = [0u64; 2];
            for e in 0..r.failed.len() {
                if r.released[e] {
                    c[0] += 1;
                } else if r.failed[e] && r.release[self.elem_material[e]] {
                    c[1] += 1;
                }
            }
            c
        });
        let mut all = [0u64; 2];
        comm.all_reduce_into(&mine[..], &mut all[..], SystemOperation::sum());
        (all[0], all[1])
    }

    /// The kinetic energy and momentum of the nodes now, after a release took mass off them
    /// (collective): the same exact sums as the closing kick's, with the new masses.
    pub fn refresh_kinetic(&mut self, comm: &SimpleCommunicator) {
        let (ge, gp) = (self.grids.energy, self.grids.momentum);
        let mut s = [[0.0; 3]; 4];
        for n in 0..self.x.len() {
            if self.owned[n] {
                let (m, v) = (self.mass[n], self.v[n]);
                for c in 0..3 {
                    ge.add(&mut s[0], m * (v[c] * v[c]));
                    gp.add(&mut s[1 + c], m * v[c]);
                }
            }
        }
        let flat = crate::exact::flatten(&s);
        let mut g = vec![0.0; flat.len()];
        comm.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
        let g = crate::exact::values(&g);
        self.energies.kinetic = 0.5 * g[0];
        self.energies.momentum = [g[1], g[2], g[3]];
    }

    /// After a restart whose checkpoint had released elements: their mass off their nodes
    /// again (collective; nothing where none was released on any rank).
    pub fn restore_released_masses(
        &mut self,
        exchange: &mut NodeExchange,
    ) -> Result<(), StepError> {
        if self.releases() {
            self.resum_masses(exchange)?;
        }
        Ok(())
    }

    /// The lumped masses of the elements not released, summed as at the set-up (collective).
    fn resum_masses(&mut self, exchange: &mut NodeExchange) -> Result<(), StepError> {
        let released = self.erosion.as_ref().map(|r| &r.released);
        let mut mass3 = vec![[0.0; 3]; self.x.len()];
        for (e, conn) in self.elems.iter().enumerate() {
            if released.is_some_and(|r| r[e]) {
                self.assembly.record(e, |_| [0.0; 3]);
                continue;
            }
            let me = self.materials[self.elem_material[e]].density() * self.vol0[e] / 8.0;
            for &n in conn {
                for c in 0..3 {
                    mass3[n as usize][c] += me;
                }
            }
            self.assembly.record(e, |_| [me; 3]);
        }
        self.assembly.finish(&mut mass3, exchange)?;
        for (m, m3) in self.mass.iter_mut().zip(&mass3) {
            *m = m3[0];
        }
        Ok(())
    }

    /// Whether a material of this run fails.
    pub fn erodes(&self) -> bool {
        self.erosion.is_some()
    }

    /// Counts the failed elements over all ranks (collective where a material fails), kept for
    /// [`ExplicitFe::eroded`].
    pub fn count_failed(&mut self, comm: &SimpleCommunicator) {
        let mine = self.failed_count();
        if let Some(r) = self.erosion.as_mut() {
            let mut all = 0u64;
            comm.all_reduce_into(&mine, &mut all, SystemOperation::sum());
            r.global = all;
        }
    }

    /// Failed elements over all ranks after the last step (0 where no material fails).
    pub fn eroded(&self) -> u64 {
        self.erosion.as_ref().map_or(0, |r| r.global)
    }

    /// Whether element `e` has failed.
    #[inline]
    pub fn is_failed(&self, e: usize) -> bool {
        self.erosion.as_ref().is_some_and(|r| r.failed[e])
    }

    /// Whether element `e`'s material has a failure criterion (it may fail).
    pub fn can_fail(&self, e: usize) -> bool {
        self.erosion
            .as_ref()
            .is_some_and(|r| r.criteria[self.elem_material[e]].is_some())
    }

    /// This rank's failed elements.
    pub fn failed_count(&self) -> u64 {
        self.erosion
            .as_ref()
            .map_or(0, |r| r.failed.iter().filter(|&&f| f).count() as u64)
    }

    /// After the element update of a step of `dt`: the elements whose criterion is met fail
    /// (module doc). Their stress and hourglass forces become zero.
    pub(super) fn check_failure(&mut self, dt: f64) {
        let Some(r) = self.erosion.as_mut() else {
            return;
        };
        let stride = self.mat_stride;
        let mut failing = Vec::new();
        for e in 0..self.elems.len() {
            let Some(crit) = r.criteria[self.elem_material[e]] else {
                continue;
            };
            if r.failed[e] {
                continue;
            }
            let model = &self.materials[self.elem_material[e]];
            let ep = model.plastic_strain(&self.mat_state[e * stride..(e + 1) * stride]);
            let dep = ep - r.ep_last[e];
            r.ep_last[e] = ep;
            if crit.fails(&mut r.damage[e], ep, dep, &self.state.stress(e), dt) {
                failing.push(e);
            }
        }
        for e in failing {
            // its volume at the end of the step the loop accepted: its particle's
            let volume = hex::volume(&gather(&self.x, &self.elems[e]));
            self.mark_failed(e, volume);
        }
    }

    /// Element `e` fails in the step of `dt` in which it would invert (its material has a
    /// failure criterion; [`ExplicitFe::element_forces`]): marked failed before its update, it
    /// keeps the state of the last step it was updated in; its particle's volume is its
    /// volume then, at the start of the step (x(n) = x(n+1) - dt v(n+1/2)).
    pub(super) fn fail_inverted(&mut self, e: usize, dt: f64) {
        let xn: [[f64; 3]; 8] = std::array::from_fn(|k| {
            let node = self.elems[e][k] as usize;
            std::array::from_fn(|c| self.x[node][c] - dt * self.v[node][c])
        });
        let volume = hex::volume(&xn);
        if let Some(r) = self.erosion.as_mut() {
            r.damage[e] = r.damage[e].max(1.0);
        }
        self.mark_failed(e, volume);
    }

    /// Marks element `e` failed with its particle's `volume` (m^3): its stress and hourglass
    /// forces become zero (its stress kept where it becomes a particle).
    fn mark_failed(&mut self, e: usize, volume: f64) {
        let Some(r) = self.erosion.as_mut() else {
            return;
        };
        r.failed[e] = true;
        r.any = true;
        r.vol_fail[e] = volume;
        let mut s = self.state.get(e);
        // a failed element that becomes a particle keeps its stress for it
        if !r
            .release
            .get(self.elem_material[e])
            .copied()
            .unwrap_or(false)
        {
            s.stress = [0.0; 6];
        }
        s.hg = Default::default();
        self.state.set(e, &s);
    }

    /// Whether one of the elements `e..e + n` has failed.
    pub(super) fn has_failed_in(&self, e: usize, n: usize) -> bool {
        self.erosion
            .as_ref()
            .is_some_and(|r| r.any && (e..e + n).any(|k| r.failed[k]))
    }
}
