//! Child processes for the tools that do not join MPI themselves (`tdyn crosscheck`, `tdyn
//! validate`): `mpirun -np N tdyn run ...` and other programs, each with its output kept in a
//! log file and the log's tail in the error when it fails.
use std::path::Path;
use std::process::Command;

/// Lines of a failed child's log quoted in the error.
const LOG_TAIL_LINES: usize = 15;

/// Runs `cmd`, its standard output and error into `log`; an error with the log's tail when it
/// cannot start or exits non-zero.
pub fn run_logged(mut cmd: Command, log: &Path, what: &str) -> Result<(), String> {
    let out = cmd
        .output()
        .map_err(|e| format!("cannot start {what} ({:?}): {e}", cmd.get_program()))?;
    let mut text = out.stdout.clone();
    text.extend_from_slice(&out.stderr);
    std::fs::write(log, &text).map_err(|e| format!("{}: {e}", log.display()))?;
    if !out.status.success() {
        let s = String::from_utf8_lossy(&text);
        let tail: Vec<&str> = s.lines().rev().take(LOG_TAIL_LINES).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        return Err(format!(
            "{what} failed ({}); last lines of {}:\n{}",
            out.status,
            log.display(),
            tail.join("\n")
        ));
    }
    Ok(())
}

/// This executable (`tdyn`) with `args`, not yet started.
pub fn tdyn(args: &[&str]) -> Result<Command, String> {
    let exe = std::env::current_exe().map_err(|e| format!("own executable: {e}"))?;
    let mut cmd = Command::new(exe);
    cmd.args(args);
    Ok(cmd)
}

/// `mpirun -np NP tdyn run SCENE --out OUT --overwrite --quiet`, not yet started (add `--param` and
/// `--end-time` arguments). mpirun takes its environment from this process (as root and with
/// more ranks than cores it needs the OMPI_* variables the Makefile sets).
pub fn tdyn_run(np: usize, scene: &Path, out: &Path) -> Result<Command, String> {
    let exe = std::env::current_exe().map_err(|e| format!("own executable: {e}"))?;
    let mut cmd = Command::new("mpirun");
    cmd.args(["-np", &np.max(1).to_string()])
        .arg(exe)
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        // the tool's own run folder: a new run of the suite replaces the last one's
        .arg("--overwrite")
        .arg("--quiet");
    Ok(cmd)
}
