//! Nothing lost, and restart (issue 16; SCENE.md "Runs, restarts and earlier results"): a run
//! stopped with SIGTERM (as mpirun passes on Ctrl-C) and continued with `--restart` ends as the
//! run without a stop; a run killed with SIGKILL leaves whole CSV rows and readable frames; an
//! earlier run's results are never replaced unless asked.
use std::path::{Path, PathBuf};
use std::process::Child;
use std::time::{Duration, Instant};
use tdyn_tests::*;

/// The scene at `rel` with its mesh paths made absolute, written into `dir`.
fn scene_copy(rel: &str, dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join(rel))
        .unwrap()
        .replace("\"../meshes/", &format!("\"{}/meshes/", root().display()));
    let p = dir.join(Path::new(rel).file_name().unwrap());
    std::fs::write(&p, text).unwrap();
    p
}

fn start(np: usize, scene: &Path, out: &Path, extra: &[&str]) -> Child {
    mpirun(np, 600)
        .arg(tdyn())
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .args(extra)
        .arg("--quiet")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("mpirun")
}

/// Lines of `path` (0 when absent).
fn lines(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .map(|t| t.lines().count())
        .unwrap_or(0)
}

/// Waits until history.csv in `out` has more than `rows` lines (rows reach the file in
/// whole-row flushes), then sends `signal` to the ranks (SIGTERM: as a batch system does at
/// the end of an allocation; Open MPI's mpirun, signalled itself, kills its ranks a second
/// later) or, for SIGKILL, to mpirun and every rank.
fn signal_after_rows(child: &mut Child, out: &Path, rows: usize, signal: &str) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(300) {
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        if lines(&out.join("history.csv")) > rows {
            let pattern = if signal == "-KILL" {
                format!("tdyn run .* --out {}", out.display())
            } else {
                format!("^{} run .* --out {}", tdyn().display(), out.display())
            };
            let st = std::process::Command::new("pkill")
                .args([signal, "-f", &pattern])
                .status()
                .unwrap();
            return st.success();
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

/// Column-by-column equality of two CSV files' text, except the named columns (the contact
/// decomposition's cost figures, which a restart's rebuild of the decomposition changes).
fn same_csv(a: &Path, b: &Path, except: &[&str]) -> Result<(), String> {
    let (ta, tb) = (
        std::fs::read_to_string(a).unwrap(),
        std::fs::read_to_string(b).unwrap(),
    );
    let (la, lb): (Vec<&str>, Vec<&str>) = (ta.lines().collect(), tb.lines().collect());
    if la.len() != lb.len() {
        return Err(format!("{} rows against {}", la.len(), lb.len()));
    }
    let header: Vec<&str> = la[0].split(',').collect();
    for (r, (x, y)) in la.iter().zip(&lb).enumerate() {
        for (k, (u, v)) in x.split(',').zip(y.split(',')).enumerate() {
            if u != v && !except.contains(&header[k]) {
                return Err(format!("row {r}, column {}: {u} against {v}", header[k]));
            }
        }
    }
    Ok(())
}

/// Runs the scene once to its end (A), once stopped by SIGTERM after `rows` history rows and
/// continued with --restart (B); B must end with A's history and probes bit for bit (the text
/// is Rust's shortest round-trip form) and A's last frame.
fn stop_and_restart(rel: &str, np: usize, rows: usize, except: &[&str]) {
    let dir = workdir(&format!(
        "restart_{}_np{np}",
        Path::new(rel).file_stem().unwrap().to_string_lossy()
    ));
    let scene = scene_copy(rel, &dir);
    let (a, b) = (dir.join("A"), dir.join("B"));
    run_ok(np, &scene, &a);
    let mut child = start(np, &scene, &b, &[]);
    assert!(
        signal_after_rows(&mut child, &b, rows, "-TERM"),
        "{rel} np {np}: the run ended before it could be stopped"
    );
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("stopped at step") && err.contains("--restart"),
        "{rel} np {np}: a clean stop says where and how to continue:\n{err}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["status"], "stopped", "report.json of a stopped run");
    let o = mpirun(np, 600)
        .arg(tdyn())
        .args(["run"])
        .arg(&scene)
        .arg("--restart")
        .arg(&b)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{rel} np {np}: restart failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for f in ["history.csv", "probes.csv"] {
        if let Err(e) = same_csv(&a.join(f), &b.join(f), except) {
            panic!("{rel} np {np}: {f} after a stop and restart differs from the run without a stop: {e}");
        }
    }
    let (fa, fb) = (last_frame(&a), last_frame(&b));
    assert_eq!(fa.0, fb.0, "{rel} np {np}: the same number of frames");
    assert!(!fa.1.is_empty());
    for ((name, x), (_, y)) in fa.1.iter().zip(&fb.1) {
        assert!(
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()),
            "{rel} np {np}: the last frame's {name} bit for bit"
        );
    }
}

/// The number of frames in a run's fields.h5, and its last frame's positions (nodes and
/// particles, those present).
fn last_frame(out: &Path) -> (usize, Vec<(String, Vec<f64>)>) {
    let f = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut names = f.group("frames").unwrap().member_names().unwrap();
    names.sort();
    let last = names.last().unwrap();
    let mut v = Vec::new();
    for set in ["nodes/position", "particles/position", "particles/velocity"] {
        if let Ok(d) = f.dataset(&format!("frames/{last}/{set}")) {
            v.push((set.to_string(), d.read_raw::<f64>().unwrap()));
        }
    }
    (names.len(), v)
}

#[test]
fn fe_run_stopped_and_restarted_ends_bit_identical_at_np_1_and_2() {
    // The Taylor bar (J2 plasticity, symmetry planes): element stress, plastic strain and
    // hourglass state all continue from the checkpoint.
    for np in [1, 2] {
        stop_and_restart("scenes/taylor_impact.toml", np, 600, &[]);
    }
}

#[test]
fn sph_run_stopped_and_restarted_ends_bit_identical_at_np_1_and_3() {
    // Sod's tube: the particles in their order, the kept pair list and the RCB cuts continue.
    for np in [1, 3] {
        stop_and_restart("scenes/sod_tube.toml", np, 64, &[]);
    }
}

#[test]
fn contact_run_stopped_and_restarted_ends_bit_identical_at_np_2() {
    // The block dropped on a plate: the physics columns bit for bit; the contact stage's cost
    // columns differ after the restart because its decomposition is rebuilt there.
    stop_and_restart(
        "scenes/block_drop.toml",
        2,
        64,
        &["contact_imbalance", "contact_bytes"],
    );
}

#[test]
fn kept_sph_decomposition_stopped_and_restarted_ends_bit_identical_at_np_2() {
    // Water particles on a plate without a periodic box: on two ranks the SPH stage keeps its
    // decomposition, ghosts and pair candidates between rebuilds, and the checkpoint carries
    // them (the candidates, the ghost plan's destinations), so the restarted run sums the same
    // pairs in the same order: the physics columns bit for bit.
    stop_and_restart(
        "scenes/cloud_on_plate.toml",
        2,
        400,
        &["contact_imbalance", "contact_bytes"],
    );
}

#[test]
fn a_killed_run_leaves_whole_rows_and_readable_frames_and_earlier_results_are_kept() {
    let dir = workdir("restart_kill");
    let scene = scene_copy("scenes/taylor_impact.toml", &dir);
    let out = dir.join("out");
    // SIGKILL to mpirun and the ranks after some rows: every CSV row whole, every frame of
    // fields.xmf readable.
    let mut child = start(2, &scene, &out, &[]);
    assert!(signal_after_rows(&mut child, &out, 200, "-KILL"));
    let _ = child.wait();
    std::thread::sleep(Duration::from_millis(500));
    for f in ["history.csv", "probes.csv"] {
        let text = std::fs::read_to_string(out.join(f)).unwrap();
        let mut it = text.split_inclusive('\n');
        let cols = it.next().unwrap().split(',').count();
        for (r, line) in it.enumerate() {
            assert!(
                line.ends_with('\n') && line.trim_end().split(',').count() == cols,
                "{f}: row {r} cut by the kill: {line:?}"
            );
            assert!(
                line.trim_end().split(',').all(|v| v.parse::<f64>().is_ok()),
                "{f}: row {r} holds a number per column"
            );
        }
    }
    let fr = frames::read_frames(&out);
    assert!(
        !fr.times.is_empty(),
        "the frames written before the kill read back"
    );
    // The folder now holds a run: a new run naming it is refused and leaves it intact.
    let before = std::fs::read_to_string(out.join("history.csv")).unwrap();
    let o = run(1, &scene, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("--overwrite"),
        "an earlier run is kept unless asked:\n{err}"
    );
    assert_eq!(
        before,
        std::fs::read_to_string(out.join("history.csv")).unwrap(),
        "the earlier history intact"
    );
    // Asked: replaced.
    run_ok_args(1, &scene, &out, &["--overwrite"]);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["status"], "finished");
}
