//! Checkpoint and restart (docs/scene.md "Runs, restarts and earlier results").
//!
//! A checkpoint is a folder `checkpoint/` in the run's output folder: one file per rank,
//! `rank-RRRRRR-step-SSSSSSSSSS.bin`, holding that rank's state as named arrays
//! (`output::state`: each stage's `save`), and `meta.json` (rank 0), which names the step and
//! holds what every rank shares: the clock, the energy check, how many history and probe rows
//! and which field frames were written, and the scene's hash. The rank files are written in
//! parallel, each rank its own (no rank waits on another's I/O), then `meta.json` is written
//! through a temporary file and renamed, and only then are older rank files removed: a run
//! killed while writing leaves the previous checkpoint whole.
//!
//! Written as plain per-rank files rather than one HDF5 file: every rank's arrays have their own
//! length, and in parallel HDF5 every rank would have to create every other rank's datasets
//! (creation is collective); a restart on the same ranks reads back exactly its own bytes.
//!
//! A restart rebuilds the stages from the scene as a new run would (the mesh distribution is
//! deterministic on the same ranks), then overwrites their state from the files: on the same
//! rank count it continues bit for bit (the SPH stage keeps its pair list and RCB cuts; the
//! contact stage rebuilds its decomposition, whose contacts are those of a rebuild at every
//! step). On another rank count every rank reads every rank file (a few bytes per node,
//! element and particle: simpler than a scatter, and each rank needs pieces of many files)
//! and each stage takes what its new decomposition holds by global id (`Stage::
//! restore_remapped`): nodes and elements by the mesh's ids, particles by theirs; global
//! values (energies, the clock, the energy check) are the same in every file. The run then
//! agrees with the run without a stop to round-off (sums are taken in another order), as runs
//! on different rank counts do.
use super::energy::HourglassWatch;
use super::options::{restart_command, run_args, RunOverrides};
use super::setup::Model;
use crate::input::scene::Scene;
use crate::kernels::collective::first_error;
use crate::output::state::{StateReader, StateWriter};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The checkpoint folder's name in the output folder.
pub const DIR: &str = "checkpoint";

/// Format version written in `meta.json`.
const VERSION: u32 = 1;

/// The clock's state.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct ClockState {
    /// Steps taken.
    pub step: u64,
    /// Time, s.
    pub time: f64,
    /// The next step's size, s.
    pub dt: f64,
    /// The smallest step so far, s.
    pub dt_min: f64,
    /// The next field frame's and history row's index.
    pub next_frame: u64,
    /// See `next_frame`.
    pub next_row: u64,
}

/// The energy check's state.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CheckState {
    /// E(0), J.
    pub e0: f64,
    /// The largest energy errors so far.
    pub err_max: f64,
    /// See `err_max`.
    pub err_max_checked: f64,
    /// The blocks' hourglass watch.
    pub hourglass: HourglassWatch,
    /// The energy scale's state.
    #[serde(default)]
    pub scale: super::energy::EnergyScale,
    /// The external work after the last step, J.
    #[serde(default)]
    pub external_last: f64,
    /// Steps in a row, up to the last, whose checked energy error was past the limit.
    #[serde(default)]
    pub over_limit_steps: u64,
}

/// What every rank shares (`meta.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Meta {
    /// Format version.
    pub version: u32,
    /// Ranks that wrote it.
    pub ranks: i32,
    /// SHA-256 of the scene as the run computes it: parsed, with the command line's
    /// replacements of its values (`scene_hash`). Comments, layout and the order of `-p`
    /// values do not change it.
    pub scene_hash: String,
    /// SHA-256 of the scene as parsed, before the command line's replacements (`scene_hash`
    /// of the scene file alone): tells a changed scene from changed command-line values.
    /// Empty in a checkpoint of an earlier tdyn, whose `scene_hash` is of the file's bytes.
    #[serde(default)]
    pub scene_file_hash: String,
    /// The `-p` values of the run, `(NAME, value)` (`RunOverrides::params`).
    #[serde(default)]
    pub params: Vec<(String, f64)>,
    /// The run's `--end-time`, s (none: the scene's).
    #[serde(default)]
    pub end_time: Option<f64>,
    /// The clock.
    pub clock: ClockState,
    /// The energy check.
    pub check: CheckState,
    /// Rows of history.csv and probes.csv written (header not counted).
    pub history_rows: usize,
    /// See `history_rows`.
    pub probe_rows: usize,
    /// The field frames written (`FieldWriter::index`).
    pub frames: String,
    /// The next checkpoint's index (checkpoint k at k * checkpoint_every).
    pub next_checkpoint: u64,
}

