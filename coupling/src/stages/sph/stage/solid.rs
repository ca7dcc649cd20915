//! The SPH stage's solid particles (`sph::solid`): their state beside the particles, carried
//! where the particles go (migration, checkpoints), and the evaluation of a step with solids:
//! the passes of the `sph::solid` module doc with their communication through the ghost plan.
//!
//! ```text
//! update_eos (owned fluids)
//! velocity_gradient_pass (with every entry's continuity density rate);
//!                          ghosts -> owners (GradSums, 256 B); settle_gradients (drho, L, B,
//!                          the surface flags)
//!                          owners -> ghosts (the flags, 1 B)
//! quadratic_pass (pairs with a flagged end); ghosts -> owners (QuadSums, 768 B);
//!                          settle_quadratic (the surface particles' L, B, C_quad)
//! update_stress (owned; set-up: solid_pressure)
//!                          owners -> ghosts (SolidGhost: rho, p, c, stress, B, C_quad; 288 B)
//! stress_force_pass;       ghosts -> owners (PairSums: f, de); settle_forces; add_gravity
//! ```
//!
//! The fused continuity-and-force pass of the fluids cannot serve: the forces need the stress
//! at the end of the step, which needs this step's velocity gradient (a pass of its own, which
//! takes the continuity density rates along: one walk and one fold-back for both). Every
//! sum is exact (`sph::exact`), so the particles' rates are the same bits at any rank count.
use super::*;
use crate::driver::KernelChoice;
use crate::kernels::rcb::RcbItem;
use sph::solid::build::Build;
use sph::solid::{
    quad_sums_of, quadratic_pass, settle_gradients, settle_quadratic, solid_pressure,
    stress_force_pass, update_stress, velocity_gradient_pass, GradSums, QuadSums, SolidGhost,
    SolidRecord,
};
use sph::{ArtificialStress, Solids};

/// The solid particles' part of the stage.
pub struct SolidPart {
    /// The solid state of every entry, beside `SphStage::parts` (owned entries in their order).
    pub solids: Solids,
    /// Monaghan's artificial stress, if any.
    pub art: Option<ArtificialStress>,
    /// The grids of the gradient pass's exact sums (the same on every rank).
    pub grad_grids: PassGrids,
    /// The grids of the quadratic pass's exact sums (`sph::solid::quadratic`; the same on
    /// every rank).
    pub quad_grids: PassGrids,
    /// The owned particles' stress for output (a solid's, a fluid's -p I), Pa, and equivalent
    /// plastic strain (0 for a fluid), as of the end of the last step (`refresh_output`).
    pub out_stress: Vec<[f64; 6]>,
    /// See `out_stress`.
    pub out_plastic: Vec<f64>,
    /// See `out_stress`: 1 for a failed particle, else 0.
    pub out_failed: Vec<f64>,
    /// See `out_stress`: the temperature of a Johnson-Cook solid with thermal softening, K
    /// (NaN for a particle whose material keeps none).
    pub out_temperature: Vec<f64>,
}

/// The owned solid particles' output fields (`SphStage::solid_output`).
pub struct SolidOutput<'a> {
    /// Cauchy stress (a fluid's -p I), Pa.
    pub stress: &'a [[f64; 6]],
    /// Equivalent plastic strain (0 for a fluid).
    pub plastic_strain: &'a [f64],
    /// 1 for a failed particle, else 0.
    pub failed: &'a [f64],
    /// Temperature, K (NaN where the material keeps none).
    pub temperature: &'a [f64],
}

/// A particle with its solid state as RCB moves it (the fluid runs' `Item` and 80 bytes).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct SolidItem {
    pub(super) rec: ParticleRecord,
    pub(super) weight: f64,
    pub(super) solid: SolidRecord,
}

impl RcbItem for SolidItem {
    fn position(&self) -> [f64; 3] {
        self.rec.x
    }
    fn id(&self) -> u64 {
        self.rec.id
    }
    fn weight(&self) -> f64 {
        self.weight
    }
}

