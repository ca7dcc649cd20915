//! The run: scene -> the stages it needs -> the time loop (the paper's Fig. 3) -> output.
//!
//! One driver for every scene: the stages a scene declares are built (`setup`): the FE stage
//! for meshes (explicit, or implicit with `run.mode = "implicit"`), the SPH stage for
//! `[[particles]]`, the contact stage for `[contact]`; a particle-only run is the same loop with
//! no FE stage. Each step is `step::step` (Fig. 3); around it the clock (`schedule`), the
//! energy check (`energy`), the files (`outputs`), progress lines (`progress`) and at the end
//! report.json (`report`).
use crate::input::scene::{self, Mode, Scene};
use crate::kernels::collective;
use crate::stages::{StageEnergies, StageError};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::PathBuf;
use std::time::Instant;

pub mod checkpoint;
pub mod energy;
pub mod impact;
mod options;
pub mod outdir;
pub mod outputs;
pub mod overlap;
pub mod probes;
pub mod progress;
pub mod report;
pub mod schedule;
pub mod setup;
pub mod step;

pub use energy::{early_note, energy_error_limit, EARLY_BLOW_UP_ERROR, ENERGY_CHECK_FROM_STEP};
pub use options::{Algorithms, KernelChoice, RunOptions, RunOverrides};
pub use outputs::{
    block_history_columns, CONTACT_HISTORY_COLUMNS, HISTORY_COLUMNS, HISTORY_INTEGER_COLUMNS,
};

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
    /// Largest energy error from the check's first step on (`energy::ENERGY_CHECK_FROM_STEP`).
    pub energy_error_max_checked: f64,
    /// The energy error after the last step.
    pub energy_error_last: f64,
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
    /// Stopped by the user (Ctrl-C, SIGTERM): the output closed, a checkpoint written.
    Stopped,
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

