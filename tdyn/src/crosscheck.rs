//! `tdyn crosscheck`: runs a LIGGGHTS deck and the equivalent scene of ours on the same particle
//! file, reads both codes' `dump custom` files and prints, per dumped step, the per-field
//! differences (x, v, f, rho, p: max |ours - LIGGGHTS| / max |LIGGGHTS|) and two global
//! measures (kinetic energy of the moving particles, and the front: their largest x), with each
//! code's cost in us per particle-step from the same run.
//!
//! This process does not join MPI itself: it launches `liggghts` (or `mpirun -np M liggghts`) and
//! `mpirun -np N tdyn run` as child processes, so that neither inherits an MPI environment.
use crate::launch::{run_logged, tdyn_run};
use coupling::input::liggghts::{read_dump, Dump};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What to run.
#[derive(Clone, Debug)]
pub struct CrosscheckOptions {
    /// Our scene (particles from the same data file as the deck, `[output] dump_every` set).
    pub scene: PathBuf,
    /// The LIGGGHTS input deck; every file of its directory (the data files it reads) is
    /// copied beside it into the work directory.
    pub deck: PathBuf,
    /// Ranks of our run.
    pub np: usize,
    /// Ranks of LIGGGHTS's run (1: run without mpirun).
    pub liggghts_np: usize,
    /// `-var NAME VALUE` pairs for LIGGGHTS.
    pub vars: Vec<(String, String)>,
    /// Work directory (default out/<scene name>/crosscheck).
    pub out: Option<PathBuf>,
    /// Fail when a per-field difference exceeds this (relative to the field's largest
    /// LIGGGHTS magnitude).
    pub tol: Option<f64>,
    /// Reuse the LIGGGHTS dumps already in the work directory (skip running LIGGGHTS).
    pub reuse_liggghts: bool,
}

/// One compared step.
#[derive(Clone, Debug)]
pub struct StepDiff {
    /// The step.
    pub step: u64,
    /// Per-field relative differences, in the order of `FIELDS`.
    pub fields: [f64; 5],
    /// Kinetic energy of the moving particles (type 1): ours, LIGGGHTS's, J.
    pub ke: (f64, f64),
    /// Largest x of the moving particles: ours, LIGGGHTS's, m.
    pub front: (f64, f64),
}

/// Field groups compared, with their dump columns.
pub const FIELDS: [(&str, &[&str]); 5] = [
    ("x", &["x", "y", "z"]),
    ("v", &["vx", "vy", "vz"]),
    ("f", &["fx", "fy", "fz"]),
    ("rho", &["rho"]),
    ("p", &["p"]),
];

/// The outcome.
#[derive(Clone, Debug)]
pub struct CrosscheckSummary {
    /// Compared steps.
    pub steps: Vec<StepDiff>,
    /// Our cost, us per particle-step (report.json).
    pub ours_us: Option<f64>,
    /// LIGGGHTS's cost from its "Loop time" line, us per particle-step (x ranks).
    pub liggghts_us: Option<f64>,
    /// The work directory.
    pub dir: PathBuf,
}

/// `dump.*` files of `dir` by their TIMESTEP.
fn dumps_in(dir: &Path, prefix: &str) -> Result<BTreeMap<u64, PathBuf>, String> {
    let mut out = BTreeMap::new();
    let rd = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if !name.starts_with(prefix) {
            continue;
        }
        // the step is the last dot-separated word (LIGGGHTS's `dump.<tag>.*`)
        if let Some(step) = name.rsplit('.').next().and_then(|s| s.parse::<u64>().ok()) {
            out.insert(step, e.path());
        }
    }
    Ok(out)
}