impl SphStage {
    /// Makes the particles whose material has a model in `models` solids (before `setup`).
    pub fn set_solids(&mut self, models: crate::stages::sph::setup::SolidModels) {
        let solids = Solids::new(models.models, &self.parts);
        self.solid = Some(SolidPart {
            solids,
            art: models.art,
            grad_grids: PassGrids::default(),
            quad_grids: PassGrids::default(),
            out_stress: Vec::new(),
            out_plastic: Vec::new(),
            out_failed: Vec::new(),
            out_temperature: Vec::new(),
        });
    }

    /// Sets the build of the solid pair loops every rank runs (collective; `sph::solid::build`:
    /// every build gives the same bits, as every element kernel does): `--kernel scalar` the
    /// baseline x86-64 build, `lanes4` AVX2, `auto` and `lanes8` the widest build every rank's
    /// CPU runs (AVX-512F, else AVX2), each where the CPUs run it (else the widest below it).
    pub fn choose_solid_build(&mut self, world: &SimpleCommunicator, choice: KernelChoice) {
        let code = |b: Build| match b {
            Build::Baseline => 1i32,
            Build::Avx2 => 4,
            Build::Avx512 => 8,
        };
        let mut all = 0i32;
        world.all_reduce_into(&code(Build::widest()), &mut all, SystemOperation::min());
        let common = match all {
            8 => Build::Avx512,
            4 => Build::Avx2,
            _ => Build::Baseline,
        };
        let build = match choice {
            KernelChoice::Auto | KernelChoice::Lanes8 => common,
            KernelChoice::Lanes4 if all >= 4 => Build::Avx2,
            KernelChoice::Lanes4 | KernelChoice::Scalar => Build::Baseline,
        };
        if let Some(sp) = &mut self.solid {
            sp.solids.build = build;
        }
    }

    /// The solid state, where the run has solid particles.
    pub fn solids(&self) -> Option<&Solids> {
        self.solid.as_ref().map(|s| &s.solids)
    }

    /// 1 with solids: RCB over the owned particles with their solid state; the particles and
    /// their solid state rebuilt in RCB's order where anything came or went.
    pub(super) fn rebalance_solid(&mut self) -> Result<(), String> {
        let sp = self.solid.as_mut().expect("solids");
        sp.solids.truncate(self.parts.n_owned);
        let items: Vec<SolidItem> = (0..self.parts.n_owned)
            .map(|i| SolidItem {
                rec: self.parts.record(i),
                weight: 1.0 + self.pair_count.get(i).copied().unwrap_or(0) as f64,
                solid: sp.solids.record(i),
            })
            .collect();
        if let Some(mine) = self.balance(items)? {
            let s = &mut self.solid.as_mut().expect("solids").solids;
            let mut parts = Particles::new();
            s.clear();
            for it in &mine {
                parts.push_owned(&it.rec);
                s.push_owned(&it.solid);
            }
            self.parts = parts;
        }
        Ok(())
    }

    /// Sets the owned particles' solid state from `recs` (in their order; restart).
    pub(super) fn set_solid_records(&mut self, recs: &[SolidRecord]) {
        if let Some(sp) = &mut self.solid {
            sp.solids.clear();
            for r in recs {
                sp.solids.push_owned(r);
            }
        }
        self.refresh_output();
    }

    /// 3-4 with solids (module doc): `dt` is the step (None at the set-up: the stress stays,
    /// p and c follow from it).
    pub(super) fn evaluate_solid(&mut self, dt: Option<f64>) {
        let list = self.pair_list();
        let n0 = self.parts.n_owned;
        {
            let sp = self.solid.as_mut().expect("solids");
            sp.solids.truncate(n0);
            sp.solids.resize(self.parts.len());
        }
        update_eos(&mut self.parts, &self.params);
        self.gradients(&list);
        let sp = self.solid.as_mut().expect("solids");
        match dt {
            Some(dt) => update_stress(&mut self.parts, &mut sp.solids, dt),
            None => solid_pressure(&mut self.parts, &sp.solids),
        }
        self.solid_to_ghosts();
        let mut sp = self.solid.take().expect("solids");
        let art = sp.art;
        self.work = self.exact(|st, g, m| {
            stress_force_pass(
                &list,
                &mut st.parts,
                &mut sp.solids,
                &st.params,
                art.as_ref(),
                g,
                m,
            )
        });
        self.solid = Some(sp);
        self.fold_back(false, true);
        add_gravity(&mut self.parts, &self.params);
        self.stats.pairs = list.len() as u64;
    }

