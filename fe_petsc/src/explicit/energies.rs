//! The global energies: the reduction of each step's sums, and the energies at step 0.
use super::*;

impl ExplicitFe {
    /// The local sums of a step to be reduced over ranks (one reduction, MPI's sum), as
    /// folds laid out flat ([`exact_sum::flatten`]): `finish_step`'s six, the element loop's
    /// hourglass work, then with several blocks `blocks.step_sums`.
    pub fn step_sums(&self, finish: &StepFolds, hg_work: &Folds) -> Vec<f64> {
        let mut v = finish.to_vec();
        v.push(*hg_work);
        if self.blocks.active() {
            v.extend_from_slice(&self.blocks.step_sums);
        }
        exact_sum::flatten(&v)
    }

    /// Applies the reduced sums of a step (`step_sums` summed over ranks) to the global
    /// energies: the kinetic energy is half the sum of m v.v, the change of internal plus
    /// hourglass energy minus half the sum of f . dx over both halves of the trapezoids.
    pub fn accumulate(&mut self, global_folds: &[f64], dt: f64) {
        let global = exact_sum::values(global_folds);
        self.energies.kinetic = 0.5 * global[0];
        self.internal_plus_hg += -0.5 * global[1];
        self.energies.external_work += global[2];
        self.energies.momentum = [global[3], global[4], global[5]];
        self.energies.hourglass += global[6];
        self.energies.internal = self.internal_plus_hg - self.energies.hourglass;
        let nb = self.block_energies.len();
        if self.blocks.active() {
            for (b, be) in self.block_energies.iter_mut().enumerate() {
                be.internal_plus_hg += global[7 + b];
                be.hourglass += global[7 + nb + b];
                be.internal = be.internal_plus_hg - be.hourglass;
            }
        } else if let Some(be) = self.block_energies.first_mut() {
            be.internal = self.energies.internal;
            be.hourglass = self.energies.hourglass;
        }
        self.time += dt;
        self.step += 1;
    }

    /// Global kinetic energy and momentum now (collective); used at step 0. Also each block's
    /// kinetic energy: its elements' lumped masses (rho V0 / 8 per corner) at their nodes'
    /// velocities, so that a node between blocks counts in each by its share of mass.
    pub fn initial_energies(&mut self, comm: &SimpleCommunicator) {
        // The grids of every energy and momentum sum, from the mass summed exactly.
        let owned_mass: Vec<f64> = (0..self.x.len())
            .filter(|&n| self.owned[n] && self.mass[n].is_finite())
            .map(|n| self.mass[n])
            .collect();
        self.grids = SumGrids::for_mass(exact_sum::total(comm, &owned_mass));
        self.blocks.grid = self.grids.energy;
        let (ge, gp) = (self.grids.energy, self.grids.momentum);
        let nb = self.block_energies.len();
        let mut s = vec![[0.0; 3]; 4 + nb];
        for n in 0..self.x.len() {
            if self.owned[n] {
                let m = self.mass[n];
                let v = self.v[n];
                for c in 0..3 {
                    ge.add(&mut s[0], m * (v[c] * v[c]));
                    gp.add(&mut s[1 + c], m * v[c]);
                }
            }
        }
        for (e, conn) in self.elems.iter().enumerate() {
            let me = self.materials[self.elem_material[e]].density() * self.vol0[e] / 8.0;
            let b = self.blocks.block_of(e);
            for &n in conn {
                let v = self.v[n as usize];
                for c in 0..3 {
                    ge.add(&mut s[4 + b], me * (v[c] * v[c]));
                }
            }
        }
        if let Some(t) = &self.tets {
            let nh = self.elems.len();
            for (e, conn) in t.conn.iter().enumerate() {
                let me = self.materials[t.material[e]].density() * t.vol0[e] / 4.0;
                let b = self.blocks.block_of(nh + e);
                for &n in conn {
                    let v = self.v[n as usize];
                    for c in 0..3 {
                        ge.add(&mut s[4 + b], me * (v[c] * v[c]));
                    }
                }
            }
        }
        let flat = exact_sum::flatten(&s);
        let mut g = vec![0.0; flat.len()];
        comm.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
        let g = exact_sum::values(&g);
        self.energies.kinetic = 0.5 * g[0];
        self.energies.momentum = [g[1], g[2], g[3]];
        for (b, be) in self.block_energies.iter_mut().enumerate() {
            be.kinetic0 = 0.5 * g[4 + b];
        }
    }
}