/// "Loop time of T on P procs for N steps with M atoms" -> T P / (N M) in us.
fn liggghts_cost(log: &str) -> Option<f64> {
    let l = log.lines().rev().find(|l| l.starts_with("Loop time of"))?;
    let w: Vec<&str> = l.split_whitespace().collect();
    let t: f64 = w.get(3)?.parse().ok()?;
    let p: f64 = w.get(5)?.parse().ok()?;
    let n: f64 = w.get(8)?.parse().ok()?;
    let m: f64 = w.get(11)?.parse().ok()?;
    (n > 0.0 && m > 0.0).then(|| t * p / (n * m) * 1e6)
}

/// Compares one step's dumps.
fn compare_step(step: u64, ours: &Dump, theirs: &Dump) -> Result<StepDiff, String> {
    if ours.rows.len() != theirs.rows.len() {
        return Err(format!(
            "step {step}: {} particles in our dump, {} in LIGGGHTS's",
            ours.rows.len(),
            theirs.rows.len()
        ));
    }
    let col = |d: &Dump, name: &str| -> Result<usize, String> {
        d.columns
            .iter()
            .position(|c| c == name)
            .ok_or_else(|| format!("step {step}: no column {name} in a dump"))
    };
    let ctype = col(ours, "type")?;
    let cmass = col(ours, "mass")?;
    let mut fields = [0.0; 5];
    for (k, (name, cols)) in FIELDS.iter().enumerate() {
        let (mut diff, mut scale) = (0.0f64, 0.0f64);
        for c in cols.iter() {
            let (co, ct) = (col(ours, c)?, col(theirs, c)?);
            for (id, ro) in &ours.rows {
                let rt = theirs
                    .rows
                    .get(id)
                    .ok_or_else(|| format!("step {step}: id {id} is not in LIGGGHTS's dump"))?;
                // forces on fixed particles are not compared: LIGGGHTS sums wall-wall pairs
                // onto them, which never act (they do not move); we skip those pairs
                if *name == "f" && ro[ctype] != 1.0 {
                    continue;
                }
                diff = diff.max((ro[co] - rt[ct]).abs());
                scale = scale.max(rt[ct].abs());
            }
        }
        fields[k] = if scale > 0.0 { diff / scale } else { diff };
    }
    let measures = |d: &Dump| -> Result<(f64, f64), String> {
        let (cx, cvx, cvy, cvz) = (col(d, "x")?, col(d, "vx")?, col(d, "vy")?, col(d, "vz")?);
        let (mut ke, mut front) = (0.0, f64::NEG_INFINITY);
        for (id, r) in &d.rows {
            let mine = &ours.rows[id];
            if mine[ctype] != 1.0 {
                continue;
            }
            let v2 = r[cvx] * r[cvx] + r[cvy] * r[cvy] + r[cvz] * r[cvz];
            ke += 0.5 * mine[cmass] * v2;
            front = front.max(r[cx]);
        }
        Ok((ke, front))
    };
    let (ko, fo) = measures(ours)?;
    let (kt, ft) = measures(theirs)?;
    Ok(StepDiff {
        step,
        fields,
        ke: (ko, kt),
        front: (fo, ft),
    })
}

fn rel(a: f64, b: f64) -> f64 {
    if b != 0.0 {
        (a - b).abs() / b.abs()
    } else {
        (a - b).abs()
    }
}

