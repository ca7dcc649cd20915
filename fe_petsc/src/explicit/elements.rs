//! The element loop and its kernel dispatch: groups of one material through the lane kernels
//! ([`Batch`]), the rest element by element ([`hex::update`]), the forces added to the nodes
//! in canonical element order.
use super::*;

impl ExplicitFe {
    /// Element loop at the new positions with the half-step velocities, then the ghost
    /// exchange. Returns the local hourglass work of this step; sets `dt_stable_local`.
    ///
    /// With [`ElementKernel::Batched`] (the default), groups of consecutive elements of one
    /// material with a lane form ([`LaneMaterial`]) are updated together by [`Batch::update`]
    /// (four or eight at once: [`ExplicitFe::width`]); the other elements, and a group with an
    /// inverted element, go through [`hex::update`] one by one. Either way each element's forces are added to the nodes in element order (the
    /// canonical order, [`crate::assembly`]), so the two kernels' sums are the same.
    pub fn element_forces(
        &mut self,
        dt: f64,
        exchange: &mut NodeExchange,
    ) -> Result<Folds, StepError> {
        let t0 = std::time::Instant::now();
        // The last step's forces were last read by the kick and the contact push-back; the
        // kick zeroed them where no contact stage reads them after it.
        if !std::mem::take(&mut self.forces_zeroed) {
            for f in self.force.iter_mut() {
                *f = [0.0; 3];
            }
        }
        let mut sums = LoopSums {
            hg_work: [0.0; 3],
            grid: self.grids.energy,
            dt_min: f64::INFINITY,
            inverted: None,
        };
        self.blocks.begin();
        match self.width {
            Width::W4 => self.element_loop::<batch::w4::LaneGroup>(dt, &mut sums),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => self.element_loop::<batch::w8::LaneGroup>(dt, &mut sums),
        }
        self.dt_stable_local = sums.dt_min;
        if sums.inverted.is_none() {
            // The nodes' displacement over the step, dt v(n+1/2) (see `NodalSums::add`).
            let v = &self.v;
            self.blocks
                .accept(|n| std::array::from_fn(|c| dt * v[n][c]));
        }
        let t1 = std::time::Instant::now();
        self.timers.elements += (t1 - t0).as_secs_f64();
        // The shared nodes' forces in canonical element order over all ranks holding them.
        self.assembly.finish(&mut self.force, exchange)?;
        // The pressure loads at the step's end, added to the summed element forces.
        self.add_loads(self.time + dt, exchange)?;
        self.timers.exchange += t1.elapsed().as_secs_f64();
        match sums.inverted {
            Some(e) => Err(e),
            None => Ok(sums.hg_work),
        }
    }

    /// Every element's update, in element order. Each run of consecutive elements of one
    /// material with a lane form goes through the batched kernel in groups of `B::LANES`, the
    /// run's last group padded (see [`Self::group_update`]); other elements, and a group with
    /// an inverted element, through the scalar kernel.
    ///
    /// So every element of a lane material is updated by the same kernel source however the
    /// elements are dealt to ranks and whatever the width: every width runs the same IEEE
    /// operations in the same order (no fused multiply-adds), so an element's result does not
    /// depend on its group, its lane or its rank's share (docs/scene.md, "One answer").
    fn element_loop<B: Batch>(&mut self, dt: f64, sums: &mut LoopSums) {
        let mut group = Box::<B>::default();
        let mut e = 0;
        while e < self.elems.len() {
            let n = self.lane_run(e, B::LANES);
            if n == 0 {
                self.element_update(e, dt, sums);
                e += 1;
                continue;
            }
            let m = self.lane_materials[self.elem_material[e]].expect("a lane run");
            if !self.group_update(e, n, &m, dt, &mut *group, sums) {
                // An inverted element in the group: the scalar kernel names it.
                for k in e..e + n {
                    self.element_update(k, dt, sums);
                }
            }
            e += n;
        }
    }

    /// How many of the elements `e..` go into one batched group: those that exist, lie before
    /// the next multiple of `lanes` and share `e`'s material, when that material has a lane
    /// form (one with [`ElementKernel::Scalar`]); 0 otherwise. (Groups end at multiples of
    /// `lanes` so that a whole group finds its state as whole vectors in [`HexStates`].)
    fn lane_run(&self, e: usize, lanes: usize) -> usize {
        let mi = self.elem_material[e];
        if self.lane_materials[mi].is_none() {
            return 0;
        }
        if self.kernel == ElementKernel::Scalar {
            return 1;
        }
        let end = ((e / lanes + 1) * lanes).min(self.elems.len());
        (e..end)
            .take_while(|&k| self.elem_material[k] == mi)
            .count()
    }

    /// Updates element `e` with the scalar kernel and adds its output (an inverted element is
    /// recorded in `sums`, the first one kept: the ghost exchange after the loop is
    /// collective, and a rank that left before it would hang the others in it).
    fn element_update(&mut self, e: usize, dt: f64, sums: &mut LoopSums) {
        let conn = &self.elems[e];
        let xe = gather(&self.x, conn);
        let ve = gather(&self.v, conn);
        let mat = &*self.materials[self.elem_material[e]];
        let stride = self.mat_stride;
        let ms = &mut self.mat_state[e * stride..(e + 1) * stride];
        let mut st = self.state.get(e);
        match hex::update(
            &xe,
            &ve,
            dt,
            mat.density(),
            self.vol0[e],
            mat,
            &self.controls,
            &mut st,
            ms,
        ) {
            Ok(out) => {
                self.state.set(e, &st);
                self.add_output(e, &out, sums)
            }
            Err(hex::ElementError::Inverted { volume }) => {
                sums.inverted.get_or_insert(StepError::Inverted {
                    elem: self.elem_id[e],
                    volume,
                    at: centroid(&xe),
                    time: self.time + dt,
                    step: self.step + 1,
                });
            }
        }
    }