    /// The velocity-gradient and density-rate pass (exact, on the solids' own grids, redone
    /// until its terms fit), the ghosts' sums merged into their owners, the owners' density
    /// rates and gradients settled.
    fn gradients(&mut self, list: &[(u32, u32)]) {
        let comm = self.comm.clone();
        let reduce = |m: &TermMax| {
            let mut g = [0.0; 3];
            comm.all_reduce_into(&m[..], &mut g[..], SystemOperation::max());
            g
        };
        let k = self.params.smoothing_kernel();
        let sp = self.solid.as_mut().expect("solids");
        let p = &self.parts;
        let (_, redone) = exact_pass(&mut sp.grad_grids, reduce, |g, m| {
            velocity_gradient_pass(list, p, &mut sp.solids, &k, g, m)
        });
        self.passes_redone += redone as u64;
        let n0 = p.n_owned;
        let sums: Vec<GradSums> = (0..p.n_ghosts()).map(|g| sp.solids.sums[n0 + g]).collect();
        let plan = self.plan.as_mut().expect("ghosts made");
        let back = plan.reverse(&sums);
        self.bytes += plan.bytes_sent;
        plan.bytes_sent = 0;
        for (k, s) in back.iter().enumerate() {
            sp.solids.sums[self.ghost_src[k]].merge(s);
        }
        settle_gradients(&mut self.parts, &mut sp.solids);
        self.quadratic_fit();
    }

    /// The surface particles' quadratic fit (`sph::solid::quadratic`): the owners' flags out
    /// to their ghosts, the quadratic pass (exact, on its own grids, redone until its terms
    /// fit), the ghosts' sums merged into their owners, the flagged owners' gradients settled.
    fn quadratic_fit(&mut self) {
        let comm = self.comm.clone();
        let reduce = |m: &TermMax| {
            let mut g = [0.0; 3];
            comm.all_reduce_into(&m[..], &mut g[..], SystemOperation::max());
            g
        };
        let sp = self.solid.as_mut().expect("solids");
        let n0 = self.parts.n_owned;
        let flags: Vec<u8> = self
            .ghost_src
            .iter()
            .map(|&i| u8::from(sp.solids.quad_flag[i]))
            .collect();
        let plan = self.plan.as_mut().expect("ghosts made");
        let got = plan.exchange(&flags);
        for (g, &f) in got.iter().enumerate() {
            sp.solids.quad_flag[n0 + g] = f != 0;
        }
        let p = &self.parts;
        let (_, redone) = exact_pass(&mut sp.quad_grids, reduce, |g, m| {
            quadratic_pass(p, &mut sp.solids, g, m)
        });
        self.passes_redone += redone as u64;
        let sums: Vec<QuadSums> = (0..p.n_ghosts())
            .map(|g| quad_sums_of(&sp.solids, n0 + g))
            .collect();
        let back = plan.reverse(&sums);
        self.bytes += plan.bytes_sent;
        plan.bytes_sent = 0;
        for (k, s) in back.iter().enumerate() {
            let slot = sp.solids.quad_slot[self.ghost_src[k]];
            if slot != u32::MAX {
                sp.solids.quad_sums[slot as usize].merge(s);
            }
        }
        settle_quadratic(&self.parts, &mut sp.solids);
    }

    /// The owners' new density, pressure, sound speed, stress and correction out to their
    /// ghosts (the fluids' too: their p and c came from `update_eos` in this evaluation).
    fn solid_to_ghosts(&mut self) {
        let sp = self.solid.as_mut().expect("solids");
        let states: Vec<SolidGhost> = self
            .ghost_src
            .iter()
            .map(|&i| sp.solids.ghost_state(&self.parts, i))
            .collect();
        let plan = self.plan.as_mut().expect("ghosts made");
        let got = plan.exchange(&states);
        self.bytes += plan.bytes_sent;
        plan.bytes_sent = 0;
        let n0 = self.parts.n_owned;
        for (g, s) in got.iter().enumerate() {
            sp.solids.set_ghost_state(&mut self.parts, n0 + g, s);
        }
    }

    /// After the second half of a step (which ran the EOS on every owned particle): the
    /// solids' p and c from their stress again, and the output's stress and plastic strain.
    pub(super) fn solid_pressure_after_step(&mut self) {
        if let Some(sp) = &self.solid {
            solid_pressure(&mut self.parts, &sp.solids);
        }
        self.refresh_output();
    }