/// Runs both codes and compares (see the module comment).
pub fn crosscheck(o: &CrosscheckOptions) -> Result<CrosscheckSummary, String> {
    for (flag, np) in [("--np", o.np), ("--liggghts-np", o.liggghts_np)] {
        if np < 1 {
            return Err(format!("{flag} {np}: expected at least 1 rank"));
        }
    }
    let scene = coupling::input::scene::load(&o.scene).map_err(|e| e.to_string())?;
    if scene.output.dump_every == 0 {
        return Err(format!(
            "{}: output.dump_every: the cross-check needs our particle dumps; set [output] dump_every = N (steps) to match the deck's dump frequency",
            o.scene.display()
        ));
    }
    let stem = o
        .scene
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    let dir = o
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(stem).join("crosscheck"));
    let (ldir, tdir) = (dir.join("liggghts"), dir.join("tdyn"));
    if !o.reuse_liggghts {
        run_liggghts(o, &ldir)?;
    }
    let _ = std::fs::remove_dir_all(&tdir);
    let cmd = tdyn_run(o.np, &o.scene, &tdir)?;
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    run_logged(cmd, &dir.join("tdyn.out"), "tdyn run")?;

    let steps = compare_dumps(&tdir.join("dumps"), &ldir)?;
    let ours_us = std::fs::read_to_string(tdir.join("report.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v["us_per_particle_step"].as_f64());
    let liggghts_us = std::fs::read_to_string(ldir.join("liggghts.out"))
        .ok()
        .and_then(|t| liggghts_cost(&t));
    write_csv(&dir, &steps)?;
    if let Some(tol) = o.tol {
        within(&steps, tol, &dir.join("crosscheck.csv"))?;
    }
    Ok(CrosscheckSummary {
        steps,
        ours_us,
        liggghts_us,
        dir,
    })
}

/// Runs the deck in `ldir` (emptied, then given a copy of every file of the deck's directory):
/// `liggghts -in`, under `mpirun -np M` for M > 1 ranks, its output in liggghts.out.
fn run_liggghts(o: &CrosscheckOptions, ldir: &Path) -> Result<(), String> {
    let _ = std::fs::remove_dir_all(ldir);
    std::fs::create_dir_all(ldir).map_err(|e| format!("{}: {e}", ldir.display()))?;
    let deck_dir = o.deck.parent().unwrap_or(Path::new("."));
    let deck_dir = if deck_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        deck_dir
    };
    let rd = std::fs::read_dir(deck_dir).map_err(|e| format!("{}: {e}", deck_dir.display()))?;
    for e in rd.flatten() {
        let p = e.path();
        if p.is_file() {
            std::fs::copy(&p, ldir.join(e.file_name()))
                .map_err(|err| format!("{}: {err}", p.display()))?;
        }
    }
    let deck_name = o
        .deck
        .file_name()
        .ok_or_else(|| format!("{}: not a file", o.deck.display()))?;
    if !ldir.join(deck_name).is_file() {
        return Err(format!("{}: no such deck", o.deck.display()));
    }
    let mut cmd = if o.liggghts_np > 1 {
        let mut c = Command::new("mpirun");
        c.args(["-np", &o.liggghts_np.to_string(), "liggghts"]);
        c
    } else {
        Command::new("liggghts")
    };
    cmd.arg("-in").arg(deck_name).current_dir(ldir);
    for (k, v) in &o.vars {
        cmd.args(["-var", k, v]);
    }
    run_logged(cmd, &ldir.join("liggghts.out"), "liggghts")
}

/// Compares our dumps (in `ours_dir`) with LIGGGHTS's (in `ldir`) at every step both wrote;
/// an error when there is none.
fn compare_dumps(ours_dir: &Path, ldir: &Path) -> Result<Vec<StepDiff>, String> {
    let theirs = dumps_in(ldir, "dump.")?;
    let ours = dumps_in(ours_dir, "dump.tdyn.")?;
    let common: Vec<u64> = ours
        .keys()
        .filter(|s| theirs.contains_key(s))
        .copied()
        .collect();
    if common.is_empty() {
        return Err(format!(
            "no step dumped by both codes (ours: {:?}, LIGGGHTS: {:?}); match [output] dump_every to the deck's dump frequency",
            ours.keys().collect::<Vec<_>>(),
            theirs.keys().collect::<Vec<_>>()
        ));
    }
    let mut steps = Vec::new();
    for s in &common {
        let a = read_dump(&ours[s])?;
        let b = read_dump(&theirs[s])?;
        steps.push(compare_step(*s, &a, &b)?);
    }
    Ok(steps)
}

