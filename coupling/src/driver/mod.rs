//! The run: scene -> mesh -> distribution -> time loop (the paper's Fig. 3) -> output.
//!
//! Only the stages a scene declares are built: the FE stage, integrated explicitly (central
//! differences) or implicitly (Newmark average acceleration, Newton and PETSc KSP:
//! `run.mode = "implicit"`); with `[[particles]]` the SPH stage on its own decomposition; with
//! `[contact]` the contact stage on a third one (explicit mode only). One explicit step is the
//! paper's Fig. 3: FE kick and drift, SPH kick and drift, contact detection and push-back on
//! both (nodes and, with `contact.particles`, particles), FE element forces, SPH passes, the
//! closing kicks. A scene of particles only runs in `sph_run`.
use crate::kernels::collective::{self, first_error};
pub mod probes;

use crate::driver::probes::Probes;
use crate::input::gmsh;
use crate::input::scene::{self, Mode};
use crate::output::{
    ElementFrame, FieldWriter, GlobalCounts, History, NodeFrame, Report, StageStats,
};
use crate::stages::contact::baseline::BaselineStage;
use crate::stages::contact::stage::ContactStage;
use crate::stages::fe::setup::{self as fe_setup, Groups};
use crate::stages::sph::SphCtx;
use crate::transfer::fe_contact::FeContact;
use fe_petsc::explicit::{ExplicitFe, ExplicitSetup, StepError};
use fe_petsc::hex::HexControls;
use fe_petsc::implicit::{ImplicitError, ImplicitFe};
use fe_petsc::mesh::{DistributedMesh, NodeExchange};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Tolerance on frame and row times, in steps (SCENE.md: t >= k * every - 1e-6 dt).
const TIME_EPS_STEPS: f64 = 1e-6;

/// `run.max_energy_error` is checked from this step on (SCENE.md). The measure is relative to
/// E(0) + |W_external|: a body starting from rest (E0 = 0) under gravity has, in its first
/// steps, velocity Verlet's O(dt^2) energy error against energies of round-off size (a steel
/// block resting on a plate: 9.6e-2 at step 1), while by step 100 the external work dominates
/// and the ratio is small. Before this step only a blow-up stops the run
/// ([`EARLY_BLOW_UP_ERROR`]); the non-finite check applies from step 1.
pub const ENERGY_CHECK_FROM_STEP: u64 = 100;

/// Before [`ENERGY_CHECK_FROM_STEP`], an energy error above this (or above
/// `run.max_energy_error`, whichever is larger) still stops the run: the energy off by ten
/// times the run's energy scale E(0) + |W_external| is no start-up transient (measured from
/// rest: 0.02-0.1 at step 1) but a run blowing up, whose error grows geometrically (a
/// vibrating bar forced to 3 times its stable step: 0.1, 2.0, 80, 4e3 over steps 1-4, an
/// element inverted at step 6), and it is better stopped with its cause than by what follows.
pub const EARLY_BLOW_UP_ERROR: f64 = 10.0;

/// The energy error that stops a run at `step` (see [`ENERGY_CHECK_FROM_STEP`]).
pub fn energy_error_limit(step: u64, max_energy_error: f64) -> f64 {
    if step >= ENERGY_CHECK_FROM_STEP {
        max_energy_error
    } else {
        max_energy_error.max(EARLY_BLOW_UP_ERROR)
    }
}

/// The hourglass share of a block's internal energy above which the run warns (the field's
/// guideline: hourglass energy under 10 % of the internal energy).
const HOURGLASS_WARN_RATIO: f64 = 0.10;

/// A block's internal energy below this fraction of the run's energy scale, E(0) +
/// |W_external| (the energy error's denominator), is negligible: no hourglass ratio is taken
/// from it. A block's own initial kinetic energy is no floor (a target plate starts at rest,
/// with zero), and early on the internal energy of a block the loading has barely reached is
/// round-off, where hourglass/internal is noise; 1e-30 J keeps the floor positive when the run
/// starts from rest.
const HOURGLASS_NEGLIGIBLE: f64 = 1e-6;

/// The columns history.csv writes as integers (SCENE.md).
pub const HISTORY_INTEGER_COLUMNS: [&str; 2] = ["step", "contacts"];

/// Columns of history.csv, in order (SCENE.md).
pub const HISTORY_COLUMNS: [&str; 13] = [
    "step",
    "time",
    "dt",
    "kinetic_energy",
    "internal_energy",
    "hourglass_energy",
    "external_work",
    "contact_energy",
    "energy_error",
    "momentum_x",
    "momentum_y",
    "momentum_z",
    "contacts",
];

/// Columns history.csv adds after [`HISTORY_COLUMNS`] in a run with contact: the search's
/// balance (max/mean over ranks of owned nodes + faces held) and the bytes the stage sent point
/// to point (all ranks, RCB included), both of the step.
pub const CONTACT_HISTORY_COLUMNS: [&str; 2] = ["contact_imbalance", "contact_bytes"];

/// How the user asked to run.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// The scene file.
    pub scene: PathBuf,
    /// Output directory (default `out/<scene file stem>`).
    pub out: Option<PathBuf>,
    /// No progress bar, no summary on stdout.
    pub quiet: bool,
    /// Values that replace the scene's keys (`tdyn compare`, `tdyn sweep`, `tdyn run --param`).
    pub overrides: RunOverrides,
    /// Stop after set-up (mesh, FE stage, stable step): no time step, no output.
    pub setup_only: bool,
    /// Algorithm choices for benchmarks and reference runs (`tdyn run` flags).
    pub algorithms: Algorithms,
}

/// Algorithm choices that do not change the answer, only how it is computed: the defaults are
/// what every run should use; the others are the references the tests and benchmarks compare
/// against (`tdyn run --contact-decomposition static --contact-rebuild every-step
/// --contact-skins G,C --sph-pairs fresh`). Every rank parses the same command line, so every
/// rank makes the same choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Algorithms {
    /// Contact searched on the static FE decomposition (the paper's baseline, for benchmarks)
    /// instead of its own RCB decomposition. Mesh nodes only: particles are not contact nodes.
    pub contact_static: bool,
    /// Keep the contact decomposition and candidate lists between steps within their skins
    /// (default); false rebuilds them every step (Fig. 10 steps 1-6 each step).
    pub contact_kept: bool,
    /// The contact skins as multiples of the step's largest motion (ghost faces, candidate
    /// lists); `None`: the stage's defaults.
    pub contact_skins: Option<(f64, f64)>,
    /// Keep the SPH pair candidates between steps on one rank (default); false searches
    /// afresh every step.
    pub sph_kept_pairs: bool,
}

impl Default for Algorithms {
    fn default() -> Self {
        Algorithms {
            contact_static: false,
            contact_kept: true,
            contact_skins: None,
            sph_kept_pairs: true,
        }
    }
}

