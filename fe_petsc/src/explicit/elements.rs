//! The element loop and its kernel dispatch: groups of consecutive elements of one material
//! through the element kernel ([`Batch`]), the forces added to the nodes in canonical element
//! order.
use super::tets;
use super::*;
use crate::batch::GroupInverted;

impl ExplicitFe {
    /// Element loop at the new positions with the half-step velocities, then the ghost
    /// exchange. Returns the local hourglass work of this step; sets `dt_stable_local`.
    ///
    /// Groups of consecutive elements of one material are updated together by the element
    /// kernel ([`Batch`], one, four or eight at once: [`ExplicitFe::width`]). Each element's
    /// forces are added to the nodes in element order (the canonical order,
    /// [`crate::assembly`]), so every width's sums are the same.
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
            Width::W1 => self.element_loop::<batch::w1::LaneGroup>(dt, &mut sums),
            Width::W4 => self.element_loop::<batch::w4::LaneGroup>(dt, &mut sums),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => self.element_loop::<batch::w8::LaneGroup>(dt, &mut sums),
        }
        self.dt_stable_local = sums.dt_min;
        if sums.inverted.is_none() {
            self.check_failure(dt);
        }
        let t1 = std::time::Instant::now();
        self.timers.elements += (t1 - t0).as_secs_f64();
        // The shared nodes' forces in canonical element order over all ranks holding them.
        self.assembly.finish(&mut self.force, exchange)?;
        // The native tetrahedra: their two passes, their forces summed apart and added (their
        // time counted as the element loop's, not the exchange's).
        let before = self.timers.elements;
        self.tet_forces(dt, &mut sums, exchange)?;
        let tet_s = self.timers.elements - before;
        if sums.inverted.is_none() {
            // The nodes' displacement over the step, dt v(n+1/2) (see `NodalSums::add`).
            let v = &self.v;
            self.blocks
                .accept(|n| std::array::from_fn(|c| dt * v[n][c]));
        }
        // The pressure loads at the step's end, added to the summed element forces.
        self.add_loads(self.time + dt, exchange)?;
        self.timers.exchange += t1.elapsed().as_secs_f64() - tet_s;
        match sums.inverted {
            Some(e) => Err(e),
            None => Ok(sums.hg_work),
        }
    }

    /// The native tetrahedra's forces added to the summed hexahedra's ([`TetPart::forces`]),
    /// their stable step and first inverted element in `sums` (collective where the mesh has
    /// tetrahedra).
    fn tet_forces(
        &mut self,
        dt: f64,
        sums: &mut LoopSums,
        exchange: &mut NodeExchange,
    ) -> Result<(), StepError> {
        let Some(tets) = &mut self.tets else {
            return Ok(());
        };
        let t0 = std::time::Instant::now();
        let offset = self.elems.len();
        let t = tets.forces(
            (&self.x, &self.v, dt),
            (&self.materials, &self.lane_materials, self.width),
            &self.controls,
            (&mut self.force, &mut self.blocks, offset),
            exchange,
        )?;
        self.dt_stable_local = self.dt_stable_local.min(t.dt_min);
        if let (None, Some((e, volume))) = (&sums.inverted, t.inverted) {
            let xe = tets::gather4(&self.x, &tets.conn[e]);
            sums.inverted = Some(StepError::Inverted {
                elem: tets.id[e],
                volume,
                at: tets::centroid4(&xe),
                time: self.time + dt,
                step: self.step + 1,
            });
        }
        self.timers.elements += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// Every element's update, in element order: each run of consecutive elements of one
    /// material through the element kernel in groups of `B::LANES`, the run's last group padded
    /// (see [`Self::group_update`]).
    ///
    /// So every element is updated by the same kernel source however the elements are dealt
    /// to ranks and whatever the width: every width runs the same IEEE operations in the same
    /// order (no fused multiply-adds), so an element's result does not depend on its group, its
    /// lane or its rank's share (docs/scene.md, "One answer").
    ///
    /// A group with an inverted element is left as it was. Where the element's material fails
    /// ([`ExplicitFe::fail_inverted`]) it fails and the group goes again without it; otherwise
    /// the first such element is recorded in `sums` (the step fails; the ghost exchange after
    /// the loop is collective, and a rank that left before it would hang the others in it).
    fn element_loop<B: Batch>(&mut self, dt: f64, sums: &mut LoopSums) {
        // The models are read while the elements' arrays are written.
        let materials = std::mem::take(&mut self.materials);
        let mut group = Box::<B>::default();
        let mut e = 0;
        while e < self.elems.len() {
            let n = self.lane_run(e, B::LANES);
            let mi = self.elem_material[e];
            let m = self.lane_materials[mi];
            let model = &*materials[mi];
            let mut res = match self.has_failed_in(e, n) {
                false => self.group_update(e, n, &m, model, dt, &mut *group, sums),
                true => self.live_group_update(e, n, (&m, model), dt, &mut *group, sums),
            };
            // An element of a material that fails fails where it would invert (instead of
            // stopping the run), and its group goes again without it (nothing of the group
            // was changed): the decision reads the element alone, so the same bits at any
            // width and rank count.
            while let Err(bad) = res {
                if !self.can_fail(e + bad.lane) {
                    self.record_inverted(e + bad.lane, bad.volume, dt, sums);
                    break;
                }
                self.fail_inverted(e + bad.lane, dt);
                res = self.live_group_update(e, n, (&m, model), dt, &mut *group, sums);
            }
            e += n;
        }
        self.materials = materials;
    }

    /// How many of the elements `e..` go into one group: those that exist, lie before the next
    /// multiple of `lanes` and share `e`'s material.
    /// (Groups end at multiples of `lanes` so that a whole group finds its state as whole
    /// vectors in [`HexStates`].)
    pub(crate) fn lane_run(&self, e: usize, lanes: usize) -> usize {
        let mi = self.elem_material[e];
        let end = ((e / lanes + 1) * lanes).min(self.elems.len());
        (e..end)
            .take_while(|&k| self.elem_material[k] == mi)
            .count()
    }

    /// Records element `e`, inverted with `volume` over the step `dt`, in `sums` (the first
    /// one kept).
    #[cold]
    fn record_inverted(&self, e: usize, volume: f64, dt: f64, sums: &mut LoopSums) {
        let xe = gather(&self.x, &self.elems[e]);
        sums.inverted.get_or_insert(StepError::Inverted {
            elem: self.elem_id[e],
            volume,
            at: centroid(&xe),
            time: self.time + dt,
            step: self.step + 1,
        });
    }

    /// Updates elements `e0..e0 + n` (the material `model`, its lane form `m`; `n` at most
    /// `B::LANES`, the group not crossing a multiple of `B::LANES`) with the element kernel in
    /// the buffer `g` and adds their outputs in element order; `Err`, with nothing changed,
    /// when one of them is inverted. A whole group of a lane law moves its state as whole
    /// vectors ([`Batch::update_lanes`]); a group of fewer than `B::LANES` elements fills its
    /// other lanes with copies of element `e0`, whose results are dropped (lanes are
    /// independent: each computes its own element only).
    #[allow(clippy::too_many_arguments)]
    fn group_update<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        m: &LaneMaterial,
        model: &dyn Material,
        dt: f64,
        g: &mut B,
        sums: &mut LoopSums,
    ) -> Result<(), GroupInverted> {
        let stride = self.mat_stride;
        let history = m.n_state() > 0;
        let whole = n == B::LANES && !m.law.is_pointwise() && (stride == 1 || !history);
        if whole {
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
            g.update_lanes(&mut io, dt, m, &self.controls)?;
        } else {
            self.group_update_by_lane(e0, n, m, model, dt, g)?;
        }
        self.add_group_output(e0, n, g, !whole, sums);
        Ok(())
    }

    /// [`ExplicitFe::group_update`] for a group with failed elements (`failure`): its live
    /// elements through the lane-by-lane path, then every element's output in element order,
    /// zero for the failed ones. `Err` names the inverted element's offset from `e0`.
    fn live_group_update<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        (m, model): (&LaneMaterial, &dyn Material),
        dt: f64,
        g: &mut B,
        sums: &mut LoopSums,
    ) -> Result<(), GroupInverted> {
        let live: Vec<usize> = (e0..e0 + n).filter(|&e| !self.is_failed(e)).collect();
        if !live.is_empty() {
            self.update_list(&live, m, model, dt, g)
                .map_err(|bad| GroupInverted {
                    lane: live[bad.lane] - e0,
                    volume: bad.volume,
                })?;
        }
        let [hg_work, _, dt_stable, _] = g.scalars();
        let mut lane = 0;
        for e in e0..e0 + n {
            if self.is_failed(e) {
                self.assembly.record(e, |_| [0.0; 3]);
                self.blocks.add(e, &[[0.0; 3]; 8], 0.0);
                continue;
            }
            for (k, &node) in self.elems[e].iter().enumerate() {
                let f = &mut self.force[node as usize];
                let fe = g.force(lane, k);
                f[0] += fe[0];
                f[1] += fe[1];
                f[2] += fe[2];
            }
            self.assembly.record(e, |k| g.force(lane, k));
            if self.blocks.active() {
                let out = g.lane_output(lane);
                self.blocks.add(e, &out.force, out.hg_work);
            }
            sums.grid.add(&mut sums.hg_work, hg_work[lane]);
            sums.dt_min = sums.dt_min.min(dt_stable[lane]);
            lane += 1;
        }
        Ok(())
    }

    /// [`ExplicitFe::group_update`]'s path for a part group, a pointwise law or materials with
    /// several history values per element: the lanes loaded and stored one element at a time.
    fn group_update_by_lane<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        m: &LaneMaterial,
        model: &dyn Material,
        dt: f64,
        g: &mut B,
    ) -> Result<(), GroupInverted> {
        let mut list = [0usize; batch::MAX_LANES];
        for (l, e) in list.iter_mut().zip(e0..e0 + n) {
            *l = e;
        }
        self.update_list(&list[..n], m, model, dt, g)
    }

    /// The elements `list` (at most `B::LANES`) through the kernel lane by lane: loaded,
    /// updated and stored one element at a time; `Err` names the lane of an inverted one.
    fn update_list<B: Batch>(
        &mut self,
        list: &[usize],
        m: &LaneMaterial,
        model: &dyn Material,
        dt: f64,
        g: &mut B,
    ) -> Result<(), GroupInverted> {
        let n_state = m.n_state();
        let arrays = batch::arrays::ElementArrays {
            xs: &self.x,
            vs: &self.v,
            elems: &self.elems,
            vol0: &self.vol0,
            state: &self.state,
            history: &self.mat_state,
            stride: self.mat_stride,
        };
        batch::arrays::load_list(g, &arrays, list, n_state);
        g.update(dt, m, model, &self.controls)?;
        let (state, history) = (&mut self.state, &mut self.mat_state);
        batch::arrays::store_list(g, list, n_state, state, history, self.mat_stride);
        Ok(())
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
}