fn rank_file(dir: &Path, rank: i32, step: u64) -> PathBuf {
    dir.join(format!("rank-{rank:06}-step-{step:010}.bin"))
}

/// The hash a checkpoint is tied to: of what the run computes, the scene as parsed (with the
/// command line's replacements of its values already in it), not the file's bytes: comments,
/// layout, the spelling of numbers and the order of `-p` values do not change it. Where the
/// scene file is (its path, the folder its mesh files are resolved against), its title and its
/// `[compare]` and `[sweep]` tables (not read by a run) are left out.
pub fn scene_hash(scene: &Scene) -> String {
    let mut s = scene.clone();
    for m in &mut s.meshes {
        if let Ok(rel) = m.file.strip_prefix(&scene.dir) {
            m.file = rel.to_path_buf();
        }
    }
    s.file = PathBuf::new();
    s.dir = PathBuf::new();
    s.title = String::new();
    s.compare = None;
    s.sweep = None;
    sha256(&[format!("{s:?}").as_bytes()])
}

/// The hash an earlier tdyn wrote: the scene file's bytes and the replacements' `Debug` form.
fn legacy_scene_hash(scene_text: &str, overrides: &RunOverrides) -> String {
    sha256(&[
        scene_text.as_bytes(),
        &[0u8],
        format!("{overrides:?}").as_bytes(),
    ])
}