/// Runs a scene. Collective; every rank returns the same error.
pub fn run(world: &SimpleCommunicator, opts: &RunOptions) -> Result<RunSummary, RunFailure> {
    let wall0 = Instant::now();
    // Every rank parses the scene (identical result, no communication).
    let mut scene = scene::load(&opts.scene).map_err(|e| e.to_string())?;
    let scene_file_hash = checkpoint::scene_hash(&scene);
    opts.overrides.apply(&mut scene)?;
    setup::check_scene(&scene)?;
    if world.rank() == 0 {
        let warnings = scene::unit_warnings(&scene)
            .into_iter()
            .chain(scene::interaction_warnings(&scene))
            .chain(scene::sph_warnings(&scene))
            .chain(scene::mode_warnings(&scene));
        for w in warnings {
            eprintln!("tdyn: warning: {w}");
        }
    }
    let default_out = PathBuf::from("out").join(scene.file.file_stem().unwrap_or_default());
    let t_setup = Instant::now();
    let mut model = setup::build(world, &scene, &opts.algorithms)?;
    let stable0 = model.stable_dt(world);
    let forced = check_fixed_dt(world, &scene, &model, stable0, opts.quiet)?;
    let mut clock = schedule::Clock::new(&scene, stable0);
    scene::check_work(&scene, clock.dt).map_err(|e| e.to_string())?;
    if opts.setup_only {
        let wall_s = collective::max(world, wall0.elapsed().as_secs_f64());
        return Ok(RunSummary {
            out: opts.out.clone().unwrap_or(default_out),
            wall_s,
            ..RunSummary::set_up(scene.run.mode, stable0, clock.dt)
        });
    }
    let identity = checkpoint::RunIdentity {
        scene_hash: checkpoint::scene_hash(&scene),
        scene_file_hash,
        scene_file: &scene.file,
        overrides: &opts.overrides,
    };
    let mut check = EnergyCheck::new(world, &scene, &model, forced, stable0);
    let restart = restart_from(world, opts, &identity, &mut model, &mut clock, &mut check)?;
    let out_dir = out_dir_of(world, opts, &default_out, restart.is_some())?;
    let setup_s = t_setup.elapsed().as_secs_f64();
    let mut outputs = outputs::Outputs::create(world, &out_dir, &scene, &model, restart.as_ref())?;
    let mut ctx = LoopCtx {
        out_dir: &out_dir,
        identity: &identity,
        next_checkpoint: restart.as_ref().map_or(1, |m| m.next_checkpoint),
        checkpoint_every: scene.output.checkpoint_every,
    };
    if restart.is_none() {
        // Each is collective and may fail on one rank alone: all three, then one agreement.
        let frame = outputs.frame(0.0, &model);
        let dump = outputs.dump(world, 0, false, &model);
        let rows = outputs.rows(world, &model, &check.row(&clock, &model, 0.0));
        row_written(&mut model, clock.time);
        collective::first_error(world, frame.and(dump).and(rows).err())?;
    } else if world.rank() == 0 && !opts.quiet {
        eprintln!(
            "tdyn: restarting from the checkpoint at step {}, t = {:e} s",
            clock.step, clock.time
        );
    }
    // The loop's time without its output (frames, rows, dumps, checkpoints written in it).
    let loop_t0 = Instant::now();
    let output_s0 = outputs.wall_s;
    let res = time_loop(
        world,
        &scene,
        opts,
        &mut model,
        &mut clock,
        &mut check,
        &mut outputs,
        &mut ctx,
        stable0,
    );
    let loop_s = loop_t0.elapsed().as_secs_f64() - (outputs.wall_s - output_s0);
    let output_s = outputs.wall_s;
    let finished = outputs.finish();
    if let Err(e) = collective::first_error(world, finished.as_ref().err().cloned()) {
        // The loop's own failure, when it had one, is what the user needs to read.
        return Err(res.err().unwrap_or_else(|| e.into()));
    }
    let output_bytes = finished.expect("agreed");
    let loop_s = collective::max(world, loop_s);
    let wall_s = collective::max(world, wall0.elapsed().as_secs_f64());
    report::write(
        world,
        &out_dir,
        &scene,
        &model,
        &report::RunFigures {
            steps: clock.step,
            wall_s,
            loop_s,
            setup_s,
            output_s,
            output_bytes,
            energy_error_max: check.err_max,
            energy_error_max_checked: check.err_max_checked,
            dt_stable_initial: stable0,
            dt_min: clock.dt_min,
            hourglass: &check.hourglass,
            energy_floor: check.scale.floor,
            mass: check.scale.floor / (0.5 * energy::FLOOR_SPEED * energy::FLOOR_SPEED),
            failure: res.as_ref().err().map(|e| (e.kind, e.message.as_str())),
        },
    )?;
    res?;
    // A run shorter than the energy check's start was never checked: say so when its error
    // at the end is past the limit (an E in MPa read as Pa ends 2 steps later at 100 %).
    if world.rank() == 0
        && clock.step < energy::ENERGY_CHECK_FROM_STEP
        && check.err_last > check.max_energy_error
    {
        eprintln!(
            "tdyn: warning: {}: energy error {:.2} % at the end, over run.max_energy_error = {} ({} %): this run of {} steps ended before the check starts (step {}); check the scene's units and the end time",
            check.file,
            100.0 * check.err_last,
            check.max_energy_error,
            100.0 * check.max_energy_error,
            clock.step,
            energy::ENERGY_CHECK_FROM_STEP
        );
    }
    let elements = model.fe.as_ref().map_or(0, |f| f.mesh.local.global_elems);
    let cycles = elements as f64 * clock.step as f64;
    Ok(RunSummary {
        out: out_dir,
        steps: clock.step,
        energy_error_max: check.err_max,
        energy_error_max_checked: check.err_max_checked,
        energy_error_last: check.err_last,
        ns_per_element_cycle: if cycles > 0.0 {
            loop_s * 1e9 * world.size() as f64 / cycles
        } else {
            0.0
        },
        dt_min: clock.dt_min,
        wall_s,
        loop_s,
        ..RunSummary::set_up(scene.run.mode, stable0, clock.dt)
    })
}

