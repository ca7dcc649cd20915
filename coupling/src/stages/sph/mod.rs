//! The SPH stage inside a run that also has a mesh (Fig. 3 with both FE and SPH): the stage on
//! its own RCB decomposition, its global energies and momentum, the work of gravity on the
//! particles, and what it cost. The driver calls `drift` and `finish` around the contact stage.
pub mod setup;
pub mod stage;

use crate::input::particles::{self as particles_setup, ParticleIds};
use crate::input::scene::Scene;
use crate::output::ParticleFrame;
use crate::stages::sph::setup::{globals, params_from_scene, particles_from_seeds};
use crate::stages::sph::stage::SphStage;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// The SPH side of a coupled run.
pub struct SphCtx {
    /// The stage.
    pub stage: SphStage,
    /// Particles over all ranks.
    pub n_total: u64,
    /// The user-facing particle ids (the particle file's).
    pub ids: ParticleIds,
    /// Global energies and momentum after the last step: [kinetic, internal, px, py, pz,
    /// gravity power].
    pub globals: [f64; 6],
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
    /// See `rcb_s`.
    pub rcb_bytes: f64,
    /// See `rcb_s`.
    pub rcb_imbalance_sum: f64,
}

impl SphCtx {
    /// Particles of the scene on their decomposition, set up at t = 0 (collective); `kept_pairs`:
    /// keep pair candidates between steps where the stage can (`Algorithms::sph_kept_pairs`).
    pub fn new(
        world: &SimpleCommunicator,
        scene: &Scene,
        kept_pairs: bool,
    ) -> Result<SphCtx, String> {
        let (params, map) = params_from_scene(scene)?;
        let seeds = particles_setup::particles(scene, world.rank() as usize, world.size() as usize);
        crate::kernels::collective::first_error(world, seeds.as_ref().err().cloned())?;
        let (seeds, ids) = seeds.expect("checked");
        let n_total = crate::kernels::collective::sum(world, seeds.len() as f64) as u64;
        let parts = particles_from_seeds(&seeds, &map)?;
        let mut stage = SphStage::new(world, parts, params);
        stage.set_kept_pairs(kept_pairs);
        stage.setup()?;
        let g = globals(world, &stage);
        Ok(SphCtx {
            stage,
            n_total,
            ids,
            globals: g,
            external_work: 0.0,
            wall_s: 0.0,
            bytes: 0.0,
            pairs_local: 0.0,
            rcb_s: 0.0,
            rcb_bytes: 0.0,
            rcb_imbalance_sum: 0.0,
        })
    }

    /// Kinetic + internal energy of the particles, J.
    pub fn energy(&self) -> f64 {
        self.globals[0] + self.globals[1]
    }

    /// The rest of the step after the drift and the contact correction (collective): the
    /// stage's passes, then the global sums and the gravity work over the step.
    pub fn finish(&mut self, world: &SimpleCommunicator, dt: f64) -> Result<(), String> {
        self.stage.finish(dt)?;
        self.wall_s += self.stage.stats.wall_s;
        self.bytes += self.stage.stats.bytes_sent as f64;
        self.pairs_local += self.stage.stats.pairs_local as f64;
        let r = &self.stage.stats.rcb;
        self.rcb_s += r.wall_s;
        self.rcb_bytes += r.bytes_sent as f64;
        self.rcb_imbalance_sum += r.imbalance;
        let g = globals(world, &self.stage);
        self.external_work += 0.5 * (self.globals[5] + g[5]) * dt;
        self.globals = g;
        Ok(())
    }

    /// The owned particles as a field frame (the particle file's ids, SCENE.md); `ranks` and
    /// `labels` are its storage.
    pub fn frame<'a>(
        &'a self,
        ranks: &'a mut Vec<i32>,
        labels: &'a mut Vec<u64>,
        rank: i32,
    ) -> ParticleFrame<'a> {
        particle_frame(&self.stage.parts, &self.ids, ranks, labels, rank)
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
        rank: Some(ranks),
    }
}
