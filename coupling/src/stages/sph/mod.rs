//! The SPH stage (Fig. 3, step 2; Fig. 8): the particles on their own RCB decomposition
//! (`stage`: rebalance, ghosts, the pairwise passes under the centre-of-interaction rule), built
//! from the scene (`setup`), with its global energies and momentum, the work of gravity on the
//! particles, and what it cost. A particle-only run is the same driver with no FE stage.
mod contact_body;
pub mod setup;
pub mod stage;
pub mod strength;

use super::{Stage, StageEnergies, StageError};
use crate::input::particles::{self as particles_setup, ParticleIds};
use crate::input::scene::Scene;
use crate::output::state::{StateReader, StateWriter};
use crate::output::{ParticleFrame, Report, StageStats};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use setup::{globals, params_from_scene, particles_from_seeds, SphGlobals};
use stage::SphStage;

/// The SPH stage of a run.
pub struct Sph {
    /// The stage.
    pub stage: SphStage,
    /// Particles over all ranks.
    pub n_total: u64,
    /// The user-facing particle ids (the particle file's).
    pub ids: ParticleIds,
    /// Global energies, momentum and gravity power after the last step.
    pub globals: SphGlobals,
    /// The energy the holds on faces and walls took from the solid particles so far, J
    /// (global; `SphStage::hold_on_faces`): part of history.csv's `contact_energy`.
    pub hold_taken: f64,
    /// Work of gravity on the particles so far (trapezoid of its power), J.
    pub external_work: f64,
    /// Wall time of the stage (max over ranks per step, summed), s.
    pub wall_s: f64,
    /// Bytes sent by the stage, all ranks, summed over steps.
    pub bytes: f64,
    /// Pairs computed on this rank, summed over steps (the stage's work).
    pub pairs_local: f64,
    /// The SPH decomposition's RCB: wall time (max over ranks per call), bytes (all ranks) and
    /// imbalance, summed over steps.
    pub rcb_s: f64,
    /// Steps taken.
    pub steps: u64,
    /// The scene file, for messages.
    file: String,
    /// See `rcb_s`.
    pub rcb_bytes: f64,
    /// See `rcb_s`.
    pub rcb_imbalance_sum: f64,
    /// Steps whose RCB rebalanced (those `rcb_imbalance_sum` sums over).
    pub rcb_rebalances: u64,
    /// The scene's gravity and its scale in time (`gravity_curve`).
    gravity0: [f64; 3],
    gravity_curve: Option<crate::input::curve::Curve>,
    /// The time at the start of the present step (the driver's clock), s.
    time: f64,
    /// Per scene material, its EOS index and initial specific energy (`setup::MaterialMap`).
    map: setup::MaterialMap,
    /// The particles the scene seeded, over all ranks (the failed elements' particles come
    /// after them, in the order they failed, at each step in the order of element ids).
    pub seeded: u64,
}

/// What the SPH stage of a scene whose failed elements become particles knows of them
/// before the first one fails.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Births {
    /// Their mean element size (V0^(1/3)), m: the spacing of the artificial stress where no
    /// `[[particles]]` entry is solid.
    pub spacing: f64,
    /// The mass of the elements that may fail, kg (the sums' grids bound it).
    pub mass: f64,
}

/// The smoothing length of a failed element's particle over its size V^(1/3) (the
/// `[[particles]] h_factor` default).
pub const BORN_H_FACTOR: f64 = 1.2;