/// `--restart DIR`: the checkpoint's state set into `model`, `clock` and `check` (collective;
/// `identity` the run's, which the checkpoint must match). Returns its metadata (`None`
/// without `--restart`).
fn restart_from(
    world: &SimpleCommunicator,
    opts: &RunOptions,
    identity: &checkpoint::RunIdentity,
    model: &mut Model,
    clock: &mut schedule::Clock,
    check: &mut EnergyCheck,
) -> Result<Option<checkpoint::Meta>, RunFailure> {
    Ok(match &opts.restart {
        Some(dir) => {
            if opts.out.as_ref().is_some_and(|o| o != dir) {
                return Err(format!(
                    "--restart {} continues that run in its own folder: leave out --out",
                    dir.display()
                )
                .into());
            }
            let (meta, saved) = checkpoint::read(world, dir, identity)?;
            // A run that reached its end time has nothing to continue (the same scene: the
            // checkpoint matched it, so the same end time).
            let mut at = clock.clone();
            at.restore(&meta.clock);
            if at.at_end() {
                if !opts.overwrite {
                    return Err(format!(
                        "--restart {}: that run is finished (step {}, t = {:e} s, its run.end_time): nothing to continue; --overwrite runs it again from t = 0 in that folder, replacing its results",
                        dir.display(),
                        meta.clock.step,
                        meta.clock.time
                    )
                    .into());
                }
                if world.rank() == 0 && !opts.quiet {
                    eprintln!(
                        "tdyn: {}: that run is finished; --overwrite: running it again from t = 0",
                        dir.display()
                    );
                }
                return Ok(None);
            }
            let restored = restore(world, model, &saved);
            collective::first_error(world, restored.err())?;
            clock.restore(&meta.clock);
            check.restore(&meta.check);
            Some(meta)
        }
        None => None,
    })
}

impl RunSummary {
    /// A run that only set up (`--setup-only`): no steps; `dt_stable` the stable step found,
    /// `dt` the first step.
    fn set_up(mode: scene::Mode, dt_stable: f64, dt: f64) -> RunSummary {
        RunSummary {
            out: PathBuf::new(),
            mode,
            steps: 0,
            energy_error_max: 0.0,
            energy_error_max_checked: 0.0,
            energy_error_last: 0.0,
            ns_per_element_cycle: 0.0,
            dt_stable,
            dt_min: dt,
            wall_s: 0.0,
            loop_s: 0.0,
        }
    }
}

/// The run's folder: `--restart`'s, else `--out` or the default (`outdir::resolve`: a folder
/// holding an earlier run's results needs `--overwrite`), its note printed once (collective).
fn out_dir_of(
    world: &SimpleCommunicator,
    opts: &RunOptions,
    default_out: &std::path::Path,
    restarted: bool,
) -> Result<PathBuf, RunFailure> {
    let (out_dir, note) = match &opts.restart {
        Some(dir) if restarted => (dir.clone(), None),
        // A finished run's folder, run again (`--restart DIR --overwrite`).
        Some(dir) => outdir::resolve(world, Some(dir), default_out, true, false)?,
        None => outdir::resolve(
            world,
            opts.out.as_deref(),
            default_out,
            opts.overwrite,
            false,
        )?,
    };
    if let (Some(n), true) = (note, world.rank() == 0 && !opts.quiet) {
        eprintln!("tdyn: {n}");
    }
    Ok(out_dir)
}

/// What the time loop needs besides the model, clock and files.
struct LoopCtx<'a> {
    out_dir: &'a std::path::Path,
    identity: &'a checkpoint::RunIdentity<'a>,
    next_checkpoint: u64,
    checkpoint_every: Option<f64>,
}