/// Replacements for scene keys: `[run]` keys (`tdyn compare`), mesh parameters and particle
/// spacings (`tdyn run --param`, `tdyn sweep`).
#[derive(Debug, Clone, Default)]
pub struct RunOverrides {
    /// `run.mode`.
    pub mode: Option<Mode>,
    /// `run.dt`.
    pub dt: Option<f64>,
    /// `run.force_dt`.
    pub force_dt: Option<bool>,
    /// `run.end_time` (a shorter run for per-step figures: `scripts/scaling.sh`).
    pub end_time: Option<f64>,
    /// `mesh[k].params.NAME = value`, as (k, NAME, value); NAME must be in the scene's table.
    pub mesh_params: Vec<(usize, String, f64)>,
    /// `particles[i].spacing = value`, as (Some(i), value), or of every `[[particles]]` (None).
    pub particle_spacing: Vec<(Option<usize>, f64)>,
}

impl RunOverrides {
    /// Writes the replacements into `scene`; an index or a mesh parameter the scene does not
    /// have is an error naming the key.
    pub fn apply(&self, scene: &mut scene::Scene) -> Result<(), String> {
        let file = scene.file.display().to_string();
        if let Some(m) = self.mode {
            scene.run.mode = m;
        }
        if let Some(dt) = self.dt {
            scene.run.dt = Some(dt);
        }
        if let Some(f) = self.force_dt {
            scene.run.force_dt = f;
        }
        if let Some(t) = self.end_time {
            if !(t > 0.0 && t.is_finite()) {
                return Err(format!(
                    "{file}: run.end_time: expected a positive time in s, got {t}"
                ));
            }
            scene.run.end_time = t;
        }
        for (k, name, v) in &self.mesh_params {
            let n = scene.meshes.len();
            let m = scene
                .meshes
                .get_mut(*k)
                .ok_or_else(|| format!("{file}: mesh[{k}]: the scene has {n} [[mesh]] entries"))?;
            let known: Vec<String> = m.params.keys().cloned().collect();
            match m.params.get_mut(name) {
                Some(p) => *p = *v,
                None => {
                    return Err(format!(
                        "{file}: mesh[{k}].params.{name}: not a parameter of this mesh (it has {}); add it to the scene's params table to vary it",
                        known.join(", ")
                    ))
                }
            }
        }
        for (i, v) in &self.particle_spacing {
            if !(*v > 0.0 && v.is_finite()) {
                return Err(format!(
                    "{file}: particles.spacing: expected a positive spacing in m, got {v}"
                ));
            }
            let n = scene.particles.len();
            match i {
                Some(i) => {
                    scene
                        .particles
                        .get_mut(*i)
                        .ok_or_else(|| {
                            format!(
                                "{file}: particles[{i}]: the scene has {n} [[particles]] entries"
                            )
                        })?
                        .spacing = *v
                }
                None if n == 0 => {
                    return Err(format!(
                        "{file}: particles.spacing: the scene has no [[particles]]"
                    ))
                }
                None => scene.particles.iter_mut().for_each(|p| p.spacing = *v),
            }
        }
        Ok(())
    }
}

/// What a finished run reports to its caller.
#[derive(Debug, Clone)]
pub struct RunSummary {
    /// Output directory.
    pub out: PathBuf,
    /// The integration mode.
    pub mode: Mode,
    /// Steps taken.
    pub steps: u64,
    /// Largest energy error seen.
    pub energy_error_max: f64,
    /// Time-loop cost, ns per element-cycle.
    pub ns_per_element_cycle: f64,
    /// The explicit stable step at t = 0 (no safety factor), s.
    pub dt_stable: f64,
    /// Smallest step taken, s.
    pub dt_min: f64,
    /// Whole run, s (max over ranks).
    pub wall_s: f64,
    /// Time-step loop without output, s (max over ranks).
    pub loop_s: f64,
}

/// What stopped a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FailureKind {
    /// A bad scene, mesh or file: nothing was computed.
    Input,
    /// An explicit fixed step above the stable limit, refused before the first step.
    Refused,
    /// The run blew up: energy check, non-finite values, or any failure of a forced explicit
    /// run above its stable limit.
    Unstable,
    /// Another numerical failure (inverted element, Newton or KSP not converging).
    Failed,
}

/// A run's error: its kind and the one line to print.
#[derive(Debug, Clone)]
pub struct RunFailure {
    /// What kind of failure.
    pub kind: FailureKind,
    /// The message (file, key or place, what happened, what to do).
    pub message: String,
}

impl From<String> for RunFailure {
    fn from(message: String) -> Self {
        RunFailure {
            kind: FailureKind::Input,
            message,
        }
    }
}

impl std::fmt::Display for RunFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl RunFailure {
    fn new(kind: FailureKind, message: String) -> Self {
        RunFailure { kind, message }
    }
}

/// The FE stage in the scene's mode. Both keep their state in an [`ExplicitFe`], which probes
/// and output read.
enum FeStage {
    Explicit(Box<ExplicitFe>),
    Implicit(Box<ImplicitFe>),
}

impl FeStage {
    fn fe(&self) -> &ExplicitFe {
        match self {
            FeStage::Explicit(fe) => fe,
            FeStage::Implicit(imp) => &imp.fe,
        }
    }
}

/// Where contact is searched: the dynamic RCB decomposition (Fig. 10), or, for benchmarks only
/// (`tdyn run --contact-decomposition static`), the static FE decomposition.
enum ContactImpl {
    Dynamic(ContactStage),
    Baseline(BaselineStage),
}

/// The contact stage of a run with `[contact]`: the FE side's surfaces, the stage on its own
/// decomposition, and what it found and cost.
struct ContactCtx {
    fe_side: FeContact,
    stage: ContactImpl,
    node_gid: Vec<u64>,
    /// SPH particles are contact nodes too (`contact.particles`), with ids from this offset
    /// (the mesh's node count, so no particle id meets a node id).
    particles: bool,
    particle_gid_offset: u64,
    /// Energy taken by the push-back (minus the work of the contact forces), J.
    energy: f64,
    /// Contacts found in the last step.
    contacts: u64,
    wall_s: f64,
    bytes: f64,
    /// Sum over steps of the search imbalance (for the mean).
    imbalance_sum: f64,
    /// Largest search imbalance of a step.
    imbalance_max: f64,
    /// Nodes + faces searched summed over steps: on the busiest rank, and over all ranks.
    work_max_sum: f64,
    work_total_sum: f64,
    /// The last step's search imbalance and bytes sent (history.csv).
    last_imbalance: f64,
    last_bytes: f64,
    /// Contacts summed over steps, and the most in one step.
    contacts_total: u64,
    contacts_max: u64,
    /// The contact decomposition's RCB: nodes moved between contact owners, bytes sent, wall
    /// time (each call's max over ranks) and imbalance, summed over steps.
    rcb_migrated: u64,
    rcb_bytes: f64,
    rcb_wall_s: f64,
    rcb_imbalance_sum: f64,
    /// Transfers between decompositions (FE/SPH owners <-> contact owners): bytes, time (each
    /// step's max over ranks) and byte imbalance, summed over steps.
    transfer_bytes: f64,
    transfer_s: f64,
    transfer_imbalance_sum: f64,
    steps: u64,
}