    /// Sets the output's stress and plastic strain of the owned particles (`SolidPart`).
    pub(super) fn refresh_output(&mut self) {
        let Some(sp) = &mut self.solid else {
            return;
        };
        let (p, s) = (&self.parts, &sp.solids);
        let n = p.n_owned;
        sp.out_stress.clear();
        sp.out_stress.extend((0..n).map(|i| {
            if s.is_solid(p.mat[i]) {
                s.stress[i]
            } else {
                let q = -p.p[i];
                [q, q, q, 0.0, 0.0, 0.0]
            }
        }));
        sp.out_plastic.clear();
        sp.out_plastic
            .extend((0..n).map(|i| s.plastic_strain(p.mat[i], i)));
        sp.out_failed.clear();
        sp.out_failed
            .extend((0..n).map(|i| f64::from(u8::from(s.failed(p.mat[i], i)))));
        sp.out_temperature.clear();
        sp.out_temperature
            .extend((0..n).map(|i| s.temperature(p.mat[i], i).unwrap_or(f64::NAN)));
    }

    /// The owned particles' stress, plastic strain and failed flags for a field frame (runs
    /// with solids).
    pub fn solid_output(&self) -> Option<SolidOutput<'_>> {
        self.solid.as_ref().map(|sp| SolidOutput {
            stress: &sp.out_stress,
            plastic_strain: &sp.out_plastic,
            failed: &sp.out_failed,
            temperature: &sp.out_temperature,
        })
    }

    /// The solid state of the owned particles for a checkpoint.
    pub(super) fn save_solid(&self, w: &mut StateWriter) {
        if let Some(sp) = &self.solid {
            let recs: Vec<SolidRecord> = (0..self.parts.n_owned)
                .map(|i| sp.solids.record(i))
                .collect();
            w.put("sph.solid", &recs);
            w.put("sph.grad_grids", &sp.grad_grids.fitted());
            w.put("sph.quad_grids", &sp.quad_grids.fitted());
        }
    }

    /// The gradient and quadratic-fit grids a checkpoint holds (fitted afresh where it holds
    /// none).
    pub(super) fn restore_grad_grids(&mut self, r: &StateReader) -> Result<(), String> {
        if let Some(sp) = &mut self.solid {
            sp.grad_grids = super::restart::saved_grids(r, "sph.grad_grids")?;
            sp.quad_grids = super::restart::saved_grids(r, "sph.quad_grids")?;
        }
        Ok(())
    }

    /// The solid records a checkpoint holds for its particles (`n` of them), zero where it
    /// holds none.
    pub(super) fn solid_records_of(
        &self,
        r: &StateReader,
        n: usize,
    ) -> Result<Vec<SolidRecord>, String> {
        if self.solid.is_none() {
            return Ok(Vec::new());
        }
        let recs: Vec<SolidRecord> = r.get("sph.solid")?;
        if recs.len() != n {
            return Err("checkpoint: sph.solid".into());
        }
        Ok(recs)
    }
}

impl SphStage {
    /// Adds particles of failed elements to this rank's owned particles (each with its solid
    /// state; the FE -> SPH transfer, `transfer::fe_sph`). Call [`SphStage::after_births`]
    /// next, on every rank.
    pub fn add_born(&mut self, born: &[(ParticleRecord, SolidRecord)]) {
        self.parts.truncate_ghosts();
        let sp = self
            .solid
            .as_mut()
            .expect("particles of failed elements are solids");
        sp.solids.truncate(self.parts.n_owned);
        for (rec, solid) in born {
            self.parts.push_owned(rec);
            sp.solids.push_owned(solid);
        }
    }

    /// After particles were born on any rank (collective): a fresh decomposition (RCB moves
    /// the new particles to their boxes), its ghosts, and the rates at the present state with
    /// every particle, as at the set-up (the stress stays; p and c follow from it).
    pub fn after_births(&mut self) -> Result<(), String> {
        self.verlet = None;
        self.kept_box = None;
        self.pair_count.clear();
        self.rebuild()?;
        self.make_ghosts();
        self.evaluate_solid(None);
        self.refresh_output();
        self.check_partners()
    }
}