/// The time loop: steps until the end time, with rows, frames, dumps, checkpoints, progress,
/// and a clean stop when asked (collective).
#[allow(clippy::too_many_arguments)]
fn time_loop(
    world: &SimpleCommunicator,
    scene: &Scene,
    opts: &RunOptions,
    model: &mut Model,
    clock: &mut schedule::Clock,
    check: &mut EnergyCheck,
    outputs: &mut outputs::Outputs,
    ctx: &mut LoopCtx,
    stable0: f64,
) -> Result<(), RunFailure> {
    let mut progress = progress::Progress::start(
        world.rank() == 0 && !opts.quiet,
        world.rank() == 0,
        &start_info(world, scene, model, stable0, (clock.time, clock.dt)),
    );
    if let Some(c) = model.contact.as_mut() {
        c.energy_scale = check.scale_now();
    }
    while let Some(dt) = clock.next_step() {
        for stage in model.stages_mut() {
            stage.set_clock(clock.time);
        }
        let next = step::step(world, model, clock.time, dt).map_err(|e| check.failure(e))?;
        clock.advance();
        if let (true, Some(fe)) = (clock.fixed(), model.fe.as_mut()) {
            fe.set_time(clock.time);
        }
        let err = check.after_step(world, clock, model, outputs)?;
        if let Some(c) = model.contact.as_mut() {
            c.energy_scale = check.scale_now();
        }
        // This rank's first output failure; the others go on with their (collective) output.
        let mut out_err = None;
        if clock.row_due() {
            out_err = outputs
                .rows(world, model, &check.row(clock, model, err))
                .err();
            row_written(model, clock.time);
        }
        if clock.frame_due() {
            out_err = out_err.or(outputs.frame(clock.time, model).err());
        }
        out_err = out_err.or(outputs.dump(world, clock.step, clock.at_end(), model).err());
        clock.propose(next);
        let stop = opts
            .stop
            .as_ref()
            .is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed));
        let stop = agree_step(world, stop, out_err)?;
        let due = ctx.checkpoint_every.is_some_and(|every| {
            clock.time >= every * ctx.next_checkpoint as f64 - schedule::TIME_EPS_STEPS * dt
                || clock.at_end()
        });
        if due || stop {
            if let Some(every) = ctx.checkpoint_every {
                while every * ctx.next_checkpoint as f64
                    <= clock.time + schedule::TIME_EPS_STEPS * dt
                {
                    ctx.next_checkpoint += 1;
                }
            }
            write_checkpoint(world, clock, check, outputs, model, ctx)?;
        }
        if stop {
            progress.finish();
            return Err(RunFailure::new(
                FailureKind::Stopped,
                format!(
                    "stopped at step {}, t = {:e} s: the output is closed and a checkpoint written; `{}` continues",
                    clock.step,
                    clock.time,
                    options::restart_command(
                        &scene.file,
                        &opts.overrides.run_args(),
                        ctx.out_dir
                    )
                ),
            ));
        }
        progress.update(
            clock.step,
            clock.time,
            clock.fraction(),
            dt,
            scene.run.end_time,
            err,
        );
    }
    progress.finish();
    Ok(())
}

/// A history row (and its reactions.csv row) was written at `time`: the walls' impulses start
/// again from zero.
fn row_written(model: &mut Model, time: f64) {
    if let Some(w) = model.walls.as_mut() {
        w.row_written(time);
    }
}

/// The step's one agreement (collective): whether any rank was asked to stop, and, when any
/// rank's output failed this step, the lowest such rank's message on every rank. Output may
/// fail on one rank alone (rank 0 writes the CSV rows and the dumps; a full disk): agreed
/// here, every rank stops at the same step with the same line instead of the others waiting
/// in the next step's collective calls. Both ride in the one reduction the stop request
/// needs anyway; the message's broadcast happens only on failure.
fn agree_step(
    world: &SimpleCommunicator,
    stop: bool,
    out_err: Option<String>,
) -> Result<bool, String> {
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    let mine = [flag(stop), flag(out_err.is_some())];
    let mut any = [0.0f64; 2];
    world.all_reduce_into(&mine[..], &mut any[..], SystemOperation::max());
    if any[1] > 0.0 {
        collective::first_error(world, out_err)?;
    }
    Ok(any[0] > 0.0)
}