impl ContactCtx {
    /// Steps 4-5 of Fig. 3 after the drift: detection on the contact decomposition, push-back
    /// forces back on the FE nodes (all copies), positions and half-step velocities corrected.
    fn step(
        &mut self,
        world: &SimpleCommunicator,
        fe: &mut ExplicitFe,
        exchange: &mut NodeExchange,
        dt: f64,
        sph: Option<&mut SphCtx>,
    ) -> Result<(), String> {
        let t0 = Instant::now();
        let mut nodes = self.fe_side.node_records(fe, &self.node_gid);
        let n_fe = nodes.len();
        let sph = sph.filter(|_| self.particles);
        if let Some(s) = &sph {
            nodes.extend(s.stage.contact_records(self.particle_gid_offset));
        }
        let (out, mut f) = match &mut self.stage {
            ContactImpl::Dynamic(stage) => {
                let (fe_side, gids) = (&self.fe_side, &self.node_gid);
                let fe_ref = &*fe;
                let out = stage.step(&nodes, || fe_side.face_records(fe_ref, gids), dt)?;
                let f = self
                    .fe_side
                    .forces_on_nodes(fe.n_nodes(), &out.force[..n_fe]);
                (out, f)
            }
            ContactImpl::Baseline(stage) => {
                // the benchmark baseline searches mesh nodes only (`particles` is off)
                let faces = self.fe_side.face_records(fe, &self.node_gid);
                let b = stage.step(&nodes[..n_fe], &faces, dt)?;
                let mut f = self.fe_side.forces_on_nodes(fe.n_nodes(), &b.outcome.force);
                self.fe_side.add_corner_forces(&mut f, &b.corner_force);
                (b.outcome, f)
            }
        };
        let mut w = fe
            .apply_contact(&mut f, dt, exchange)
            .map_err(|e| e.to_string())?;
        if let Some(s) = sph {
            w += s.stage.apply_contact(&out.force[n_fe..], dt);
        }
        self.energy -= collective::sum(world, w);
        self.contacts = out.contacts;
        self.bytes += out.bytes_sent as f64;
        self.imbalance_sum += out.imbalance;
        self.imbalance_max = self.imbalance_max.max(out.imbalance);
        self.work_max_sum += out.work_items_max;
        self.work_total_sum += out.work_items_total;
        self.last_imbalance = out.imbalance;
        self.last_bytes = out.bytes_sent as f64;
        self.contacts_total += out.contacts;
        self.contacts_max = self.contacts_max.max(out.contacts);
        self.rcb_migrated += out.rcb.migrated;
        self.rcb_bytes += out.rcb.bytes_sent as f64;
        self.rcb_wall_s += out.rcb.wall_s;
        self.rcb_imbalance_sum += out.rcb.imbalance;
        self.transfer_bytes += out.transfer.bytes_sent as f64;
        self.transfer_s += out.transfer.wall_s;
        self.transfer_imbalance_sum += out.transfer.imbalance;
        self.steps += 1;
        self.wall_s += t0.elapsed().as_secs_f64();
        Ok(())
    }
}

/// One explicit step (Fig. 3's FE part): kick and drift, element forces with the ghost
/// exchange, the closing kick, energy sums. Returns the next stable step (min over ranks).
/// Collective; on an inverted element every rank returns the failing rank's message.
fn explicit_step(
    world: &SimpleCommunicator,
    file: &str,
    fe: &mut ExplicitFe,
    exchange: &mut NodeExchange,
    dt: f64,
    contact: Option<&mut ContactCtx>,
    mut sph: Option<&mut SphCtx>,
) -> Result<f64, String> {
    // Fig. 3: 3. move nodes and particles (each on its own decomposition); 4-5. contact
    // detection and push-back on both; 1. FE forces at the new positions; 2. SPH forces;
    // 6. the closing kicks.
    fe.kick_drift(dt);
    if let Some(s) = sph.as_deref_mut() {
        s.stage.drift(dt);
    }
    if let Some(c) = contact {
        c.step(world, fe, exchange, dt, sph.as_deref_mut())?;
    }
    let hg = fe.element_forces(dt, exchange);
    // Agree on failure (inverted element) with the same reduction as the next step size:
    // a failing rank proposes a negative step.
    let (local_dt, local_err, hg_work) = match hg {
        Ok(w) => (fe.dt_stable_local, None, w),
        Err(e) => (-1.0 - world.rank() as f64, Some(e), 0.0),
    };
    let next = collective::min(world, local_dt);
    if next < 0.0 {
        let msg = local_err.map(|e: StepError| format!("{file}: {e}"));
        first_error(world, msg)?;
    }
    let sums = fe.finish_step(dt);
    // The totals and the per-block sums in one reduction.
    let local = fe.step_sums(&sums, hg_work);
    let mut global = vec![0.0; local.len()];
    world.all_reduce_into(&local[..], &mut global[..], SystemOperation::sum());
    fe.accumulate(&global, dt);
    match sph {
        Some(s) => {
            s.finish(world, dt)?;
            Ok(next.min(s.stage.stable_dt()))
        }
        None => Ok(next),
    }
}

/// One implicit step; every rank returns the failing rank's message and its kind.
fn implicit_step(
    world: &SimpleCommunicator,
    file: &str,
    imp: &mut ImplicitFe,
    exchange: &mut NodeExchange,
) -> Result<(), RunFailure> {
    let res = imp.step(world, exchange);
    let kind = match &res {
        Err(ImplicitError::Step(StepError::NonFinite { .. })) => FailureKind::Unstable,
        _ => FailureKind::Failed,
    };
    let kind_code = collective::max(
        world,
        if res.is_err() {
            kind as i32 as f64
        } else {
            -1.0
        },
    );
    let msg = match res {
        Ok(()) | Err(ImplicitError::OtherRank) => None,
        Err(e) => Some(format!("{file}: {e}")),
    };
    first_error(world, msg).map_err(|m| {
        let kind = if kind_code as i32 == FailureKind::Unstable as i32 {
            FailureKind::Unstable
        } else {
            FailureKind::Failed
        };
        RunFailure::new(kind, m)
    })
}

/// history.csv's per-block columns, after the SCENE.md ones: `hourglass_energy.<group>` and
/// `internal_energy.<group>` for each `[[block]]` in scene order.
pub fn block_history_columns(scene: &scene::Scene) -> Vec<String> {
    scene
        .blocks
        .iter()
        .flat_map(|b| {
            [
                format!("hourglass_energy.{}", b.group),
                format!("internal_energy.{}", b.group),
            ]
        })
        .collect()
}

/// Each block's hourglass share of its internal energy, watched every step: one warning line
/// per block the first time it passes [`HOURGLASS_WARN_RATIO`], and the largest ratio for the
/// report. Every rank holds the same global energies, so every rank agrees; rank 0 prints.
struct HourglassWatch {
    names: Vec<String>,
    warned: Vec<bool>,
    /// Largest ratio, with its time and step (None: never measurable).
    max: Vec<Option<(f64, f64, u64)>>,
}

impl HourglassWatch {
    fn new(scene: &scene::Scene) -> Self {
        Self::with_names(scene.blocks.iter().map(|b| b.group.clone()).collect())
    }

    fn with_names(names: Vec<String>) -> Self {
        let n = names.len();
        HourglassWatch {
            names,
            warned: vec![false; n],
            max: vec![None; n],
        }
    }