/// Writes `dir`/crosscheck.csv: per step the fields' differences, then ours, LIGGGHTS's and
/// their relative difference for the kinetic energy and the front.
fn write_csv(dir: &Path, steps: &[StepDiff]) -> Result<(), String> {
    let mut csv = std::fs::File::create(dir.join("crosscheck.csv"))
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut header = vec!["step".to_string()];
    header.extend(FIELDS.iter().map(|(n, _)| format!("rel_{n}")));
    header.extend(
        [
            "ke_ours",
            "ke_liggghts",
            "rel_ke",
            "front_ours",
            "front_liggghts",
            "rel_front",
        ]
        .map(String::from),
    );
    let mut text = header.join(",") + "\n";
    for d in steps {
        let mut row = vec![d.step.to_string()];
        row.extend(d.fields.iter().map(|v| format!("{v:e}")));
        for (a, b) in [d.ke, d.front] {
            row.extend([
                format!("{a:?}"),
                format!("{b:?}"),
                format!("{:e}", rel(a, b)),
            ]);
        }
        text += &(row.join(",") + "\n");
    }
    csv.write_all(text.as_bytes()).map_err(|e| e.to_string())
}

/// An error naming the first step and field whose difference exceeds `tol` (or is NaN), and
/// the CSV at `csv` to look at.
fn within(steps: &[StepDiff], tol: f64, csv: &Path) -> Result<(), String> {
    for d in steps {
        for (k, (name, _)) in FIELDS.iter().enumerate() {
            if !(d.fields[k] <= tol) {
                return Err(format!(
                    "step {}: {name} differs from LIGGGHTS by {:.3e} of its largest value (tolerance {tol:e}); see {}",
                    d.step,
                    d.fields[k],
                    csv.display()
                ));
            }
        }
    }
    Ok(())
}

/// The table `tdyn crosscheck` prints.
pub fn table(s: &CrosscheckSummary) -> String {
    let mut t = format!(
        "{:>6} {:>9} {:>9} {:>9} {:>9} {:>9}  {:>12} {:>12} {:>9}  {:>10} {:>10} {:>9}\n",
        "step",
        "x",
        "v",
        "f",
        "rho",
        "p",
        "KE ours",
        "KE LIGGGHTS",
        "rel",
        "front ours",
        "front LIG.",
        "rel"
    );
    for d in &s.steps {
        t += &format!(
            "{:>6} {:>9.2e} {:>9.2e} {:>9.2e} {:>9.2e} {:>9.2e}  {:>12.6e} {:>12.6e} {:>9.2e}  {:>10.6} {:>10.6} {:>9.2e}\n",
            d.step,
            d.fields[0],
            d.fields[1],
            d.fields[2],
            d.fields[3],
            d.fields[4],
            d.ke.0,
            d.ke.1,
            rel(d.ke.0, d.ke.1),
            d.front.0,
            d.front.1,
            rel(d.front.0, d.front.1)
        );
    }
    t += "(x .. p: max |ours - LIGGGHTS| / max |LIGGGHTS| over the particles; f over moving particles)\n";
    match (s.ours_us, s.liggghts_us) {
        (Some(a), Some(b)) => {
            t += &format!(
                "cost: ours {a:.3} us/particle-step, LIGGGHTS {b:.3} us/particle-step (x ranks), ratio ours/LIGGGHTS {:.2}\n",
                a / b
            )
        }
        (a, b) => t += &format!("cost: ours {a:?} LIGGGHTS {b:?} us/particle-step\n"),
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The "Loop time" line as LIGGGHTS 3.8.0 prints it.
    #[test]
    fn reads_liggghts_loop_time() {
        let log = "Step Atoms\nLoop time of 44.5 on 2 procs for 2000 steps with 18568 atoms\n";
        let us = liggghts_cost(log).unwrap();
        assert!((us - 44.5 * 2.0 / (2000.0 * 18568.0) * 1e6).abs() < 1e-12);
    }
}