    /// Updates elements `e0..e0 + n` (material `m`, `n` at most `B::LANES`, the group not
    /// crossing a multiple of `B::LANES`) with the batched kernel in the buffer `g` and adds
    /// their outputs in element order; `false`, with nothing changed, when one of them is
    /// inverted. A whole group moves its state as whole vectors ([`Batch::update_lanes`]); a
    /// group of fewer than `B::LANES` elements fills its other lanes with copies of element
    /// `e0`, whose results are dropped (lanes are independent: each computes its own element
    /// only).
    fn group_update<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        m: &LaneMaterial,
        dt: f64,
        g: &mut B,
        sums: &mut LoopSums,
    ) -> bool {
        let stride = self.mat_stride;
        let history = m.n_state() > 0;
        let ok = if n == B::LANES && (stride == 1 || !history) {
            let lanes = e0..e0 + n;
            let mut io = batch::GroupLanes {
                xs: &self.x,
                vs: &self.v,
                conn: &self.elems[lanes.clone()],
                vol0: &self.vol0[lanes.clone()],
                state: self.state.lanes_mut(e0),
                history: history.then(|| &mut self.mat_state[lanes]),
                force: Some(&mut self.force),
            };
            // The forces added to the nodes in the kernel.
            g.update_lanes(&mut io, dt, m, &self.controls)
                .is_ok()
                .then_some(true)
        } else {
            self.group_update_by_lane(e0, n, m, dt, g).then_some(false)
        };
        let Some(added) = ok else {
            return false;
        };
        self.add_group_output(e0, n, g, !added, sums);
        true
    }

    /// [`ExplicitFe::group_update`]'s path for a part group or materials with several
    /// history values per element: the lanes loaded and stored one element at a time.
    fn group_update_by_lane<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        m: &LaneMaterial,
        dt: f64,
        g: &mut B,
    ) -> bool {
        let stride = self.mat_stride;
        let history = m.n_state() > 0;
        let elem = |l: usize| e0 + if l < n { l } else { 0 };
        let ms = &self.mat_state;
        let hist = |l: usize| if history { ms[elem(l) * stride] } else { 0.0 };
        let conn: Vec<[u32; 8]> = (0..B::LANES).map(|l| self.elems[elem(l)]).collect();
        let vol0: Vec<f64> = (0..B::LANES).map(|l| self.vol0[elem(l)]).collect();
        let state: Vec<HexState> = (0..B::LANES).map(|l| self.state.get(elem(l))).collect();
        g.load(&self.x, &self.v, &conn, &vol0, &state, hist);
        if g.update(dt, m, &self.controls).is_err() {
            return false;
        }
        for l in 0..n {
            let e = e0 + l;
            let (s, h) = g.lane_state(l);
            self.state.set(e, &s);
            if history {
                self.mat_state[e * stride] = h;
            }
        }
        true
    }

    /// Adds the outputs of a group's first `n` lanes (elements `e0..e0 + n`), as
    /// [`ExplicitFe::add_output`] for each, read straight from the lanes; their forces only
    /// where `forces` (a whole group's were added in the kernel: [`batch::GroupLanes`]).
    ///
    /// Cost per element: the scatter-add of 24 force doubles (192 B read and written) through
    /// the connectivity (32 B); 26 flops. (The volumes and pressures are not kept: see
    /// [`ExplicitFe::density`] and [`ExplicitFe::pressure`].)
    #[inline]
    fn add_group_output<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        g: &B,
        forces: bool,
        sums: &mut LoopSums,
    ) {
        for l in (0..n).filter(|_| forces) {
            let e = e0 + l;
            for (k, &node) in self.elems[e].iter().enumerate() {
                let f = &mut self.force[node as usize];
                let fe = g.force(l, k);
                f[0] += fe[0];
                f[1] += fe[1];
                f[2] += fe[2];
            }
        }
        for l in 0..n {
            self.assembly.record(e0 + l, |k| g.force(l, k));
        }
        let [hg_work, _, dt_stable, _] = g.scalars();
        if self.blocks.active() {
            for l in 0..n {
                let out = g.lane_output(l);
                self.blocks.add(e0 + l, &out.force, out.hg_work);
            }
        }
        for l in 0..n {
            sums.grid.add(&mut sums.hg_work, hg_work[l]);
            sums.dt_min = sums.dt_min.min(dt_stable[l]);
        }
    }

    /// Adds element `e`'s output: its forces to its nodes and its block, its hourglass work and
    /// stable step to `sums`.
    #[inline]
    fn add_output(&mut self, e: usize, out: &hex::HexOutput, sums: &mut LoopSums) {
        for (k, &n) in self.elems[e].iter().enumerate() {
            let f = &mut self.force[n as usize];
            f[0] += out.force[k][0];
            f[1] += out.force[k][1];
            f[2] += out.force[k][2];
        }
        self.assembly.record(e, |k| out.force[k]);
        sums.grid.add(&mut sums.hg_work, out.hg_work);
        self.blocks.add(e, &out.force, out.hg_work);
        sums.dt_min = sums.dt_min.min(out.dt_stable);
    }
}