    /// After a step at `time`, `step`: `scale` is the run's energy scale, E(0) +
    /// |W_external|. Returns the warning lines to print (each block's first passing).
    fn check(
        &mut self,
        time: f64,
        step: u64,
        blocks: &[fe_petsc::explicit::BlockEnergy],
        scale: f64,
    ) -> Vec<String> {
        let mut lines = Vec::new();
        for (b, be) in blocks.iter().enumerate().take(self.names.len()) {
            if !(be.internal > HOURGLASS_NEGLIGIBLE * scale + 1e-30) {
                continue;
            }
            let ratio = be.hourglass / be.internal;
            if self.max[b].is_none_or(|(r, _, _)| ratio > r) {
                self.max[b] = Some((ratio, time, step));
            }
            if ratio > HOURGLASS_WARN_RATIO && !self.warned[b] {
                self.warned[b] = true;
                lines.push(format!(
                    "tdyn: warning: block \"{}\": hourglass energy {:.1} % of internal energy at t = {:.3e} s (guideline: under {:.0} %)",
                    self.names[b],
                    100.0 * ratio,
                    time,
                    100.0 * HOURGLASS_WARN_RATIO
                ));
            }
        }
        lines
    }

    /// report.json's `blocks`: per group, the final energies and the largest ratio.
    fn report(&self, fe: &ExplicitFe) -> serde_json::Value {
        let mut m = serde_json::Map::new();
        for (b, name) in self.names.iter().enumerate() {
            let be = fe.block_energies.get(b).copied().unwrap_or_default();
            let (r, t, step) = match self.max[b] {
                Some((r, t, s)) => (r.into(), t.into(), s.into()),
                None => (
                    serde_json::Value::Null,
                    serde_json::Value::Null,
                    serde_json::Value::Null,
                ),
            };
            m.insert(
                name.clone(),
                serde_json::json!({
                    "hourglass_energy": be.hourglass,
                    "internal_energy": be.internal,
                    "hourglass_ratio_max": r,
                    "hourglass_ratio_max_time": t,
                    "hourglass_ratio_max_step": step,
                    "hourglass_warning": self.warned[b],
                }),
            );
        }
        serde_json::Value::Object(m)
    }
}

/// What the stop message adds before step 100 (checked from there; earlier only a blow-up).
pub fn early_note(step: u64) -> String {
    if step < ENERGY_CHECK_FROM_STEP {
        format!(
            " (checked from step {ENERGY_CHECK_FROM_STEP}; before it only an error over {EARLY_BLOW_UP_ERROR} stops a run)"
        )
    } else {
        String::new()
    }
}

/// Relative energy error (SCENE.md).
fn energy_error(e: f64, e0: f64, w: f64) -> f64 {
    (e - e0 - w).abs() / (e0 + w.abs()).max(1e-30)
}