impl Sph {
    /// Particles of the scene on their decomposition, set up at t = 0 (collective); `kept_pairs`:
    /// keep pair candidates between steps where the stage can (`Algorithms::sph_kept_pairs`).
    pub fn new(
        world: &SimpleCommunicator,
        scene: &Scene,
        kept_pairs: bool,
        kernel: crate::driver::KernelChoice,
        births: Option<Births>,
    ) -> Result<Sph, String> {
        let (mut params, map, solid_models) = params_from_scene(scene, births.map(|b| b.spacing))?;
        // Gravity at t = 0 (`gravity_curve`); `finish` sets it at each step's end.
        if let Some(c) = &scene.gravity_curve {
            let s = c.value(0.0);
            params.gravity = scene.gravity.map(|g| g * s);
        }
        let seeds = particles_setup::particles(scene, world.rank() as usize, world.size() as usize);
        crate::kernels::collective::first_error(world, seeds.as_ref().err().cloned())?;
        let (seeds, ids) = seeds.expect("checked");
        let n_total = crate::kernels::collective::sum(world, seeds.len() as f64) as u64;
        let parts = particles_from_seeds(&seeds, &map)?;
        let mut contact_rho = vec![0.0; params.eos.len()];
        for (m, entry) in scene.materials.iter().zip(&map) {
            if let Some((k, _)) = entry {
                contact_rho[*k as usize] = m.density;
            }
        }
        let mut stage = SphStage::new(world, parts, params);
        if let Some(models) = solid_models {
            stage.set_solids(models);
            stage.choose_solid_build(world, kernel);
        }
        let p = &stage.parts;
        let mass = fe_petsc::exact::total(world, &p.m[..p.n_owned]);
        let mass = mass + births.map_or(0.0, |b| b.mass);
        stage.grids = fe_petsc::exact::SumGrids::for_mass(if mass > 0.0 { mass } else { 1.0 });
        stage.set_contact_density(contact_rho);
        stage.set_kept_pairs(kept_pairs);
        stage.setup()?;
        let g = globals(world, &stage);
        Ok(Sph {
            stage,
            n_total,
            ids,
            globals: g,
            external_work: 0.0,
            hold_taken: 0.0,
            wall_s: 0.0,
            bytes: 0.0,
            pairs_local: 0.0,
            rcb_s: 0.0,
            rcb_bytes: 0.0,
            rcb_imbalance_sum: 0.0,
            rcb_rebalances: 0,
            steps: 0,
            file: scene.file.display().to_string(),
            gravity0: scene.gravity,
            gravity_curve: scene.gravity_curve.clone(),
            time: 0.0,
            map,
            seeded: n_total,
        })
    }

    /// Failed elements become particles (collective: every rank calls it when any element
    /// was released on any rank; `born` is this rank's, each with its scene material; dense
    /// indices `n_total` on, in element id order): each
    /// a particle of its material at the element's centroid, with its mass, momentum
    /// (the mean of its nodes' velocities), density m / V, size V^(1/3) (h =
    /// [`BORN_H_FACTOR`] times it), stress and history, its damage (born failed: no
    /// deviatoric stress and no tension from its first update on, `strength::MaterialStress`)
    /// and zero specific internal energy (the work the element took stays in the mesh's
    /// internal energy). The stage then
    /// rebuilds its decomposition and its rates with them (`SphStage::after_births`).
    pub fn add_born(
        &mut self,
        world: &SimpleCommunicator,
        born: &[(fe_petsc::explicit::failure::Released, usize)],
    ) -> Result<(), String> {
        // Dense indices in the order of the element ids over all ranks, after every particle
        // so far: the same at any rank count, and 0..N over the particles stays whole.
        let mine: Vec<u64> = born.iter().map(|(r, _)| r.elem_id).collect();
        let mut all = crate::kernels::collective::all_gather_varcount(world, &mine);
        all.sort_unstable();
        let mut recs = Vec::with_capacity(born.len());
        for (r, mat) in born {
            let k = all.binary_search(&r.elem_id).expect("gathered") as u64;
            let (eos, e0) = self.map[*mat].ok_or("a failed element's material has no SPH model")?;
            let rho = r.mass / r.volume;
            let h = BORN_H_FACTOR * r.volume.cbrt();
            let rec = sph::ParticleRecord {
                id: self.n_total + k,
                x: r.x,
                v: r.v,
                vhat: r.v,
                m: r.mass,
                rho,
                e: e0,
                h,
                rho_half: rho,
                e_half: e0,
                mat: eos as u32,
                ..sph::ParticleRecord::default()
            };
            let mut solid = sph::solid::SolidRecord {
                stress: r.stress,
                ..Default::default()
            };
            solid.state[..r.state.len()].copy_from_slice(&r.state);
            // born failed: the damage slot past the law's history (`strength::MaterialStress`)
            solid.state[r.state.len()] = r.damage;
            recs.push((rec, solid));
        }
        self.stage.add_born(&recs);
        self.stage.after_births()?;
        self.n_total += all.len() as u64;
        self.globals = globals(world, &self.stage);
        Ok(())
    }