fn sha256(parts: &[&[u8]]) -> String {
    use sha2::{Digest, Sha256};
    let mut h = Sha256::new();
    for p in parts {
        h.update(p);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// What a restart is checked against: the scene as the run computes it, the scene file alone,
/// and the command line's replacements.
pub struct RunIdentity<'a> {
    /// `scene_hash` of the scene with the replacements.
    pub scene_hash: String,
    /// `scene_hash` of the scene file alone.
    pub scene_file_hash: String,
    /// The scene file.
    pub scene_file: &'a Path,
    /// The replacements given on the command line.
    pub overrides: &'a RunOverrides,
}

/// Why a checkpoint of `meta` is not of the run `now` (`None`: it is). Names the `-p` and
/// `--end-time` values that differ, else says the scene's values changed.
fn mismatch(meta: &Meta, now: &RunIdentity, run_dir: &Path) -> Option<String> {
    if meta.scene_file_hash.is_empty() {
        // An earlier tdyn's checkpoint: its hash is of the file's bytes.
        let text = std::fs::read_to_string(now.scene_file).unwrap_or_default();
        if legacy_scene_hash(&text, now.overrides) == meta.scene_hash {
            return None;
        }
        return Some(format!(
            "--restart {}: {} (or the values given on the command line) changed since the checkpoint was written; a restart continues the same scene: undo the change, or start a new run",
            run_dir.display(),
            now.scene_file.display()
        ));
    }
    if meta.scene_hash == now.scene_hash {
        return None;
    }
    let mut diffs = Vec::new();
    let then: std::collections::BTreeMap<&str, f64> =
        meta.params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    let params = now.overrides.params();
    let current: std::collections::BTreeMap<&str, f64> =
        params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    let names: std::collections::BTreeSet<&str> =
        then.keys().chain(current.keys()).copied().collect();
    let given = |v: Option<&f64>| v.map_or("not given".to_string(), |v| format!("{v}"));
    for name in names {
        let (a, b) = (then.get(name), current.get(name));
        if a != b {
            diffs.push(format!(
                "-p {name}: {} at the checkpoint, {} now",
                given(a),
                given(b)
            ));
        }
    }
    if meta.end_time != now.overrides.end_time {
        diffs.push(format!(
            "--end-time: {} at the checkpoint, {} now",
            given(meta.end_time.as_ref()),
            given(now.overrides.end_time.as_ref())
        ));
    }
    if meta.scene_file_hash != now.scene_file_hash {
        diffs.push(format!(
            "the scene's values changed ({})",
            now.scene_file.display()
        ));
    }
    if diffs.is_empty() {
        diffs.push("the values given on the command line changed".to_string());
    }
    let fix = if meta.scene_file_hash == now.scene_file_hash {
        format!(
            "`{}` continues it, or start a new run",
            restart_command(
                now.scene_file,
                &run_args(&meta.params, meta.end_time),
                run_dir
            )
        )
    } else {
        "undo the change, or start a new run".to_string()
    };
    Some(format!(
        "--restart {}: not the run of the checkpoint: {}; a restart continues the same run: {fix}",
        run_dir.display(),
        diffs.join("; ")
    ))
}

/// Writes a checkpoint of `model` into `out_dir/checkpoint` (collective).
pub fn write(
    world: &SimpleCommunicator,
    out_dir: &Path,
    meta: &Meta,
    model: &Model,
) -> Result<(), String> {
    let dir = out_dir.join(DIR);
    let rank = world.rank();
    let mut err = None;
    if rank == 0 {
        if let Err(e) = std::fs::create_dir_all(&dir) {
            err = Some(format!("checkpoint: {}: {e}", dir.display()));
        }
    }
    first_error(world, err)?;
    let mut w = StateWriter::default();
    for stage in model.stages() {
        stage.save(&mut w);
    }
    if let Some(c) = &model.contact {
        c.save(&mut w);
    }
    if let Some(walls) = &model.walls {
        walls.save(&mut w);
    }
    if let Some(r) = &model.releases {
        r.save(&mut w);
    }
    let step = meta.clock.step;
    let path = rank_file(&dir, rank, step);
    let res = std::fs::write(&path, w.into_bytes())
        .map_err(|e| format!("checkpoint: {}: {e}", path.display()));
    first_error(world, res.err())?;
    let mut err = None;
    if rank == 0 {
        let text = serde_json::to_string_pretty(meta).expect("meta serialises");
        let tmp = dir.join("meta.json.tmp");
        let res =
            std::fs::write(&tmp, text).and_then(|_| std::fs::rename(&tmp, dir.join("meta.json")));
        if let Err(e) = res {
            err = Some(format!("checkpoint: {}: {e}", dir.display()));
        }
    }
    first_error(world, err)?;
    // The new checkpoint is whole: this rank's older files go.
    if let Ok(rd) = std::fs::read_dir(&dir) {
        let mine = format!("rank-{rank:06}-step-");
        let keep = path.file_name().map(|n| n.to_os_string());
        for e in rd.flatten() {
            let name = e.file_name();
            let s = name.to_string_lossy();
            if s.starts_with(&mine) && Some(&name) != keep.as_ref() {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    Ok(())
}

/// The rank files a restart reads.
pub enum Saved {
    /// This rank's own file: the checkpoint was written on this rank count.
    Mine(StateReader),
    /// Every writing rank's file, in rank order: it was written on another rank count.
    All(Vec<StateReader>),
}

/// Reads the checkpoint in `run_dir/checkpoint` (collective): this rank's file, or every
/// rank's when it was written on another rank count. Refused, naming what differs, when it
/// was written for another run (`scene_hash`, the `-p` and `--end-time` values) or by another
/// format version.
pub fn read(
    world: &SimpleCommunicator,
    run_dir: &Path,
    now: &RunIdentity,
) -> Result<(Meta, Saved), String> {
    let dir = run_dir.join(DIR);
    let meta_path = dir.join("meta.json");
    let meta: Result<Meta, String> = std::fs::read_to_string(&meta_path)
        .map_err(|e| {
            format!(
                "--restart {}: no checkpoint there ({}: {e}); a run writes one with [output] checkpoint_every, at its end, or when stopped with Ctrl-C",
                run_dir.display(),
                meta_path.display()
            )
        })
        .and_then(|t| {
            serde_json::from_str(&t).map_err(|e| format!("{}: {e}", meta_path.display()))
        });
    let meta = match meta {
        Ok(m) => m,
        Err(e) => {
            first_error(world, Some(e))?;
            unreachable!("first_error returns the error")
        }
    };
    let err = if meta.version != VERSION {
        Some(format!(
            "{}: format version {}, this tdyn reads {VERSION}",
            meta_path.display(),
            meta.version
        ))
    } else if meta.ranks < 1 {
        Some(format!("{}: ranks {}", meta_path.display(), meta.ranks))
    } else {
        mismatch(&meta, now, run_dir)
    };
    first_error(world, err)?;
    let read_one = |rank: i32| {
        let path = rank_file(&dir, rank, meta.clock.step);
        std::fs::read(&path)
            .map_err(|e| format!("--restart: {}: {e}", path.display()))
            .and_then(|b| StateReader::parse(&b))
    };
    let saved = if meta.ranks == world.size() {
        read_one(world.rank()).map(Saved::Mine)
    } else {
        (0..meta.ranks)
            .map(read_one)
            .collect::<Result<Vec<_>, _>>()
            .map(Saved::All)
    };
    match saved {
        Ok(s) => {
            first_error(world, None)?;
            Ok((meta, s))
        }
        Err(e) => {
            first_error(world, Some(e))?;
            unreachable!("first_error returns the error")
        }
    }
}