/// Runs a scene. Collective; every rank returns the same error.
pub fn run(world: &SimpleCommunicator, opts: &RunOptions) -> Result<RunSummary, RunFailure> {
    let wall0 = Instant::now();
    let rank = world.rank();
    let size = world.size();
    // Every rank parses the scene (identical result, no communication).
    let mut scene = scene::load(&opts.scene).map_err(|e| e.to_string())?;
    let file = scene.file.display().to_string();
    opts.overrides.apply(&mut scene)?;
    let mode = scene.run.mode;
    if !scene.particles.is_empty() && mode == Mode::Implicit {
        return Err(format!(
            "{file}: run.mode: the SPH stage is explicit only; use mode = \"explicit\" or remove the [[particles]] tables"
        )
        .into());
    }
    if mode == Mode::Implicit {
        if let Some(b) = scene.blocks.iter().find(|b| {
            scene
                .materials
                .iter()
                .any(|m| m.name == b.material && m.model == "fluid")
        }) {
            return Err(format!(
                "{file}: run.mode: block \"{}\" is meshed with the fluid material \"{}\", which is explicit only (its stress is a function of the density, with no strain tangent); use mode = \"explicit\"",
                b.group, b.material
            )
            .into());
        }
    }
    if scene.contact.is_some() && mode == Mode::Implicit {
        return Err(format!(
            "{file}: contact: the contact stage runs in explicit mode only; use mode = \"explicit\" or remove the [contact] table"
        )
        .into());
    }
    if scene.meshes.is_empty() {
        return Err(format!(
            "{file}: mesh: the contact stage needs mesh faces: a scene of particles only cannot have a [contact] table"
        )
        .into());
    }
    let implicit_dt = match (mode, scene.run.dt) {
        (Mode::Implicit, Some(dt)) => Some(dt),
        (Mode::Implicit, None) => {
            return Err(format!(
                "{file}: run.dt: mode = \"implicit\" needs a fixed step run.dt (seconds)"
            )
            .into())
        }
        (Mode::Explicit, _) => None,
    };
    let out_dir = opts.out.clone().unwrap_or_else(|| {
        PathBuf::from("out").join(
            scene
                .file
                .file_stem()
                .map(|s| s.to_os_string())
                .unwrap_or_default(),
        )
    });

    // Meshing on rank 0 (gmsh, cached; several meshes merged, each moved by its translation),
    // then every rank reads the physical names.
    let mut mesh_path = PathBuf::new();
    let mut err = None;
    if rank == 0 {
        let mut parts = Vec::new();
        for (i, m) in scene.meshes.iter().enumerate() {
            let cache = gmsh::default_cache_dir(m.file.parent().unwrap_or(Path::new(".")));
            match gmsh::mesh_file(m, &cache) {
                Ok(p) => parts.push((p, m.translate)),
                Err(e) => {
                    err = Some(format!("{file}: mesh[{i}]: {e}"));
                    break;
                }
            }
        }
        if err.is_none() {
            if parts.len() == 1 {
                mesh_path = parts.remove(0).0;
            } else {
                match gmsh::merge(&parts, &gmsh::default_cache_dir(&scene.dir)) {
                    Ok(p) => mesh_path = p,
                    Err(e) => err = Some(format!("{file}: mesh: {e}")),
                }
            }
        }
    }
    first_error(world, err)?;
    let mut buf = mesh_path.to_string_lossy().into_owned().into_bytes();
    let mut len = buf.len() as u64;
    world.process_at_rank(0).broadcast_into(&mut len);
    buf.resize(len as usize, 0);
    world.process_at_rank(0).broadcast_into(&mut buf[..]);
    let mesh_path = PathBuf::from(String::from_utf8_lossy(&buf).into_owned());
    let names = gmsh::physical_names(&mesh_path).map_err(|e| format!("{file}: mesh: {e}"))?;
    let mut groups = Groups::default();
    for n in &names {
        match n.dim {
            3 => {
                groups.volumes.insert(n.name.clone(), n.tag);
            }
            2 => {
                groups.surfaces.insert(n.name.clone(), n.tag);
            }
            _ => {}
        }
    }
    let vols: Vec<String> = groups.volumes.keys().cloned().collect();
    let surfs: Vec<String> = groups.surfaces.keys().cloned().collect();
    scene::validate_groups(&scene, &vols, &surfs).map_err(|e| e.to_string())?;

    let t_setup = Instant::now();
    let mut dm =
        DistributedMesh::load(world, &mesh_path).map_err(|e| format!("{file}: mesh: {e}"))?;
    // One mesh is moved here; several were moved when merged.
    let tr = scene.meshes[0].translate;
    if scene.meshes.len() == 1 && tr != [0.0; 3] {
        for x in dm.local.coords.iter_mut() {
            for c in 0..3 {
                x[c] += tr[c];
            }
        }
    }
    let inputs = fe_setup::prepare(world, &scene, &groups, &mut dm)?;
    let controls = HexControls {
        hourglass: scene.run.hourglass.control(),
        bv_linear: scene.run.bulk_viscosity.linear,
        bv_quadratic: scene.run.bulk_viscosity.quadratic,
    };
    let setup = ExplicitSetup {
        mesh: &dm.local,
        elem_material: inputs.elem_material,
        elem_block: inputs.elem_block,
        n_blocks: scene.blocks.len(),
        materials: inputs.materials,
        velocity: inputs.velocity,
        constraints: inputs.constraints,
        controls,
        gravity: scene.gravity,
    };
    let mut stage = match implicit_dt {
        None => {
            let fe_res = ExplicitFe::new(setup, &mut dm.exchange);
            first_error(world, fe_res.as_ref().err().map(|e| format!("{file}: {e}")))?;
            FeStage::Explicit(Box::new(fe_res.map_err(|e| e.to_string())?))
        }
        Some(dt) => {
            let res = ImplicitFe::new(world, setup, dt, &mut dm.exchange);
            first_error(world, res.as_ref().err().map(|e| format!("{file}: {e}")))?;
            FeStage::Implicit(Box::new(res.map_err(|e| e.to_string())?))
        }
    };
    match &mut stage {
        FeStage::Explicit(fe) => fe.initial_energies(world),
        FeStage::Implicit(imp) => imp.fe.initial_energies(world),
    }
    let mut sph = if scene.particles.is_empty() {
        None
    } else {
        Some(SphCtx::new(world, &scene, opts.algorithms.sph_kept_pairs)?)
    };
    let probes = Probes::locate(world, &file, &scene.probes, stage.fe(), sph.is_some())?;
    let mut contact = match &scene.contact {
        Some(c) => {
            // The named physical surfaces as node bits ("exterior": every boundary face).
            let bits = if c.surfaces.iter().any(|s| s == "exterior") {
                None
            } else {
                let mut b = 0u32;
                for name in &c.surfaces {
                    let tag = groups.surfaces.get(name).copied();
                    if let Some(k) = dm.local.surface_tags.iter().position(|&t| Some(t) == tag) {
                        b |= 1 << k;
                    }
                }
                Some(b)
            };
            let fe_side = FeContact::build(world, &dm.local, bits);
            if fe_side.global_faces == 0 {
                return Err(format!(
                    "{file}: contact.surfaces: no boundary face lies on {:?}",
                    c.surfaces
                )
                .into());
            }
            Some(ContactCtx {
                fe_side,
                stage: {
                    let mut dynamic = ContactStage::new(world, c.self_contact);
                    dynamic.configure(opts.algorithms.contact_kept, opts.algorithms.contact_skins);
                    if opts.algorithms.contact_static {
                        ContactImpl::Baseline(BaselineStage::new(world, dynamic.params))
                    } else {
                        ContactImpl::Dynamic(dynamic)
                    }
                },
                node_gid: dm.local.node_id.clone(),
                particles: c.particles && sph.is_some() && !opts.algorithms.contact_static,
                particle_gid_offset: dm.local.global_nodes,
                energy: 0.0,
                contacts: 0,
                wall_s: 0.0,
                bytes: 0.0,
                imbalance_sum: 0.0,
                imbalance_max: 0.0,
                work_max_sum: 0.0,
                work_total_sum: 0.0,
                last_imbalance: 1.0,
                last_bytes: 0.0,
                contacts_total: 0,
                contacts_max: 0,
                rcb_migrated: 0,
                rcb_bytes: 0.0,
                rcb_wall_s: 0.0,
                rcb_imbalance_sum: 0.0,
                transfer_bytes: 0.0,
                transfer_s: 0.0,
                transfer_imbalance_sum: 0.0,
                steps: 0,
            })
        }
        None => None,
    };

    // The explicit stable step (reduced over ranks); reported in implicit mode for comparison.
    let stable0 = collective::min(world, stage.fe().dt_stable_local).min(
        sph.as_ref()
            .map(|s| s.stage.stable_dt())
            .unwrap_or(f64::INFINITY),
    );
    let mut forced = false;
    if let (Mode::Explicit, Some(dt)) = (mode, scene.run.dt) {
        if dt > stable0 {
            if !scene.run.force_dt {
                return Err(RunFailure::new(
                    FailureKind::Refused,
                    format!(
                        "{file}: run.dt: {dt:e} s is above the explicit stable limit {stable0:e} s (Flanagan-Belytschko element estimate with bulk viscosity{}); use run.dt <= {stable0:e}, remove run.dt, set mode = \"implicit\", or set run.force_dt = true to run it anyway",
                        if sph.is_some() { ", and 0.3 h/(c + |v|) over the particles" } else { "" }
                    ),
                ));
            }
            forced = true;
            if rank == 0 && !opts.quiet {
                eprintln!(
                    "tdyn: warning: run.dt = {dt:e} s is {:.3} times the explicit stable limit {stable0:e} s (run.force_dt = true): the energy check will stop the run if it blows up",
                    dt / stable0
                );
            }
        }
    }
    let setup_s = t_setup.elapsed().as_secs_f64();
    if opts.setup_only {
        return Ok(RunSummary {
            out: out_dir,
            mode,
            steps: 0,
            energy_error_max: 0.0,
            ns_per_element_cycle: 0.0,
            dt_stable: stable0,
            dt_min: scene.run.dt.unwrap_or(scene.run.dt_safety * stable0),
            wall_s: collective::max(world, wall0.elapsed().as_secs_f64()),
            loop_s: 0.0,
        });
    }
    // A numerical failure of a forced explicit run above its limit is its instability.
    let numerical = if forced {
        FailureKind::Unstable
    } else {
        FailureKind::Failed
    };

    // Output.
    if rank == 0 {
        std::fs::create_dir_all(&out_dir)
            .map_err(|e| format!("cannot create output directory {}: {e}", out_dir.display()))?;
    }
    world.barrier();
    let l = &dm.local;
    let counts = GlobalCounts {
        nodes: l.global_nodes,
        elements: l.global_elems,
        particles: sph.as_ref().map(|s| s.n_total).unwrap_or(0),
    };
    let mut writer = FieldWriter::create(world, &out_dir, counts, &scene.output.fields)
        .map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let mut history_cols: Vec<String> = HISTORY_COLUMNS.iter().map(|c| c.to_string()).collect();
    if contact.is_some() {
        history_cols.extend(CONTACT_HISTORY_COLUMNS.iter().map(|c| c.to_string()));
    }
    history_cols.extend(block_history_columns(&scene));
    let history_cols: Vec<&str> = history_cols.iter().map(|c| c.as_str()).collect();
    let mut history = History::create(world, &out_dir.join("history.csv"), &history_cols)
        .map_err(|e| e.to_string())?
        .integer_columns(&HISTORY_INTEGER_COLUMNS);
    let mut probe_cols = vec!["time".to_string()];
    probe_cols.extend(probes.columns.iter().cloned());
    let probe_cols_ref: Vec<&str> = probe_cols.iter().map(|s| s.as_str()).collect();
    let mut probe_csv = History::create(world, &out_dir.join("probes.csv"), &probe_cols_ref)
        .map_err(|e| e.to_string())?;

    let fe0 = stage.fe();
    let owned_nodes: Vec<usize> = (0..fe0.n_nodes()).filter(|&n| fe0.owned[n]).collect();
    let node_ids: Vec<u64> = owned_nodes.iter().map(|&n| l.node_id[n]).collect();
    let conn_ids: Vec<[u64; 8]> = fe0
        .elems
        .iter()
        .map(|c| std::array::from_fn(|k| l.node_id[c[k] as usize]))
        .collect();
    let rank_field = vec![rank; fe0.elems.len()];
    let mut output_s = 0.0;
    let mut particle_ranks = Vec::new();
    let mut particle_labels = Vec::new();
    let mut write_frame =
        |fe: &ExplicitFe, sph: Option<&SphCtx>, writer: &mut FieldWriter| -> Result<f64, String> {
            let t0 = Instant::now();
            let pos: Vec<[f64; 3]> = owned_nodes.iter().map(|&n| fe.x[n]).collect();
            let disp: Vec<[f64; 3]> = owned_nodes
                .iter()
                .map(|&n| std::array::from_fn(|c| fe.x[n][c] - fe.x0[n][c]))
                .collect();
            let vel: Vec<[f64; 3]> = owned_nodes.iter().map(|&n| fe.v[n]).collect();
            let stress: Vec<[f64; 6]> = fe.state.iter().map(|s| s.stress).collect();
            let eps: Vec<f64> = (0..fe.elems.len()).map(|e| fe.plastic_strain(e)).collect();
            let nodes = NodeFrame {
                ids: &node_ids,
                position: &pos,
                displacement: Some(&disp),
                velocity: Some(&vel),
            };
            let elems = ElementFrame {
                ids: &fe.elem_id,
                connectivity: &conn_ids,
                stress: Some(&stress),
                plastic_strain: Some(&eps),
                pressure: Some(&fe.pressure),
                rank: Some(&rank_field),
            };
            let parts = sph.map(|s| s.frame(&mut particle_ranks, &mut particle_labels, rank));
            writer
                .write_frame(fe.time, Some(&nodes), Some(&elems), parts.as_ref())
                .map_err(|e| format!("writing fields.h5: {e}"))?;
            Ok(t0.elapsed().as_secs_f64())
        };

    let e0 = stage.fe().energies.kinetic + sph.as_ref().map(|s| s.energy()).unwrap_or(0.0);
    let mut err_max = 0.0f64;
    let mut err_max_checked = 0.0f64;
    let end = scene.run.end_time;
    let output_every = scene.run.output_every.unwrap_or(end);
    let history_every = scene.run.history_every;
    let mut next_frame = 1u64; // frame 0 written now
    let mut next_row = 1u64;
    output_s += write_frame(stage.fe(), sph.as_ref(), &mut writer)?;
    // history.csv: FE and particles together (kinetic, internal and external work summed).
    let row = |fe: &ExplicitFe,
               dt: f64,
               err: f64,
               c: Option<&ContactCtx>,
               s: Option<&SphCtx>|
     -> Vec<f64> {
        let en = &fe.energies;
        let g = s.map(|s| s.globals).unwrap_or([0.0; 6]);
        let w_sph = s.map(|s| s.external_work).unwrap_or(0.0);
        let mut r = vec![
            fe.step as f64,
            fe.time,
            dt,
            en.kinetic + g[0],
            en.internal + g[1],
            en.hourglass,
            en.external_work + w_sph,
            c.map(|c| c.energy).unwrap_or(0.0),
            err,
            en.momentum[0] + g[2],
            en.momentum[1] + g[3],
            en.momentum[2] + g[4],
            c.map(|c| c.contacts as f64).unwrap_or(0.0),
        ];
        if let Some(c) = c {
            r.extend([c.last_imbalance, c.last_bytes]);
        }
        for b in &fe.block_energies {
            r.extend([b.hourglass, b.internal]);
        }
        r
    };
    let mut hg_watch = HourglassWatch::new(&scene);
    let mut dt = scene.run.dt.unwrap_or(scene.run.dt_safety * stable0);
    history
        .row(&row(stage.fe(), dt, 0.0, contact.as_ref(), sph.as_ref()))
        .map_err(|e| e.to_string())?;
    let mut pr = vec![0.0];
    pr.extend(probes.sample(world, stage.fe(), sph.as_ref().map(|s| &s.stage)));
    probe_csv.row(&pr).map_err(|e| e.to_string())?;

    let progress = (rank == 0 && !opts.quiet).then(|| {
        let pb = indicatif::ProgressBar::new(1000);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% t={msg} ETA {eta}",
            )
            .unwrap(),
        );
        pb
    });

    let loop_t0 = Instant::now();
    let mut loop_output_s = 0.0;
    let mut fe_wall = 0.0;
    let fixed_dt = scene.run.dt;
    let mut dt_min = f64::INFINITY;
    loop {
        // With a fixed step t = step * dt exactly; otherwise clip the last step onto end_time.
        let fe = stage.fe();
        let remaining = end - fe.time;
        if let Some(d) = fixed_dt {
            if (fe.step as f64) * d >= end - TIME_EPS_STEPS * d {
                break;
            }
            dt = d;
        } else {
            if remaining <= TIME_EPS_STEPS * dt {
                break;
            }
            dt = dt.min(remaining);
        }
        dt_min = dt_min.min(dt);
        let tf = Instant::now();
        let contact_s0 = contact.as_ref().map(|c| c.wall_s).unwrap_or(0.0);
        let next = match &mut stage {
            FeStage::Explicit(fe) => explicit_step(
                world,
                &file,
                fe,
                &mut dm.exchange,
                dt,
                contact.as_mut(),
                sph.as_mut(),
            )
            .map_err(|m| RunFailure::new(numerical, m))?,
            FeStage::Implicit(imp) => {
                implicit_step(world, &file, imp, &mut dm.exchange)?;
                dt
            }
        };
        // The FE stage's time without the contact step inside it.
        fe_wall += tf.elapsed().as_secs_f64()
            - (contact.as_ref().map(|c| c.wall_s).unwrap_or(0.0) - contact_s0);
        let fe = match &mut stage {
            FeStage::Explicit(fe) => fe,
            FeStage::Implicit(imp) => &mut imp.fe,
        };
        if fixed_dt.is_some() {
            fe.time = fe.step as f64 * dt;
        }
        let fe = stage.fe();
        let en = fe.energies;
        let total = en.kinetic
            + en.internal
            + en.hourglass
            + contact.as_ref().map(|c| c.energy).unwrap_or(0.0)
            + sph.as_ref().map(|s| s.energy()).unwrap_or(0.0);
        let external = en.external_work + sph.as_ref().map(|s| s.external_work).unwrap_or(0.0);
        let err = energy_error(total, e0, external);
        let blow_up = if forced {
            format!(
                "the explicit run is unstable: run.dt = {dt:e} s is {:.3} times the stable limit {stable0:e} s (forced with run.force_dt = true)",
                dt / stable0
            )
        } else {
            "the run is unstable or under-resolved; reduce run.dt or run.dt_safety".to_string()
        };
        if !total.is_finite() || !external.is_finite() {
            return Err(RunFailure::new(
                FailureKind::Unstable,
                format!(
                    "{file}: non-finite energy at t = {:e} s, step {}: {blow_up}",
                    fe.time, fe.step
                ),
            ));
        }
        err_max = err_max.max(err);
        for line in hg_watch.check(fe.time, fe.step, &fe.block_energies, e0 + external.abs()) {
            if rank == 0 {
                eprintln!("{line}");
            }
        }
        let checked = fe.step >= ENERGY_CHECK_FROM_STEP;
        if checked {
            err_max_checked = err_max_checked.max(err);
        }
        if err > energy_error_limit(fe.step, scene.run.max_energy_error) {
            let _ = history.row(&row(fe, dt, err, contact.as_ref(), sph.as_ref()));
            let _ = history.flush();
            return Err(RunFailure::new(
                FailureKind::Unstable,
                format!(
                    "{file}: energy error {err:.3e} passed run.max_energy_error = {}{} at t = {:e} s, step {} (E = {total:e} J, E0 = {e0:e} J, external work {external:e} J): {blow_up}",
                    scene.run.max_energy_error,
                    early_note(fe.step),
                    fe.time,
                    fe.step
                ),
            ));
        }
        let at_end = fe.time >= end - TIME_EPS_STEPS * dt;
        let t_row = history_every * next_row as f64;
        if history_every <= 0.0 || fe.time >= t_row - TIME_EPS_STEPS * dt || at_end {
            history
                .row(&row(fe, dt, err, contact.as_ref(), sph.as_ref()))
                .map_err(|e| e.to_string())?;
            let mut pr = vec![fe.time];
            pr.extend(probes.sample(world, fe, sph.as_ref().map(|s| &s.stage)));
            probe_csv.row(&pr).map_err(|e| e.to_string())?;
            if history_every > 0.0 {
                while history_every * next_row as f64 <= fe.time + TIME_EPS_STEPS * dt {
                    next_row += 1;
                }
            }
        }
        if fe.time >= output_every * next_frame as f64 - TIME_EPS_STEPS * dt || at_end {
            let s = write_frame(fe, sph.as_ref(), &mut writer)?;
            output_s += s;
            loop_output_s += s;
            while output_every * next_frame as f64 <= fe.time + TIME_EPS_STEPS * dt {
                next_frame += 1;
            }
        }
        if fixed_dt.is_none() {
            dt = scene.run.dt_safety * next;
        }
        if let Some(pb) = &progress {
            pb.set_position(((fe.time / end) * 1000.0) as u64);
            pb.set_message(format!("{:.3e}", fe.time));
        }
    }
    let loop_s = loop_t0.elapsed().as_secs_f64() - loop_output_s;
    if let Some(pb) = progress {
        pb.finish_and_clear();
    }
    let written = writer.bytes_written();
    writer.finish().map_err(|e| e.to_string())?;
    history.flush().map_err(|e| e.to_string())?;
    probe_csv.flush().map_err(|e| e.to_string())?;

    // Report.
    let fe = stage.fe();
    let elements = l.global_elems;
    let steps = fe.step;
    let loop_s = collective::max(world, loop_s);
    let ns_per_element_cycle = if elements > 0 && steps > 0 {
        loop_s * 1e9 * size as f64 / (elements as f64 * steps as f64)
    } else {
        0.0
    };
    // The FE stage's own time: the step less the SPH stage inside it (the contact step is
    // already taken out in the loop).
    let fe_own = fe_wall - sph.as_ref().map(|s| s.wall_s).unwrap_or(0.0);
    let fe_stats = StageStats::reduce(
        world,
        fe_own.max(0.0),
        fe.elems.len() as f64,
        dm.exchange.bytes_sent as f64,
    );
    let out_stats = StageStats::reduce(world, output_s, owned_nodes.len() as f64, written as f64);
    let mem_bytes = collective::sum(world, fe.bytes() as f64);
    let wall_s = collective::max(world, wall0.elapsed().as_secs_f64());
    let n_particles = sph.as_ref().map(|s| s.n_total).unwrap_or(0);
    let mut report = Report::new(
        size as usize,
        elements,
        l.global_nodes,
        n_particles,
        steps,
        wall_s,
    );
    report.stages_run = vec!["fe".into()];
    report.fe = Some(fe_stats);
    let mut skipped = serde_json::Map::new();
    match &sph {
        Some(s) => {
            report.stages_run.push("sph".into());
            let st = StageStats::reduce(world, s.wall_s, s.pairs_local, s.bytes / size as f64);
            report.sph = Some(StageStats {
                wall_s: s.wall_s,
                bytes_sent: s.bytes,
                ..st
            });
            report.rcb = Some(StageStats {
                wall_s: s.rcb_s,
                imbalance: s.rcb_imbalance_sum / steps.max(1) as f64,
                bytes_sent: s.rcb_bytes,
            });
            report.us_per_particle_step = Some(
                loop_s * size as f64 / (n_particles.max(1) as f64 * steps.max(1) as f64) * 1e6,
            );
            report.extra.insert(
                "sph_share_of_step".into(),
                (s.wall_s / loop_s.max(1e-30)).into(),
            );
        }
        None => {
            skipped.insert("sph".into(), "no [[particles]]".into());
        }
    }
    if contact.is_none() {
        skipped.insert("contact".into(), "no [contact]".into());
    }
    report
        .extra
        .insert("stages_skipped".into(), serde_json::Value::Object(skipped));
    if let Some(c) = &contact {
        report.stages_run.push("contact".into());
        report.contact = Some(StageStats {
            wall_s: collective::max(world, c.wall_s),
            imbalance: c.imbalance_sum / c.steps.max(1) as f64,
            bytes_sent: c.bytes,
        });
        let n_steps = c.steps.max(1) as f64;
        // `rcb`: both dynamic decompositions' rebalances (SPH and contact) together.
        if matches!(c.stage, ContactImpl::Dynamic(_)) {
            let mine = StageStats {
                wall_s: c.rcb_wall_s,
                imbalance: c.rcb_imbalance_sum / n_steps,
                bytes_sent: c.rcb_bytes,
            };
            report.rcb = Some(match report.rcb.take() {
                Some(r) => StageStats {
                    wall_s: r.wall_s + mine.wall_s,
                    imbalance: r.imbalance.max(mine.imbalance),
                    bytes_sent: r.bytes_sent + mine.bytes_sent,
                },
                None => mine,
            });
            report.transfer = Some(StageStats {
                wall_s: c.transfer_s,
                imbalance: c.transfer_imbalance_sum / n_steps,
                bytes_sent: c.transfer_bytes,
            });
            report.stages_run.push("transfer".into());
        }
        report.extra.insert(
            "contact_share_of_step".into(),
            (collective::max(world, c.wall_s) / loop_s.max(1e-30)).into(),
        );
        let ex = &mut report.extra;
        ex.insert(
            "contact_nodes".into(),
            (collective::sum(world, c.fe_side.nodes.len() as f64) as u64).into(),
        );
        ex.insert("contacts_found_total".into(), c.contacts_total.into());
        ex.insert("contacts_found_max_step".into(), c.contacts_max.into());
        ex.insert("contact_imbalance_max".into(), c.imbalance_max.into());
        ex.insert("contact_bytes_per_step".into(), (c.bytes / n_steps).into());
        ex.insert(
            "contact_s_per_step".into(),
            (collective::max(world, c.wall_s) / n_steps).into(),
        );
        ex.insert("contact_rcb_migrated".into(), c.rcb_migrated.into());
        if let ContactImpl::Dynamic(stage) = &c.stage {
            // Steps that rebuilt the decomposition, and candidate-list rebuilds summed over
            // ranks (the other steps kept them: the skins in contact_stage).
            ex.insert(
                "contact_rebuilds".into(),
                stage.rebuilds.decomposition.into(),
            );
            ex.insert(
                "contact_candidate_rebuilds".into(),
                (collective::sum(world, stage.rebuilds.candidates as f64) as u64).into(),
            );
        }
        ex.insert(
            "contact_work_max_per_step".into(),
            (c.work_max_sum / n_steps).into(),
        );
        ex.insert(
            "contact_work_total_per_step".into(),
            (c.work_total_sum / n_steps).into(),
        );
        ex.insert(
            "contact_decomposition".into(),
            match c.stage {
                ContactImpl::Dynamic(_) => "dynamic_rcb",
                ContactImpl::Baseline(_) => "static_fe_baseline",
            }
            .into(),
        );
        report
            .extra
            .insert("contact_faces".into(), c.fe_side.global_faces.into());
        report
            .extra
            .insert("contact_bodies".into(), c.fe_side.n_bodies.into());
    }
    report.output = Some(out_stats);
    report.ns_per_element_cycle = Some(ns_per_element_cycle);
    report.energy_error_max = err_max;
    let ex = &mut report.extra;
    ex.insert("energy_error_max_checked".into(), err_max_checked.into());
    ex.insert("blocks".into(), hg_watch.report(stage.fe()));
    ex.insert("title".into(), scene.title.clone().into());
    ex.insert(
        "mode".into(),
        match mode {
            Mode::Explicit => "explicit",
            Mode::Implicit => "implicit",
        }
        .into(),
    );
    ex.insert("dt_stable_initial".into(), stable0.into());
    ex.insert("dt_min".into(), dt_min.into());
    ex.insert("setup_s".into(), collective::max(world, setup_s).into());
    ex.insert("loop_s".into(), loop_s.into());
    ex.insert(
        "bytes_per_element".into(),
        (mem_bytes / elements.max(1) as f64).into(),
    );
    let t = fe.timers;
    ex.insert(
        "fe_element_kernel_s".into(),
        collective::max(world, t.elements).into(),
    );
    ex.insert(
        "fe_ghost_exchange_s".into(),
        collective::max(world, t.exchange).into(),
    );
    ex.insert("fe_nodal_s".into(), collective::max(world, t.nodal).into());
    if let FeStage::Implicit(imp) = &stage {
        // Counters are the same on every rank (collective solves); timers are maxima.
        let s = imp.stats;
        ex.insert("newton_iterations".into(), s.newton_iterations.into());
        ex.insert(
            "newton_iterations_per_step".into(),
            (s.newton_iterations as f64 / steps.max(1) as f64).into(),
        );
        ex.insert(
            "newton_iterations_max_step".into(),
            s.max_step_iterations.into(),
        );
        ex.insert("ksp_iterations".into(), s.ksp_iterations.into());
        ex.insert(
            "ksp_iterations_per_solve".into(),
            (s.ksp_iterations as f64 / s.newton_iterations.max(1) as f64).into(),
        );
        ex.insert("tangent_assemblies".into(), s.assemblies.into());
        ex.insert("residual_evaluations".into(), s.residuals.into());
        ex.insert(
            "implicit_assembly_s".into(),
            collective::max(world, s.assembly_s).into(),
        );
        ex.insert(
            "implicit_ksp_s".into(),
            collective::max(world, s.solve_s).into(),
        );
        ex.insert("newton_rtol".into(), imp.options.rtol.into());
    }
    if rank == 0 {
        report
            .write(&out_dir.join("report.json"))
            .map_err(|e| e.to_string())?;
    }
    Ok(RunSummary {
        out: out_dir,
        mode,
        steps,
        energy_error_max: err_max,
        ns_per_element_cycle,
        dt_stable: stable0,
        dt_min,
        wall_s,
        loop_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fe_petsc::explicit::BlockEnergy;

    #[allow(clippy::field_reassign_with_default)]
    fn be(internal: f64, hourglass: f64) -> BlockEnergy {
        let mut b = BlockEnergy::default();
        b.internal = internal;
        b.hourglass = hourglass;
        b
    }

    /// SCENE.md: max_energy_error from step 100; before it only a blow-up (an error over 10,
    /// or over max_energy_error when that is larger).
    #[test]
    fn energy_error_limit_from_step_100() {
        assert_eq!(energy_error_limit(0, 0.05), EARLY_BLOW_UP_ERROR);
        assert_eq!(energy_error_limit(99, 0.05), EARLY_BLOW_UP_ERROR);
        assert_eq!(energy_error_limit(100, 0.05), 0.05);
        assert_eq!(energy_error_limit(5, 20.0), 20.0);
    }

    /// The warning rule by hand: block "wall" passes 10 % (12.3 %) at step 3 and is warned
    /// once; block "ball" stays at 5 %; a ratio of 50 % on a negligible internal energy (1e-9 J
    /// against an energy scale of 100 J: below 1e-6 of it) is neither warned nor reported.
    #[test]
    fn hourglass_warning_once_per_block_and_not_on_negligible_energy() {
        let mut w = HourglassWatch::with_names(vec!["wall".into(), "ball".into()]);
        let scale = 100.0;
        let steps = [
            [be(1e-9, 5e-10), be(1.0, 0.05)],
            [be(2.0, 0.1), be(2.0, 0.1)],
            [be(10.0, 1.23), be(3.0, 0.15)],
            [be(10.0, 2.0), be(3.0, 0.15)],
            [be(20.0, 1.0), be(3.0, 0.15)],
        ];
        let mut lines = Vec::new();
        for (k, b) in steps.iter().enumerate() {
            lines.extend(w.check(1.0e-5 * k as f64, k as u64, b, scale));
        }
        assert_eq!(lines.len(), 1, "one warning (wall), said once: {lines:?}");
        assert_eq!(
            lines[0],
            "tdyn: warning: block \"wall\": hourglass energy 12.3 % of internal energy at t = 2.000e-5 s (guideline: under 10 %)"
        );
        let (r, t, step) = w.max[0].unwrap();
        assert!(
            (r - 0.2).abs() < 1e-15 && step == 3 && (t - 3e-5).abs() < 1e-20,
            "wall's largest ratio 2/10 at step 3"
        );
        assert!(
            (w.max[1].unwrap().0 - 0.05).abs() < 1e-15,
            "ball's largest ratio 5 %"
        );
        assert!(!w.warned[1]);
    }
}