    /// The rest of the step after the drift and the contact correction (collective): the
    /// stage's passes, then the global sums and the gravity work over the step.
    fn finish(&mut self, world: &SimpleCommunicator, dt: f64) -> Result<(), String> {
        // Gravity at the step's end, where the force pass adds it (`gravity_curve`); its
        // work is the trapezoid of its power at both ends.
        if let Some(c) = &self.gravity_curve {
            let s = c.value(self.time + dt);
            self.stage.params.gravity = self.gravity0.map(|g| g * s);
        }
        self.stage.finish(dt)?;
        self.wall_s += self.stage.stats.wall_s;
        self.bytes += self.stage.stats.bytes_sent as f64;
        self.pairs_local += self.stage.stats.pairs_local as f64;
        let r = &self.stage.stats.rcb;
        self.rcb_s += r.wall_s;
        self.rcb_bytes += r.bytes_sent as f64;
        // (a step that kept its decomposition reports no imbalance: the mean is over rebalances)
        if r.imbalance > 0.0 {
            self.rcb_imbalance_sum += r.imbalance;
            self.rcb_rebalances += 1;
        }
        let g = globals(world, &self.stage);
        self.external_work += 0.5 * (self.globals.gravity_power + g.gravity_power) * dt;
        self.hold_taken -= g.hold_work;
        self.globals = g;
        self.steps += 1;
        Ok(())
    }

    /// The owned particles as a field frame (the particle file's ids, docs/scene.md); `ranks` and
    /// `labels` are its storage.
    pub fn frame<'a>(
        &'a self,
        ranks: &'a mut Vec<i32>,
        labels: &'a mut Vec<u64>,
        rank: i32,
    ) -> ParticleFrame<'a> {
        let mut f = particle_frame(&self.stage.parts, &self.ids, ranks, labels, rank);
        if let Some(o) = self.stage.solid_output() {
            f.stress = Some(o.stress);
            f.plastic_strain = Some(o.plastic_strain);
            f.failed = Some(o.failed);
            f.temperature = Some(o.temperature);
        }
        f
    }

    /// Sets the global energies, the gravity work and the step count `save` wrote.
    fn restore_globals(&mut self, r: &StateReader) -> Result<(), String> {
        let g: Vec<f64> = r.get("sph.globals")?;
        // (8 since the holds' energy; a checkpoint of 7 had none)
        if g.len() != 7 && g.len() != 8 {
            return Err("checkpoint: sph.globals".into());
        }
        self.globals = SphGlobals {
            kinetic: g[0],
            internal: g[1],
            momentum: [g[2], g[3], g[4]],
            gravity_power: g[5],
            hold_work: 0.0,
            hold_impulses: Vec::new(),
            // (the next step's sums set it; the check reads it after a step)
            solid_internal: 0.0,
        };
        self.external_work = g[6];
        self.hold_taken = g.get(7).copied().unwrap_or(0.0);
        self.steps = r.get::<u64>("sph.steps")?.first().copied().unwrap_or(0);
        // the particles over all ranks, failed elements' included (absent: the seeded ones)
        if let Some(n) = r
            .get::<u64>("sph.n_total")
            .ok()
            .and_then(|v| v.first().copied())
        {
            self.n_total = n;
        }
        Ok(())
    }
}

