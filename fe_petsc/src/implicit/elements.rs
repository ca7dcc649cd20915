//! The implicit residual's element loop: the element kernel of the explicit loop ([`Batch`],
//! groups of consecutive elements of one material) on the trial positions, from the state at
//! t(n) into the trial state, the forces added to the nodes in canonical element order.
use super::{centroid, gather, ImplicitFe, StepError};
use crate::batch::arrays::{self, ElementArrays};
use crate::batch::{self, Batch, LaneMaterial, Width};
use crate::exact::Folds;

impl ImplicitFe {
    /// Every element's forces at the trial positions `x_trial` with the mean velocities
    /// `v_mean` over the step `dt`, from the state at t(n) into `state_trial` and `mat_trial`,
    /// added to `force` in element order (and recorded for the shared nodes' canonical sums).
    /// Returns the hourglass work of the step, or the first inverted element (the loop stops
    /// there; the caller makes the failure collective).
    pub(super) fn trial_element_forces(&mut self, dt: f64) -> Result<Folds, StepError> {
        match self.fe.width {
            Width::W1 => self.trial_loop::<batch::w1::LaneGroup>(dt),
            Width::W4 => self.trial_loop::<batch::w4::LaneGroup>(dt),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => self.trial_loop::<batch::w8::LaneGroup>(dt),
        }
    }

    /// [`Self::trial_element_forces`] in groups of `B::LANES`, the run's last group padded, as
    /// the explicit loop runs them.
    fn trial_loop<B: Batch>(&mut self, dt: f64) -> Result<Folds, StepError> {
        let lane_materials: Vec<LaneMaterial> = (self.fe.materials.iter())
            .map(|m| LaneMaterial::new(&**m, &self.controls))
            .collect();
        let mut g = Box::<B>::default();
        let grid = self.fe.grids.energy;
        let mut hg_work = [0.0; 3];
        self.trial_dt_min = f64::INFINITY;
        let mut e = 0;
        while e < self.fe.elems.len() {
            let n = self.fe.lane_run(e, B::LANES);
            let mi = self.fe.elem_material[e];
            let m = &lane_materials[mi];
            let from = ElementArrays {
                xs: &self.x_trial,
                vs: &self.v_mean,
                elems: &self.fe.elems,
                vol0: &self.fe.vol0,
                state: &self.fe.state,
                history: &self.fe.mat_state,
                stride: self.mat_stride,
            };
            arrays::load(&mut *g, &from, e, n, m.n_state());
            if let Err(bad) = g.update(dt, m, &*self.fe.materials[mi], &self.controls) {
                let k = e + bad.lane;
                return Err(StepError::Inverted {
                    elem: self.fe.elem_id[k],
                    volume: bad.volume,
                    at: centroid(&gather(&self.x_trial, &self.fe.elems[k])),
                    time: self.fe.time + dt,
                    step: self.fe.step + 1,
                });
            }
            let (state, history) = (&mut self.state_trial, &mut self.mat_trial);
            arrays::store(&*g, e, n, m.n_state(), state, history, self.mat_stride);
            for l in 0..n {
                let k = e + l;
                let out = g.lane_output(l);
                self.trial_dt_min = self.trial_dt_min.min(out.dt_stable);
                for (j, &node) in self.fe.elems[k].iter().enumerate() {
                    let f = &mut self.force[node as usize];
                    for c in 0..3 {
                        f[c] += out.force[j][c];
                    }
                }
                self.fe.assembly.record(k, |j| out.force[j]);
                grid.add(&mut hg_work, out.hg_work);
                self.fe.blocks.add(k, &out.force, out.hg_work);
            }
            e += n;
        }
        Ok(hg_work)
    }
}
