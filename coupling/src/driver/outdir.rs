//! Where a run writes, without destroying an earlier run (docs/scene.md "Runs, restarts and earlier
//! results"): a folder that already holds a run's files is refused unless the user asked for it
//! to be replaced (`--overwrite`); without `--out` the default `out/<scene>` is kept and the run
//! goes to the first free `out/<scene>-2`, `-3`, ... instead.
use crate::kernels::collective::first_error;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};

/// The files and folders a run writes in its output folder.
pub const RUN_FILES: [&str; 12] = [
    "report.json",
    "history.csv",
    "probes.csv",
    "reactions.csv",
    "contact_forces.csv",
    "fields.h5",
    "fields.xmf",
    "energies.png",
    "energies.svg",
    "dumps",
    "checkpoint",
    "failure.txt",
];

/// Whether `dir` holds a run's files.
pub fn holds_run(dir: &Path) -> bool {
    RUN_FILES.iter().any(|f| dir.join(f).exists())
}

/// The output folder of this run, decided on rank 0 and the same on every rank (collective):
/// `out` when given (an earlier run there is refused unless `overwrite`, which removes its
/// files first), else `default` or the first free numbered folder beside it. `note` is set
/// when the folder is not the one asked for. A restart writes into its own folder.
pub fn resolve(
    world: &SimpleCommunicator,
    out: Option<&Path>,
    default: &Path,
    overwrite: bool,
    restart: bool,
) -> Result<(PathBuf, Option<String>), String> {
    let mut chosen = PathBuf::new();
    let mut note = None;
    let mut err = None;
    if world.rank() == 0 {
        match choose(out, default, overwrite, restart) {
            Ok((d, n)) => {
                chosen = d;
                note = n;
            }
            Err(e) => err = Some(e),
        }
    }
    first_error(world, err)?;
    let mut buf = chosen.to_string_lossy().into_owned().into_bytes();
    let mut len = buf.len() as u64;
    world.process_at_rank(0).broadcast_into(&mut len);
    buf.resize(len as usize, 0);
    world.process_at_rank(0).broadcast_into(&mut buf[..]);
    Ok((
        PathBuf::from(String::from_utf8_lossy(&buf).into_owned()),
        note,
    ))
}

fn choose(
    out: Option<&Path>,
    default: &Path,
    overwrite: bool,
    restart: bool,
) -> Result<(PathBuf, Option<String>), String> {
    if let Some(dir) = out {
        if dir.exists() && !dir.is_dir() {
            return Err(format!(
                "--out {}: is a file, not a folder; name a folder",
                dir.display()
            ));
        }
        if restart || !holds_run(dir) {
            return Ok((dir.to_path_buf(), None));
        }
        if !overwrite {
            return Err(format!(
                "--out {}: holds an earlier run's results; use --overwrite to replace them, or another --out",
                dir.display()
            ));
        }
        remove_run_files(dir)?;
        return Ok((dir.to_path_buf(), None));
    }
    if default.exists() && !default.is_dir() {
        return Err(format!(
            "{}: is a file, not a folder; name an output folder with --out",
            default.display()
        ));
    }
    if !holds_run(default) {
        return Ok((default.to_path_buf(), None));
    }
    if overwrite {
        remove_run_files(default)?;
        return Ok((default.to_path_buf(), None));
    }
    let name = default.file_name().unwrap_or_default().to_string_lossy();
    for k in 2..10_000 {
        let d = default.with_file_name(format!("{name}-{k}"));
        let free = !holds_run(&d) && (!d.exists() || d.is_dir());
        if free {
            let note = format!(
                "{} holds an earlier run (kept); this run writes {} (--overwrite replaces the earlier one)",
                default.display(),
                d.display()
            );
            return Ok((d, Some(note)));
        }
    }
    Err(format!(
        "{}: no free numbered output folder; use --out",
        default.display()
    ))
}

/// Removes the files of an earlier run from `dir` (`--overwrite`), leaving anything else.
fn remove_run_files(dir: &Path) -> Result<(), String> {
    for f in RUN_FILES {
        let p = dir.join(f);
        let res = if p.is_dir() {
            std::fs::remove_dir_all(&p)
        } else if p.exists() {
            std::fs::remove_file(&p)
        } else {
            Ok(())
        };
        res.map_err(|e| format!("--overwrite: cannot remove {}: {e}", p.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("tdyn_outdir_{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// docs/scene.md: a run never destroys an earlier run's results without being asked.
    #[test]
    fn an_earlier_run_is_kept_unless_overwrite_is_asked() {
        let base = tmp("keep");
        let default = base.join("out").join("scene");
        std::fs::create_dir_all(&default).unwrap();
        // an empty folder is free
        assert_eq!(choose(None, &default, false, false).unwrap().0, default);
        std::fs::write(default.join("report.json"), "{}").unwrap();
        // the default taken: the next numbered folder, with a note
        let (d, note) = choose(None, &default, false, false).unwrap();
        assert_eq!(d, base.join("out").join("scene-2"));
        assert!(note.unwrap().contains("kept"));
        // --out naming it: refused, the file intact
        let e = choose(Some(&default), &default, false, false).unwrap_err();
        assert!(e.contains("--overwrite"), "{e}");
        assert!(default.join("report.json").exists());
        // a restart writes into its own folder
        assert_eq!(
            choose(Some(&default), &default, false, true).unwrap().0,
            default
        );
        // --overwrite: the earlier files go, other files stay
        std::fs::write(default.join("notes.txt"), "mine").unwrap();
        choose(Some(&default), &default, true, false).unwrap();
        assert!(!default.join("report.json").exists());
        assert!(default.join("notes.txt").exists());
        // a file where a folder is needed
        let f = base.join("file");
        std::fs::write(&f, "x").unwrap();
        assert!(choose(Some(&f), &default, false, false)
            .unwrap_err()
            .contains("is a file"));
        let _ = std::fs::remove_dir_all(&base);
    }
}
