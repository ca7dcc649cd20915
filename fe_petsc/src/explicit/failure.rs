//! Element failure and erosion (`[[material]] failure`, `[[block]] failed = "delete"`,
//! docs/scene.md): an element whose material fails is taken out of the element loop and
//! carries no force from then on; its mass stays on its nodes.
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
//! stays on its nodes: mass and momentum are untouched by the erosion, and the work the element
//! took stays in `internal_energy` (energy it no longer gives back), so the balance holds.
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
        }));
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
            let fails = match crit {
                Failure::PlasticStrain(eps_f) => ep >= eps_f,
                Failure::JohnsonCook { .. } => {
                    if dep > 0.0 {
                        let triax = triaxiality(&self.state.stress(e));
                        r.damage[e] += dep / crit.strain_to_failure(triax, dep / dt);
                    }
                    r.damage[e] >= 1.0
                }
            };
            if fails {
                r.failed[e] = true;
                r.any = true;
                let mut s = self.state.get(e);
                s.stress = [0.0; 6];
                s.hg = Default::default();
                self.state.set(e, &s);
            }
        }
    }
}