/// Sets every stage's state from a checkpoint's rank files (collective: a stage's remap on
/// another rank count communicates, and every stage takes part whatever another's result).
fn restore(
    world: &SimpleCommunicator,
    model: &mut Model,
    saved: &checkpoint::Saved,
) -> Result<(), String> {
    let mut res = Ok(());
    for stage in model.stages_mut() {
        let r = match saved {
            checkpoint::Saved::Mine(state) => stage.restore(state),
            checkpoint::Saved::All(pieces) => stage.restore_remapped(world, pieces),
        };
        res = res.and(r);
    }
    // The contact stage keeps only global values (its energy and the last step's figures):
    // any rank's file serves, rank 0's on another rank count.
    let contact_state = match saved {
        checkpoint::Saved::Mine(state) => Some(state),
        checkpoint::Saved::All(pieces) => pieces.first(),
    };
    if let (Some(c), Some(state)) = (model.contact.as_mut(), contact_state) {
        res = res.and(c.restore(state));
    }
    // The walls' state is global too.
    if let (Some(w), Some(state)) = (model.walls.as_mut(), contact_state) {
        res = res.and(w.restore(state));
    }
    // And the FE -> SPH transfer's; the masses after the restored releases.
    if let (Some(r), Some(state)) = (model.releases.as_mut(), contact_state) {
        res = res.and(r.restore(state));
        if let Some(fe) = model.fe.as_mut() {
            fe.restore_release_counts(world);
        }
    }
    if model.erosion_masses.is_some() {
        model.sum_erosion_masses(world);
    }
    res
}

/// Writes a checkpoint of the run now (collective).
fn write_checkpoint(
    world: &SimpleCommunicator,
    clock: &schedule::Clock,
    check: &EnergyCheck,
    outputs: &mut outputs::Outputs,
    model: &Model,
    ctx: &LoopCtx,
) -> Result<(), String> {
    let t0 = Instant::now();
    // Rank 0 writes the rows: its failure (a full disk) agreed before the collective writes.
    collective::first_error(world, outputs.flush_rows().err())?;
    let (history_rows, probe_rows, frames) = outputs.progress();
    let meta = checkpoint::Meta {
        version: 1,
        ranks: world.size(),
        scene_hash: ctx.identity.scene_hash.clone(),
        scene_file_hash: ctx.identity.scene_file_hash.clone(),
        params: ctx.identity.overrides.params(),
        end_time: ctx.identity.overrides.end_time,
        clock: clock.state(),
        check: check.state(),
        history_rows,
        probe_rows,
        frames,
        next_checkpoint: ctx.next_checkpoint,
    };
    checkpoint::write(world, ctx.out_dir, &meta, model)?;
    outputs.wall_s += t0.elapsed().as_secs_f64();
    Ok(())
}

/// The start line's figures (collective: none; every rank has them).
fn start_info<'a>(
    world: &SimpleCommunicator,
    scene: &'a Scene,
    model: &Model,
    stable0: f64,
    (time, dt): (f64, f64),
) -> progress::StartInfo<'a> {
    // (the stages in report.json's `stages_run` order: the rigid walls' pass included)
    let mut stages: Vec<&'static str> = model.stages().iter().map(|s| s.name()).collect();
    if model.contact.is_some() {
        stages.push("contact");
    }
    if model.walls.is_some() {
        stages.push("rigid_walls");
    }
    let mesh = model.fe.as_ref().map(|f| &f.mesh.local);
    progress::StartInfo {
        scene: scene.file.to_str().unwrap_or("scene"),
        elements: mesh.map_or(0, |l| l.global_elems),
        nodes: mesh.map_or(0, |l| l.global_nodes),
        particles: model.sph.as_ref().map_or(0, |s| s.n_total),
        stages,
        ranks: world.size(),
        dt_stable: stable0,
        dt,
        end_time: scene.run.end_time,
        fixed_dt: scene.run.dt.is_some(),
        // (a restart's steps start part way: its count stays the current step's)
        impact: model.impact.clone().filter(|_| time == 0.0),
        mesh_split: model.mesh_split.map(|s| s.describe()).or_else(|| {
            // Native tetrahedra: say so, as the split says what it did.
            let tets = mesh.map_or(0, |l| l.global_tets);
            (tets > 0).then(|| {
                format!(
                    "{} tetrahedra run natively (nodal-averaged pressure, [run] tetrahedra = \"nodal_pressure\"){}",
                    crate::input::split::grouped(tets as usize),
                    match mesh.map_or(0, |l| l.global_hexes) {
                        0 => String::new(),
                        h => format!(", beside {} hexahedra", crate::input::split::grouped(h as usize)),
                    }
                )
            })
        }),
    }
}