impl Stage for Sph {
    fn name(&self) -> &'static str {
        "sph"
    }

    fn set_clock(&mut self, t: f64) {
        self.time = t;
    }

    fn drift(&mut self, dt: f64) {
        self.stage.drift(dt);
    }

    fn forces(&mut self, world: &SimpleCommunicator, dt: f64) -> Result<f64, StageError> {
        self.finish(world, dt)?;
        if !self.globals.is_finite() {
            return Err(StageError {
                unstable: true,
                message: format!(
                    "{}: the SPH state became non-finite at step {}; reduce run.dt_safety or check the EOS",
                    self.file, self.steps
                ),
            });
        }
        Ok(self.stage.stable_dt())
    }

    fn stable_dt(&self, _world: &SimpleCommunicator) -> f64 {
        self.stage.stable_dt()
    }

    fn energies(&self) -> StageEnergies {
        let g = &self.globals;
        StageEnergies {
            kinetic: g.kinetic,
            internal: g.internal,
            hourglass: 0.0,
            external_work: self.external_work,
            momentum: g.momentum,
            solid_internal: g.solid_internal,
        }
    }

    fn wall_s(&self) -> f64 {
        self.wall_s
    }

    fn save(&self, w: &mut StateWriter) {
        self.stage.save(w);
        w.put("sph.n_total", &[self.n_total]);
        let g = &self.globals;
        w.put(
            "sph.globals",
            &[
                g.kinetic,
                g.internal,
                g.momentum[0],
                g.momentum[1],
                g.momentum[2],
                g.gravity_power,
                self.external_work,
                self.hold_taken,
            ],
        );
        w.put("sph.steps", &[self.steps]);
    }

    fn restore(&mut self, r: &StateReader) -> Result<(), String> {
        self.stage.restore(r)?;
        self.restore_globals(r)
    }

    fn restore_remapped(
        &mut self,
        _world: &SimpleCommunicator,
        pieces: &[StateReader],
    ) -> Result<(), String> {
        self.stage.restore_remapped(pieces)?;
        // The energies, the gravity work and the step count are global: rank 0's file.
        self.restore_globals(pieces.first().ok_or("checkpoint: no rank files")?)
    }

    fn report(&self, world: &SimpleCommunicator, report: &mut Report, loop_s: f64) {
        let size = world.size() as f64;
        let steps = report.steps.max(1) as f64;
        let st = StageStats::reduce(world, self.wall_s, self.pairs_local, self.bytes / size);
        report.sph = Some(StageStats {
            wall_s: self.wall_s,
            bytes_sent: self.bytes,
            ..st
        });
        report.rcb = Some(StageStats {
            wall_s: self.rcb_s,
            imbalance: mean_imbalance(self.rcb_imbalance_sum, self.rcb_rebalances),
            bytes_sent: self.rcb_bytes,
        });
        report.us_per_particle_step =
            Some(loop_s * size / (self.n_total.max(1) as f64 * steps) * 1e6);
        let s = &self.stage;
        let ex = &mut report.extra;
        ex.insert(
            "sph_share_of_step".into(),
            (self.wall_s / loop_s.max(1e-30)).into(),
        );
        ex.insert("sph_pairs_last_step".into(), s.stats.pairs.into());
        // Pair searches run (between them the candidates are kept: sph::KeptPairs), summed
        // over ranks.
        ex.insert(
            "sph_pair_searches".into(),
            (crate::kernels::collective::sum(world, s.pair_searches as f64) as u64).into(),
        );
        ex.insert("sph_ghosts_last_step".into(), s.stats.ghosts.into());
        // The particle arrays (owned and ghost entries) over the particles, all ranks.
        let bytes = crate::kernels::collective::sum(world, s.parts.bytes() as f64);
        ex.insert(
            "bytes_per_particle".into(),
            (bytes / self.n_total.max(1) as f64).into(),
        );
        ex.insert(
            "sph_pair_imbalance_last_step".into(),
            s.stats.pair_imbalance.into(),
        );
        ex.insert("rcb_migrated_last_step".into(), s.stats.rcb.migrated.into());
    }
}

/// The owned entries of `p` as a field frame, rows by dense index and `particles/id` the
/// user-facing ids; `ranks` is filled with `rank`, `labels` with the ids (their storage).
pub fn particle_frame<'a>(
    p: &'a sph::Particles,
    ids: &ParticleIds,
    ranks: &'a mut Vec<i32>,
    labels: &'a mut Vec<u64>,
    rank: i32,
) -> ParticleFrame<'a> {
    let n = p.n_owned;
    ranks.clear();
    ranks.resize(n, rank);
    labels.clear();
    labels.extend(p.id[..n].iter().map(|&d| ids.id(d)));
    ParticleFrame {
        ids: &p.id[..n],
        labels: Some(labels),
        position: &p.x_real[..n],
        velocity: Some(&p.v[..n]),
        density: Some(&p.rho[..n]),
        pressure: Some(&p.p[..n]),
        h: Some(&p.h[..n]),
        stress: None,
        plastic_strain: None,
        failed: None,
        temperature: None,
        rank: Some(ranks),
    }
}

/// The mean imbalance (max/mean) of `n` RCB rebalances summing to `sum`; 1 where none ran.
pub(crate) fn mean_imbalance(sum: f64, n: u64) -> f64 {
    if n == 0 {
        1.0
    } else {
        sum / n as f64
    }
}