/// A fixed explicit `run.dt` above the stable step is refused, unless `run.force_dt` (then the
/// run is marked forced: its numerical failures are its instability) or the particles follow
/// LIGGGHTS (`sph.profile = "liggghts"` takes the step as given, as LIGGGHTS does). Returns
/// whether the run is forced.
fn check_fixed_dt(
    world: &SimpleCommunicator,
    scene: &Scene,
    model: &Model,
    stable0: f64,
    quiet: bool,
) -> Result<bool, RunFailure> {
    let (Mode::Explicit, Some(dt)) = (scene.run.mode, scene.run.dt) else {
        return Ok(false);
    };
    if dt <= stable0 {
        return Ok(false);
    }
    let file = scene.file.display();
    let say = world.rank() == 0 && !quiet;
    let liggghts = scene.sph.as_ref().is_some_and(|s| s.profile == "liggghts");
    if liggghts && !scene.run.force_dt {
        if say {
            eprintln!("tdyn: warning: run.dt {dt:e} s is above the stable limit {stable0:e} s; taken as given (sph.profile = \"liggghts\")");
        }
        return Ok(false);
    }
    if !scene.run.force_dt {
        let native_tets = scene.run.tetrahedra == crate::input::scene::Tetrahedra::NodalPressure;
        let elements = if native_tets {
            "the element estimate with bulk viscosity (Flanagan-Belytschko for hexahedra, the native tetrahedra's own bound)"
        } else {
            "Flanagan-Belytschko element estimate with bulk viscosity"
        };
        let what = match (&model.fe, &model.sph) {
            (Some(_), Some(_)) => format!("{elements}, and 0.3 h/(c + |v|) over the particles"),
            (Some(_), None) => elements.to_string(),
            _ => "SPH: 0.3 min h/(c + |v|) over the particles".to_string(),
        };
        // implicit mode only where the scene could run in it (setup::check_scene's refusals)
        let implicit_possible = model.sph.is_none()
            && scene.contact.is_none()
            && !native_tets
            && scene.failures.iter().all(Option::is_none)
            && !scene.blocks.iter().any(|b| {
                (scene.materials.iter()).any(|m| m.name == b.material && m.model == "fluid")
            });
        let implicit = if implicit_possible {
            " set mode = \"implicit\","
        } else {
            ""
        };
        return Err(RunFailure::new(
            FailureKind::Refused,
            format!(
                "{file}: run.dt: {dt:e} s is above the explicit stable limit {stable0:e} s ({what}); use run.dt <= {stable0:e}, remove run.dt,{implicit} or set run.force_dt = true to run it anyway"
            ),
        ));
    }
    if say {
        eprintln!(
            "tdyn: warning: run.dt = {dt:e} s is {:.3} times the explicit stable limit {stable0:e} s (run.force_dt = true): the energy check will stop the run if it blows up",
            dt / stable0
        );
    }
    Ok(true)
}

/// The model's mass, kg: the FE nodes' (owned, finite) and the particles' (owned), summed
/// over ranks exactly (`fe_petsc::exact::total`: the same bits at any rank count; it sets the
/// energy floor, part of the energy error's denominator). Collective.
fn model_mass(world: &SimpleCommunicator, model: &Model) -> f64 {
    let mut m = Vec::new();
    if let Some(fe) = &model.fe {
        let s = fe.state();
        for (mass, owned) in s.mass.iter().zip(&s.owned) {
            if *owned && mass.is_finite() {
                m.push(*mass);
            }
        }
    }
    if let Some(sph) = &model.sph {
        let p = &sph.stage.parts;
        m.extend_from_slice(&p.m[..p.n_owned]);
    }
    fe_petsc::exact::total(world, &m)
}

/// The stages' energies and momentum summed (FE, then SPH), and the moving walls' work in the
/// external work.
fn sum_energies(model: &Model) -> StageEnergies {
    let mut s = StageEnergies {
        external_work: model.walls.as_ref().map_or(0.0, |w| w.work),
        ..StageEnergies::default()
    };
    for stage in model.stages() {
        let e = stage.energies();
        s.kinetic += e.kinetic;
        s.internal += e.internal;
        s.hourglass += e.hourglass;
        s.external_work += e.external_work;
        s.solid_internal += e.solid_internal;
        for c in 0..3 {
            s.momentum[c] += e.momentum[c];
        }
    }
    s
}

use setup::Model;

mod energy_check;
use energy_check::*;
